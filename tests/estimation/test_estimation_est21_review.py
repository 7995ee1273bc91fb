"""Review est21: consistency between the paths of the estimation pipeline (a run filtered
whole vs in the segments of :func:`run_with_pseudo_slip` carrying the filter state)."""

from __future__ import annotations

import numpy as np
from hypothesis import example, given, settings, strategies as st
import pytest

from terrain.estimation import SensorSamples, run_filter
from terrain.estimation.skid_steer_slip import (SPEED_BOUND_MOVABLE, SkidSteerSlipModel,
                                                SkidSteerSlipSettings, _speed_bounds,
                                                run_with_pseudo_slip)


def _whole_and_segmented(grid, seed):
    """The same run filtered whole and cut into segments whose noises all equal the whole
    run's (pseudo std = ``slip_std``, no drift terms): the two must agree."""
    rng = np.random.default_rng(seed)
    t0, t1 = grid[0], grid[-1]
    tw = np.sort(rng.uniform(t0 - 0.1, t1 + 0.1, 150))
    wheels = SensorSamples(tw, np.column_stack([1.0 + 0.03 * rng.normal(size=tw.size),
                                                1.2 + 0.03 * rng.normal(size=tw.size)]))
    tg = np.sort(rng.uniform(t0 - 0.1, t1 + 0.1, 300))
    samples = {"wheels": wheels, "gyro": SensorSamples(tg, 0.1 + 0.01 * rng.normal(size=tg.size)),
               "accel": SensorSamples(tg, np.column_stack([0.01 * rng.normal(size=tg.size),
                                                           9.81 + rng.normal(size=tg.size)]))}
    s = SkidSteerSlipSettings()
    tp = np.sort(rng.uniform(t0, t1, 6))
    sp = np.column_stack([np.full(tp.size, 0.1), np.full(tp.size, 0.12)])
    seg = run_with_pseudo_slip(grid, samples, s, tp, sp, np.full(tp.size, s.slip_std))
    whole = run_filter(SkidSteerSlipModel(s), grid, {**samples, "slip_model":
                                                     SensorSamples(tp, sp)},
                       store_covariance=True, engine="numpy",
                       step_bounds=_speed_bounds(grid, wheels, s),
                       step_bound_movable=SPEED_BOUND_MOVABLE)
    return seg, whole


def _assert_same(seg, whole):
    assert seg.counts == whole.counts
    np.testing.assert_allclose(seg.x, whole.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(seg.P, whole.P, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(seg.accepted, whole.accepted)
    np.testing.assert_array_equal(seg.dof, whole.dof)


@pytest.mark.slow
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_segments_equal_the_whole_run_on_a_uniform_grid(seed):
    grid = np.arange(301) * 0.01
    _assert_same(*_whole_and_segmented(grid, seed))


def test_segments_equal_the_whole_run_on_a_non_uniform_grid():
    # each segment after the first took the samples of its first step from a window one
    # step of its *own* grid wide: where the step after a cut was shorter than the one
    # before it, samples the whole run used were counted as outside and dropped
    # (wheels 'outside' 27 vs 22 on this grid, states 0.08 apart)
    grid = np.cumsum(np.r_[0.0, np.tile([0.02, 0.005], 120)])
    for seed in range(3):
        _assert_same(*_whole_and_segmented(grid, seed))


def _agrimaro_run(imu_shift_s=0.0):
    import pandas as pd

    from terrain.run import Run

    rng = np.random.default_rng(4)
    t = np.round(np.arange(201) * 0.01, 10)
    imu = pd.DataFrame({"t_s": t - imu_shift_s, "ax": rng.normal(0, 0.1, t.size),
                        "ay": rng.normal(0, 0.1, t.size), "wz": 0.1 + rng.normal(0, .01, t.size)})
    cam = pd.DataFrame({"t_s": t[::3], "v_cx": 0.3, "v_cy": 0.0, "yaw_rate_c": 0.1,
                        "yaw_c": 0.1 * t[::3]})
    return Run("sim/TEST/07", "sim", "TEST", {"imu": imu, "cam": cam}, vehicle="agrimaro",
               source="test.csv")


def test_an_imu_latency_equals_imu_timestamps_moved_by_it():
    # estimate_agrimaro laid its grid over the IMU timestamps as recorded, not as corrected
    # by time_offsets_s["imu"]: the first samples of the corrected IMU stream fell before
    # the grid (counted outside, 4 of 201 for 0.05 s) and the grid ran on past the last
    from terrain.estimation.agrimaro import estimate_agrimaro

    latency = estimate_agrimaro(_agrimaro_run(), time_offsets_s={"imu": 0.05})
    moved = estimate_agrimaro(_agrimaro_run(0.05))
    np.testing.assert_allclose(latency.t_s, moved.t_s, rtol=0, atol=1e-12)
    assert latency.counts == moved.counts
    assert latency.counts["imu"]["outside"] == 0
    np.testing.assert_allclose(latency.x, moved.x, rtol=0, atol=1e-9)


def _turning_wheels(seed: int, turn: float):
    """300 noisy wheel samples at 50 Hz of a steady turn (vel_l, vel_r = 0.7 -/+ turn m/s)."""
    import pandas as pd

    rng = np.random.default_rng(seed)
    t = np.round(np.arange(300) * 0.02, 10)
    return pd.DataFrame({"t_s": t, "vel_l": 0.7 - turn + 0.03 * rng.normal(size=t.size),
                         "vel_r": 0.7 + turn + 0.03 * rng.normal(size=t.size)})


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), turn=st.floats(0.1, 0.6))
def test_without_imu_the_icr_factor_and_the_gyro_bias_stay_at_their_prior(seed, turn):
    # estimate_skid_steer documents that on the wheels alone "chi and the bias then stay
    # at their prior"; the wheel rows observe only chi x yaw_rate, yet the linearised update
    # moved ln(chi) from its prior 0.405 to -0.33 with its variance down from 1.0 to 0.02
    import pandas as pd

    from terrain.estimation.skid_steer import SkidSteerModel, estimate_skid_steer
    from terrain.run import Run

    wheels = _turning_wheels(seed, turn)
    prior = SkidSteerModel()
    dead_gyro = pd.DataFrame({"t_s": wheels["t_s"], "wz": np.nan})     # an IMU whose wz is all NaN
    for streams in ({"wheels": wheels}, {"wheels": wheels, "imu": dead_gyro}):
        res = estimate_skid_steer(Run("sim/TEST/00", "sim", "TEST", streams))
        for name in ("log_icr_chi", "gyro_bias"):
            j = res.state_names.index(name)
            np.testing.assert_array_equal(res.state(name), prior.x0[j])
            assert (np.diff(res.P_diag[:, j]) >= 0).all()   # only the random walk's growth


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), engine=st.sampled_from(["numpy", "numba"]),
       gated=st.booleans())
def test_every_sample_is_counted_once(seed, engine, gated):
    """Of a one-row sensor's samples each is outside the grid, non-finite, superseded in its
    step, or the one of a step where it was used or rejected by the gate: the counts add up
    to the samples, and used + rejected are the steps the filter saw a value at."""
    from terrain.estimation import Gate
    from terrain.estimation.skid_steer import SkidSteerModel

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    grid = np.cumsum(np.r_[0.0, rng.uniform(0.001, 0.05, n - 1)])
    t = np.unique(np.r_[rng.uniform(-0.2, grid[-1] + 0.2, int(rng.integers(0, 80))),
                        grid[rng.integers(0, n, 5)]])
    g = rng.normal(0, 1, (t.size, 1)) * rng.choice([1, 50], (t.size, 1))
    g[rng.random(g.shape) < 0.2] = np.nan
    res = run_filter(SkidSteerModel(), grid, {"gyro": SensorSamples(t, g)},
                     gate=Gate(0.9) if gated else None, engine=engine)
    c = res.counts["gyro"]
    assert c["samples"] == t.size == (c["outside"] + c["non_finite"] + c["superseded"]
                                      + c["used"] + c["rejected"])
    row = res.measurement_names.index("wz")
    assert c["used"] == int(res.accepted[:, row].sum())
    assert c["used"] + c["rejected"] == int(np.isfinite(res.y[:, row]).sum())


def test_equal_latencies_of_every_stream_equal_timestamps_moved_by_them():
    import pandas as pd

    from terrain.estimation.skid_steer import estimate_skid_steer
    from terrain.run import Run

    rng = np.random.default_rng(2)
    t = np.round(np.arange(400) * 0.01, 10)
    tw = t[::5] + 0.003
    vel_l, vel_r = 0.5 + 0.03 * rng.normal(size=tw.size), 0.8 + 0.03 * rng.normal(size=tw.size)
    wz = 0.3 + 0.01 * rng.normal(size=t.size)

    def recording(shift):
        return Run("sim/TEST/00", "sim", "TEST", {
            "wheels": pd.DataFrame({"t_s": tw - shift, "vel_l": vel_l, "vel_r": vel_r}),
            "imu": pd.DataFrame({"t_s": t - shift, "wz": wz})})

    late = estimate_skid_steer(recording(0.0), time_offsets_s={"wheels": 0.04, "gyro": 0.04})
    moved = estimate_skid_steer(recording(0.04))
    np.testing.assert_allclose(late.t_s, moved.t_s, rtol=0, atol=1e-12)
    assert late.counts == moved.counts
    np.testing.assert_allclose(late.x, moved.x, rtol=0, atol=1e-9)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), turn=st.floats(0.05, 0.3))
@example(
    # The test always failed when commented parts were varied together.
    seed=0,  # or any other generated value
    turn=0.25,  # or any other generated value
).via('discovered failure')
def test_on_a_frame_with_a_dead_gyro_the_icr_factor_stays_at_its_prior(seed, turn):
    # est21's left-alone: skid_steer_on_frame (the EKF channels' path) with wz all NaN moved
    # ln(chi) on the wheels alone as estimate_skid_steer did before fad1e9c; one rule now
    from terrain.estimation.skid_steer import SkidSteerModel, skid_steer_on_frame

    frame = _turning_wheels(seed, turn).assign(wz=np.nan)
    res = skid_steer_on_frame(frame)
    j = res.state_names.index("log_icr_chi")
    np.testing.assert_array_equal(res.state("log_icr_chi"), SkidSteerModel().x0[j])
    live = skid_steer_on_frame(frame.assign(wz=turn / 0.28))     # a gyro: chi is estimated
    assert not np.array_equal(live.state("log_icr_chi"), res.state("log_icr_chi"))
