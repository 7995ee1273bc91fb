"""Review tests (est11): the seed 000 adaptive observer over a time gap and with no sample."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ShapeError
from terrain.estimation.observer import run_adaptive_observer

D = 0.2854                      # Husky half track, m
ETA = (0.8, 0.9)                # true eta_R, eta_L


def _circle(t):
    """Exact pose of a constant-speed turn (seed 000 eq. 5) with the true etas."""
    vr, vl = np.full(t.size, 1.0), np.full(t.size, 0.6)
    v = 0.5 * (ETA[0] * vr + ETA[1] * vl)
    w = (ETA[0] * vr - ETA[1] * vl) / (2.0 * D)
    th = w * t
    dt = np.diff(t, prepend=t[0])
    x = np.cumsum(v * np.cos(th) * dt)
    y = np.cumsum(v * np.sin(th) * dt)
    return np.column_stack([x, y, th]), vr, vl


def test_a_time_gap_does_not_kick_the_estimates_off():
    # before: the correction L e and the adaptive law of the last sample before a 1 s gap
    # were integrated over the whole gap by one forward-Euler step (l3 h = 10): the etas,
    # converged to 0.0007 of the truth, jumped 0.245 away; the same gap given as NaN samples
    # (predicted without correction) stayed within 0.005
    t = np.arange(0.0, 30.0, 0.01)
    pose, vr, vl = _circle(t)
    keep = (t <= 15.0) | (t >= 16.0)
    res = run_adaptive_observer(t[keep], pose[keep], vr[keep], vl[keep])
    after = t[keep] > 15.5
    assert np.abs(res.eta[after] - ETA).max() < 0.02
    # as good as the same gap given as missing samples
    gapped = np.where(keep[:, None], pose, np.nan)
    ref = run_adaptive_observer(t, gapped, vr, vl)
    assert np.abs(res.eta[-1] - ref.eta[-1]).max() < 0.01


def test_no_sample_is_a_shape_error():
    # before: numpy's bare "attempt to get argmax of an empty sequence" (ValueError)
    with pytest.raises(ShapeError, match="no sample"):
        run_adaptive_observer(np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros(0))
