"""Review ctl21: the control layer at its boundaries (values exactly at a threshold, a limit
or a range end, and one ulp either side)."""

from types import MappingProxyType

import numpy as np
import pytest

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
