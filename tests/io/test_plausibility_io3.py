"""Plausibility thresholds of the io review (io3) that no test pinned: the correlation of rule
``gyro_units`` and the tenth of the overlap of rule ``clock_overlap``."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataWarning
from terrain.io.plausibility import check_run
from terrain.run import TIME
from test_file_lines_and_bounds import _streams


def _turning_run(noise: float, seed: int = 3):
    """Wheels whose speed difference has a std of 0.025 m/s, and a deg/s gyro whose yaw rate
    is 1.5 1/m times it plus white noise of ``noise`` (deg/s), sampled on the wheel clock."""
    rng = np.random.default_rng(seed)
    t_w = np.arange(201) / 10.0
    dv = 0.035 * np.sin(2 * np.pi * t_w / 5.0)
    wheels = pd.DataFrame({TIME: t_w, "vel_l": 0.5 - dv / 2, "vel_r": 0.5 + dv / 2,
                           "cur_l": 5 + rng.standard_normal(t_w.size),
                           "cur_r": 6 + rng.standard_normal(t_w.size)})
    t_i = t_w.copy()     # the IMU on the wheel clock: the rule's correlation is the noise's
    wz = np.degrees(1.5 * dv) + noise * rng.standard_normal(t_i.size)
    imu = pd.DataFrame({TIME: t_i, "wx": 0.01 * rng.standard_normal(t_i.size),
                        "wy": 0.01 * rng.standard_normal(t_i.size), "wz": wz,
                        "ax": 0.1 * rng.standard_normal(t_i.size),
                        "ay": 0.1 * rng.standard_normal(t_i.size),
                        "az": 9.81 + 0.1 * rng.standard_normal(t_i.size)})
    corr = float(np.corrcoef(dv, wz)[0, 1])
    return {"imu": imu, "wheels": wheels}, corr


@pytest.mark.parametrize("noise, refused", [(2.8, True), (5.5, False)])
def test_a_deg_s_gyro_is_refused_from_a_correlation_of_one_half(noise, refused):
    """Rule gyro_units' certain case needs ``|corr| >= 0.5`` (module docstring), not a
    near-perfect one: a noisy deg/s gyro at 0.6 is refused, one at 0.4 only warned."""
    from terrain.errors import UnitError

    streams, corr = _turning_run(noise)
    assert (0.5 <= corr < 0.7) if refused else (0.3 < corr < 0.5)
    call = (lambda: check_run("x/A/00", streams, "husky",
                              {"imu": "imu_00.csv", "wheels": "pro_00.csv"}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if refused:
            with pytest.raises(UnitError, match="rule gyro_units: slope"):
                call()
        else:
            found = call()["warnings"]
            assert any("rule gyro_units" in w and "probably in deg/s" in w for w in found)


@pytest.mark.parametrize("run_on_s, warned", [(9.9, False), (10.5, True), (15.0, True)])
def test_a_stream_running_on_is_warned_beyond_a_tenth_of_a_long_overlap(run_on_s, warned):
    """Rule ``clock_overlap``: past MAX_UNUSED_SPAN_S (2 s), a stream running on is warned
    only beyond a tenth of the overlap: 100 s of overlap tolerate 10 s (counted either
    way)."""
    imu_t = np.arange(5001) / 50.0                           # 0 .. 100 s
    wheel_t = np.arange(round((100.0 + run_on_s) * 10) + 1) / 10.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        out = check_run("r", _streams(imu_t, wheel_t), "husky", {"imu": "imu.csv"})
    assert out["unused_s"] == pytest.approx({"wheels": run_on_s})
    found = [w for w in out["warnings"] if "clock_overlap" in w]
    assert len(found) == warned


@pytest.mark.parametrize("rate_hz, warned", [(2004.0, True), (2000.4, False)])
def test_the_implied_rate_is_judged_to_four_significant_digits(rate_hz, warned):
    """Rule ``timestamp_units`` judges the rate as printed, to 4 significant digits: an IMU
    at 2004 Hz is outside its 10-2000 Hz (three digits would make it 2000, inside), and
    2000.4 Hz is 2000 Hz."""
    from terrain.io.plausibility import check_rate, implied_rate_hz

    t = np.arange(200) / rate_hz
    assert implied_rate_hz(t) == round(rate_hz)
    found: list[str] = []
    check_rate(t, "imu", "imu_00.csv", found=found)
    assert len(found) == warned
    if warned:
        assert "implied sample rate 2004 Hz outside the nominal 10-2000 Hz" in found[0]


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_deg_s_gyro_is_refused_with_a_non_finite_sample_among_its_rates(bad):
    """A served request is checked before its isolated non-finite samples are flagged: one
    NaN in ``wz`` made the rule's correlation NaN, so a deg/s gyro passed as rad/s; the
    rule now judges the finite samples (as rule wheel_speed_units does)."""
    from terrain.errors import UnitError

    streams, _ = _turning_run(2.8)
    streams["imu"].loc[50, "wz"] = bad
    streams["imu"].loc[70, "wx"] = bad
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(UnitError, match="rule gyro_units: slope"):
            check_run("x/A/00", streams, "husky", {"imu": "imu_00.csv"})


def test_a_rad_s_gyro_with_non_finite_samples_is_judged_on_its_finite_ones():
    """Three inf yaw rates among 201 made the rule's 99th percentile, spread and
    correlation NaN (NumPy's "invalid value" warnings), judging nothing."""
    streams, _ = _turning_run(0.0)
    imu = streams["imu"]
    imu["wz"] = np.radians(imu["wz"])                  # the same gyro in rad/s
    imu.loc[[20, 90, 150], "wz"] = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        warnings.simplefilter("error", RuntimeWarning)
        found = check_run("x/A/00", streams, "husky", {"imu": "imu_00.csv"})["warnings"]
    assert not any("gyro_units" in w for w in found), found
