"""A recorded run cut into the closed loop's observations (terrain.control.replay)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.control.replay import measured_observations
from terrain.errors import ConfigError, MissingColumnError
from terrain.run import Run


def _run(imu_t, wheel_t):
    imu = pd.DataFrame({"t_s": imu_t, "wx": 0.0, "wy": 0.0, "wz": np.arange(len(imu_t)) * 1.0,
                        "ax": 0.5, "ay": 0.0, "az": 9.81})
    wheels = pd.DataFrame({"t_s": wheel_t, "vel_l": 0.2, "vel_r": -0.4, "cur_l": -3.0,
                           "cur_r": 2.0})
    return Run("test/SNOW/00", "test", "SNOW", {"imu": imu, "wheels": wheels}, source="mem")


def test_every_sample_in_the_common_span_arrives_once_in_time_order():
    imu_t = np.arange(0.0, 3.0, 0.01)            # 100 Hz from 0 s
    wheel_t = 0.25 + np.arange(0, 17) / 6.5      # 6.5 Hz from 0.25 s
    obs = list(measured_observations(_run(imu_t, wheel_t), wheel_radius_m=0.2,
                                     control_rate_hz=20.0))
    t = np.array([o.t_s for o in obs])
    np.testing.assert_allclose(np.diff(t), 0.05)
    assert t[0] == 0.25 and t[-1] <= 2.71
    for name, times in (("imu", imu_t), ("wheels", wheel_t), ("currents", wheel_t)):
        got = np.concatenate([getattr(o, name)[:, 0] for o in obs])
        expect = times[(times >= 0.25 - 1e-12) & (times <= t[-1] + 1e-12)]
        np.testing.assert_array_equal(got, expect)          # once each, in order
        for o in obs:                                       # none from the call's future
            assert np.all(getattr(o, name)[:, 0] <= o.t_s)
    w = np.concatenate([o.wheels for o in obs])
    np.testing.assert_allclose(w[:, 1:], [[1.0, -2.0]] * len(w))   # rim speed / radius
    c = np.concatenate([o.currents for o in obs])
    np.testing.assert_allclose(c[:, 1:], [[3.0, 2.0]] * len(c))    # magnitudes
    i = np.concatenate([o.imu for o in obs])
    np.testing.assert_allclose(i[:, 1], 0.5)                       # ax, ay, wz as logged
    np.testing.assert_array_equal(i[:, 3], np.round(i[:, 0] / 0.01))
    full = np.concatenate([o.imu_full for o in obs])               # wx wy wz ax ay az
    np.testing.assert_array_equal(full[:, [0, 4, 5, 3]], i)
    np.testing.assert_allclose(full[:, 6], 9.81)
    assert all(o.cam.shape == (0, 5) and o.steer.shape[0] == 0 for o in obs)


def test_a_run_without_currents_or_with_bad_settings_is_refused_by_name():
    run = _run(np.arange(0.0, 1.0, 0.01), np.arange(0.0, 1.0, 0.15))
    bare = Run(run.run_id, run.dataset, run.terrain,
               {"imu": run.streams["imu"],
                "wheels": run.streams["wheels"].drop(columns=["cur_r"])}, source="x.csv")
    with pytest.raises(MissingColumnError, match="cur_r") as err:
        next(measured_observations(bare, 0.2))
    assert "test/SNOW/00" in str(err.value) and err.value.path == "x.csv"
    with pytest.raises(MissingColumnError, match="imu"):
        next(measured_observations(Run("r", "t", None, {"wheels": run.streams["wheels"]}), 0.2))
    with pytest.raises(ConfigError):
        next(measured_observations(run, 0.0))


def test_empty_or_disjoint_streams_and_unusable_settings_are_typed_errors():
    """A run with an empty wheels stream raised numpy's 'index 0 is out of bounds for axis 0
    with size 0'; IMU samples over 0-1 s and wheel samples over 5-6 s gave no observation
    at all, without a word (the whole run dropped); a control rate of inf raised Python's
    'cannot convert float infinity to integer' and one given as text '50' a bare TypeError.
    Now a DataFormatError naming the run and the stream, a ClockError with both spans, and
    ConfigErrors naming the setting."""
    from terrain.errors import ClockError, DataFormatError

    imu_t = np.arange(0.0, 1.0, 0.01)
    with pytest.raises(DataFormatError, match=r"run test/SNOW/00 has no wheels samples") \
            as err:
        next(measured_observations(_run(imu_t, np.array([])), 0.2))
    assert err.value.path == "mem"
    with pytest.raises(ClockError, match=r"imu 0.00-0.99 s, wheels 5.00-5.90 s"):
        next(measured_observations(_run(imu_t, np.arange(5.0, 6.0, 0.15)), 0.2))
    run = _run(imu_t, np.arange(0.0, 1.0, 0.15))
    for radius, rate, name in ((0.2, float("inf"), "control_rate_hz"),
                               (0.2, "50", "control_rate_hz"),
                               (float("inf"), 50.0, "wheel_radius_m"),
                               (None, 50.0, "wheel_radius_m")):
        with pytest.raises(ConfigError, match=name):
            next(measured_observations(run, radius, rate))


def test_a_stream_whose_clock_is_not_finite_and_non_decreasing_is_refused_naming_the_row():
    """Two wheel samples logged out of order (t 0.45 before 0.6 swapped) cut the stream with
    a binary search that needs sorted times: one of the 14 wheel samples never reached an
    observation, unsaid; a NaN time (first or last row) dropped that sample the same way.
    Now a DataFormatError naming the run, the stream, the column t_s and the row."""
    from terrain.errors import DataFormatError

    imu_t = np.arange(0.0, 2.0, 0.01)
    wheel_t = np.arange(0.0, 2.0, 0.15)
    swapped = wheel_t.copy()
    swapped[[3, 4]] = swapped[[4, 3]]
    for times, row in ((swapped, 4), (np.r_[np.nan, wheel_t[1:]], 0),
                       (np.r_[wheel_t[:-1], np.nan], 13)):
        with pytest.raises(DataFormatError, match=r"run test/SNOW/00.*wheels") as err:
            next(measured_observations(_run(imu_t, times), 0.2))
        assert (err.value.column, err.value.row, err.value.path) == ("t_s", row, "mem")


def test_the_last_call_is_at_the_end_of_the_common_span_and_repeated_times_are_kept():
    """Calls run from t0 to the last t0 + k / rate not after the common end t1 (here t1
    itself, 2.0 s at 20 Hz: 41 calls, the last one carrying the samples at 2.0 s); a clock
    that repeats a time (non-decreasing) is accepted, both samples delivered; streams that
    meet in one instant give that one call, not a ClockError."""
    imu_t = np.arange(0, 201) / 100.0                          # 0 .. 2.0 s
    wheel_t = np.r_[np.arange(0, 21) / 10.0]                   # 0 .. 2.0 s
    obs = list(measured_observations(_run(imu_t, wheel_t), 0.2, 20.0))
    assert len(obs) == 41 and obs[-1].t_s == pytest.approx(2.0)
    assert obs[-1].wheels[-1, 0] == 2.0 and obs[-1].imu[-1, 0] == 2.0
    assert sum(len(o.wheels) for o in obs) == 21 and sum(len(o.imu) for o in obs) == 201
    repeated = np.r_[wheel_t[:5], wheel_t[4], wheel_t[5:]]     # 0.4 s logged twice
    obs = list(measured_observations(_run(imu_t, repeated), 0.2, 20.0))
    w = np.concatenate([o.wheels[:, 0] for o in obs])
    np.testing.assert_array_equal(w, repeated)
    meet = list(measured_observations(_run(np.array([0.0, 0.5, 1.0]),
                                           np.array([1.0, 1.5])), 0.2, 20.0))
    assert [o.t_s for o in meet] == [1.0]
    assert meet[0].imu[:, 0].tolist() == [1.0] and meet[0].wheels[:, 0].tolist() == [1.0]
