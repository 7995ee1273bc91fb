"""Run-grouped cross-validation, the papers' protocol, metrics, and leak-free nested search."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin, TransformerMixin
from sklearn.model_selection import StratifiedKFold
from sklearn.pipeline import Pipeline

from features.windows import WindowConfig, WindowSet, make_windows
from terrain.errors import ConfigError, ShapeError
from terrain.models.cv import (PAPER_RANDOM_STATE, cross_validate, grouped_units,
                               iter_splits, purge_block_overlaps, split_single_run_classes)
from terrain.models.experiment import PAPER_WINDOW, ExperimentConfig, run_cv
from terrain.models.metrics import (confusion, majority_vote, run_majority_accuracy,
                                    window_metrics)
from terrain.models.svm import SVMConfig, make_search, make_svm


# --- splits on real shipped windows --------------------------------------------------------

@pytest.fixture(scope="module")
def shipped_windows(borealtc_runs, vulpi_runs):
    """Non-overlapping 2 s wheel windows of all 70 shipped runs (50 Hz)."""
    return make_windows(borealtc_runs + vulpi_runs, "wheels",
                        WindowConfig(window_s=2.0, rate_hz=50.0))


@pytest.fixture(scope="module")
def paper_windows(vulpi_runs):
    """Vulpi windows of the papers' protocol: 1.7 s by 0.1 s inside 5 s partitions."""
    return make_windows(vulpi_runs, "all", WindowConfig(rate_hz=50.0, **PAPER_WINDOW))


def _assert_no_shared_group(train, test, groups):
    assert np.intersect1d(groups[train], groups[test]).size == 0
    assert np.intersect1d(train, test).size == 0
    assert train.size + test.size == groups.size


@pytest.mark.parametrize("split_single", [False, True])
@pytest.mark.parametrize("seed", [0, 1])
def test_grouped_protocol_never_shares_a_run(shipped_windows, seed, split_single):
    labels = shipped_windows.labels.astype(str)
    groups = shipped_windows.groups
    if split_single:
        groups, _ = split_single_run_classes(labels, groups, shipped_windows.t_start_s, 5)
    tested = np.zeros(len(labels), dtype=int)
    for train, test in iter_splits("grouped", labels, groups, seed, n_splits=5):
        _assert_no_shared_group(train, test, groups)
        # the run id too: a run (not only a block of it) is never on both sides...
        if not split_single:
            assert np.intersect1d(shipped_windows.run_ids[train],
                                  shipped_windows.run_ids[test]).size == 0
        tested[test] += 1
    assert (tested == 1).all()  # ... and every window is tested exactly once


def test_loro_leaves_one_run_out(shipped_windows):
    labels = shipped_windows.labels.astype(str)
    groups = shipped_windows.groups
    seen = []
    for train, test in iter_splits("loro", labels, groups, seed=0):
        _assert_no_shared_group(train, test, groups)
        (held,) = np.unique(groups[test])
        seen.append(held)
    assert sorted(seen) == sorted(np.unique(groups)) and len(seen) == 70


@pytest.mark.parametrize("seed", [0, 1])
def test_paper_protocol_is_sklearn_split_of_partitions(paper_windows, seed):
    labels = paper_windows.labels.astype(str)
    groups = paper_windows.groups
    units, first = np.unique(groups, return_index=True)
    skf = StratifiedKFold(5, shuffle=True, random_state=21 + seed)
    expected = [set(units[te]) for _, te in skf.split(units, labels[first])]
    got = []
    for train, test in iter_splits("paper", labels, groups, seed):
        _assert_no_shared_group(train, test, groups)  # partitions are never split
        got.append(set(groups[test]))
    assert got == expected
    assert PAPER_RANDOM_STATE == 21


def test_paper_protocol_leaks_runs_across_folds(paper_windows):
    """Documented weakness: partitions of one run land on both sides of a split."""
    labels = paper_windows.labels.astype(str)
    train, test = next(iter_splits("paper", labels, paper_windows.groups, 0))
    runs = paper_windows.run_ids
    assert np.intersect1d(runs[train], runs[test]).size > 0


def test_paper_partitions_hold_windows_of_one_run(paper_windows):
    for g in np.unique(paper_windows.groups):
        sel = paper_windows.groups == g
        assert len(set(paper_windows.run_ids[sel])) == 1
        assert paper_windows.t_end_s[sel].max() - paper_windows.t_start_s[sel].min() <= 5.0 + 1e-9


def test_unknown_protocol_is_rejected():
    with pytest.raises(ConfigError, match="grouped"):
        list(iter_splits("kfold", np.array(["A", "B"]), np.array(["a", "b"]), 0))


@pytest.mark.parametrize("protocol", ["grouped", "paper"])
def test_no_class_with_as_many_members_as_folds_is_a_config_error(protocol):
    # 6 units of 3 classes, 2 windows (and for paper 2 partitions) per class, 5 folds:
    # scikit-learn's stratified splitters raised a bare ValueError ("internal error" in the CLI)
    labels = np.repeat(["A", "B", "C"], 2)
    groups = np.array([f"u{i}" for i in range(6)])
    with pytest.raises(ConfigError, match="no class has as many"):
        list(iter_splits(protocol, labels, groups, 0, n_splits=5))


def test_leave_one_run_out_over_a_single_run_is_a_config_error():
    # scikit-learn's bare ValueError "LeaveOneGroupOut expects at least 2" reached the user
    labels, groups = np.array(["A", "B", "A"]), np.array(["r1", "r1", "r1"])
    with pytest.raises(ConfigError, match=r"leave one run out needs at least 2 runs, got 1 "
                                          r"\(\['r1'\]\)"):
        list(iter_splits("loro", labels, groups, 0))
    folds = list(iter_splits("loro", labels, np.array(["r1", "r1", "r2"]), 0))
    assert [(list(a), list(b)) for a, b in folds] == [([2], [0, 1]), ([0, 1], [2])]


def test_a_grouped_fold_left_without_test_runs_is_a_config_error():
    # 5 runs of 2 terrains (29, 44, 29 windows of A; 12, 10 of B), 5 folds: as many runs as
    # folds, yet StratifiedGroupKFold(5, seed 0) puts no run in one test fold, and fitting on
    # it reached the user as scikit-learn's bare "Found array with 0 sample(s)"
    sizes = [29, 44, 29, 12, 10]
    labels = np.repeat(["A", "A", "A", "B", "B"], sizes)
    groups = np.repeat([f"r{i}" for i in range(5)], sizes)
    with pytest.raises(ConfigError, match="no test run"):
        list(iter_splits("grouped", labels, groups, 0, n_splits=5))
    X = np.random.default_rng(0).standard_normal((len(labels), 3))
    t = np.arange(len(labels), dtype=float)
    with pytest.raises(ConfigError, match="no test run"):
        cross_validate(lambda seed: make_svm(), X, labels, groups, groups, t, t + 1.0,
                       seeds=(0,))
    # every fold of this split holds a test run: nothing refused
    assert all(len(test) for _, test in iter_splits("grouped", labels, groups, 0, n_splits=2))


def test_vulpi_windows_too_long_for_the_folds_are_a_config_error(vulpi_runs):
    # 45 s windows leave every Vulpi class fewer than 5 windows
    config = ExperimentConfig(dataset="vulpi", window_s=45.0, seeds=(0,))
    with pytest.raises(ConfigError, match="no class has as many windows"):
        run_cv(config, runs=vulpi_runs)


def test_single_dirt_road_run_is_cut_into_contiguous_blocks(vulpi_runs):
    ws = make_windows(vulpi_runs, "all", WindowConfig(window_s=1.0, rate_hz=50.0))
    labels = ws.labels.astype(str)
    groups, split = split_single_run_classes(labels, ws.groups, ws.t_start_s, n_blocks=5)
    assert split == ["DIRT_ROAD"]
    dirt = labels == "DIRT_ROAD"
    assert set(groups[dirt]) == {f"vulpi/DIRT_ROAD/1@block{k}" for k in range(5)}
    np.testing.assert_array_equal(groups[~dirt], ws.groups[~dirt])  # others untouched
    sizes = [np.sum(groups == f"vulpi/DIRT_ROAD/1@block{k}") for k in range(5)]
    assert max(sizes) - min(sizes) <= 1 and sum(sizes) == dirt.sum()
    spans = [(ws.t_start_s[groups == f"vulpi/DIRT_ROAD/1@block{k}"].min(),
              ws.t_end_s[groups == f"vulpi/DIRT_ROAD/1@block{k}"].max()) for k in range(5)]
    for (_, end), (start, _) in zip(spans, spans[1:]):
        assert end <= start + 1e-9  # blocks follow each other in time, never interleave


def test_cv_notes_the_blocks_actually_made_and_warns_below_two(vulpi_runs):
    # 30 s windows: the one CONCRETE run gives 1 window, DIRT_ROAD's gives 2 (of 5 blocks
    # asked); np.array_split's empty blocks are not blocks
    res = run_cv(ExperimentConfig(dataset="vulpi", signals=("wheels",), window_s=30.0,
                                  seeds=(0,)), vulpi_runs)
    notes = {c: [n for n in res.report.notes if n.startswith(f"class {c} has a single run")]
             for c in ("CONCRETE", "DIRT_ROAD")}
    assert len(notes["CONCRETE"]) == 1 and len(notes["DIRT_ROAD"]) == 1
    assert "cut into 1 contiguous time block(s) (of 5 asked)" in notes["CONCRETE"][0]
    assert "WARNING" in notes["CONCRETE"][0] and "generalisation" in notes["CONCRETE"][0]
    assert "cut into 2 contiguous time block(s) (of 5 asked)" in notes["DIRT_ROAD"][0]
    assert "WARNING" not in notes["DIRT_ROAD"][0]


@pytest.mark.slow
def test_loro_with_several_seeds_says_the_folds_repeat(vulpi_runs):
    config = dict(dataset="vulpi", signals=("wheels",), window_s=30.0, protocol="loro")
    twice = run_cv(ExperimentConfig(seeds=(0, 1), **config), vulpi_runs)
    folds = twice.report.folds
    assert len(folds) == 2 * len(folds[folds["seed"] == 0])
    first, second = (folds[folds["seed"] == s].reset_index(drop=True) for s in (0, 1))
    assert (first["n_test"] == second["n_test"]).all()   # the same runs held out, in order
    assert any(n.startswith("loro: leave-one-run-out folds are the same for all 2 seeds")
               for n in twice.report.notes)
    once = run_cv(ExperimentConfig(seeds=(0,), **config), vulpi_runs)
    assert not any(n.startswith("loro:") for n in once.report.notes)


# --- metrics ---------------------------------------------------------------------------------

def test_window_metrics_on_a_known_confusion():
    y_true = ["A", "A", "A", "B", "B", "C"]
    y_pred = ["A", "A", "B", "B", "C", "C"]
    m = window_metrics(y_true, y_pred, ["A", "B", "C", "D"])
    assert m["accuracy"] == pytest.approx(4 / 6)
    assert m["recall_A"] == pytest.approx(2 / 3)
    assert m["recall_B"] == pytest.approx(1 / 2)
    assert m["recall_C"] == pytest.approx(1.0)
    assert "recall_D" not in m   # absent from y_true
    assert m["balanced_accuracy"] == pytest.approx((2 / 3 + 1 / 2 + 1) / 3)
    # precision A 1, B 1/2, C 1/2 -> F1 0.8, 0.5, 2/3
    assert m["macro_f1"] == pytest.approx((0.8 + 0.5 + 2 / 3) / 3)
    cm = confusion(y_true, y_pred, ["A", "B", "C"])
    np.testing.assert_array_equal(cm.to_numpy(), [[2, 1, 0], [0, 1, 1], [0, 0, 1]])
    assert list(cm.index) == ["A", "B", "C"] and cm.index.name == "true"


def test_balanced_accuracy_equals_scikit_learn_without_its_warning():
    # a fold whose predictions hold a class its truth lacks (D): scikit-learn warns and drops
    # D; window_metrics gives the same figure silently
    import warnings

    from sklearn.metrics import balanced_accuracy_score
    y_true = ["A", "A", "A", "B", "B", "C", "C"]
    y_pred = ["A", "D", "B", "B", "C", "C", "D"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = window_metrics(y_true, y_pred, ["A", "B", "C", "D"])
    with pytest.warns(UserWarning, match="y_pred contains classes not in y_true"):
        expected = balanced_accuracy_score(y_true, y_pred)
    assert m["balanced_accuracy"] == pytest.approx(expected, abs=1e-15)
    assert m["balanced_accuracy"] == pytest.approx((1 / 3 + 1 / 2 + 1 / 2) / 3)
    # macro-F1 counts the predicted-only class D with F1 = 0, as scikit-learn's default does
    # (leaving it out put a Vulpi fold at 0.931 where scikit-learn says 0.698)
    from sklearn.metrics import f1_score
    assert m["macro_f1"] == pytest.approx(f1_score(y_true, y_pred, average="macro"),
                                          abs=1e-15)
    assert m["macro_f1"] == pytest.approx((0.5 + 0.5 + 0.5 + 0.0) / 4)


def test_run_majority_accuracy_on_a_hand_example():
    groups = ["r1", "r1", "r1", "r2", "r2", "r2", "r3", "r3"]
    y_true = ["A", "A", "A", "B", "B", "B", "C", "C"]
    y_pred = ["A", "A", "B", "A", "A", "B", "C", "B"]  # r1 right, r2 wrong, r3 tie -> "B"
    vote = majority_vote(y_pred, groups)
    assert vote.to_dict() == {"r1": "A", "r2": "A", "r3": "B"}
    assert run_majority_accuracy(y_true, y_pred, groups) == pytest.approx(1 / 3)
    assert run_majority_accuracy(y_true, y_true, groups) == 1.0
    # one prediction short: pandas's bare "All arrays must be of the same length" before
    with pytest.raises(ShapeError, match=r"lengths \(8, 7, 8\)"):
        run_majority_accuracy(y_true, y_pred[:-1], groups)


# --- cross_validate: planted effect and null case ----------------------------------------------

def _planted(n_runs=12, per_run=20, effect=3.0, seed=0):
    """Two classes, alternate runs; feature 0 is +-effect by class, the rest is noise."""
    rng = np.random.default_rng(seed)
    run = np.repeat(np.arange(n_runs), per_run)
    y = np.where(run % 2 == 0, "ASPHALT", "SNOW").astype(object)
    X = rng.standard_normal((run.size, 4))
    X[:, 0] = np.where(y == "ASPHALT", -effect, effect) + 0.3 * rng.standard_normal(run.size)
    groups = np.array([f"sim/T/{r:02d}" for r in run], dtype=object)
    t0 = np.tile(np.arange(per_run) * 2.0, n_runs)
    return X, y, groups, t0


def test_planted_effect_is_found():
    X, y, groups, t0 = _planted()
    report = cross_validate(lambda seed: make_svm(SVMConfig(), seed), X, y, groups, groups,
                            t0, t0 + 2.0, protocol="grouped", seeds=(0, 1), n_splits=3)
    assert report.classes == ["ASPHALT", "SNOW"]
    assert (report.folds["accuracy"] == 1.0).all()
    assert (report.pooled["accuracy"] == 1.0).all()
    assert (report.pooled["run_majority_accuracy"] == 1.0).all()
    assert len(report.folds) == 6 and len(report.predictions) == 2 * len(y)
    assert report.confusion.to_numpy().trace() == 2 * len(y)
    assert report.summary()["accuracy"]["min"] == 1.0
    # each fold fits on the runs it does not test, all of them (group ids recorded at fit;
    # before, the check was set(groups) - tested against tested: true whatever was fitted)
    log = _Log()
    group_id = np.array([int(g.rsplit("/", 1)[1]) for g in groups])
    report = cross_validate(lambda seed: Pipeline([("record", RecordGroups(log)),
                                                   *make_svm(SVMConfig(), seed).steps]),
                            np.column_stack([group_id, X]), y, groups, groups, t0, t0 + 2.0,
                            protocol="grouped", seeds=(0, 1), n_splits=3)
    tested = [frozenset(group_id[np.isin(groups, p["group"])].tolist())
              for _, p in report.predictions.groupby(["seed", "fold"], sort=False)]
    assert len(log.fits) == len(tested) == 6
    for fitted, test in zip(log.fits, tested):
        assert fitted and fitted.isdisjoint(test) and fitted | test == set(group_id)


def test_shuffled_labels_stay_near_chance():
    X, y, groups, t0 = _planted()
    y_null = np.random.default_rng(1).permutation(y)
    report = cross_validate(lambda seed: make_svm(SVMConfig(), seed), X, y_null, groups,
                            groups, t0, t0 + 2.0, protocol="grouped", seeds=(0, 1, 2),
                            n_splits=3)
    acc = report.pooled["accuracy"].to_numpy()
    assert abs(acc.mean() - 0.5) < 0.1, acc


def test_grouped_cv_is_not_fooled_by_run_fingerprints():
    """Features that identify the run but not the terrain: grouped CV gives chance while
    splitting partitions of runs (the papers' protocol) reports a leak-driven high score."""
    rng = np.random.default_rng(2)
    n_runs, per_run = 32, 20
    run = np.repeat(np.arange(n_runs), per_run)
    labels_of_run = rng.permutation(np.repeat(["A", "B"], n_runs // 2))
    y = labels_of_run[run]
    X = 4.0 * rng.standard_normal((n_runs, 3))[run] + 0.2 * rng.standard_normal((run.size, 3))
    runs = np.array([f"r{r:02d}" for r in run], dtype=object)
    partitions = np.array([f"r{r:02d}#{k // 5}" for r, k in
                           zip(run, np.tile(np.arange(per_run), n_runs))], dtype=object)
    t0 = np.zeros(run.size)
    factory = (lambda seed: make_svm(SVMConfig(), seed))
    grouped = cross_validate(factory, X, y, runs, runs, t0, t0, "grouped", (0, 1, 2), 4)
    paper = cross_validate(factory, X, y, partitions, runs, t0, t0, "paper", (0,), 5)
    assert grouped.pooled["accuracy"].mean() < 0.7
    assert paper.pooled["accuracy"].mean() > 0.9


class _SignOfFirstFeature(ClassifierMixin, BaseEstimator):
    """Predicts "A" where feature 0 is > 0, else "B" (whatever it was fitted on)."""

    def fit(self, X, y):
        self.classes_ = np.unique(y)
        return self

    def predict(self, X):
        return np.where(np.asarray(X)[:, 0] > 0, "A", "B")


def test_run_vote_is_per_split_unit_in_every_fold_and_pooled():
    # 6 runs, each cut into 2 split units of 4 windows: the first unit predicted right, the
    # second 3 times wrong. A unit's vote is right only for the first unit; a run's vote
    # (5 right of 8 windows) would always be right
    n_runs, per_unit = 6, 4
    run = np.repeat(np.arange(n_runs), 2 * per_unit)
    unit = np.repeat(np.arange(2 * n_runs), per_unit)
    y = np.where(run % 2 == 0, "A", "B")
    sign = np.where(y == "A", 1.0, -1.0)
    wrong = (unit % 2 == 1) & (np.tile(np.arange(per_unit), 2 * n_runs) < 3)
    X = np.where(wrong, -sign, sign)[:, None]
    runs = np.array([f"r{r}" for r in run], dtype=object)
    groups = np.array([f"r{u // 2}@block{u % 2}" for u in unit], dtype=object)
    t0 = np.tile(np.arange(2 * per_unit) * 2.0, n_runs)
    # (units cutting runs of classes with several runs are the paper protocol's partitions:
    # the run-grouped protocols refuse them, test_run_units_mdl31_review.py)
    report = cross_validate(lambda seed: _SignOfFirstFeature(), X, y, groups, runs, t0,
                            t0 + 2.0, "paper", seeds=(0,), n_splits=3)
    assert report.pooled["run_majority_accuracy"].iloc[0] == pytest.approx(1 / 2)
    both_units_tested = False
    for (_, fold), p in report.predictions.groupby(["seed", "fold"]):
        units = p["group"].unique()
        right = sum(u.endswith("@block0") for u in units)
        row = report.folds[report.folds["fold"] == fold].iloc[0]
        assert row["run_majority_accuracy"] == pytest.approx(right / len(units))
        both_units_tested |= p.groupby("run")["group"].nunique().max() == 2
    assert both_units_tested   # a fold where a run's vote would differ from its units'


def test_probabilities_keep_their_class_columns_when_a_fold_trains_without_a_class():
    from sklearn.linear_model import LogisticRegression

    # class A has a single run: the fold testing it trains on B and C only, whose model's
    # columns (B, C) must land in proba_B and proba_C, with proba_A = 0
    rng = np.random.default_rng(0)
    run_labels = ["A"] + ["B"] * 4 + ["C"] * 4
    y = np.repeat(run_labels, 10)
    runs = np.repeat([f"r{i}" for i in range(len(run_labels))], 10).astype(object)
    centres = {"A": 0.0, "B": -4.0, "C": 4.0}
    X = np.array([centres[c] for c in y])[:, None] + rng.normal(0, 0.5, (y.size, 1))
    t0 = np.tile(np.arange(10) * 2.0, len(run_labels))
    report = cross_validate(lambda seed: LogisticRegression(), X, y, runs, runs, t0,
                            t0 + 2.0, "grouped", seeds=(0,), n_splits=3)
    pred = report.predictions
    proba = pred[["proba_A", "proba_B", "proba_C"]].to_numpy()
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    assert (np.array(["A", "B", "C"])[proba.argmax(axis=1)] == pred["predicted"]).all()
    tested_a = pred["fold"] == pred.loc[pred["true"] == "A", "fold"].iloc[0]
    assert (pred.loc[tested_a, "proba_A"] == 0.0).all()
    assert (pred.loc[pred["true"] == "B", "predicted"] == "B").all()
    assert (pred.loc[pred["true"] == "C", "predicted"] == "C").all()


def test_a_split_unit_on_both_sides_of_a_split_stops_the_cross_validation(monkeypatch):
    import terrain.models.cv as cv

    X, y, groups, t0 = _planted(n_runs=4, per_run=4)
    # a broken splitter that puts the first window of the test run into training too
    leaky = (lambda *args, **kwargs: iter([(np.arange(0, 9), np.arange(8, 16))]))
    monkeypatch.setattr(cv, "iter_splits", leaky)
    with pytest.raises(RuntimeError, match="both sides"):
        cross_validate(lambda seed: make_svm(SVMConfig(), seed), X, y, groups, groups, t0,
                       t0 + 2.0, "grouped", seeds=(0,), n_splits=2)


# --- nested search sees training groups only ---------------------------------------------------

class _Log:
    """Shared record of fits; survives ``clone`` (deep copies return the same log)."""

    def __init__(self):
        self.fits: list[frozenset] = []

    def __deepcopy__(self, memo):
        return self


class RecordGroups(TransformerMixin, BaseEstimator):
    """Pipeline step recording the groups (column 0 of X) of every fit, then dropping them."""

    def __init__(self, log=None):
        self.log = log

    def fit(self, X, y=None):
        self.log.fits.append(frozenset(np.unique(X[:, 0]).astype(int).tolist()))
        return self

    def transform(self, X):
        return X[:, 1:]


def test_nested_search_only_sees_training_groups():
    X, y, groups, t0 = _planted(n_runs=12)
    group_id = np.array([int(g.rsplit("/", 1)[1]) for g in groups])
    Xg = np.column_stack([group_id, X])
    config = SVMConfig(search_C=(1.0, 10.0), search_gamma=("scale",), inner_splits=3)
    log = _Log()

    def factory(seed):
        search = make_search(config, seed)
        return search.set_params(estimator=Pipeline([("record", RecordGroups(log)),
                                                     *search.estimator.steps]))

    report = cross_validate(factory, Xg, y, groups, groups, t0, t0 + 2.0, "grouped",
                            seeds=(0,), n_splits=3, search=True)
    assert (report.pooled["accuracy"] == 1.0).all()
    assert set(report.folds["best_svc__C"]) <= {1.0, 10.0}
    per_fold = 2 * 3 + 1  # candidates x inner folds, then the refit
    splits = list(iter_splits("grouped", y.astype(str), groups, 0, 3))
    assert len(log.fits) == len(splits) * per_fold
    for k, (train, test) in enumerate(splits):
        fits = log.fits[k * per_fold:(k + 1) * per_fold]
        train_ids, test_ids = set(group_id[train]), set(group_id[test])
        assert all(f.isdisjoint(test_ids) for f in fits)
        assert fits[-1] == train_ids                        # refit on every training run
        assert all(f < train_ids for f in fits[:-1])        # inner fits: a subset of them
        assert set().union(*fits[:-1]) == train_ids


def test_run_cv_search_tunes_each_fold_on_its_training_units(vulpi_runs):
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,), search=True,
                              n_splits=3, svm=SVMConfig(search_C=(1.0, 10.0),
                                                        search_gamma=("scale",),
                                                        inner_splits=3))
    folds = run_cv(config, runs=vulpi_runs).report.folds
    assert len(folds) == 3 and set(folds["best_svc__C"]) <= {1.0, 10.0}


def test_overlapping_windows_never_straddle_time_blocks_of_a_single_run_class():
    # one run, windows 2 s long every 0.5 s: blocks would share samples without the purge
    t0 = np.arange(0, 40, 0.5)
    t1 = t0 + 2.0
    labels = np.full(t0.size, "DIRT_ROAD", dtype=object)
    runs = np.full(t0.size, "v/DIRT_ROAD/1", dtype=object)
    groups, split = split_single_run_classes(labels, runs.copy(), t0, n_blocks=4)
    assert split == ["DIRT_ROAD"]
    keep = purge_block_overlaps(groups, runs, t0, t1)
    assert 0 < (~keep).sum() <= 3 * 3  # at most (window/hop - 1) windows per boundary
    g, a, b = groups[keep], t0[keep], t1[keep]
    for i in range(len(g)):
        other = g != g[i]
        assert not np.any((a[other] < b[i]) & (b[other] > a[i])), "windows of two blocks overlap"
    # non-overlapping windows lose nothing
    t0 = np.arange(0, 40, 2.0)
    groups, _ = split_single_run_classes(labels[:20], runs[:20].copy(), t0, n_blocks=4)
    assert purge_block_overlaps(groups, runs[:20], t0, t0 + 2.0).all()


def _one_run_windows(hop_s: float) -> WindowSet:
    t0 = np.arange(0, 40, hop_s)
    n = t0.size
    run = np.full(n, "v/DIRT_ROAD/1", dtype=object)
    return WindowSet(np.zeros((n, 1, 4)), ("wz",), run, run.copy(), np.full(n, "DIRT_ROAD"),
                     t0, t0 + 2.0, 2.0, {})


def test_grouped_units_splits_and_purges_as_terrain_cv_does():
    # the single run above as a WindowSet: blocks and the purge in one call
    ws = _one_run_windows(0.5)
    kept, labels, groups, split, n_dropped = grouped_units(ws, 4)
    groups_all, _ = split_single_run_classes(ws.labels.astype(str), ws.groups, ws.t_start_s, 4)
    keep = purge_block_overlaps(groups_all, ws.run_ids, ws.t_start_s, ws.t_end_s)
    assert split == ["DIRT_ROAD"] and n_dropped == int((~keep).sum()) > 0
    assert np.array_equal(kept.t_start_s, ws.t_start_s[keep])
    assert np.array_equal(groups, groups_all[keep])
    assert len(labels) == len(kept) and labels.dtype.kind == "U"
    # non-overlapping windows: nothing dropped, the same WindowSet back rather than a copy
    ws = _one_run_windows(2.0)
    kept, _, _, _, n_dropped = grouped_units(ws, 4)
    assert kept is ws and n_dropped == 0


@pytest.mark.parametrize("blocks", [0, 1, 2.5, True])
def test_single_run_blocks_below_two_are_refused_before_any_data(blocks):
    from terrain.models.compare import CompareConfig

    # 0 reached NumPy's bare ValueError in np.array_split once the windows were cut
    with pytest.raises(ConfigError, match="single_run_blocks"):
        ExperimentConfig(single_run_blocks=blocks)
    with pytest.raises(ConfigError, match="single_run_blocks"):
        CompareConfig(models=("svm",), single_run_blocks=blocks)
    assert ExperimentConfig(single_run_blocks=2).single_run_blocks == 2


def test_summary_says_over_how_many_folds_each_metric_is_averaged():
    """A class with 2 runs among 5 folds is tested in 2 of them: its recall's mean (0.225)
    was over those 2 only, next to metrics over all 5, with nothing saying so."""
    rng = np.random.default_rng(0)
    per_run = 20
    runs = [("ASPHALT", i) for i in range(6)] + [("SNOW", i) for i in range(6)] + \
        [("MUD", i) for i in range(2)]
    y = np.repeat([c for c, _ in runs], per_run).astype(object)
    groups = np.repeat([f"sim/{c}/{i:02d}" for c, i in runs], per_run).astype(object)
    X = rng.standard_normal((y.size, 4))
    X[:, 0] += np.select([y == "ASPHALT", y == "SNOW"], [-2.0, 2.0], 0.0)
    t0 = np.tile(np.arange(per_run) * 2.0, len(runs))
    report = cross_validate(lambda seed: make_svm(SVMConfig(), seed), X, y, groups, groups,
                            t0, t0 + 2.0, protocol="grouped", seeds=(0,), n_splits=5)
    summary = report.summary()
    held = int(report.folds["recall_MUD"].notna().sum())
    assert held == 2 and summary["recall_MUD"]["n_folds"] == held
    assert summary["recall_MUD"]["mean"] == pytest.approx(report.folds["recall_MUD"].mean())
    assert summary["recall_ASPHALT"]["n_folds"] == summary["accuracy"]["n_folds"] == 5


def test_a_search_over_fewer_runs_than_its_inner_folds_is_a_config_error():
    """Two runs for 3 inner folds reached scikit-learn's bare ValueError ('Cannot have
    number of splits n_splits=3 greater than the number of groups: 2'), no groups its
    'number of groups: 1'."""
    X, y, groups, _ = _planted(n_runs=2)
    search = make_search(SVMConfig(search_C=(1.0,), search_gamma=("scale",)))
    with pytest.raises(ConfigError, match=r"3 inner folds \(SVMConfig.inner_splits\).* 2 runs "
                                          r"\(runs sim/T/00, sim/T/01\) and needs at least 3"):
        search.fit(X, y, groups=groups)
    with pytest.raises(ConfigError, match=r"0 runs \(no groups given\)"):
        search.fit(X, y)
    X, y, groups, _ = _planted(n_runs=6)                 # enough: fits, as before
    assert make_search(SVMConfig(search_C=(1.0,), search_gamma=("scale",))).fit(
        X, y, groups=groups).best_params_["svc__C"] == 1.0


def test_cv_notes_the_run_tails_not_windowed(vulpi_runs):
    # the notes listed the windows dropped for gaps or unsteady motion, not the run time
    # after each run's last full window, which the input report shows (30 s windows over
    # the 15 Vulpi runs leave 232.1 s of tails)
    res = run_cv(ExperimentConfig(dataset="vulpi", signals=("wheels",), window_s=30.0,
                                  seeds=(0,)), vulpi_runs)
    tail = res.counts["window_tail_s"]
    assert tail > 30.0 and res.counts["partition_tail_s"] == 0.0
    note = f"not windowed: {tail:.1f} s of run tails after the last full window in 15 run(s)"
    assert note == "not windowed: 232.1 s of run tails after the last full window in 15 run(s)"
    assert note in res.report.notes and note in res.input_notes
    assert not any("last full partition" in n for n in res.report.notes)


def test_cv_notes_the_time_between_windows_of_a_long_hop(vulpi_runs):
    # `terrain cv --window-s 2 --hop-s 10` leaves 8 s between two windows out of every count
    res = run_cv(ExperimentConfig(dataset="vulpi", signals=("wheels",), window_s=2.0,
                                  hop_s=10.0, seeds=(0,)), vulpi_runs)
    between = res.counts["between_windows_s"]
    assert between == pytest.approx(448.0)     # 8 s between each pair of a run's windows
    # (one of the 15 runs holds a single window, so nothing between two)
    note = ("not windowed: 448.0 s between windows (a hop longer than the window) in 14 "
            "run(s)")
    assert note in res.report.notes and note in res.input_notes
