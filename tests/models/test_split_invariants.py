"""Second-pass review pins of the classifier library: fold sizes, training units at block
edges, ensemble weights and the decision history."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError
from terrain.models.cv import iter_splits, training_units


# --- splits and training units ---------------------------------------------------------------

@pytest.mark.parametrize("n_splits", [1, 4])
def test_grouped_folds_outside_two_to_the_unit_count_are_a_config_error(n_splits):
    # 3 runs of 2 classes, 10 windows each: 4 folds over 3 runs reached scikit-learn's bare
    # ValueError without the unit count; 1 fold has no training side
    labels = np.repeat(["A", "B", "A"], 10)
    groups = np.repeat(["r0", "r1", "r2"], 10)
    with pytest.raises(ConfigError, match=rf"^{n_splits} folds over 3 split units \(runs, or "
                                          r"blocks of a single-run class\)"):
        list(iter_splits("grouped", labels, groups, 0, n_splits=n_splits))


def test_a_training_window_ending_where_the_next_block_starts_belongs_to_its_own_block():
    # one run cut into two blocks of 2 s evaluation windows, [0, 4) and [4, 8); training
    # windows of 2 s every 1 s: [2, 4) only touches block 1 at 4 s and is block 0's,
    # [3, 5) straddles the edge and is nobody's, [4, 6) is block 1's
    run = np.full(4, "v/DIRT_ROAD/1", dtype=object)
    t0 = np.array([0.0, 2.0, 4.0, 6.0])
    blocks = np.array(["b0", "b0", "b1", "b1"], dtype=object)
    dense_t0 = np.arange(0.0, 7.0, 1.0)
    dense_run = np.full(dense_t0.size, "v/DIRT_ROAD/1", dtype=object)
    units = training_units(run, t0, t0 + 2.0, blocks, dense_run, dense_t0, dense_t0 + 2.0)
    assert units.tolist() == ["b0", "b0", "b0", None, "b1", "b1", "b1"]
    # a run of the training cut without evaluation windows (all dropped) is never trained on
    other = np.full(3, "v/ASPHALT/2", dtype=object)
    units = training_units(run, t0, t0 + 2.0, blocks, np.concatenate([dense_run, other]),
                           np.arange(10.0), np.arange(10.0) + 2.0)
    assert units.tolist()[7:] == [None] * 3


# --- ensemble weights --------------------------------------------------------------------------

def _sure_recorder(seen: list):
    """:func:`test_training_cut.recorder_class` with a one-hot ``predict_proba``."""
    from test_training_cut import recorder_class   # same folder (prepend import mode)

    class SureRecorder(recorder_class(seen)):
        def predict_proba(self, X):
            return (self.classes_[None, :] == self.predict(X)[:, None]).astype(float)

    return SureRecorder


def test_ensemble_weights_are_chosen_by_members_that_never_saw_the_held_out_runs():
    # 8 runs of 2 classes; column 0 is the row id. The members that score the weights are
    # fitted on the training runs of the inner split only; then every member is refitted
    # on every window
    from terrain.models.ensemble import SoftVotingEnsemble

    seen = []
    rows = np.arange(80)
    groups = np.repeat([f"r{i}" for i in range(8)], 10)
    y = np.repeat(["A", "B"] * 4, 10)
    X = np.column_stack([rows, np.zeros(80)])
    members = [("a", _sure_recorder(seen)()), ("b", _sure_recorder(seen)())]
    ens = SoftVotingEnsemble(members, weight_step=0.5).fit(X, y, groups=groups)
    held = np.isin(groups, ens.validation_groups_)
    assert 0 < held.sum() < 80
    assert len(seen) == 4
    for fit in seen[:2]:                               # scoring the weights
        np.testing.assert_array_equal(fit, rows[~held])
    for fit in seen[2:]:                               # the refit
        np.testing.assert_array_equal(fit, rows)
    # both members say A (the training majority, a tie broken alphabetically) with
    # certainty: every weight scores the B windows held out at -log(1e-12), the clip
    frac_b = (y[held] == "B").mean()
    assert 0 < frac_b < 1
    np.testing.assert_allclose(list(ens.weight_scores_.values()),
                               [-frac_b * np.log(1e-12)] * 3, rtol=1e-9)


def test_equal_ensemble_weights_without_runs_sum_to_one():
    from sklearn.dummy import DummyClassifier

    from terrain.models.ensemble import SoftVotingEnsemble

    X = np.zeros((6, 2))
    y = np.array(["A", "A", "A", "A", "B", "B"])
    members = [(f"d{i}", DummyClassifier()) for i in range(3)]
    ens = SoftVotingEnsemble(members).fit(X, y)
    np.testing.assert_allclose(ens.weights_, [1 / 3] * 3)
    np.testing.assert_allclose(ens.predict_proba(X), [[2 / 3, 1 / 3]] * 6)


def test_summary_gives_the_population_spread_over_the_folds_holding_a_value():
    from terrain.models.cv import CVReport

    folds = pd.DataFrame({"seed": [0, 0, 1], "fold": [0, 1, 0], "accuracy": [0.5, 1.0, 0.75],
                          "recall_MUD": [np.nan, 0.2, 0.6], "n_test": [4.0, 4.0, 4.0]})
    empty = pd.DataFrame()
    summary = CVReport(["A", "MUD"], folds, empty, empty, empty).summary()
    assert set(summary) == {"accuracy", "recall_MUD", "n_test"}
    assert summary["accuracy"] == pytest.approx({"mean": 0.75, "std": np.sqrt(1 / 24),
                                                 "min": 0.5, "max": 1.0, "n_folds": 3})
    assert summary["recall_MUD"] == pytest.approx({"mean": 0.4, "std": 0.2, "min": 0.2,
                                                   "max": 0.6, "n_folds": 2})


# --- comparison cells --------------------------------------------------------------------------

def test_a_comparison_cell_splits_by_its_own_seed():
    # every cell of a seed ran the seed-0 folds had run_cell lost its seed; the rows are
    # labelled with the cell's seed either way
    from terrain.models.compare import Cell, CompareConfig, cell_windows, run_cell

    config = CompareConfig(models=("svm",), signals=("wheels",), windows_s=(2.0,),
                           datasets=("vulpi",), seeds=(1,), n_splits=2, history=(1,))
    cell = Cell("svm", "wheels", 2.0, "vulpi", 1)
    cut = cell_windows(cell, config.single_run_blocks)
    folds = [set(cut.groups[test]) for _, test in
             iter_splits("grouped", cut.labels, cut.groups, 1, 2)]
    assert folds != [set(cut.groups[test]) for _, test in
                     iter_splits("grouped", cut.labels, cut.groups, 0, 2)]
    pred = run_cell(cell, config)["predictions"]
    assert (pred["seed"] == 1).all()
    assert [set(p["group"]) for _, p in pred.groupby("fold")] == folds


def test_the_svm_search_scores_macro_f1_on_seeded_grouped_inner_folds():
    from sklearn.model_selection import StratifiedGroupKFold

    from terrain.models.svm import SVMConfig, make_search

    search = make_search(SVMConfig(inner_splits=4), random_state=7)
    assert search.scoring == "f1_macro" and search.refit is True
    assert isinstance(search.cv, StratifiedGroupKFold)
    assert (search.cv.n_splits, search.cv.shuffle, search.cv.random_state) == (4, True, 7)


def test_the_fast_path_refuses_features_of_another_width_as_scikit_learn_does():
    # the scaler shortcut would broadcast a 1-column input over the fitted 4 columns
    from terrain.models.svm import SVMConfig, SVMPipeline, make_svm

    rng = np.random.default_rng(0)
    X = rng.standard_normal((60, 4))
    y = np.repeat(["A", "B", "C"], 20)
    X[:, 0] += np.repeat([0.0, 3.0, 6.0], 20)
    model = SVMPipeline(make_svm(SVMConfig(probability=True)).steps).fit(X, y)
    assert model.predict_proba(X[:2]).shape == (2, 3)
    with pytest.raises(ValueError, match="StandardScaler is expecting 4 features"):
        model.predict_proba(X[:2, :1])


def test_pooled_metrics_are_those_of_each_seeds_own_predictions():
    from sklearn.linear_model import LogisticRegression
    from test_cv import _planted       # same folder (prepend import mode)

    from terrain.models.cv import cross_validate

    X, y, groups, t0 = _planted(n_runs=8, per_run=10, effect=0.4, seed=3)
    report = cross_validate(lambda seed: LogisticRegression(), X, y, groups, groups, t0,
                            t0 + 2.0, seeds=(0, 1), n_splits=4)
    per_seed = report.predictions.groupby("seed").apply(
        lambda p: (p["true"] == p["predicted"]).mean(), include_groups=False)
    assert per_seed[0] != per_seed[1]
    np.testing.assert_allclose(report.pooled.set_index("seed")["accuracy"], per_seed)
