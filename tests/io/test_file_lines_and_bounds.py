"""Second review of the readers (mutation testing): the file line an error names when
blank and comment lines lie above the bad row, the bounds of the plausibility rules, and
the clock-overlap and alignment edges that the earlier tests left open."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from terrain.errors import (DataFormatError, DataWarning, ImplausibleValueError, NonFiniteError,
                            RaggedRowError)
from terrain.io.measured import read_stream_csv


def _plant(path, row, column, text):
    """Put ``text`` into data row ``row`` (0-based), column ``column`` of a CSV file, then
    add a blank line and a comment line above that row; returns the row's file line."""
    lines = path.read_text().split("\n")
    header = lines[0].split(",")
    cells = lines[1 + row].split(",")
    if column is None:
        cells.append(text)           # one field too many
    else:
        cells[header.index(column)] = text
    lines[1 + row] = ",".join(cells)
    lines[3:3] = ["", "# operator note"]
    path.write_text("\n".join(lines))
    return 1 + row + 1 + 2


@pytest.mark.parametrize("column, text, error", [
    ("time", "nan", NonFiniteError),             # a timestamp is never repaired
    ("wz", "1e400", ImplausibleValueError),      # beyond float64: a value, not a gap
    (None, "0.5", RaggedRowError),               # one field too many
])
def test_errors_name_the_file_line_below_skipped_lines(tmp_path, synth_imu, column, text,
                                                       error):
    """The NonFiniteError of a timestamp, the ImplausibleValueError of an overflowing
    number and the RaggedRowError all name the bad row's own file line: header line 1 plus
    the blank and comment lines skipped above the row, not the data row + 2."""
    path = tmp_path / "imu_00.csv"
    synth_imu(duration_s=2.0).to_csv(path, index=False)
    line = _plant(path, 40, column, text)
    with pytest.raises(error) as info:
        read_stream_csv(path, "imu")
    assert info.value.line == line == 44
    assert text in path.read_text().split("\n")[info.value.line - 1]
    assert info.value.row == 40 or error is RaggedRowError


@pytest.mark.parametrize("channel, limit", [("vel_r", 5.0), ("cur_l", 1000.0),
                                            ("wz", np.radians(2000.0)),
                                            ("az", 24 * 9.80665)])
def test_a_value_on_its_channel_limit_is_plausible_and_just_beyond_is_not(channel, limit):
    """The ranges are ``|value| <= limit`` (module docstring of terrain.io.plausibility):
    +limit and -limit themselves pass, the next float beyond either is refused, naming the
    file's column and line."""
    import pandas as pd

    from terrain.io.measured import COLUMN_MAPS
    from terrain.io.plausibility import check_ranges

    columns = {**COLUMN_MAPS["pro"], **COLUMN_MAPS["imu"]}
    lines = np.array([2, 3, 5, 6])
    on = pd.DataFrame({channel: [0.0, limit, -limit, 0.0]})
    check_ranges(on, "f.csv", columns, lines)
    for sign, line in ((1.0, 3), (-1.0, 5)):
        beyond = on.copy()
        beyond.loc[1 if sign > 0 else 2, channel] = sign * np.nextafter(limit, np.inf)
        with pytest.raises(ImplausibleValueError) as info:
            check_ranges(beyond, "f.csv", columns, lines)
        file_column = next(c for c, n in columns.items() if n == channel)
        assert (info.value.column, info.value.line) == (file_column, line)
        assert str(info.value).startswith("1 value(s) beyond")


def _streams(imu_t, wheel_t):
    """A quiet IMU and a straight, steady wheel stream on the given clocks (no rule but
    ``clock_overlap`` has anything to say)."""
    import pandas as pd

    from terrain.run import TIME

    rng = np.random.default_rng(0)
    imu = pd.DataFrame({TIME: imu_t, **{c: 0.01 * rng.standard_normal(imu_t.size)
                                        for c in ("wx", "wy", "wz", "ax", "ay")},
                        "az": 9.81 + 0.01 * rng.standard_normal(imu_t.size)})
    wheels = pd.DataFrame({TIME: wheel_t, "vel_l": 0.5, "vel_r": 0.5,
                           "cur_l": 5.0 + np.sin(wheel_t), "cur_r": 6.0 + np.cos(wheel_t)})
    return {"imu": imu, "wheels": wheels}


@pytest.mark.parametrize("wheel_end_s, warned", [(6.0, False), (6.1, True)])
def test_clocks_overlapping_for_half_the_shorter_stream_pass_on_the_bound(wheel_end_s,
                                                                          warned):
    """Rule ``clock_overlap``'s likely case is strict on both of its bounds: an IMU over
    0..4 s beside wheels over 2..6 s overlap for 2 s, exactly half the shorter stream, and
    each leaves out exactly MAX_UNUSED_SPAN_S (2 s): no warning, the 2 s of each counted in
    ``unused_s``; wheels running on to 6.1 s leave 2.1 s out: warned, naming both."""
    from terrain.io.plausibility import check_run

    imu_t = np.arange(201) / 50.0
    wheel_t = 2.0 + np.arange(round((wheel_end_s - 2.0) * 10) + 1) / 10.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        out = check_run("r", _streams(imu_t, wheel_t), "husky", {"imu": "imu.csv"})
    assert out["unused_s"] == pytest.approx({"imu": 2.0, "wheels": wheel_end_s - 4.0})
    found = [w for w in out["warnings"] if "clock_overlap" in w]
    assert len(found) == warned
    if warned:
        assert "imu 2.0 s" in found[0] and "wheels 2.1 s" in found[0]


def test_unused_seconds_are_counted_for_the_stream_that_runs_on():
    """A wheel file cut 1 s before the end of its IMU file: the IMU's last second is the
    unused one (``unused_s`` {'imu': 1.0}), not the wheels'."""
    from terrain.io.plausibility import check_run

    out = check_run("r", _streams(np.arange(501) / 50.0, np.arange(91) / 10.0), "husky", {})
    assert out["unused_s"] == pytest.approx({"imu": 1.0})
    assert not out["warnings"]


def test_timestamps_are_judged_in_ms_only_strictly_ten_times_below_the_nominal_rate():
    """An IMU stream implying 1 Hz is exactly ten times below its 10 Hz floor: slow (a
    warning), not certainly in ms; 0.999 Hz is below that bound and x1000 = 999 Hz fits."""
    from terrain.io.plausibility import timestamp_unit

    assert timestamp_unit(1.0, "imu") is None
    assert timestamp_unit(0.999, "imu") == "ms"


def test_wheel_speeds_of_exactly_twice_the_top_speed_are_not_certainly_km_h():
    """Rule ``wheel_speed_units``'s certain case is strictly more than twice the Husky's
    1.0 m/s."""
    from terrain.io.plausibility import VEHICLE_LIMITS, wheel_speed_in_kmh

    husky = VEHICLE_LIMITS["husky"]
    assert not wheel_speed_in_kmh(2.0, husky)
    assert wheel_speed_in_kmh(np.nextafter(2.0, 3.0), husky)


def _check_quietly(streams):
    from terrain.io.plausibility import check_run

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        return check_run("r", streams, "husky", {"imu": "imu.csv", "wheels": "pro.csv"})


@pytest.mark.parametrize("speed, warned", [(1.2, False), (1.3, True), (1.9, True)])
def test_wheel_speeds_above_1_2_times_the_top_speed_are_probably_km_h(speed, warned):
    """Rule ``wheel_speed_units``'s likely case: a 99th-percentile wheel speed above
    1.2 x the top speed (and at most twice it) is a warning naming the wheel file."""
    streams = _streams(np.arange(501) / 50.0, np.arange(101) / 10.0)
    streams["wheels"][["vel_l", "vel_r"]] = speed
    found = [w for w in _check_quietly(streams)["warnings"] if "wheel_speed_units" in w]
    assert len(found) == warned
    if warned:
        assert found[0].startswith("pro.csv: ") and f"speed {speed:.3g} above 1.2" in found[0]


@pytest.mark.parametrize("yaw_rate, warned", [(3.5, False), (4.5, True)])
def test_a_yaw_rate_beyond_twice_the_limit_makes_the_gyro_probably_deg_s(yaw_rate, warned):
    """Rule ``gyro_units``'s likely case by the yaw rate: a 99th-percentile |wz| above
    twice the Husky's 2.0 rad/s (with a quiet gyro otherwise) is a warning; 3.5 rad/s,
    above the limit but under twice it, is not."""
    streams = _streams(np.arange(501) / 50.0, np.arange(101) / 10.0)
    streams["imu"]["wz"] += yaw_rate
    found = [w for w in _check_quietly(streams)["warnings"] if "gyro_units" in w]
    assert len(found) == warned
    if warned:
        assert found[0].startswith("imu.csv: ") and "|wz| 4.5" in found[0]


def test_streams_meeting_at_one_instant_have_no_common_clock(make_run):
    """Spans that only touch (an IMU over 0..5 s, wheels from 5 s on) share no grid, as the
    reader's rule ``clock_overlap`` says: align_streams refuses them rather than returning
    a one-row frame at t = 5 s."""
    from terrain.io.align import align_streams, overlap_grid

    imu_t, wheel_t = np.arange(251) / 50.0, 5.0 + np.arange(51) / 10.0
    assert overlap_grid([imu_t, wheel_t], 50.0).size == 0
    streams = _streams(imu_t, wheel_t)
    with pytest.raises(DataFormatError, match="do not overlap"):
        align_streams(make_run(streams))


def test_gyro_slope_is_fitted_over_the_wheel_samples_the_imu_spans():
    """Rule ``gyro_units`` fits the slope of wz on v_R - v_L over the wheel samples inside
    the IMU's span only: an IMU in deg/s recorded for 20 s beside a wheel file running on
    to 60 s gives the planted slope 57.3 / 0.8 = 71.6 1/m (corr 1.00), not one diluted by
    40 s of wheel turns set against the IMU's last yaw rate (26.5 1/m, corr 0.51)."""
    import pandas as pd

    from terrain.errors import UnitError
    from terrain.io.plausibility import check_run
    from terrain.run import TIME

    t_i, t_w = np.arange(1001) / 50.0, np.arange(601) / 10.0
    streams = _streams(t_i, t_w)
    streams["imu"]["wz"] = np.degrees(0.5 * np.sin(0.5 * t_i))      # deg/s
    dv = 0.8 * 0.5 * np.sin(0.5 * t_w)                               # chi B = 0.8 m
    streams["wheels"] = pd.DataFrame({TIME: t_w, "vel_l": 0.5 - dv / 2, "vel_r": 0.5 + dv / 2,
                                      "cur_l": 5.0 + np.sin(t_w), "cur_r": 6.0 + np.cos(t_w)})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        with pytest.raises(UnitError) as info:
            check_run("r", streams, "husky", {"imu": "imu.csv", "wheels": "pro.csv"})
    assert "is 71.6 1/m (corr 1.00)" in str(info.value)
    assert (info.value.path, info.value.column) == ("imu.csv", "wz")


def test_a_short_row_inside_a_file_without_a_final_line_break_is_not_called_cut_off(
        tmp_path, synth_imu):
    """Only the last line of a file that has no line break after it may have been cut off
    while written: a short row in the middle of such a file is a ragged row, named by its
    line, without the cut-off hint."""
    path = tmp_path / "imu_00.csv"
    synth_imu(duration_s=1.0).to_csv(path, index=False)
    lines = path.read_text().rstrip("\n").split("\n")
    lines[10] = lines[10].rsplit(",", 1)[0]          # data row 9 loses its last field
    path.write_text("\n".join(lines))
    with pytest.raises(RaggedRowError) as info:
        read_stream_csv(path, "imu")
    assert info.value.line == 11 and "cut off" not in str(info.value)


@pytest.mark.parametrize("unrelated, warned", [(0.0, True), (0.2, False)])
def test_a_km_h_slope_counts_only_when_the_speed_follows_the_acceleration(unrelated,
                                                                          warned):
    """Rule ``wheel_speed_units``'s slope evidence needs the wheel-speed derivative to
    correlate with the forward acceleration (>= 0.5): speeds rising 3 x faster than the
    acceleration say km/h; the same speeds beside a 0.2 m/s swing that the accelerometer
    does not see (slope still 2.9) say nothing."""
    t_i, t_w = np.arange(3001) / 50.0, np.arange(601) / 10.0
    streams = _streams(t_i, t_w)
    streams["imu"]["ax"] = 0.05 * np.sin(2 * np.pi * 0.1 * t_i)
    v = (3.0 * 0.05 / (2 * np.pi * 0.1) * (1.0 - np.cos(2 * np.pi * 0.1 * t_w))
         + unrelated * np.sin(2 * np.pi * 0.23 * t_w))
    streams["wheels"]["vel_l"] = v
    streams["wheels"]["vel_r"] = v
    found = [w for w in _check_quietly(streams)["warnings"] if "wheel_speed_units" in w]
    assert len(found) == warned
    if warned:
        assert "slope 3.00" in found[0]


def test_the_anti_alias_cut_off_is_0_4_times_the_grid_rate():
    """A 20 Hz tone of a 100 Hz stream aligned at 50 Hz sits on the filter's cut-off
    (0.4 x 50 Hz): -3 dB forward and -3 dB backward (zero phase) leave half its amplitude."""
    from terrain.io.align import align_arrays, overlap_grid

    t = np.arange(2001) / 100.0
    tone = np.sin(2 * np.pi * 20.0 * t)[:, None]
    grid = overlap_grid([t], 50.0)
    out = align_arrays([t], [tone], grid, 50.0)[100:-100, 0]     # away from the ends
    assert np.sqrt(2.0 * np.mean(out ** 2)) == pytest.approx(0.5, abs=0.01)


@pytest.mark.parametrize("imu_hz, warned", [(92.0, False), (88.0, True)])
def test_converting_warns_of_an_imu_rate_more_than_a_tenth_off_the_datasets(
        tmp_path, synth_imu, synth_pro, write_run, imu_hz, warned):
    """``terrain convert`` warns when the IMU's rate is more than 10 % off the dataset's
    (BorealTC: 100 Hz), since every window is aligned at the dataset's rate: 8 % off passes,
    12 % off is named."""
    from terrain.io.shipped import convert_dataset

    write_run(tmp_path / "csv", "ASPHALT", "00", synth_imu(rate_hz=imu_hz),
              synth_pro(rate_hz=6.5))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        convert_dataset(tmp_path / "csv", "borealtc", tmp_path / "data")
    said = [str(w.message) for w in seen if "IMU runs at" in str(w.message)]
    assert said == ([f"{tmp_path / 'csv'}: the IMU runs at {imu_hz:g} Hz, dataset "
                     "'borealtc' at 100 Hz: its windows will be aligned at 100 Hz (the IMU "
                     "resampled); convert the runs under the dataset they come from"]
                    if warned else [])
