"""Score tables of the held-out streams: written as CSV and read back for pooling, also
from the tables logged before the JSON columns (numpy reprs), with typed errors."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError
from terrain.serving.evaluation import (StreamScore, encode_stream_scores, pool_scores,
                                        read_stream_scores, seed_accuracies, smooth_runs)
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig


def _rows():
    scores = [StreamScore(0.9, (np.float64(1.5), np.float64(np.inf)), 100, 0.95, 80,
                          {"ICE": {"ICE": 90, "SNOW": 10}}),
              StreamScore(0.8, (np.float64(0.5),), 300, 0.85, 200,
                          {"ICE": {"ICE": 40}, "SNOW": {"SNOW": 200, "none": 60}})]
    return pd.DataFrame([{"seed": i, "fold": 0, "smoothing": "f", **s.as_row()}
                         for i, s in enumerate(scores)])


def test_score_table_round_trips_through_csv(tmp_path):
    rows = _rows()
    path = tmp_path / "scores.csv"
    encode_stream_scores(rows).to_csv(path, index=False)
    back = read_stream_scores(path)
    assert back["delays_s"].tolist() == [[1.5, np.inf], [0.5]]
    assert back["confusion"].tolist() == rows["confusion"].tolist()
    assert pool_scores(back) == pool_scores(rows)
    assert pool_scores(back)["accuracy"] == pytest.approx((0.9 * 100 + 0.8 * 300) / 400)
    assert seed_accuracies(back) == {0: 0.9, 1: 0.8}


def test_tables_logged_with_numpy_reprs_are_read(tmp_path):
    path = tmp_path / "old.csv"
    pd.DataFrame({"accuracy": [0.9], "n_decisions": [10], "accuracy_settled": [0.9],
                  "n_settled": [10],
                  "delays_s": ["[np.float64(1.4), np.float64(2e-1), np.float64(inf)]"],
                  "confusion": ["{'ICE': {'ICE': 9, 'SNOW': 1}}"]}).to_csv(path, index=False)
    back = read_stream_scores(path)
    assert back["delays_s"][0] == [1.4, 0.2, np.inf]
    assert pool_scores(back)["recall"] == {"ICE": 0.9}


@pytest.mark.parametrize("column,bad", [("delays_s", "1.5"), ("confusion", "[1, 2]"),
                                        ("confusion", "{oops")])
def test_a_broken_cell_names_file_column_and_line(tmp_path, column, bad):
    frame = encode_stream_scores(_rows())
    frame.loc[1, column] = bad
    path = tmp_path / "broken.csv"
    frame.to_csv(path, index=False)
    with pytest.raises(DataFormatError, match=rf"{column}.*line 3") as err:
        read_stream_scores(path)
    assert err.value.path == str(path) and err.value.column == column


class _WzClassifier:
    """Deterministic probabilities from a window's mean yaw rate (three classes)."""

    classes_ = np.array(("ASPHALT", "ICE", "SNOW"))

    def predict_proba(self, X):
        k = np.floor(X[:, 0, :].mean(axis=1) * 10).astype(int) % 3
        out = np.full((len(X), 3), 0.1)
        out[np.arange(len(X)), k] = 0.8
        return out


@pytest.mark.slow
def test_offline_scoring_takes_unclassified_windows_as_the_live_service_does():
    # a 20 s stretch of accelerometer in g is not classified live (accel_units: the filter
    # only predicts); stream-eval's unsmoothed replay repeated the last probabilities there
    # and the offline filter folded them in again as fresh evidence
    from features.windows import WindowConfig
    from terrain.run import TIME, Run
    from terrain.serving.evaluation import filter_sequence, raw_decisions
    from terrain.serving.model import StreamModel
    from terrain.serving.replay import replay_run
    from terrain.serving.service import StreamConfig, StreamService
    from terrain.serving.smoothing import SmoothingConfig
    from terrain.serving.targets import CataloguePeakTargets

    rng = np.random.default_rng(0)
    t = np.arange(0.0, 120.0, 0.01)
    acc = np.column_stack([0.2 * rng.standard_normal(len(t)), 0.2 * rng.standard_normal(len(t)),
                           9.81 + 0.2 * rng.standard_normal(len(t))])
    acc[(t > 50) & (t < 70)] /= 9.81
    imu = pd.DataFrame({TIME: t, "wx": 0 * t, "wy": 0 * t,
                        "wz": 0.5 + 0.5 * np.sin(2 * np.pi * t / 37.0)
                        + 0.01 * rng.standard_normal(len(t)),
                        "ax": acc[:, 0], "ay": acc[:, 1], "az": acc[:, 2]})
    tw = np.arange(0.0, 120.0, 0.1)
    wheels = pd.DataFrame({TIME: tw, "vel_l": 0.5 + 0 * tw, "vel_r": 0.5 + 0 * tw,
                           "cur_l": 2.0 + 0 * tw, "cur_r": 2.0 + 0 * tw})
    run = Run("probe/ASPHALT/0", "probe", "ASPHALT", {"imu": imu, "wheels": wheels})
    classes = tuple(_WzClassifier.classes_)
    model = StreamModel(_WzClassifier(), ("wz", "ax", "ay", "az"),
                        WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=100.0), classes)
    config = SmoothingConfig()
    live = replay_run(StreamService(model, CataloguePeakTargets(classes),
                                    StreamConfig(hop_s=0.5, smoothing=config)), run)
    unclassified = np.array(["accel_units" in d.flags.split("|") for d in live])
    assert unclassified.sum() > 30
    t_s, proba = raw_decisions(model, run, 0.5)
    np.testing.assert_array_equal(t_s, [d.t_s for d in live])
    np.testing.assert_array_equal(np.isnan(proba).all(axis=1), unclassified)
    names = np.array(list(classes) + [None], dtype=object)
    np.testing.assert_array_equal(names[filter_sequence(proba, 0.5, config)],
                                  np.array([d.terrain for d in live], dtype=object))


def test_a_run_shorter_than_one_window_gives_no_decision_rows_not_a_reshape_error():
    # a 1.5 s run under 2 s windows: no decision, and proba.reshape(0, -1) raised numpy's
    # bare "cannot reshape array of size 0 into shape (0,newaxis)"
    from features.windows import WindowConfig
    from terrain.run import TIME, Run
    from terrain.serving.evaluation import raw_decisions
    from terrain.serving.model import StreamModel

    t = np.arange(0.0, 1.5, 0.01)
    imu = pd.DataFrame({TIME: t, "wx": 0 * t, "wy": 0 * t, "wz": 0.5 + 0 * t, "ax": 0 * t,
                        "ay": 0 * t, "az": 9.81 + 0 * t})
    run = Run("probe/ASPHALT/1", "probe", "ASPHALT", {"imu": imu})
    classes = tuple(_WzClassifier.classes_)
    model = StreamModel(_WzClassifier(), ("wz", "ax", "ay", "az"),
                        WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=100.0), classes)
    t_s, proba = raw_decisions(model, run, 0.5)
    assert t_s.shape == (0,) and proba.shape == (0, len(classes))


def test_window_cv_smooths_at_the_hop_its_windows_were_cut_at():
    # at the wheel recipe's 10 Hz a hop of 0.25 s is cut as 2 samples (0.2 s): the windows
    # of hop 0.25 and 0.2 are the same, but the filter was stepped as if 0.25 s apart
    # (p_switch 0.5 instead of 0.4 at a 0.5 s dwell), so the smoothed accuracies differed
    from dataclasses import replace

    from terrain.run import Run
    from terrain.serving.evaluation import window_cv
    from terrain.serving.recipes import RECIPES
    from terrain.serving.smoothing import SmoothingConfig

    def run(i, terrain, level):
        rng = np.random.default_rng(i)
        t = np.arange(0.0, 60.0, 0.1)
        v = 0.5 + 0.2 * np.sin(t / 3 + i) + 0.02 * rng.standard_normal(len(t))
        cur = level + 2.0 * v + 0.8 * rng.standard_normal(len(t))
        frame = pd.DataFrame({"t_s": t, "vel_l": v, "vel_r": v + 0.05 * np.sin(t / 5),
                              "cur_l": cur, "cur_r": cur + 0.3 * rng.standard_normal(len(t))})
        return Run(f"syn/{terrain}/{i:02d}", "syn", terrain, {"wheels": frame})

    runs = [run(i, "ICE" if i % 2 else "SNOW", 3.0 if i % 2 else 3.5) for i in range(6)]
    recipe = replace(RECIPES["wheels"], n_trees=20)
    smoothing = {"f": SmoothingConfig(dwell_s=0.5, evidence_power=1.0)}
    cut, exact = (window_cv(runs, recipe, hop, [0], smoothing, n_splits=2)
                  for hop in (0.25, 0.2))
    assert cut["n_windows"] == exact["n_windows"]
    assert cut["pooled_accuracy"] == exact["pooled_accuracy"]


def test_smooth_runs_gives_no_decision_for_a_first_window_without_evidence():
    # a run whose first window's probabilities are NaN: ForwardFilter.update gives no
    # decision (None), which smooth_runs wrote into its int array (TypeError), with the
    # filter on or off; it is now -1, no decision, as in filter_sequence, and a later NaN
    # window keeps the decision (prediction only)
    proba = np.array([[np.nan, np.nan], [0.2, 0.8], [np.nan, np.nan], [0.9, 0.1],
                      [np.inf, 0.0], [0.3, 0.7]])
    runs = np.array(["a", "a", "a", "a", "b", "b"])
    t = np.array([0.0, 0.5, 1.0, 1.5, 0.0, 0.5])
    for config in (SmoothingConfig(dwell_s=None), SmoothingConfig(dwell_s=0.5)):
        assert smooth_runs(proba, runs, t, 0.5, config).tolist() == [-1, 1, 1, 0, -1, 1]


def test_window_cv_counts_windows_without_a_decision_wrong_and_shows_them(monkeypatch):
    # window_cv indexed the class names with smooth_runs' decisions: a window without one
    # (-1) would have silently named the last class; it now counts as wrong, as stream-eval
    # scores an undecided window (score_stream: None), and is counted in n_undecided
    from terrain.serving import evaluation

    windows = _Windows(labels=np.array(["ICE", "ICE", "SNOW", "SNOW"]),
                       run_ids=np.array(["r1", "r1", "r2", "r2"]),
                       t_start_s=np.array([0.0, 0.5, 0.0, 0.5]), X=np.zeros((4, 1)),
                       channels=("c",))
    proba = np.array([[np.nan, np.nan], [0.9, 0.1], [np.nan, np.nan], [0.1, 0.9]])

    class Identity:
        def fit(self, X):
            return self

        def transform(self, X):
            return X

    monkeypatch.setattr(evaluation, "make_windows", lambda *a: windows)
    monkeypatch.setattr(evaluation, "recipe_features", lambda *a: Identity())
    monkeypatch.setattr(evaluation, "grouped_oof_proba",
                        lambda *a, **k: (proba, ["ICE", "SNOW"]))
    from terrain.serving.recipes import RECIPES

    cv = evaluation.window_cv([], RECIPES["wheels"], 0.5, [0, 1],
                              {"raw": SmoothingConfig(dwell_s=None),
                               "filter": SmoothingConfig()}, n_splits=2)
    assert cv["pooled_accuracy"] == {"raw": 0.5, "filter": 0.5}
    assert cv["run_mean_accuracy"] == {"raw": 0.5, "filter": 0.5}
    assert cv["n_undecided"] == {"raw": 4, "filter": 4}


class _Windows:
    """A stand-in for make_windows' result (attributes and length)."""

    def __init__(self, **fields):
        self.__dict__.update(fields)

    def __len__(self):
        return len(self.labels)


def test_smooth_runs_predicts_across_the_windows_a_run_lacks():
    # windows dropped inside a run (make_windows leaves out a window holding a gap) were
    # filtered as if one hop apart: 10 minutes without a window kept the old terrain's
    # belief (p 0.98 -> decided CLASS 0 against a window naming 1); the filter now takes the
    # missing hops' prediction steps, as the live service does (ForwardFilter.skip)
    config = SmoothingConfig(dwell_s=10.0)
    first, later = np.array([0.99, 0.01]), np.array([0.35, 0.65])
    proba = np.array([first, first, later])
    t = np.array([0.0, 0.5, 600.5])
    runs = np.array(["a", "a", "a"])
    ref = ForwardFilter(2, 0.5, config)
    ref.update(first)
    ref.update(first)
    ref.skip(1199)
    assert smooth_runs(proba, runs, t, 0.5, config).tolist() == [0, 0, ref.update(later)[0]]
    assert ref.current == 1
    # windows one hop apart (up to round-off) are filtered as before
    t_even = np.array([0.0, 0.5, 1.0 + 1e-9])
    plain = ForwardFilter(2, 0.5, config)
    assert smooth_runs(proba, runs, t_even, 0.5, config).tolist() == \
        [plain.update(q)[0] for q in proba]


def test_smooth_runs_takes_no_prediction_step_between_windows_one_hop_apart():
    # one extra prediction step per window (lambda 0.5 at a 2 s dwell, 0.5 s hop, K = 2)
    # halves the memory of the confident windows: the fourth window then decides class 1
    config = SmoothingConfig(dwell_s=2.0, evidence_power=1.0)
    proba = np.array([[0.9, 0.1]] * 3 + [[0.3, 0.7]])
    t = np.arange(4) * 0.5
    ref = ForwardFilter(2, 0.5, config)
    want = [ref.update(q)[0] for q in proba]
    assert want == [0, 0, 0, 0]
    assert smooth_runs(proba, np.zeros(4), t, 0.5, config).tolist() == want


def test_offline_scoring_takes_the_skipped_silent_stretch_as_the_live_service_does():
    # a 100 s silence of every stream: the live service skips the decisions due over
    # max_backlog_s (60 s) before the next sample and its filter takes their prediction
    # steps (ForwardFilter.skip); stream-eval's offline filter stepped once per decision
    # emitted, so after the silence it still held the old terrain's belief, and under a 0.3
    # hysteresis decided the old terrain where the live service had followed the new one
    from features.windows import WindowConfig
    from terrain.run import TIME, Run
    from terrain.serving.evaluation import filter_sequence, raw_decisions, score_smoothing
    from terrain.serving.evaluation import Segment
    from terrain.serving.model import StreamModel
    from terrain.serving.replay import replay_run
    from terrain.serving.service import StreamConfig, StreamService
    from terrain.serving.targets import CataloguePeakTargets

    t = np.r_[np.arange(0.0, 20.0, 0.1), np.arange(120.0, 135.0, 0.1)]
    v = np.where(t < 100.0, 0.05, 0.15)            # ASPHALT, then ICE (_WzClassifier)
    wheels = pd.DataFrame({TIME: t, "vel_l": v, "vel_r": v, "cur_l": 1.0, "cur_r": 1.0})
    run = Run("probe/ICE/0", "probe", "ICE", {"wheels": wheels})
    classes = tuple(_WzClassifier.classes_)
    model = StreamModel(_WzClassifier(), ("vel_l",),
                        WindowConfig(window_s=2.0, hop_s=0.5, rate_hz=10.0), classes)
    config = SmoothingConfig(dwell_s=60.0, hysteresis=0.3)
    service = StreamService(model, CataloguePeakTargets(classes),
                            StreamConfig(hop_s=0.5, smoothing=config))
    live = np.array([d.terrain for d in replay_run(service, run)], dtype=object)
    assert service.skipped_decisions > 0
    t_s, proba = raw_decisions(model, run, 0.5)
    segments = [Segment("a", "ASPHALT", 0.0, 0.0, 20.0), Segment("b", "ICE", 120.0, 0.0, 15.0)]
    score = score_smoothing(segments, t_s, proba, classes, config, 0.5)
    after = t_s >= 120.0
    assert score.delays_s == (float(t_s[after][live[after] == "ICE"][0] - 120.0),)
    names = np.array(list(classes) + [None], dtype=object)
    np.testing.assert_array_equal(names[filter_sequence(proba, 0.5, config, t_s)], live)


@pytest.mark.parametrize("bad", ["[-0.5]", "[1.0, -inf]", "[-Infinity]"])
def test_a_negative_switching_delay_is_refused(tmp_path, bad):
    # a switching delay runs from the switch to the first decision naming the new terrain:
    # it is >= 0 (inf: never followed); a negative one is a broken table, not a fast switch
    frame = encode_stream_scores(_rows())
    frame.loc[0, "delays_s"] = bad
    path = tmp_path / "negative.csv"
    frame.to_csv(path, index=False)
    with pytest.raises(DataFormatError, match=r"delays_s.*line 2"):
        read_stream_scores(path)


@pytest.mark.parametrize("window_s", [np.nan, np.inf, -1.0])
def test_score_stream_refuses_a_window_that_is_no_history(window_s):
    from terrain.errors import ConfigError
    from terrain.serving.evaluation import Segment, score_stream
    segments = [Segment("a", "ICE", 0.0, 0.0, 10.0), Segment("b", "SNOW", 0.0, 10.0, 10.0)]
    t = np.arange(0.0, 20.0, 0.5)
    decided = np.where(t < 10.0, "ICE", "SNOW").astype(object)
    with pytest.raises(ConfigError, match="window_s"):
        score_stream(segments, t, decided, window_s=window_s)
    # the same stream with a real window scores: settled decisions exclude the transient
    score = score_stream(segments, t, decided, window_s=2.0)
    assert score.accuracy == 1.0 and score.n_settled == len(t) - 8
