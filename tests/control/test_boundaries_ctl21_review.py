"""Review ctl21: the control layer at its boundaries (values exactly at a threshold, a limit
or a range end, and one ulp either side)."""

from types import MappingProxyType

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from terrain.control.closed_loop import TractionLoop
from terrain.control.desired_slip import (DesiredSlip, DesiredSlipConfig, SlipTable,
                                          fallback_entry)
from terrain.control.estimators import VelocityEstimate
from terrain.control.traction import TractionControlConfig

from tests.control.control_helpers import observation


class _Spinning:
    """Both sides spinning: rim 1.0 m/s (10 rad/s at r 0.1 m) on ground at 0.5 m/s."""

    name = "spinning"
    limits = "fixed"

    def update(self, obs):
        return VelocityEstimate(np.full(2, 10.0), np.full(2, 0.5), np.zeros(2), 0.5, 0.0)


def _table(traction: float) -> SlipTable:
    """A hand-built table of one catalogued class (ICE) with the given traction target."""
    entry = DesiredSlip("ICE", traction, -0.5, 0.0, "hand-built", "test")
    return SlipTable(MappingProxyType({"ICE": entry}), fallback_entry([entry]),
                     DesiredSlipConfig())


@pytest.mark.parametrize("traction", [1.0, float(np.nextafter(1.0, 0.0)), 0.5])
def test_loop_runs_with_a_traction_target_at_the_top_of_its_range(traction):
    """A DesiredSlip's traction target is in (0, 1] (check_slip_targets): 1 is a valid
    target. With the feed-forward on (the default) the loop handed it to feedforward_step,
    which refuses |target_slip| >= 1: the first call of a loop on a hand-built table
    whose target is 1 stopped on a ConfigError. At 1 no ground speed limits the wheel:
    no feed-forward correction; just below it the limit is a finite wheel speed."""
    loop = TractionLoop(TractionControlConfig(kp=1.0, wheel_radius_m=0.1), 2, _Spinning(),
                        _table(traction), lambda t: ("ICE", 1.0))
    for k in range(5):
        corr = loop(observation(0.02 * k, np.full(2, 10.0)))
        assert corr.shape == (2,) and np.all(np.isfinite(corr))
    if traction == 1.0:
        assert not loop.ff_engaged.any()
        # the feedback alone: slip 0.5 against a target of 1 leaves the wheel as it is
        assert np.all(corr == 0.0)


# --- estimators on an epoch clock: a sample exactly one block / one period later ----------------

EPOCH_S = 1.7e9   # a robot's log stamped in Unix time


@pytest.mark.parametrize("t0", [0.0, EPOCH_S, EPOCH_S + 0.003])
def test_averaged_imu_block_holds_eleven_samples_at_100_hz_on_any_clock(t0):
    """AgriMaRoVisualOdometryEKF's ``full-averaged`` view: "a block closes at the first
    sample accel_block_s after its first, so at 100 Hz a 0.1 s block holds 11". The block
    compared ``t - t_first`` with 0.1 s less 1 ns; on an epoch clock the difference of two
    stamps rounds by 2.4e-7 s, so the sample 0.1 s later fell short and the block held 12
    (its first std 0.8 / sqrt(12), not / sqrt(11))."""
    from terrain.control.estimators import AgriMaRoVisualOdometryEKF

    est = AgriMaRoVisualOdometryEKF(imu="full-averaged")
    stds = []
    for k in range(12):
        t = t0 + k * 0.01
        row = np.array([[t, 0.0, 0.0, 0.0, 0.1, 0.0, 9.81]])   # t, wx wy wz ax ay az
        est.update(observation(t, np.zeros(3), imu_full=row))
        stds.append(est.accel_block_std_m_s2[0])
    assert np.all(np.isnan(stds[:10]))          # samples 0..9: the block still open
    # sample 10, 0.1 s after the first, closes it: the floor of an 11-sample mean (0.8 m/s^2)
    assert stds[10] == pytest.approx(0.8 / np.sqrt(11), rel=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("t0", [EPOCH_S, EPOCH_S + 0.007, 1.23456789e9])
def test_fused_observer_takes_a_pseudo_measurement_every_period_on_any_clock(t0):
    """FusedSlipObserver: a pseudo-measurement "every period_s" (0.2 s: every 10th call at
    50 Hz). It compared the time since the last one with period_s less 1 ns; on an epoch
    clock that difference rounds by 2.4e-7 s, and a call exactly one period later was
    skipped: on a BorealTC run stamped from 1.7e9 s, 16 of 58 intervals were 0.22 s. The
    calls that take one must not depend on the clock's origin."""
    from terrain.control.estimators import FusedSlipObserver

    def taken(origin):
        est = FusedSlipObserver("husky", lambda t: ("ASPHALT", 1.0))
        calls = []
        for k in range(120):
            t = origin + k * 0.02
            before = est.t_pseudo
            est.update(observation(t, np.full(2, 5.0),
                                   wheels=np.array([[t, 5.0, 5.0]]),
                                   currents=np.array([[t, 2.0, 2.0]])))
            if est.t_pseudo != before:
                calls.append(k)
        return calls

    expected = taken(0.0)
    assert expected == list(range(0, 120, 10))
    assert taken(t0) == expected


# --- a measured run's replay: a sample stamped at a call's time belongs to that call ----------

def _logged_run(t0: float, seconds: float = 2.0):
    """A run logged with millisecond stamps (as text in a CSV): IMU at 100 Hz and wheels at
    50 Hz over ``seconds`` from ``t0``, every wheel sample on a 50 Hz call's time."""
    import pandas as pd

    from terrain.run import Run

    def stamps(rate):
        return np.array([float(f"{t0 + k / rate:.3f}") for k in range(int(seconds * rate) + 1)])

    imu = pd.DataFrame({"t_s": stamps(100), "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0,
                        "ay": 0.0, "az": 9.81})
    wheels = pd.DataFrame({"t_s": stamps(50), "vel_l": 1.0, "vel_r": 1.0, "cur_l": 2.0,
                           "cur_r": 2.0})
    return Run("logged", "test", "ASPHALT", {"imu": imu, "wheels": wheels})


@pytest.mark.parametrize("t0", [0.0, EPOCH_S + 0.01, 1.6e9 + 0.37, 1.7e9 + 0.33])
def test_replay_never_hands_a_call_a_sample_stamped_after_it_on_any_clock(t0):
    """measured_observations: "each call carries the samples after the previous call up to
    and including its own time". A wheel sample logged at a call's time (to the log's
    millisecond) and the call time t0 + k / rate round apart on an epoch clock; where the
    sample rounds above, it goes to the next call (pinned, documented): handed to the call,
    its age would be negative, and a negative age is distrusted (age_is_fresh: the safe
    output). Every sample still arrives exactly once, in order, and none is dropped."""
    from terrain.control.replay import measured_observations

    replay = measured_observations(_logged_run(t0), 0.165, control_rate_hz=50.0)
    calls = list(replay)
    assert len(calls) == 101
    for c in calls:
        for name in ("imu", "wheels", "currents", "imu_full"):
            assert np.all(getattr(c, name)[:, 0] <= c.t_s)
    run = _logged_run(t0)
    for name, stream in (("wheels", "wheels"), ("imu", "imu")):
        got = np.concatenate([getattr(c, name)[:, 0] for c in calls])
        np.testing.assert_array_equal(got, run.streams[stream]["t_s"].to_numpy())
    # a sample never arrives more than one call late
    for c in calls:
        assert np.all(c.t_s - c.wheels[:, 0] < 0.02 + 1e-6)
    assert replay.dropped_before_start == {"imu": 0, "wheels": 0}
    assert replay.dropped_after_end == {"imu": 0, "wheels": 0}


# --- the traction step's thresholds: exactly at each, and one ulp either side -----------------

def _up(x):
    return float(np.nextafter(x, np.inf))


def _down(x):
    return float(np.nextafter(x, -np.inf))


def _step(cfg=None, targets=None, omega=1.0, v=1.0, acc=0.0, chassis=1.0, dt=0.02, age=0.0,
          state=None, omega_ll=1.0):
    from terrain.control.traction import SlipTargets, TractionState, traction_control_step

    cfg = cfg or TractionControlConfig()                      # r 1 m: omega r = omega
    targets = targets or SlipTargets(0.1, -0.15, 0.05)
    state = TractionState.zeros(1) if state is None else state
    return traction_control_step(cfg, state, targets, np.array([omega_ll]), np.array([omega]),
                                 np.array([v]), np.array([acc]), chassis, dt, age)


@settings(max_examples=60, deadline=None)
@given(threshold=st.floats(0.0, 5.0, allow_subnormal=False))
def test_chassis_speed_exactly_at_the_threshold_does_not_enable(threshold):
    """"the correction reaches the motors only while the chassis speed *exceeds*
    chassis_speed_threshold_m_s" (ch. 8.3.2: "only if the robot's global velocity exceeds
    the predetermined threshold"): at it, disabled; one ulp above, enabled."""
    cfg = TractionControlConfig(chassis_speed_threshold_m_s=threshold)
    at, _ = _step(cfg, chassis=threshold)
    above, _ = _step(cfg, chassis=_up(threshold))
    assert not at.enabled[0] and above.enabled[0]
    assert not at.safe[0] and not above.safe[0]


@pytest.mark.parametrize("threshold", [0.05, 0.384, 1.0])
def test_wheel_speed_exactly_at_the_threshold_is_controlled(threshold):
    """Per-wheel enable: "the error is 0 *below* wheel_speed_threshold_m_s" (the wheel's
    speed max(|omega r|, |v_long|)), and sae_slip's dead band zeroes the slip only where
    both speeds are *below* it: at the threshold the slip is measured and the error acts;
    one ulp below, error and slip are 0. The two rules agree at the edge (a slip zeroed
    by the dead band while the error acts would drive the wheel towards its target)."""
    cfg = TractionControlConfig(wheel_speed_threshold_m_s=threshold)
    at, _ = _step(cfg, omega=0.5 * threshold, v=threshold)        # rim half the ground speed
    below, _ = _step(cfg, omega=0.5 * threshold, v=_down(threshold))
    assert at.slip[0] == pytest.approx(-0.5) and at.error[0] != 0.0
    assert below.slip[0] == 0.0 and below.error[0] == 0.0


@pytest.mark.parametrize("sign, mode", [(1.0, 1), (-1.0, -1)])
def test_power_exactly_at_the_threshold_is_steady(sign, mode):
    """Eqs. 8.7-8.9: traction where Power_state > threshold, braking where < -threshold,
    steady for -threshold <= Power_state <= threshold (both ends steady); one ulp beyond,
    traction or braking."""
    from terrain.control.traction import STEADY

    thr = TractionControlConfig().power_threshold_m2_s3           # v_long 1 m/s: power = a
    at, _ = _step(acc=sign * thr)
    beyond, _ = _step(acc=float(np.nextafter(sign * thr, sign * np.inf)))
    assert at.mode[0] == STEADY and beyond.mode[0] == mode


@settings(max_examples=60, deadline=None)
@given(max_age=st.floats(1e-6, 10.0))
def test_input_age_exactly_at_the_limit_is_fresh(max_age):
    """age_is_fresh: ages in [0, max_input_age_s] are trusted, both ends included: exactly
    at the limit (and at 0) the controller acts; one ulp older, or one ulp before 0 (a
    stamp after the step), the safe output."""
    cfg = TractionControlConfig(max_input_age_s=max_age)
    for age, safe in ((max_age, False), (_up(max_age), True), (0.0, False),
                      (_down(0.0), True)):
        out, _ = _step(cfg, age=age)
        assert out.safe[0] == safe, age


def test_targets_at_the_ends_of_their_ranges_are_accepted_and_one_ulp_beyond_refused():
    """check_slip_targets: traction in (0, 1], braking in [-1, 0), steady in [0, 1]: the
    closed ends (1, -1, 0 and 1) are targets; one ulp beyond each, and the open ends
    themselves (a traction of 0, a braking of 0), are refused by name."""
    from terrain.control.traction import SlipTargets
    from terrain.errors import ConfigError

    for targets in ((1.0, -1.0, 1.0), (_up(0.0), _down(0.0), 0.0)):
        out, _ = _step(targets=SlipTargets(*targets), v=1.0, omega=1.5)
        assert np.all(np.isfinite(out.omega_cmd_rad_s))
    for bad, name in (((_up(1.0), -0.5, 0.1), "traction"), ((0.0, -0.5, 0.0), "traction"),
                      ((0.5, _down(-1.0), 0.1), "braking"), ((0.5, 0.0, 0.1), "braking"),
                      ((0.5, -0.5, _down(0.0)), "steady"), ((0.5, -0.5, _up(1.0)), "steady")):
        with pytest.raises(ConfigError, match=f"SlipTargets.{name}"):
            SlipTargets(*bad)


def test_first_step_after_reset_has_no_derivative_and_integrates_one_step():
    """After reset the memory is empty: the first step's derivative is 0 whatever the
    previous slip was (no slip_prev is valid), and its integral is ki e dt alone, so an
    unsaturated output is (kp + ki dt) e."""
    from terrain.control.traction import SlipTargets, TractionController

    cfg = TractionControlConfig(kp=2.0, ki=10.0, kd=5.0, one_sided=False,
                                chassis_speed_threshold_m_s=0.0)
    ctl = TractionController(cfg, 1)
    targets = SlipTargets(0.1, -0.15, 0.05)
    args = (np.array([10.0]), np.array([12.0]), np.array([10.0]), np.array([1.0]), 10.0,
            0.02)
    for _ in range(5):                       # memory: slip, derivative, integral
        ctl.step(targets, *args)
    ctl.reset()
    first = ctl.step(targets, np.array([10.0]), np.array([10.5]), np.array([10.0]),
                     np.array([1.0]), 10.0, 0.02)
    e = first.error[0]
    assert first.enabled[0] and e != 0.0
    assert first.correction_rad_s[0] == pytest.approx((2.0 + 10.0 * 0.02) * e, rel=1e-12)


@pytest.mark.parametrize("t0", [0.0, 12.34, EPOCH_S + 0.007])
def test_fused_observer_window_holds_its_start_sample_on_any_clock(t0, monkeypatch):
    """FusedSlipObserver's physics slip averages "the last window_s of current and wheel
    samples": those at or after ``t - window_s``. A sample exactly ``window_s`` before the
    call (0.5 s: 25 calls back at 50 Hz) was in or out by the rounding of ``t - 0.5``: on a
    clock from 0 s the windows held 26, 25, 26, 26, 25 ... samples (n_averaged, the
    pseudo-measurement's std, jittered with it); now 26 each on any clock."""
    import terrain.control.estimators as estimators

    counts = []
    real = estimators.physics_slip

    def spy(*args, **kwargs):
        counts.append(kwargs["n_averaged"])
        return real(*args, **kwargs)

    monkeypatch.setattr(estimators, "physics_slip", spy)
    est = estimators.FusedSlipObserver("husky", lambda t: ("ASPHALT", 1.0))
    for k in range(120):
        t = t0 + k * 0.02
        est.update(observation(t, np.full(2, 5.0), wheels=np.array([[t, 5.0, 5.0]]),
                               currents=np.array([[t, 2.0, 2.0]])))
    assert counts[:3] == [1.0, 11.0, 21.0]          # the run's first 0, 0.2, 0.4 s
    assert counts[3:] == [26.0] * (len(counts) - 3)


def test_loop_first_call_integrates_over_the_one_microsecond_floor_only():
    """TractionLoop's first call has no previous one: it steps the PID with the 1 us floor
    of a repeated time, so with kp = kd = 0 its correction is ki e 1e-6 (documented; it was
    said to integrate nothing), its derivative 0; the second call integrates its interval."""
    cfg = TractionControlConfig(kp=0.0, ki=100.0, kd=0.0, wheel_radius_m=0.1)
    loop = TractionLoop(cfg, 2, _Spinning(), _table(0.1), lambda t: ("ICE", 1.0),
                        feed_forward=False)
    first = loop(observation(0.0, np.full(2, 10.0)))
    e = loop.log[0]["desired"] - 0.5                      # slip (1.0 - 0.5) / 1.0
    np.testing.assert_allclose(first, 100.0 * 1e-6 * e, rtol=1e-9)
    second = loop(observation(0.02, np.full(2, 10.0)))
    np.testing.assert_allclose(second, 100.0 * (1e-6 + 0.02) * e, rtol=1e-9)


@pytest.mark.parametrize("t0", [0.0, 12.34, EPOCH_S + 0.007])
def test_fused_observer_speed_bound_keeps_the_sample_current_hold_s_back_only(t0):
    """The speed bound holds each end at its widest over the last speed_bound_hold_s (1 s):
    "every sample after t - hold_s and the one current then". A wheel sample exactly hold_s
    back is the one current then, so the sample before it no longer counts; by the
    rounding of t - hold_s it was kept on a clock from 0 s at some calls (52 wheel rows, the
    range widened by a sample 1.02 s old, instead of 51 at 50 Hz)."""
    from terrain.control.estimators import FusedSlipObserver

    est = FusedSlipObserver("husky", lambda t: ("ASPHALT", 1.0))
    kept = []
    for k in range(150):
        t = t0 + k * 0.02
        est.update(observation(t, np.full(2, 5.0), wheels=np.array([[t, 5.0, 5.0]]),
                               currents=np.array([[t, 2.0, 2.0]])))
        kept.append(len(est.bound_rows))
        assert est.bound_rows[0][0] >= t - 1.0 - 1e-6        # none older than hold_s
    assert kept[60:] == [51] * 90


def test_loop_trusts_a_decision_exactly_max_decision_age_s_old_on_its_call_grid():
    """select_target trusts a decision whose age equals max_decision_age_s (4 s), and one of
    age 0. The loop took the age as obs.t_s - t_decided_s: on its 50 Hz call grid a decision
    made 200 calls (4 s) earlier read 4.000000000000001 s old at 194 of 1800 calls and got
    the fallback; one stamped at the call time by another rounding (1 ulp later) read a
    negative age, the fallback too. Within the clock's rounding both are trusted; a
    decision 1 us older than the limit is not."""
    cfg = TractionControlConfig(wheel_radius_m=0.1)
    table = _table(0.5)
    for lag_calls, extra_s, trusted in ((200, 0.0, True), (0, 0.0, True), (200, 1e-6, False)):
        def decision(t, n=lag_calls, x=extra_s):   # made n calls before t, x s earlier
            return "ICE", 1.0, round(t / 0.02 - n) * 0.02 - x

        loop = TractionLoop(cfg, 2, _Spinning(), table, decision, feed_forward=False)
        for k in range(200, 600):
            loop(observation(k * 0.02, np.full(2, 10.0)))
        fallback = [r["fallback"] for r in loop.log]
        assert fallback == [not trusted] * 400, (lag_calls, extra_s, sum(fallback))
    loop = TractionLoop(cfg, 2, _Spinning(), table,
                        lambda t: ("ICE", 1.0, float(np.nextafter(t, np.inf))),
                        feed_forward=False)
    for k in range(200, 300):
        loop(observation(k * 0.02, np.full(2, 10.0)))
    assert not any(r["fallback"] for r in loop.log)


@pytest.mark.parametrize("stamp", [np.inf, -np.inf, np.nan])
def test_loop_gives_the_fallback_for_a_decision_stamped_at_infinity(stamp):
    """A decision time that is not finite has no age: the fallback (its rounding allowance
    is not an infinite one)."""
    loop = TractionLoop(TractionControlConfig(wheel_radius_m=0.1), 2, _Spinning(),
                        _table(0.5), lambda t: ("ICE", 1.0, stamp), feed_forward=False)
    loop(observation(1.0, np.full(2, 10.0)))
    assert loop.log[0]["fallback"]
