"""A dead (all-zero) accelerometer is a stuck-sensor warning, not a unit error (fuzzing
finding); an accelerometer in g stays a :class:`UnitError` (README, "Bad input")."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataWarning, UnitError
from terrain.io.measured import read_runs_dir, read_stream_csv
from terrain.io.plausibility import check_accel_units


def _imu(n: int, rate_hz: float = 100.0, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate_hz
    frame = pd.DataFrame({"time": t, "wx": 0.02 * rng.standard_normal(n),
                          "wy": 0.02 * rng.standard_normal(n),
                          "wz": 0.05 * rng.standard_normal(n),
                          "ax": 0.3 * rng.standard_normal(n),
                          "ay": 0.3 * rng.standard_normal(n),
                          "az": 9.81 + 0.3 * rng.standard_normal(n)})
    return frame


def _pro(duration_s: float, rate_hz: float = 10.0, seed: int = 1) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz)) + 1
    return pd.DataFrame({"time": np.arange(n) / rate_hz,
                         "curL": 5.0 + rng.standard_normal(n),
                         "curR": 7.0 + rng.standard_normal(n),
                         "velL": 0.5 + 0.02 * rng.standard_normal(n),
                         "velR": 0.5 + 0.02 * rng.standard_normal(n)})


def _read(root):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        runs = read_runs_dir(root)
    return runs, [str(w.message) for w in caught if issubclass(w.category, DataWarning)]


def _write(root, imu, pro):
    folder = root / "ASPHALT"
    folder.mkdir(parents=True, exist_ok=True)
    imu.to_csv(folder / "imu_00.csv", index=False)
    pro.to_csv(folder / "pro_00.csv", index=False)
    return folder / "imu_00.csv"


def test_all_zero_imu_is_a_dead_sensor_warning_not_a_unit_error(tmp_path):
    imu = _imu(1001)
    imu.loc[:, ["wx", "wy", "wz", "ax", "ay", "az"]] = 0.0
    _write(tmp_path, imu, _pro(10.0))
    (run,), messages = _read(tmp_path)
    assert set(run.meta["stuck"]) == {f"imu.{c}" for c in ("wx", "wy", "wz", "ax", "ay", "az")}
    assert any("imu.az stuck" in m and "dead or stuck sensor" in m for m in messages)
    assert not any("units of g" in m for m in messages)


def test_dead_az_alone_is_not_taken_for_g_units(tmp_path):
    imu = _imu(1001)
    imu["az"] = 0.0                   # gravity axis dead, the others live
    _write(tmp_path, imu, _pro(10.0))
    (run,), messages = _read(tmp_path)
    assert list(run.meta["stuck"]) == ["imu.az"]
    assert not any("accel_units" in m for m in messages)


def test_short_near_zero_accelerometer_is_a_warning(tmp_path):
    # too short for the stuck rule (under 1 s), noise around 0: no gravity in any unit
    imu = _imu(50)
    rng = np.random.default_rng(3)
    imu[["ax", "ay", "az"]] = 0.01 * rng.standard_normal((50, 3))
    path = tmp_path / "imu_00.csv"
    imu.to_csv(path, index=False)
    with pytest.warns(DataWarning, match="rule accel_units.*dead or disconnected"):
        read_stream_csv(path, "imu")


def test_accelerometer_in_g_stays_a_unit_error(tmp_path):
    imu = _imu(1001)
    imu[["ax", "ay", "az"]] /= 9.81
    path = _write(tmp_path, imu, _pro(10.0))
    with pytest.raises(UnitError, match="rule accel_units.*units of g") as info:
        read_runs_dir(tmp_path)
    assert info.value.path == str(path) and info.value.column == "az"


def test_accelerometer_in_g_with_a_dead_stretch_stays_a_unit_error(tmp_path):
    imu = _imu(1001)
    imu[["ax", "ay", "az"]] /= 9.81
    imu.loc[imu["time"] < 6.0, ["ax", "ay", "az"]] = 0.0     # dead for 60 % of the run
    _write(tmp_path, imu, _pro(10.0))
    with pytest.raises(UnitError, match="units of g"):
        read_runs_dir(tmp_path)


def test_check_accel_units_on_frames():
    ok = _imu(300).rename(columns={"time": "t_s"})
    check_accel_units(ok, "f.csv")                       # m/s^2: nothing
    dead = ok.copy()
    dead[["ax", "ay", "az"]] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_accel_units(dead, "f.csv")                 # stuck everywhere: left to check_run
    g = ok.copy()
    g[["ax", "ay", "az"]] /= 9.81
    with pytest.raises(UnitError):
        check_accel_units(g, "f.csv")


def test_a_rate_at_the_nominal_bound_is_not_warned_and_the_message_agrees():
    """1 ms float steps imply 1000.0000000006 Hz: at the wheels' nominal 1000 Hz bound, not
    outside it (the warning used to say "1000 Hz outside the nominal 1-1000 Hz")."""
    from terrain.io.plausibility import check_rate, implied_rate_hz
    t = np.arange(2500) * 0.001
    assert implied_rate_hz(t) == 1000.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_rate(t, "wheels", "f.csv")
    with pytest.warns(UserWarning, match="1010 Hz outside the nominal 1-1000 Hz"):
        check_rate(np.arange(2500) * 0.00099, "wheels", "f.csv")


def test_the_rate_warning_names_its_rule_and_time_column():
    """The one warning of rule timestamp_units said neither the rule nor the column ("f.csv:
    implied sample rate 1010 Hz outside ..."), unlike every other rule's finding."""
    from terrain.io.plausibility import check_rate
    found = []
    check_rate(np.arange(2500) * 0.00099, "wheels", "f.csv", "t_s", found=found)
    assert found and found[0].startswith("f.csv: rule timestamp_units: column 't_s': ")
    assert "1010 Hz outside the nominal 1-1000 Hz" in found[0]


@pytest.mark.parametrize("case, rule", [("rate", "implied sample rate 5 Hz outside"),
                                        ("dead", "rule accel_units")])
def test_a_file_rule_warning_is_counted_in_the_run_and_its_input_report(tmp_path, case,
                                                                        rule):
    """The readers' file rules that only warn (an IMU rate outside its nominal range,
    assumed s; an accelerometer that sees no gravity, assumed m/s^2) were printed but not
    kept in ``Run.meta["warnings"]``: the input report then said "nothing repaired, dropped
    or skipped" and counted 0 plausibility warnings."""
    from terrain.io.report import input_report

    if case == "rate":
        imu = _imu(1001, rate_hz=5.0)               # 5 Hz: below the IMU's 10-2000 Hz
        pro = _pro(200.0)
    else:
        imu = _imu(50)
        imu[["ax", "ay", "az"]] = 0.01 * np.random.default_rng(3).standard_normal((50, 3))
        pro = _pro(0.5, rate_hz=20.0)
    _write(tmp_path, imu, pro)
    (run,), messages = _read(tmp_path)
    assert sum(rule in m for m in messages) == 1          # printed once
    assert sum(rule in m for m in run.meta["warnings"]) == 1
    report = input_report([run])
    assert report.metrics()["input_warnings"] >= 1
    assert "nothing repaired" not in report.text()
