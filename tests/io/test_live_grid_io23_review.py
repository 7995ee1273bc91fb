"""Batch and live alignment of one stream off the model's clock (review io23).

The batch windows (:func:`terrain.io.align.align_streams`, then
:func:`features.windows.window_frame`) lie on the run's clock, a grid from the streams'
common first sample. The streaming service aligned each window on the grid of the samples
in its buffers (its first point a stream sample near the window's start), so a 6.5 Hz wheel
stream on a 10 Hz model clock gave windows a fraction of a grid step apart from the batch
windows ending at the same time, values up to 12 % of the signal's amplitude off. With no
stream at the model's rate, the service's grid now ends one step before the decision
(:func:`terrain.io.align.anchored_grid_tail`), on the decision clock, which is the batch
grid's: the live windows are the batch windows.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from features.windows import WindowConfig, window_frame
from terrain.io.align import align_streams
from terrain.run import TIME, WHEEL_CHANNELS, Run
from terrain.serving import StreamModel
from terrain.serving.service import StreamConfig, StreamService
from terrain.serving.smoothing import SmoothingConfig
from terrain.serving.targets import CataloguePeakTargets

CLASSES = ("ASPHALT", "SNOW")


class _Recorder:
    """A classifier that keeps every window it is given."""

    classes_ = np.array(CLASSES)

    def __init__(self):
        self.windows = []

    def predict_proba(self, X):
        self.windows.append(np.array(X))
        return np.tile([0.5, 0.5], (len(X), 1))


def test_live_windows_of_a_stream_off_the_model_clock_are_the_batch_windows():
    recorder = _Recorder()
    window = WindowConfig(window_s=2.0, hop_s=1.0, rate_hz=10.0)
    model = StreamModel(recorder, ("vel_l",), window, CLASSES)
    svc = StreamService(model, CataloguePeakTargets(CLASSES),
                        StreamConfig(hop_s=1.0, smoothing=SmoothingConfig(dwell_s=None)))
    t = np.arange(0.0, 20.0, 1.0 / 6.5)
    wheels = pd.DataFrame({TIME: t, "vel_l": 0.5 + 0.3 * np.sin(1.3 * t),
                           "vel_r": 0.5 + 0.2 * np.cos(0.7 * t), "cur_l": 3.0 + np.sin(t),
                           "cur_r": 3.0 + np.cos(t)})
    decisions = []
    for row in wheels.itertuples(index=False):
        decisions += svc.push("wheels", row.t_s, {c: getattr(row, c) for c in WHEEL_CHANNELS})
    frame = align_streams(Run("r", "d", None, {"wheels": wheels}), ("wheels",),
                          window.rate_hz)
    X, _, t_end, _, _ = window_frame(frame, ("vel_l",), window)
    compared = 0
    for decision, live in zip(decisions, recorder.windows):
        k = np.flatnonzero(np.isclose(t_end, decision.t_s, rtol=0.0, atol=1e-9))
        if k.size:
            np.testing.assert_allclose(live[0], X[k[0]], rtol=0.0, atol=1e-9)
            compared += 1
    assert compared >= 15


def test_the_anchored_grid_tail_is_the_grid_through_the_anchor_inside_the_overlap():
    from terrain.io.align import anchored_grid_tail
    times = [np.arange(0.0, 3.0, 0.01), np.arange(0.05, 2.5, 1.0 / 6.5)]
    tail, count = anchored_grid_tail(times, 10.0, 2.43, 5)
    t1 = times[1][-1]                                  # the wheels end first
    want = [p for p in 2.43 - np.arange(30) / 10.0 if 0.05 <= p <= t1]
    assert count == len(want)
    np.testing.assert_allclose(tail, sorted(want)[-5:], rtol=0.0, atol=1e-12)
    # a point within the clock's rounding of the overlap's first sample is inside it
    tail, count = anchored_grid_tail(times, 10.0, 0.05 + 3 * 0.1 - 1e-15, 10)
    assert count == 4 and abs(tail[0] - 0.05) < 1e-12
    assert anchored_grid_tail(times, 10.0, 0.0, 3)[1] == 0      # before the overlap
