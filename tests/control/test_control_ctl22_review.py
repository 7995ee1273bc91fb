"""Review ctl22: numerical robustness and determinism of the control layer.

Long horizons (an hour of a saturated actuator), derivative kick on a target step, clocks
far from 0 (epoch stamps: intervals from differences), and the same tuning from the same
seeds.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from control_helpers import observation
from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionState,
                                      traction_control_step)

EPOCH_S = 1.7e9   # a robot's log stamped in Unix time


# --- the AgriMaRo estimator's speed slope on an epoch clock ------------------------------------

def _slope_window(origin: float, window_s: float, calls: int = 60):
    """Window sizes and slopes of ``_speed_slope`` over 50 Hz calls from ``origin`` of a
    speed rising as the square of the time since the first call."""
    from terrain.control.estimators import AgriMaRoVisualOdometryEKF

    est = AgriMaRoVisualOdometryEKF(speed_slope_s=window_s)
    sizes, slopes = [], []
    for k in range(calls):
        t = origin + k * 0.02
        slopes.append(est._speed_slope(t, np.full(3, (k * 0.02) ** 2), np.zeros(3))[0])
        sizes.append(len(est._speeds))
    return sizes, np.array(slopes)


@pytest.mark.parametrize("origin", [EPOCH_S + 636.9616873, EPOCH_S + 269.7867138,
                                    1.6e9 + 0.37])
@pytest.mark.parametrize("window_s", [0.3, 0.5, 0.7])
def test_agrimaro_speed_slope_keeps_the_same_calls_on_an_epoch_clock(origin, window_s):
    """``full-gyro``: the acceleration is the slope of the speeds of the calls in the last
    ``speed_slope_s``. The window dropped a call older than ``t - speed_slope_s - 1 ns``; on
    an epoch clock the difference of two stamps rounds by 2.4e-7 s, so with a window of
    0.3 s the call exactly 0.3 s back was kept or dropped by the clock's origin (15 or 16
    calls at 50 Hz) and the slope of a speed rising as t^2 moved by 0.02 m/s^2 (10 %)."""
    sizes0, slopes0 = _slope_window(0.0, window_s)
    sizes, slopes = _slope_window(origin, window_s)
    assert sizes == sizes0
    np.testing.assert_allclose(slopes, slopes0, atol=1e-4)


# --- a measured run's replay: the calls do not depend on the clock's origin ---------------------

def _logged_run(t0: float, seconds: float):
    """A run logged with millisecond stamps: IMU at 100 Hz, wheels at 50 Hz from ``t0``."""
    from terrain.run import Run

    def stamps(rate):
        return np.array([float(f"{t0 + k / rate:.3f}")
                         for k in range(int(round(seconds * rate)) + 1)])

    imu = pd.DataFrame({"t_s": stamps(100), "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0,
                        "ay": 0.0, "az": 9.81})
    wheels = pd.DataFrame({"t_s": stamps(50), "vel_l": 1.0, "vel_r": 1.0, "cur_l": 2.0,
                           "cur_r": 2.0})
    return Run("logged", "test", "ASPHALT", {"imu": imu, "wheels": wheels})


@pytest.mark.parametrize("t0", [0.0, 123.457, EPOCH_S + 0.013, EPOCH_S + 52_345.678,
                                1.6e9 + 0.37])
@pytest.mark.parametrize("seconds", [1.7, 2.3, 2.9])
def test_replay_makes_every_call_of_the_span_on_any_clock(t0, seconds):
    """measured_observations: "calls are at t0, t0 + 1/rate, ... from the later of the two
    streams' first samples to the earlier of their last". The number of calls compared
    ``(t1 - t0) / period`` with a slack of 1e-9 periods; on an epoch clock ``t1 - t0``
    rounds by 2.4e-7 s, so the call at t1 itself (the last sample of the span) was dropped
    on some origins: 85 calls over 1.7 s of a log stamped from 1.7e9 s, 86 from 0 s, and the
    last wheel and IMU samples were not replayed."""
    from terrain.control.replay import measured_observations

    calls = list(measured_observations(_logged_run(t0, seconds), 0.165, 50.0))
    assert len(calls) == int(round(seconds * 50)) + 1
    assert calls[-1].t_s == pytest.approx(t0 + seconds, abs=1e-5)
    for c in calls:   # still: no call receives a sample stamped after it
        assert np.all(c.wheels[:, 0] <= c.t_s) and np.all(c.imu[:, 0] <= c.t_s)


@pytest.mark.slow
def test_replay_keeps_the_call_count_of_the_shipped_runs():
    """The slack of the call count changes nothing on the shipped BorealTC runs (stamped
    from 0 s: 1 ns there, as the 1e-9 periods before, to well within a period): the same
    last call on every run, so no figure measured on them moves."""
    from terrain.control.replay import measured_observations
    from terrain.io.shipped import read_shipped

    runs = [r for r in read_shipped("borealtc") if "imu" in r.streams][:12]
    assert runs
    for run in runs:
        t_imu, t_wh = (run.streams[s]["t_s"].to_numpy(float) for s in ("imu", "wheels"))
        t0, t1 = max(t_imu[0], t_wh[0]), min(t_imu[-1], t_wh[-1])
        old = int(np.floor((t1 - t0) / 0.02 + 1e-9))
        replay = measured_observations(run, 0.165, 50.0)
        assert sum(1 for _ in replay) == old + 1, run.run_id


# --- the traction PID over an hour of a saturated actuator --------------------------------------

def _saturate(cfg, seconds, dt=0.2):
    """``seconds`` of a wheel spinning far beyond its target (slip 0.95, traction 0.1): the
    correction saturates at its room; the state after it."""
    state = TractionState.zeros(1)
    targets = SlipTargets(0.1, -0.15, 0.05)
    for _ in range(int(round(seconds / dt))):
        out, state = traction_control_step(cfg, state, targets, np.array([10.0]),
                                           np.array([20.0]), np.array([1.0]), np.zeros(1),
                                           1.0, dt)
    return out, state


@pytest.mark.slow
@pytest.mark.parametrize("one_sided", [True, False])
def test_an_hour_saturated_winds_the_integral_up_no_further_than_a_minute(one_sided):
    """Conditional integration: while the output sits at its limit the integral holds the
    value that just reaches it. After an hour of saturation (18 000 steps of 0.2 s, the
    error never changes) the state is the state after a minute, bit for bit, and the
    output is exactly at the room's edge (the command at 0: the wheel held still)."""
    cfg = TractionControlConfig(kp=1.0, ki=10.0, kd=0.5, one_sided=one_sided)
    out_min, minute = _saturate(cfg, 60.0)
    out_hour, hour = _saturate(cfg, 3600.0)
    for a, b in zip(minute, hour):
        np.testing.assert_array_equal(a, b)
    assert out_hour.correction_rad_s[0] == -10.0 and out_hour.omega_cmd_rad_s[0] == 0.0
    # p + I + d is the limit exactly: nothing left to unwind beyond it
    assert cfg.kp * out_hour.error[0] + hour.integral[0] - cfg.kd * hour.derivative[0] \
        == pytest.approx(-10.0, abs=1e-12)


# --- derivative kick on a target step ------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(kd=st.floats(0.01, 5.0), slip_v=st.floats(0.3, 0.9),
       traction=st.floats(0.05, 0.5), braking=st.floats(-0.5, -0.05))
def test_a_target_step_moves_the_output_by_kp_times_the_step_only(kd, slip_v, traction,
                                                                  braking):
    """Derivative on the measured slip: when the acceleration switches the mode from
    traction to braking (the target steps from +traction to braking) with the wheel's slip
    unchanged, the derivative term is unchanged and the output (ki 0, two-sided, far from
    its limits) moves by kp times the target step alone, no kick."""
    cfg = TractionControlConfig(kp=2.0, ki=0.0, kd=kd, one_sided=False,
                                omega_max_rad_s=1000.0, output_fraction=1.0)
    targets = SlipTargets(traction, braking, 0.0)
    omega = np.array([10.0])
    v = np.array([10.0 * (1.0 - slip_v)])
    state = TractionState.zeros(1)
    for acc in (1.0, 1.0, 1.0):   # traction: the wheel's slip settles (constant)
        out_t, state = traction_control_step(cfg, state, targets, omega, omega, v,
                                             np.array([acc]), 1.0, 0.02)
    out_b, after = traction_control_step(cfg, state, targets, omega, omega, v,
                                         np.array([-1.0]), 1.0, 0.02)
    assert out_t.mode[0] == 1 and out_b.mode[0] == -1
    assert after.derivative[0] == state.derivative[0]
    step = out_b.desired_slip[0] - out_t.desired_slip[0]
    assert out_b.correction_rad_s[0] - out_t.correction_rad_s[0] == pytest.approx(
        cfg.kp * step, abs=1e-9)


# --- the loop's PID on an epoch clock: intervals from differences --------------------------------

class _Constant:
    """An estimator whose wheel slips at 0.5 against a ground speed of 1 m/s, always fresh."""

    name = "constant"
    limits = "none"

    def update(self, obs):
        from terrain.control.estimators import VelocityEstimate

        return VelocityEstimate(np.array([2.0, 2.0]), np.array([1.0, 1.0]), np.zeros(2), 1.0,
                                0.0)


def _loop_integral(origin: float, calls: int = 500):
    from terrain.control.closed_loop import TractionLoop
    from terrain.control.desired_slip import build_slip_table

    cfg = TractionControlConfig(kp=0.0, ki=1.0, wheel_radius_m=1.0, one_sided=False,
                                omega_max_rad_s=1000.0, output_fraction=1.0)
    loop = TractionLoop(cfg, 2, _Constant(), build_slip_table(["ASPHALT"]),
                        lambda t: ("ASPHALT", 1.0), feed_forward=False)
    for k in range(calls):
        loop(observation(origin + k * 0.01, np.full(2, 2.0)))
    return loop.controller.state.integral


@pytest.mark.parametrize("origin", [EPOCH_S, EPOCH_S + 0.013, 1.6e9 + 0.37])
def test_the_loop_integrates_the_same_error_on_an_epoch_clock(origin):
    """The loop's intervals are differences of call times: on an epoch clock each rounds by
    2.4e-7 s (2.4e-5 of a 100 Hz period), which must not add up: the integral over 5 s of
    a constant error equals the one on a clock from 0 within 1e-5 (relative)."""
    ref = _loop_integral(0.0)
    assert np.all(np.abs(ref) > 0.1)
    np.testing.assert_allclose(_loop_integral(origin), ref, rtol=1e-5)


# --- tuning: the same seeds give the same table, in another process too --------------------------

_TUNE = ("from terrain.control.grid import tune_gains; "
         "best, table = tune_gains('husky', ['SNOW'], [2.0], [5.0], duration_s=0.3, "
         "seeds=[1000]); print(repr(best)); print(table.to_json(double_precision=15))")


@pytest.mark.slow
def test_tuning_is_reproducible_in_a_fresh_process_with_another_hash_seed():
    """tune_gains on the same seeds: the same best gains and the same table, bit for bit,
    in this process and in a fresh one with another PYTHONHASHSEED (no set or dict order of
    strings, no global random stream, no clock in the result)."""
    from terrain.control.grid import tune_gains

    best, table = tune_gains("husky", ["SNOW"], [2.0], [5.0], duration_s=0.3,
                             seeds=[1000])
    here = f"{best!r}\n{table.to_json(double_precision=15)}\n"
    env = dict(os.environ, PYTHONHASHSEED="12345")
    got = subprocess.run([sys.executable, "-c", _TUNE], capture_output=True, text=True,
                         env=env, timeout=120, check=True).stdout
    assert got == here


# --- an estimate stamped at the call's time by another rounding (epoch clock) -------------------

class _StampedAtTheCall(_Constant):
    """An estimate whose reference sample was taken at the call's time, but stamped by
    another clock rounding: one unit in the last place after the call on an epoch clock."""

    def update(self, obs):
        est = super().update(obs)
        return est._replace(age_s=float(obs.t_s - np.nextafter(obs.t_s, np.inf)))


def test_an_estimate_stamped_at_the_call_by_another_rounding_is_fresh():
    """TractionLoop: an estimate's age of -2.4e-7 s on an epoch clock is the clocks'
    rounding of a sample taken at the call, not a clock error; the decision's age is already
    read so (``_decision_age``), the estimate's age is not: every such call gave the safe
    output and reset the integral and the derivative."""
    from terrain.control.closed_loop import TractionLoop
    from terrain.control.desired_slip import build_slip_table

    cfg = TractionControlConfig(kp=1.0, ki=1.0, wheel_radius_m=1.0)
    loop = TractionLoop(cfg, 2, _StampedAtTheCall(), build_slip_table(["ASPHALT"]),
                        lambda t: ("ASPHALT", 1.0), feed_forward=False)
    for k in range(3):
        loop(observation(EPOCH_S + k * 0.01, np.full(2, 2.0)))
    assert not np.any(loop.log[-1]["safe"])
