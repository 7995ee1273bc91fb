"""Review tests (est11): the per-segment slip drift density of ``run_with_pseudo_slip``."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.estimation.skid_steer_slip import (STATE_NAMES, SkidSteerSlipSettings,
                                                run_with_pseudo_slip)


@pytest.mark.parametrize("side", ["slip_1", "slip_2"])
def test_each_segment_drifts_at_the_density_of_the_window_that_ends_it(side):
    # the slip is a random walk: with only the slip pseudo-measurement (no wheel, gyro or
    # accelerometer row couples it to another state) its variance grows by
    # (slip_psd + slip_psd_rel drift^2 + slip_psd_transient change^2) dt per step, with the
    # drift and change of the window that ends the segment (module docstring)
    t = np.arange(301) / 100.0
    tp = np.array([1.0, 2.0])
    s = SkidSteerSlipSettings(slip_psd=1e-4, slip_psd_rel=0.5, slip_psd_transient=2.0)
    res = run_with_pseudo_slip(t, {}, s, tp, np.full((2, 2), 0.1), np.full(2, 0.05),
                               drift_std=np.array([0.2, 0.1]),
                               transient_std=np.array([0.0, 0.5]))
    var = res.P_diag[:, STATE_NAMES.index(side)]
    first = np.diff(var)[np.searchsorted(t, 0.5)]     # drift 0.2, change 0
    second = np.diff(var)[np.searchsorted(t, 1.5)]    # drift 0.1, change 0.5
    assert first == pytest.approx((1e-4 + 0.5 * 0.2 ** 2) * 0.01, rel=1e-6)
    assert second == pytest.approx((1e-4 + 0.5 * 0.1 ** 2 + 2.0 * 0.5 ** 2) * 0.01, rel=1e-6)
