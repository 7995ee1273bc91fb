"""Review srv7b: forward filter inputs, hysteresis in skipped stretches, switching delays."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig
from terrain.errors import ConfigError, DataFormatError
from terrain.run import Run
from terrain.serving.buffers import RingBuffer
from terrain.serving.decisions import stuck_decision_flags
from terrain.serving.evaluation import concatenated_streams
from terrain.serving.model import StreamModel
from terrain.serving.recipes import ModelRecipe
from terrain.serving.service import StreamConfig, StreamService
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig
from terrain.serving.targets import CataloguePeakTargets


@pytest.mark.parametrize("q", [np.array([0.2, 0.8]), np.array([[0.2, 0.3, 0.5]]),
                               np.array(0.5)])
def test_filter_refuses_probabilities_of_another_shape_than_its_classes(q):
    """A (2,) row for a 3-class filter was a bare broadcasting ValueError of NumPy; a (1, 3)
    row broadcast silently into a (1, 3) ``p`` and a scalar into a 3-vector."""
    filt = ForwardFilter(3, 0.5, SmoothingConfig())
    with pytest.raises(DataFormatError, match=r"\(3,\)"):
        filt.update(q)
    np.testing.assert_allclose(filt.p, np.full(3, 1 / 3))     # nothing folded in


def test_a_run_with_an_empty_stream_is_named_as_too_short_not_an_index_error():
    """A run whose wheel frame holds no sample overlaps for 0 s: it is left out and named
    in ``skipped_runs`` as any run too short for a piece (was pandas's bare IndexError
    'single positional indexer is out-of-bounds' from ``iloc[0]``)."""
    def run(i, terrain, n):
        t = np.arange(n) * 0.2
        frame = pd.DataFrame({"t_s": t, "vel_l": 0.5, "vel_r": 0.5, "cur_l": 1.0,
                              "cur_r": 1.0})
        return Run(f"syn/{terrain}/{i:02d}", "syn", terrain, {"wheels": frame})

    runs = [run(0, "ICE", 300), run(1, "SNOW", 300), run(2, "SNOW", 0)]
    stream, segments = concatenated_streams(runs, ("wheels",), seed=0)
    assert [s.run_id for s in segments] in (["syn/ICE/00", "syn/SNOW/01"],
                                            ["syn/SNOW/01", "syn/ICE/00"])
    assert stream.meta["skipped_runs"] == ["syn/SNOW/02"]


@pytest.mark.parametrize("n_channels,capacity", [(2, True), (True, 4), (2, 4.7), (2.5, 4),
                                                 (2, 0), (0, 4)])
def test_ring_buffer_refuses_sizes_that_are_not_positive_integers(n_channels, capacity):
    """``capacity=True`` made a buffer of one sample, without a word; 4.7 or 2.5 was a
    bare TypeError of NumPy."""
    with pytest.raises(ConfigError, match="RingBuffer"):
        RingBuffer(n_channels, capacity)


@pytest.mark.parametrize("setting", [
    {"signals": "wheel"}, {"signals": None}, {"window_s": float("nan")}, {"window_s": True},
    {"rate_hz": -10.0}, {"train_hop_s": 0.0}, {"run_balanced": "False"},
    {"run_balanced": 1}])
def test_a_recipe_refuses_settings_its_windows_or_switches_cannot_take(setting):
    """Each was accepted by ModelRecipe: the numbers and the signal set failed only at the
    first fit (after the runs were read), and ``run_balanced="False"`` trained run-balanced
    (read by truthiness)."""
    base = dict(signals="wheels", window_s=4.0, rate_hz=10.0, train_hop_s=2.0,
                features="physics", classifier="extra_trees")
    ModelRecipe(**base)     # the base itself is valid
    with pytest.raises(ConfigError):
        ModelRecipe(**{**base, **setting})


class _Labelled:
    """A fitted classifier stand-in with the given ``classes_``."""

    def __init__(self, classes):
        self.classes_ = np.asarray(classes)

    def predict_proba(self, X):
        return np.full((len(X), len(self.classes_)), 1.0 / len(self.classes_))


@pytest.mark.parametrize("held", [["asphalt", "snow"], [0, 1], ["ICE", "GRASS"]])
def test_a_model_whose_classifier_holds_none_of_its_classes_is_refused(held):
    """Every probability read 0 and the service decided ASPHALT at confidence 0.5 (at
    min_confidence: trusted, ASPHALT's targets, no flag) on every window."""
    window = WindowConfig(window_s=1.0, rate_hz=10.0)
    with pytest.raises(ConfigError, match="none of the model's classes"):
        StreamModel(_Labelled(held), ("vel_l", "vel_r"), window, ("ASPHALT", "SNOW"))
    # one class of the model held is a model (the other reads 0, as before)
    StreamModel(_Labelled(["ASPHALT", "ICE"]), ("vel_l", "vel_r"), window,
                ("ASPHALT", "SNOW"))


class _MeanSpeed:
    """Two-class stand-in: P(SNOW) a logistic of the window's mean ``vel_l``."""

    classes_ = np.array(["ASPHALT", "SNOW"])

    def predict_proba(self, X):
        p = 1.0 / (1.0 + np.exp(-X[:, 0].mean(axis=1)))
        return np.column_stack([1.0 - p, p])


def test_decisions_of_a_silent_stretch_are_skipped_from_max_backlog_s_before_the_newest():
    """A wheel stream at 10 Hz until 2.9 s, then silent until 11.0 s, max_backlog_s 5: the
    decisions at 4.5, 5.0 and 5.5 s are due more than 5 s before the newest sample with no
    sample in their window, so they are skipped (and counted); 6.0 s is exactly 5 s before
    it and is made. (Mutant: a backlog of twice max_backlog_s skipped none, no test
    failed.)"""
    window = WindowConfig(window_s=1.0, rate_hz=10.0)
    model = StreamModel(_MeanSpeed(), ("vel_l", "vel_r"), window, ("ASPHALT", "SNOW"))
    svc = StreamService(model, CataloguePeakTargets(model.classes),
                        StreamConfig(hop_s=0.5, max_backlog_s=5.0,
                                     streams={"wheels": ("vel_l", "vel_r")}))
    row = np.array([1.0, 1.0])
    early = [d for k in range(30) for d in svc.push("wheels", k * 0.1, row)]
    assert [d.t_s for d in early] == pytest.approx([1.0, 1.5, 2.0, 2.5])
    late = [d for k in range(5) for d in svc.push("wheels", 11.0 + k * 0.1, row)]
    assert svc.skipped_decisions == 3
    made = [3.0, 3.5, 4.0] + list(np.arange(6.0, 11.1, 0.5))
    assert [d.t_s for d in late] == pytest.approx(made)


def test_a_replays_stuck_flags_sit_on_the_window_a_decision_rests_on_not_its_time():
    """The window of a decision is ``[t_s - window_age_s - window_s, t_s - window_age_s)``:
    a stuck stretch at 8.5-8.9 s lies in the window of a fresh decision at 10 s and of a
    decision at 12 s whose window is 3 s old, not in that of a decision at 10 s resting on
    a window 3 s old, nor of one with no window (infinite age). (Mutant: the window taken
    as ending at ``t_s``, no test failed.)"""
    frame = pd.DataFrame({"t_s": [10.0, 10.0, 12.0, 10.0],
                          "window_age_s": [0.0, 3.0, 3.0, np.inf]})
    flags = stuck_decision_flags(frame, {"wheels.vel_l": [[8.5, 8.9]]}, window_s=2.0)
    assert list(flags) == ["stuck:wheels.vel_l", "", "stuck:wheels.vel_l", ""]


def test_a_gap_that_ends_before_a_windows_first_grid_point_does_not_drop_the_window():
    """Wheels at 10 Hz (samples at 0.05 + k 0.1 s) miss 2.65, 2.75 and 2.85 s; decisions
    every 0.5 s from 1.05 s. The windows of 3.05 s (``[2.05, 3.05)``) and 3.55 s hold the
    gap's grid points and are dropped as ``gap``; that of 4.05 s (``[3.05, 4.05)``) lies
    wholly between live samples and is classified, as a batch window over the same span
    would be. (It was flagged ``gap``: the service judged every step it read, down to the
    sample before the look-back start ``t - window_s - 2 / rate``, here 2.55 -> 2.95 s.)"""
    window = WindowConfig(window_s=1.0, rate_hz=10.0)
    model = StreamModel(_MeanSpeed(), ("vel_l", "vel_r"), window, ("ASPHALT", "SNOW"))
    svc = StreamService(model, CataloguePeakTargets(model.classes),
                        StreamConfig(hop_s=0.5, streams={"wheels": ("vel_l", "vel_r")}))
    times = [0.05 + 0.1 * k for k in range(60)]
    times = [t for t in times if not 2.6 < t < 2.9]
    flags = {round(d.t_s, 6): d.flags for t in times
             for d in svc.push("wheels", t, np.array([1.0, 1.0]))}
    assert [t for t, f in flags.items() if "gap" in f] == [3.05, 3.55]
    assert {2.55, 4.05, 4.55} <= set(flags)
