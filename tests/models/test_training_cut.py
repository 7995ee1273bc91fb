"""Training on a denser (overlapping) cut of the training runs: no test sample leaks in."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin

from features.windows import WindowConfig, make_windows
from terrain.errors import ConfigError
from terrain.models.compare import CompareConfig
from terrain.models.cv import (TrainingWindows, cross_validate, purge_block_overlaps,
                               split_single_run_classes, training_units)
from terrain.models.experiment import ExperimentConfig, run_cv


def recorder_class(seen: list) -> type:
    """A classifier class that predicts the majority class and appends to ``seen`` the row
    ids (column 0) of every fit. The list is the calling test's own: a clone of an instance
    (as the cross-validation makes) is of the same class and records into it too."""

    class Recorder(ClassifierMixin, BaseEstimator):
        def fit(self, X, y):
            seen.append(np.asarray(X)[:, 0].astype(int).copy())
            self.classes_ = np.unique(y)
            values, counts = np.unique(y, return_counts=True)
            self.majority_ = values[np.argmax(counts)]
            return self

        def predict(self, X):
            return np.full(len(X), self.majority_)

    return Recorder


@pytest.fixture(scope="module")
def vulpi_cuts(vulpi_runs):
    """Vulpi wheel windows: the non-overlapping evaluation cut (DIRT_ROAD, a single run, cut
    into 5 time blocks) and a 0.5 s training cut of the same runs."""
    ev = make_windows(vulpi_runs, "wheels", WindowConfig(window_s=2.0, rate_hz=15.0))
    labels = ev.labels.astype(str)
    groups, split = split_single_run_classes(labels, ev.groups, ev.t_start_s, 5)
    keep = purge_block_overlaps(groups, ev.run_ids, ev.t_start_s, ev.t_end_s)
    dense = make_windows(vulpi_runs, "wheels", WindowConfig(window_s=2.0, hop_s=0.5,
                                                            rate_hz=15.0))
    return ev.subset(keep), labels[keep], groups[keep], split, dense


def test_units_follow_runs_and_blocks(vulpi_cuts):
    ev, labels, groups, split, dense = vulpi_cuts
    assert split == ["DIRT_ROAD"]
    units = training_units(ev.run_ids, ev.t_start_s, ev.t_end_s, groups, dense.run_ids,
                           dense.t_start_s, dense.t_end_s)
    assert len(dense) > 3.5 * len(ev)                      # 4x the windows at a quarter hop
    whole = ~np.char.startswith(np.asarray(dense.run_ids, dtype=str), "vulpi/DIRT_ROAD")
    # a run that is one unit: every window of it, under the run's own unit
    assert all(u == r for u, r in zip(units[whole], np.asarray(dense.run_ids)[whole]))
    # the blocked run: each used window lies inside the span of its own block only
    idx = np.flatnonzero(~whole)
    used = [i for i in idx if units[i] is not None]
    assert 0 < len(used) < len(idx)                        # the straddling ones are dropped
    for i in used:
        for block in np.unique(groups[groups != units[i]]):
            other = groups == block
            if not np.any(np.asarray(ev.run_ids)[other] == dense.run_ids[i]):
                continue
            overlap = ((ev.t_start_s[other] < dense.t_end_s[i] - 1e-9)
                       & (ev.t_end_s[other] > dense.t_start_s[i] + 1e-9))
            assert not overlap.any()


def test_folds_train_only_on_training_units(vulpi_cuts):
    ev, labels, groups, _, dense = vulpi_cuts
    units = training_units(ev.run_ids, ev.t_start_s, ev.t_end_s, groups, dense.run_ids,
                           dense.t_start_s, dense.t_end_s)
    row_id = np.arange(len(dense), dtype=float)[:, None]
    training = TrainingWindows(row_id, dense.labels.astype(str), units)
    seen: list = []
    recorder = recorder_class(seen)
    report = cross_validate(lambda s: recorder(), np.zeros((len(ev), 1)), labels, groups,
                            ev.run_ids, ev.t_start_s, ev.t_end_s, seeds=(0,), n_splits=3,
                            training=training)
    assert len(seen) == 3
    for (_, fold), rows in zip(report.predictions.groupby("fold"), seen):
        test_units = set(fold["group"])
        assert not test_units & {units[i] for i in rows}   # nothing of a test unit
        expected = {i for i, u in enumerate(units) if u is not None and u not in test_units}
        assert set(rows.tolist()) == expected              # everything else that is usable
    assert report.folds["n_train"].sum() == sum(len(r) for r in seen)
    assert (report.folds["n_test"].sum() == len(ev))       # the test windows are unchanged


def test_run_cv_with_a_training_cut(vulpi_runs):
    plain = run_cv(ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,)),
                   runs=vulpi_runs)
    dense = run_cv(ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,),
                                    train_hop_s=1.0), runs=vulpi_runs)
    assert dense.n_windows == plain.n_windows             # same evaluation windows
    ratio = dense.report.folds["n_train"].sum() / plain.report.folds["n_train"].sum()
    assert 1.8 < ratio < 2.1                              # twice the windows at half the hop
    assert any("cut every 1 s" in note for note in dense.report.notes)
    assert dense.config.as_params()["train_hop_s"] == 1.0
    assert plain.config.as_params()["train_hop_s"] == 2.0


@pytest.mark.parametrize("bad", [dict(train_hop_s=0.0),
                                 dict(train_hop_s=0.5, protocol="paper")])
def test_training_cut_config_errors(bad):
    with pytest.raises(ConfigError):
        ExperimentConfig(**bad)
    with pytest.raises(ConfigError):
        CompareConfig(**({"windows_s": (1.7,)} if "protocol" in bad else {}), **bad)


def test_fit_pipeline_trains_on_the_training_cut(vulpi_runs):
    from terrain.models.experiment import fit_pipeline

    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,))
    _, plain, _ = fit_pipeline(config, runs=vulpi_runs)
    pipe, dense, _ = fit_pipeline(ExperimentConfig(dataset="vulpi", signals=("wheels",),
                                                   seeds=(0,), train_hop_s=1.0),
                                  runs=vulpi_runs)
    assert 1.8 < len(dense) / len(plain) < 2.1
    assert dense.X.shape[1:] == plain.X.shape[1:]          # same window, same served input
    assert pipe.named_steps["scale"].n_samples_seen_ == len(dense)   # fitted on every window
    assert pipe.predict_proba(plain.X[:3]).shape == (3, len(np.unique(plain.labels)))


@pytest.mark.slow
def test_compare_cell_with_a_training_cut():
    from terrain.models.compare import Cell, run_cell, summary_table

    config = CompareConfig(models=("svm",), signals=("wheels",), windows_s=(2.0,),
                           datasets=("vulpi",), seeds=(0,), n_splits=2, history=(1,))
    plain = run_cell(Cell("svm", "wheels", 2.0, "vulpi", 0), config)
    dense = run_cell(Cell("svm", "wheels", 2.0, "vulpi", 0, train_hop_s=1.0), config)
    assert len(dense["predictions"]) == len(plain["predictions"])      # same test windows
    assert 1.8 < dense["folds"]["n_train"].sum() / plain["folds"]["n_train"].sum() < 2.1
    table = summary_table(pd.DataFrame(plain["rows"] + dense["rows"]))
    assert sorted(table["train_hop_s"]) == [1.0, 2.0]                  # two rows, keyed


def test_one_terrain_class_is_a_typed_error_naming_it(vulpi_runs):
    # a dataset converted from one terrain folder: scikit-learn's "number of classes has
    # to be greater than one" reached the CLI as an internal error
    from terrain.models.experiment import fit_pipeline

    one = [r for r in vulpi_runs if r.terrain == "PLOUGHED"]
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,))
    for call in (run_cv, fit_pipeline):
        with pytest.raises(ConfigError, match=r"1 terrain class\(es\) \['PLOUGHED'\] "
                                              r"\(runs \['vulpi/PLOUGHED/1'.*two at least"):
            call(config, runs=one)


def test_no_window_left_is_a_typed_error_in_training_as_in_cv(vulpi_runs):
    # `terrain train --dataset vulpi --model svm --window-s 1000` (every run shorter than the
    # window) was an internal error: scikit-learn's "found 0 windows" ValueError, exit 1
    from terrain.models.experiment import fit_pipeline

    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,),
                              window_s=1000.0)
    for call in (run_cv, fit_pipeline):
        with pytest.raises(ConfigError, match=r"no window left .*1000 s"):
            call(config, runs=vulpi_runs)


def test_no_window_left_names_the_paper_windows_it_cut(vulpi_runs):
    # the paper protocol cuts 1.7 s windows inside 5 s partitions: runs of 3 s hold none, and
    # the message named the unused default window_s ("2 s windows") instead
    from dataclasses import replace

    from terrain.models.experiment import fit_pipeline
    from terrain.run import TIME

    short = [replace(r, streams={k: f[f[TIME] < f[TIME].iloc[0] + 3.0]
                                 for k, f in r.streams.items()}) for r in vulpi_runs]
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,),
                              protocol="paper")
    for call in (run_cv, fit_pipeline):
        with pytest.raises(ConfigError, match=r"no window left .*1\.7 s windows in 5 s "
                                              r"partitions"):
            call(config, runs=short)


@pytest.mark.parametrize("given", [dict(window_s=3.0), dict(hop_s=1.0), dict(window_s=1.0,
                                                                             hop_s=0.1)])
def test_paper_protocol_refuses_window_options_it_would_ignore(given):
    # the paper protocol always cuts 1.7 s windows every 0.1 s: a --window-s 3 --hop-s 1 ran
    # on those and printed its results without a word
    with pytest.raises(ConfigError, match="paper protocol fixes its windows"):
        ExperimentConfig(protocol="paper", **given)
    assert ExperimentConfig(protocol="paper", window_s=1.7, hop_s=0.1).window_config() \
        == ExperimentConfig(protocol="paper").window_config()


def test_cv_paper_protocol_refuses_an_explicit_window_length(capsys):
    from terrain.cli import main
    assert main(["cv", "--dataset", "vulpi", "--protocol", "paper", "--window-s", "2"]) == 2
    assert "paper protocol fixes its windows" in capsys.readouterr().err


@pytest.mark.slow
def test_paper_protocol_says_its_vote_is_per_partition(vulpi_runs):
    res = run_cv(ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,),
                                  protocol="paper"), runs=vulpi_runs, progress=False)
    assert any("votes per 5 s partition" in note for note in res.report.notes)
    # and the run time after each run's last full partition, which no window is cut from
    tail = res.counts["partition_tail_s"]
    assert tail > 0 and (f"not windowed: {tail:.1f} s of run tails after the last full "
                         "partition (partition protocol) in ") in " ".join(res.input_notes)


def _record_search_fit(monkeypatch) -> dict:
    """Make ``fit_pipeline``'s grid search record what it is fitted on: the returned dict gets
    ``y``, ``groups`` (its split units) and ``cv`` (its inner splitter) at the fit."""
    from terrain.models import experiment

    seen = {}
    real = experiment.make_search

    def spy(*args, **kwargs):
        search = real(*args, **kwargs)
        fit = search.fit

        def record(X, y, groups=None, **params):
            seen.update(y=np.asarray(y), groups=np.asarray(groups), cv=search.cv)
            return fit(X, y, groups=groups, **params)
        search.fit = record
        return search

    monkeypatch.setattr(experiment, "make_search", spy)
    return seen


def test_fit_pipeline_search_splits_a_single_run_class_as_run_cv_does(vulpi_runs,
                                                                      monkeypatch):
    """terrain train --search grouped its inner folds by run: Vulpi's DIRT_ROAD (one run)
    was in the test side of one of the 3 inner folds, whose training lacked it (all 40 of
    its windows scored with recall 0 by construction), and never tested in the other two.
    The search now splits the units run_cv splits (grouped_units: the class's run cut into
    single_run_blocks time blocks), so every inner fold trains and tests every class."""
    from terrain.models import experiment
    from terrain.models.svm import SVMConfig

    seen = _record_search_fit(monkeypatch)
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,), search=True,
                              svm=SVMConfig(search_C=(10.0,), search_gamma=("scale",)))
    _, ws, info = experiment.fit_pipeline(config, runs=vulpi_runs)
    y, groups = seen["y"], seen["groups"]
    for train, test in seen["cv"].split(np.zeros(len(y)), y, groups):
        assert set(y[train]) == set(y) and "DIRT_ROAD" in set(y[test])
    assert info["search_split_classes"] == "DIRT_ROAD"
    assert len(ws) >= len(y)          # the model itself is fitted on every window


def test_fit_pipeline_serves_the_searched_model_with_the_first_seed(vulpi_runs, monkeypatch):
    from terrain.models.experiment import fit_pipeline
    from terrain.models.svm import SVMConfig

    seen = _record_search_fit(monkeypatch)
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(7, 0), search=True,
                              single_run_blocks=4,
                              svm=SVMConfig(search_C=(3.0,), search_gamma=(0.01,)))
    pipe, _, info = fit_pipeline(config, runs=vulpi_runs)
    assert (info["best_C"], info["best_gamma"]) == (3.0, 0.01)
    svc = pipe.named_steps["svc"].estimator                  # inside the Platt calibration
    assert (svc.C, svc.gamma, svc.random_state) == (3.0, 0.01, 7)
    # the inner folds split the single-run class into the blocks asked, not the default 5
    assert len(set(seen["groups"][seen["y"] == "DIRT_ROAD"])) == 4
