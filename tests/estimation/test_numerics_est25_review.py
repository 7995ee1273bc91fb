"""Numerical review (est25): the estimation package on valid input far from the usual
magnitudes (epoch clocks, badly scaled covariances, long runs)."""

import numpy as np
from hypothesis import given, settings, strategies as st
import pytest

from terrain.estimation.runner import (SensorSamples, make_grid, sample_steps,
                                       samples_inside)
from terrain.run import clock_slack

#: An epoch clock (s since 1970): one unit in the last place is 2.4e-7 s there.
EPOCH_S = 1.7e9


# -- which samples the filter may use, on any clock ------------------------------------------

@settings(max_examples=60, deadline=None)
@given(t0=st.sampled_from((0.0, 1e3, 1e6, EPOCH_S, 4e9)),
       rate=st.sampled_from((6.5, 30.0, 100.0, 200.0)), n=st.integers(2, 400),
       ulps=st.integers(-8, 8))
def test_samples_inside_agrees_with_the_placement_rule_at_both_ends_of_the_grid(t0, rate, n,
                                                                                ulps):
    # a sample a few units in the last place off the last step (or off the step before the
    # first) belongs to that step by the placement rule (within terrain.run.clock_slack);
    # samples_inside used a fixed 1 ns, below one rounding of an epoch clock, so the last
    # sample of a run, rounded one ulp late, was counted as outside (dropped) while
    # sample_steps put it on the last step, and one a ulp after the step before the grid was
    # used at the first step though the rule puts it on that earlier step
    grid = make_grid(t0, t0 + (n - 1) / rate, rate)
    step0 = grid[1] - grid[0]
    last = grid[-1]
    before = grid[0] - step0
    t = np.array([last, before])
    for _ in range(abs(ulps)):
        t = np.nextafter(t, np.inf if ulps > 0 else -np.inf)
    inside = samples_inside(grid, t)
    steps = sample_steps(grid, t)
    # by the rule: the last sample is inside iff its step is a grid step
    assert inside[0] == (steps[0] < grid.size)
    # by the rule: within the slack of the step before the first it is that step's (outside)
    on_before = abs(t[1] - before) <= clock_slack(t[1])
    assert inside[1] == (not on_before and t[1] > before)


def test_on_an_epoch_clock_the_last_sample_one_ulp_late_is_used_on_the_last_step():
    grid = make_grid(EPOCH_S, EPOCH_S + 1.0, 100.0)
    late = np.nextafter(grid[-1], np.inf)
    early_first = np.nextafter(grid[0] - 0.01, np.inf)
    assert samples_inside(grid, np.array([late])).all()
    assert sample_steps(grid, np.array([late]))[0] == grid.size - 1
    assert not samples_inside(grid, np.array([early_first])).any()


# -- the hold window of the speed bound on an epoch clock ------------------------------------

@settings(max_examples=40, deadline=None)
@given(t0=st.sampled_from((0.0, 1e6, EPOCH_S)),
       rate=st.sampled_from((15.0, 30.0, 50.0, 100.0)), k=st.integers(1, 8),
       j=st.integers(0, 40))
def test_a_rim_spike_widens_the_speed_bound_over_exactly_hold_s_on_any_clock(t0, rate, k, j):
    # hold_s = k steps covers the step and the k - 1 before it; on an epoch clock the step
    # exactly hold_s back (off it by the clock's rounding, hundreds of ns) was inside the
    # window of whole ns on about half the steps: a hold of 3 steps at 30 Hz held 4
    from terrain.estimation.skid_steer_slip import speed_bounds_m_s
    grid = make_grid(t0, t0 + 3.0, rate)
    j = min(k + j, grid.size - k)
    rim = np.full((grid.size, 2), 0.2)
    rim[j] = 1.0
    _, upper = speed_bounds_m_s(grid, SensorSamples(grid, rim), -0.5, 0.0, hold_s=k / rate)
    widened = np.flatnonzero(upper > upper[k:].min() + 1e-12)
    np.testing.assert_array_equal(widened[widened >= k], np.arange(j, j + k))


# -- the compiled loop's Joseph form ---------------------------------------------------------

def test_one_precise_update_on_the_compiled_loop_stays_positive_semi_definite():
    # the draws of test_ekf_review's test of the NumPy correct() (states of scales
    # 1e-3 .. 1e4, rows with noise down to 1e-14), on the skid-steer kernel's two wheel rows
    from terrain.estimation.ekf import correct
    from terrain.estimation.fast import fast_kernel_of, run_compiled
    from terrain.estimation.runner import sensor_groups
    from terrain.estimation.skid_steer import SENSOR_ROWS, SkidSteerModel
    model = SkidSteerModel()
    kernel = fast_kernel_of(model)
    x0 = np.array([0.5, 0.5, 0.0, 0.0])
    hx, H = model.observation(x0)
    rows = [0, 1]
    rng = np.random.default_rng(0)
    worst_numpy = worst_compiled = 0.0
    for _ in range(300):
        a = rng.standard_normal((4, 4)) * 10.0 ** rng.uniform(-3, 4, 4)
        R = np.full(3, 10.0 ** rng.uniform(-14, -6))
        P0 = a @ a.T
        Z = np.full((1, 3), np.nan)
        Z[0, rows] = hx[rows]
        loop = run_compiled(kernel, np.zeros(0), Z, x0, P0, R, sensor_groups(SENSOR_ROWS, 3),
                            len(SENSOR_ROWS), store_covariance=True)
        _, P1, _ = correct(x0, P0, np.zeros(2), H[rows], R[rows], check=False)
        for P, name in ((P1, "numpy"), (loop.P[0], "compiled")):
            eig = np.linalg.eigvalsh(P)
            if name == "numpy":
                worst_numpy = min(worst_numpy, eig[0] / eig[-1])
            else:
                worst_compiled = min(worst_compiled, eig[0] / eig[-1])
    assert worst_numpy > -1e-10          # the reference: round-off
    assert worst_compiled > -1e-10


# -- one hour of driving without a position reference ----------------------------------------

@pytest.mark.slow
def test_an_hour_without_camera_keeps_the_covariance_a_covariance_on_both_engines():
    # one hour at 4 Hz (14 400 steps) with the IMU, wheels and steering but no camera:
    # the position variances grow without bound (to 3.7e3 m^2 in a turn at 0.2 rad/s) while
    # the steering angles stay at 2.5e-7 rad^2 (condition 1.5e10); both engines keep every
    # covariance symmetric and positive definite and agree with each other at the end
    from terrain.estimation.agrimaro import AgriMaRoModel, noise_derived_settings
    from terrain.estimation.runner import run_filter
    rng = np.random.default_rng(7)
    n = 14_400
    grid = make_grid(0.0, (n - 1) / 4.0, 4.0)
    imu = np.column_stack([0.01 * rng.standard_normal((n, 2)), 0.2 + 0.001 * rng.standard_normal(n),
                           0.05 * np.arange(n)])
    samples = {"imu": SensorSamples(grid, imu),
               "omega": SensorSamples(grid, 6.0 + 0.1 * rng.standard_normal((n, 3))),
               "steer": SensorSamples(grid, 1e-3 * rng.standard_normal((n, 3)))}
    model = AgriMaRoModel(settings=noise_derived_settings())
    fast = run_filter(model, grid, samples, engine="numba", store_covariance=True)
    ref = run_filter(model, grid, samples, engine="numpy", store_covariance=True)
    for res in (fast, ref):
        assert np.isfinite(res.x).all() and np.isfinite(res.P).all()
        np.testing.assert_array_equal(res.P, np.swapaxes(res.P, 1, 2))
        eig = np.linalg.eigvalsh(res.P[::200])
        assert (eig[:, 0] > 0).all()
        assert eig[-1, -1] > 1e9 * eig[-1, 0]        # badly conditioned by the end
    scale = np.abs(ref.x).max(axis=0) + 1.0
    assert (np.abs(fast.x - ref.x).max(axis=0) <= 1e-6 * scale).all()
    np.testing.assert_allclose(fast.P[-1], ref.P[-1], rtol=1e-6, atol=1e-12 * np.abs(
        ref.P[-1]).max())
