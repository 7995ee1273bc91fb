"""Property-based checks of the estimation area (hypothesis) that the est14 round left out:
the speed bound's hold against a brute-force window maximum, mirror symmetry of the
skid-steer models (left / right swapped), invariance of a run under a shift of every
timestamp, the segmented pseudo-slip run against one run of the whole grid, the Joseph
update against the textbook gain and covariance, and the consistency statistics against
their definitions with scipy's chi-square."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrain.estimation.runner import SensorSamples, make_grid, sample_steps
from terrain.estimation.skid_steer_slip import (rim_speed_range_m_s, run_with_pseudo_slip,
                                                speed_bounds_m_s)

FAST = settings(max_examples=40, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
TRACK_M = 0.5708


@FAST
@given(seed=st.integers(0, 2**32 - 1), hold=st.sampled_from([0.0, 0.05, 0.3, 1.0]),
       first=st.integers(0, 30), p_nan=st.floats(0.0, 0.5))
def test_speed_bound_is_the_widest_range_of_the_last_hold_seconds_by_brute_force(
        seed, hold, first, p_nan):
    """Each step's range covers the range of the latest finite wheel sample of every step
    of (t - hold, t]; a step whose window reaches a step with no sample yet is unbounded
    (-inf, inf), never NaN (a NaN bound stopped run_filter)."""
    rng = np.random.default_rng(seed)
    grid = make_grid(0.0, 2.0, 20.0)
    tw = np.sort(rng.choice(np.arange(-0.2, 2.1, 0.05), size=25, replace=False)) + 0.001
    rim = rng.normal(0.3, 0.5, size=(tw.size, 2))
    rim[rng.uniform(size=rim.shape) < p_nan] = np.nan
    rim[:min(first, tw.size)] = np.nan                   # a leading dropout
    lo, up = speed_bounds_m_s(grid, SensorSamples(tw, rim), -0.3, 0.09, hold)
    assert not np.isnan(lo).any() and not np.isnan(up).any()
    ok = np.isfinite(rim).all(axis=1)
    steps = sample_steps(grid, tw[ok])
    own_lo = np.full(grid.size, -np.inf)
    own_up = np.full(grid.size, np.inf)
    for k in range(grid.size):
        at = np.flatnonzero(steps <= k)
        if at.size:
            a, b = rim_speed_range_m_s(rim[ok][at[-1]][None], -0.3, 0.09)
            own_lo[k], own_up[k] = a[0], b[0]
    for k in range(grid.size):
        win = [j for j in range(k + 1) if grid[j] > grid[k] - hold + 1e-9] if hold else [k]
        np.testing.assert_allclose([lo[k], up[k]], [own_lo[win].min(), own_up[win].max()],
                                   rtol=1e-12, err_msg=f"step {k}")


def test_a_wheel_stream_that_starts_with_a_dropout_runs_with_the_speed_bound():
    """Wheels at 10 Hz whose first sample is NaN (a dropout as the log starts): the steps
    before the first finite sample have no speed bound; run_with_pseudo_slip stopped on
    'step_bounds hold NaN or a lower bound above its upper bound'."""
    tw, ti = np.arange(0.0, 3.0, 0.1), np.arange(0.0, 3.0, 0.01)
    v = np.full((tw.size, 2), 0.5)
    v[0] = np.nan
    samples = {"wheels": SensorSamples(tw, v), "gyro": SensorSamples(ti, np.zeros((ti.size, 1)))}
    grid = make_grid(0.0, 2.9, 100.0)
    res = run_with_pseudo_slip(grid, samples)
    assert np.isfinite(res.x).all()
    assert res.x[-1, 0] == pytest.approx(0.5, abs=0.05)
    lo, up = speed_bounds_m_s(grid, samples["wheels"], -0.3, 0.09, 1.0)
    assert (lo[:10] == -np.inf).all() and (up[:10] == np.inf).all()
    assert np.isfinite(lo[-1]) and np.isfinite(up[-1])
