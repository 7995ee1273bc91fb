"""Batch and live alignment of one stream off the model's clock (strict xfail: serving).

The batch windows (:func:`terrain.io.align.align_streams`, then
:func:`features.windows.window_frame`) lie on the run's clock, a grid from the streams'
common first sample; the streaming service aligns each window with the same functions but
on the grid of the samples in its buffers (:func:`terrain.io.align.overlap_grid_tail` of
the buffered slice), whose first point is a stream sample near the window's start. A 6.5 Hz
wheel stream on a 10 Hz model clock then gives windows a fraction of a grid step apart from
the batch windows ending at the same time, and values up to 12 % of the signal's amplitude
off (docs/streaming.md promises the batch windows only for streams already on the model's
clock). The fix belongs to :mod:`terrain.serving` (keep the grid's origin) and would move
the documented held-out stream figures.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

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


@pytest.mark.xfail(strict=True, reason="the streaming service aligns each window on the grid "
                   "of its buffered samples, not on the run's clock of the batch windows "
                   "(terrain.serving; one grid per stream passes this, and costs 0.914 -> "
                   "0.887 on the held-out streams; a grid one step before each decision, on "
                   "the decision clock for wheel-only models, passes it too and moves the "
                   "wheel-only streams 0.798 -> 0.796 (2026-11-30, reverted): "
                   "docs/streaming.md, \"One grid per stream\")")
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
