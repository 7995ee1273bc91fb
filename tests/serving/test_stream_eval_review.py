"""Held-out stream evaluation (:mod:`terrain.serving.evaluation`): seeds honoured, pooling
weights and medians, run-grouped out-of-fold probabilities without leakage, per-run
accuracy, undecided decisions in the confusion, on small hand-made inputs."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.run import Run
from terrain.serving.evaluation import (Segment, concatenated_streams, grouped_oof_proba,
                                        pool_scores, score_stream, seed_accuracies,
                                        smooth_runs)
from terrain.serving.smoothing import SmoothingConfig


def _run(i: int, terrain: str, length_s: float = 60.0) -> Run:
    t = np.arange(0.0, length_s, 0.2)
    frame = pd.DataFrame({"t_s": t, "vel_l": 0.5, "vel_r": 0.5, "cur_l": 1.0, "cur_r": 1.0})
    return Run(f"syn/{terrain}/{i:02d}", "syn", terrain, {"wheels": frame})


def test_concatenated_streams_follow_their_seed():
    """Another seed gives another stream (order, stretches, lengths), not a fixed one."""
    runs = [_run(i, t, length_s=200.0) for i, t in enumerate(
        ("ICE", "SNOW", "ASPHALT", "ICE", "SNOW", "ASPHALT"))]
    streams = [concatenated_streams(runs, ("wheels",), seed)[1] for seed in range(6)]
    assert len({tuple(s.run_id for s in segs) for segs in streams}) > 1
    assert len({tuple(s.duration_s for s in segs) for segs in streams}) == 6
    # the stretch of a run is drawn inside it, not always its start
    starts = [s.t_from_s for segs in streams for s in segs]
    assert all(0.0 <= a <= 200.0 - 30.0 for a in starts)
    assert sum(a > 1.0 for a in starts) > len(starts) // 2


def _score_rows() -> pd.DataFrame:
    return pd.DataFrame([
        {"seed": 0, "accuracy": 1.0, "n_decisions": 100, "accuracy_settled": 1.0,
         "n_settled": 10, "delays_s": [1.0], "confusion": {"ICE": {"ICE": 100}}},
        {"seed": 0, "accuracy": 0.5, "n_decisions": 300, "accuracy_settled": 0.6,
         "n_settled": 290, "delays_s": [2.0, 30.0], "confusion": {"ICE": {"SNOW": 150,
                                                                          "ICE": 150}}},
        {"seed": 1, "accuracy": 0.8, "n_decisions": 50, "accuracy_settled": float("nan"),
         "n_settled": 0, "delays_s": [np.inf], "confusion": {"SNOW": {"SNOW": 40,
                                                                      "none": 10}}}])


def test_pooled_scores_weigh_each_decision_once_and_take_the_median_of_every_delay():
    pooled = pool_scores(_score_rows())
    assert pooled["accuracy"] == pytest.approx((100 * 1.0 + 300 * 0.5 + 50 * 0.8) / 450)
    # settled accuracy: weighted by the settled decisions, a fold without any left out
    assert pooled["accuracy_settled"] == pytest.approx((10 * 1.0 + 290 * 0.6) / 300)
    # the median of the four delays, not their mean (inf: a switch never followed)
    assert pooled["median_delay_s"] == pytest.approx(16.0) and pooled["n_switches"] == 4
    assert pooled["recall"] == {"ICE": 250 / 400, "SNOW": 40 / 50}


def test_seed_accuracies_weigh_each_fold_by_its_decisions():
    assert seed_accuracies(_score_rows()) == pytest.approx(
        {0: (100 * 1.0 + 300 * 0.5) / 400, 1: 0.8})


def test_a_row_without_decisions_has_no_weight_instead_of_making_the_pool_nan():
    # a row with n_decisions 0 has accuracy NaN; 0 x NaN made the pooled and the seed's
    # accuracy NaN where the other rows give 0.9
    rows = pd.DataFrame([
        {"seed": 0, "accuracy": 0.9, "n_decisions": 10, "accuracy_settled": 0.9,
         "n_settled": 10, "delays_s": [], "confusion": {"ICE": {"ICE": 9, "SNOW": 1}}},
        {"seed": 0, "accuracy": float("nan"), "n_decisions": 0,
         "accuracy_settled": float("nan"), "n_settled": 0, "delays_s": [], "confusion": {}}])
    assert pool_scores(rows)["accuracy"] == pytest.approx(0.9)
    assert seed_accuracies(rows) == {0: pytest.approx(0.9)}
    assert np.isnan(pool_scores(rows.iloc[[1]])["accuracy"])   # no decision at all: NaN


def test_undecided_decisions_are_counted_wrong_under_none():
    segs = [Segment("a", "ICE", 0.0, 0.0, 10.0), Segment("b", "SNOW", 0.0, 10.0, 10.0)]
    t = np.arange(0.0, 20.0, 1.0)
    decided = np.array([None] * 3 + ["ICE"] * 9 + ["SNOW"] * 8, dtype=object)
    score = score_stream(segs, t, decided)
    assert score.confusion == {"ICE": {"none": 3, "ICE": 7}, "SNOW": {"ICE": 2, "SNOW": 8}}
    assert score.accuracy == pytest.approx(15 / 20) and score.delays_s == (2.0,)


class _Memory:
    """1-nearest-neighbour on the first feature; remembers what it was trained on."""

    def __init__(self, fitted):
        self.fitted = fitted

    def fit(self, X, y, sample_weight=None):
        self.X, self.y = X[:, 0], np.asarray(y)
        self.classes_ = np.unique(self.y)
        self.fitted.append(set(X[:, 1].astype(int)))
        return self

    def predict_proba(self, X):
        near = self.y[np.abs(X[:, [0]] - self.X[None, :]).argmin(axis=1)]
        return (near[:, None] == self.classes_[None, :]).astype(float)


def test_out_of_fold_probabilities_come_from_models_that_never_saw_the_run():
    # every window carries its own index (column 1) and a feature unique to its run
    # (column 0): a model fitted on a test run's windows would recall them exactly
    rng = np.random.default_rng(0)
    groups = np.repeat([f"r{i}" for i in range(10)], 6)
    labels = np.where(np.repeat(np.arange(10), 6) % 2 == 0, "A", "B")
    F = np.column_stack([np.repeat(np.arange(10) * 10.0, 6) + rng.uniform(0, 1, 60),
                         np.arange(60)])
    fitted: list = []
    proba, classes = grouped_oof_proba(lambda s: _Memory(fitted), F, labels, groups, 0, 5)
    assert classes == ["A", "B"] and len(fitted) == 5
    held = np.array([[i not in seen for seen in fitted] for i in range(60)])
    assert (held.sum(axis=1) == 1).all()        # each window out of fold exactly once
    for k, seen in enumerate(fitted):
        test = np.flatnonzero(held[:, k])
        train = np.array(sorted(seen))
        # no run on both sides of a fold
        assert not set(groups[test]) & set(groups[train])
        # each row holds the fold model's output for that very window
        near = train[np.abs(F[test, 0][:, None] - F[train, 0][None, :]).argmin(axis=1)]
        want = (labels[near][:, None] == np.array(classes)[None, :]).astype(float)
        np.testing.assert_array_equal(proba[test], want)


def test_out_of_fold_columns_follow_the_class_names_when_a_fold_lacks_a_class():
    seen_classes = []

    class LastClass:
        def fit(self, X, y, sample_weight=None):
            self.classes_ = np.unique(y)
            seen_classes.append(tuple(self.classes_))
            return self

        def predict_proba(self, X):
            # all weight on the last class the fold was trained on
            out = np.zeros((len(X), len(self.classes_)))
            out[:, -1] = 1.0
            return out

    # class A has a single run: the fold testing it trains on B and C only
    groups = np.repeat(["a1", "b1", "b2", "c1", "c2"], 4)
    labels = np.repeat(["A", "B", "B", "C", "C"], 4)
    proba, classes = grouped_oof_proba(lambda s: LastClass(), np.zeros((20, 1)), labels, groups,
                                       0, 2)
    assert classes == ["A", "B", "C"] and ("B", "C") in seen_classes
    only_a = labels == "A"      # the run of A was tested by a model knowing B and C only
    np.testing.assert_array_equal(proba[only_a], np.tile([0.0, 0.0, 1.0], (4, 1)))


def test_smooth_runs_filters_each_run_in_time_order_whatever_the_row_order():
    config = SmoothingConfig(dwell_s=2.0, evidence_power=1.0)
    proba = np.array([[0.9, 0.1]] * 3 + [[0.3, 0.7]])
    t = np.arange(4) * 0.5
    want = smooth_runs(proba, np.zeros(4), t, 0.5, config)
    perm = np.array([3, 1, 0, 2])
    got = smooth_runs(proba[perm], np.zeros(4), t[perm], 0.5, config)
    np.testing.assert_array_equal(got, want[perm])
    # the confident windows come first in time: the last one is outweighed
    assert want.tolist() == [0, 0, 0, 0]


def test_window_cv_run_mean_accuracy_weighs_every_run_the_same(monkeypatch):
    # run r1: three windows, all right; run r2: one window, wrong. Pooled 3/4, run mean 1/2
    from terrain.serving import evaluation
    from terrain.serving.recipes import RECIPES

    class Windows:
        def __init__(self):
            self.labels = np.array(["ICE", "ICE", "ICE", "SNOW"])
            self.run_ids = np.array(["r1", "r1", "r1", "r2"])
            self.t_start_s = np.array([0.0, 0.5, 1.0, 0.0])
            self.X = np.zeros((4, 1))
            self.channels = ("c",)

        def __len__(self):
            return 4

    class Identity:
        def fit(self, X):
            return self

        def transform(self, X):
            return X

    proba = np.array([[0.9, 0.1]] * 4)
    monkeypatch.setattr(evaluation, "make_windows", lambda *a: Windows())
    monkeypatch.setattr(evaluation, "recipe_features", lambda *a: Identity())
    monkeypatch.setattr(evaluation, "grouped_oof_proba",
                        lambda *a, **k: (proba, ["ICE", "SNOW"]))
    cv = evaluation.window_cv([], RECIPES["wheels"], 0.5, [0],
                              {"raw": SmoothingConfig(dwell_s=None)}, n_splits=2)
    assert cv["pooled_accuracy"] == {"raw": 0.75}
    assert cv["run_mean_accuracy"] == {"raw": 0.5}
    assert cv["n_windows"] == 4 and cv["n_runs"] == 2


def test_held_out_streams_pass_their_seed_hop_gap_and_window_on(monkeypatch):
    """The classifier seed, the decision hop, the switch dropout and the recipe's window
    reach the fit, the replay, the stream and the scoring of every fold."""
    from terrain.serving import evaluation
    from terrain.serving.recipes import RECIPES

    runs = [_run(3 * k + i, t) for k, t in enumerate(("ICE", "SNOW", "ASPHALT"))
            for i in range(3)]
    fitted, replayed, scored = [], [], []

    class Model:
        classes = ("ASPHALT", "ICE", "SNOW")

    def fit(recipe, train, seed):
        fitted.append(seed)
        return Model()

    def replay(model, stream, hop_s):
        replayed.append((hop_s, stream.meta["segments"]))
        return np.zeros(1), np.full((1, 3), 1 / 3)

    def score(segments, t, proba, classes, config, hop_s, window_s):
        scored.append((hop_s, window_s, config))
        return evaluation.StreamScore(1.0, (), 1)

    monkeypatch.setattr(evaluation, "fit_stream_model", fit)
    monkeypatch.setattr(evaluation, "raw_decisions", replay)
    monkeypatch.setattr(evaluation, "score_smoothing", score)
    config = SmoothingConfig(dwell_s=3.0)
    recipe = RECIPES["wheels"]
    rows = evaluation.held_out_streams(runs, recipe, 7, {"f": config}, hop_s=0.25,
                                       n_splits=3, switch_gap_s=1.5)
    assert len(rows) == 3 and fitted == [7, 7, 7]
    assert scored == [(0.25, recipe.window_s, config)] * 3 and recipe.window_s > 0
    for hop_s, segments in replayed:
        assert hop_s == 0.25 and len(segments) == 3
        ends = [s["t_from_s"] + s["t_offset_s"] + s["duration_s"] for s in segments]
        starts = [s["t_from_s"] + s["t_offset_s"] for s in segments]
        np.testing.assert_allclose(np.subtract(starts[1:], ends[:-1]), 1.5, atol=1e-9)
