"""One test per class of bad input of issue 9, on real rows of the shipped runs.

Every class gets a typed error naming the file (and column and file line where they exist)
in one short line, or an explicit :class:`DataWarning`; nothing is rescaled.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig, make_windows
from terrain.errors import (ClockError, DataFormatError, DataWarning, EmptyFileError,
                            EncodingError, ImplausibleValueError, NonNumericError,
                            RaggedRowError, UnitError, UnreadableFileError)
from terrain.io.measured import read_runs_dir, read_runs_path
from terrain.io.plausibility import stuck_window_flags
from terrain.io.report import input_report
from terrain.io.shipped import load_dataset
from terrain.run import TIME

PRO_COLUMNS = {"t_s": "time", "vel_l": "velL", "vel_r": "velR", "cur_l": "curL",
               "cur_r": "curR"}


def _write(run, root):
    """Write a shipped run in the measured CSV layout; returns (imu path, pro path)."""
    _, terrain, index = run.run_id.split("/")
    folder = root / terrain
    folder.mkdir(parents=True, exist_ok=True)
    pro = folder / f"pro_{index}.csv"
    run.streams["wheels"].rename(columns=PRO_COLUMNS).to_csv(pro, index=False)
    imu = folder / f"imu_{index}.csv"
    run.streams["imu"].rename(columns={TIME: "time"}).to_csv(imu, index=False)
    return imu, pro


@pytest.fixture(scope="module")
def runs_by_id(borealtc_runs):
    return {r.run_id: r for r in borealtc_runs}


@pytest.fixture
def turning(runs_by_id, tmp_path):
    """A real run that turns (yaw rate well correlated with the wheel speed difference)."""
    return _write(runs_by_id["borealtc/ASPHALT/00"], tmp_path)


def _edit(path, fn):
    """Rewrite a CSV file through ``fn`` (edits the frame in place or returns a new one)."""
    frame = pd.read_csv(path)
    out = fn(frame)
    (frame if out is None else out).to_csv(path, index=False)


def _lines(path):
    return path.read_text().split("\n")


def _one_line(exc):
    text = str(exc)
    assert "\n" not in text and len(text) < 600, text
    return text


def _read(root):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        runs = read_runs_dir(root)
    return runs, [w for w in caught if issubclass(w.category, DataWarning)]


@pytest.mark.slow
def test_shipped_and_csv_data_load_with_zero_warnings(tmp_path, borealtc_runs, vulpi_runs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        runs = load_dataset("combined")
    assert len(runs) == 70 and all(not r.meta["warnings"] and not r.meta["stuck"] for r in runs)
    for run in borealtc_runs[:6] + vulpi_runs[:3]:
        if run.has_imu:
            _write(run, tmp_path / run.dataset)
    for root in (tmp_path / "borealtc", tmp_path / "vulpi"):
        back, caught = _read(root)
        assert back and not caught


def test_non_utf8_byte_names_file_byte_offset_and_line(turning):
    imu, _ = turning
    data = bytearray(imu.read_bytes())
    offset = 5000
    data[offset] = 0xFF
    imu.write_bytes(bytes(data))
    with pytest.raises(EncodingError) as info:
        read_runs_dir(imu.parent.parent)
    assert info.value.path == str(imu)
    assert info.value.line == bytes(data[:offset]).count(b"\n") + 1
    assert "byte offset 5000" in _one_line(info.value)


@pytest.mark.parametrize("kind", ["directory", "symlink loop", "fifo"])
def test_directory_or_symlink_loop_instead_of_a_file(turning, kind):
    import os

    imu, _ = turning
    imu.unlink()
    if kind == "directory":
        imu.mkdir()
    elif kind == "fifo":
        os.mkfifo(imu)  # reading it would block forever
    else:
        imu.symlink_to(imu)
    with pytest.raises(UnreadableFileError) as info:
        read_runs_dir(imu.parent.parent)
    assert info.value.path == str(imu)
    _one_line(info.value)


def test_huge_finite_value_is_implausible_with_file_column_line(turning):
    imu, _ = turning
    _edit(imu, lambda f: f.__setitem__("ax", f["ax"].where(f.index != 500, 1e300)))
    with pytest.raises(ImplausibleValueError) as info:
        read_runs_dir(imu.parent.parent)
    assert (info.value.path, info.value.column, info.value.line) == (str(imu), "ax", 502)
    assert "24 g" in _one_line(info.value)


@pytest.mark.parametrize("column, text", [("ax", "1e400"), ("ax", "-1E+999"),
                                          ("time", "1e400"), ("ax", '"1e400"')])
def test_a_number_beyond_float_range_is_implausible_not_repaired(turning, column, text):
    """'1e300' in ax was refused as beyond 24 g, but '1e400' overflowed to inf and was
    repaired by interpolation as an isolated non-finite cell (meta repaired {'imu.ax': 1},
    the input report 'repaired 1 isolated non-finite cell(s)'); in the time column it was
    'non-finite timestamp'. A number that float64 cannot hold is a value, not a missing one:
    refused with its file, column and line."""
    imu, _ = turning
    lines = _lines(imu)
    header = lines[0].split(",")
    cells = lines[501].split(",")
    cells[header.index(column)] = text
    lines[501] = ",".join(cells)
    imu.write_text("\n".join(lines))
    with pytest.raises(ImplausibleValueError) as info:
        read_runs_dir(imu.parent.parent)
    assert (info.value.path, info.value.column, info.value.line) == (str(imu), column, 502)
    assert text.strip('"') in _one_line(info.value) and "float64" in str(info.value)


def test_gyro_in_deg_s_on_a_turning_run_is_refused_by_the_yaw_rule(turning):
    imu, _ = turning
    _edit(imu, lambda f: f.__setitem__(["wx", "wy", "wz"], np.degrees(f[["wx", "wy", "wz"]])))
    with pytest.raises(UnitError) as info:
        read_runs_dir(imu.parent.parent)
    text = _one_line(info.value)
    assert info.value.column == "wz" and "gyro_units" in text and "deg/s" in text


def test_gyro_in_deg_s_on_a_straight_run_is_a_warning(runs_by_id, tmp_path):
    run = runs_by_id["borealtc/ICE/12"]
    w = run.streams["wheels"]
    assert (w["vel_r"] - w["vel_l"]).std() < 0.02  # straight: the yaw rule has no evidence
    imu, _ = _write(run, tmp_path)
    _edit(imu, lambda f: f.__setitem__(["wx", "wy", "wz"], np.degrees(f[["wx", "wy", "wz"]])))
    runs, caught = _read(tmp_path)
    assert len(caught) == 1 and "gyro_units" in str(caught[0].message)
    assert "assumed rad/s" in str(caught[0].message)
    # never rescaled
    np.testing.assert_allclose(runs[0].streams["imu"]["wz"], np.degrees(run.streams["imu"]["wz"]))


def test_wheel_speeds_in_km_h_refused_when_beyond_twice_top_speed(runs_by_id, tmp_path):
    _, pro = _write(runs_by_id["borealtc/ASPHALT/01"], tmp_path)  # cruises at 0.79 m/s
    _edit(pro, lambda f: f.__setitem__(["velL", "velR"], 3.6 * f[["velL", "velR"]]))
    with pytest.raises(UnitError) as info:
        read_runs_dir(tmp_path)
    assert info.value.path == str(pro) and "km/h" in _one_line(info.value)
    assert info.value.column == "velL" and "convert velL, velR to m/s" in str(info.value)


def test_wheel_speeds_in_km_h_name_the_columns_of_the_frames_checked(runs_by_id):
    # the rule said 'convert velL, velR' (column 'velL') to a served request or a shipped
    # file, whose columns are vel_l, vel_r
    from terrain.io.plausibility import check_run

    run = runs_by_id["borealtc/ASPHALT/01"]
    streams = {"wheels": run.streams["wheels"].assign(vel_l=lambda f: 3.6 * f["vel_l"],
                                                      vel_r=lambda f: 3.6 * f["vel_r"])}
    with pytest.raises(UnitError, match="convert vel_l, vel_r to m/s") as info:
        check_run("r", streams, "husky", {"wheels": "request"})
    assert info.value.column == "vel_l"
    # speeds logged as wheel angular speeds (rad/s) fail the same rule: the hint names both
    assert "(/ 3.6; a wheel angular speed in rad/s: x the wheel radius in m)" in str(info.value)


def test_slow_wheel_speeds_in_km_h_are_a_warning(turning):
    _, pro = turning  # 0.47 m/s: 1.7 in km/h, below twice the top speed
    _edit(pro, lambda f: f.__setitem__(["velL", "velR"], 3.6 * f[["velL", "velR"]]))
    _, caught = _read(pro.parent.parent)
    assert len(caught) == 1 and "wheel_speed_units" in str(caught[0].message)


@pytest.mark.parametrize("which", ["both", "imu", "pro"])
def test_timestamps_in_ms_are_refused(turning, which):
    imu, pro = turning
    for path in {"both": (imu, pro), "imu": (imu,), "pro": (pro,)}[which]:
        _edit(path, lambda f: f.__setitem__("time", 1000.0 * f["time"]))
    with pytest.raises(UnitError) as info:
        read_runs_dir(imu.parent.parent)
    assert info.value.column == "time" and "milliseconds" in _one_line(info.value)


@pytest.mark.parametrize("unit, per_s, word",
                         [("us", 1e6, "microseconds"), ("ns", 1e9, "nanoseconds")])
@pytest.mark.parametrize("which", ["imu", "pro"])
def test_timestamps_in_us_or_ns_are_refused_naming_the_unit(turning, which, unit, per_s, word):
    """An IMU file in us implies 1e-4 Hz (in ns 1e-7 Hz): before, a warning only, the
    timestamps read as s (an IMU in us then spanned 1e6 "s" and ``terrain predict`` ran out
    of memory); now the rule timestamp_units refuses it as it refuses ms."""
    imu, pro = turning
    path = {"imu": imu, "pro": pro}[which]
    _edit(path, lambda f: f.__setitem__("time", per_s * f["time"]))
    with pytest.raises(UnitError) as info:
        read_runs_dir(imu.parent.parent)
    text = _one_line(info.value)
    assert info.value.path == str(path) and info.value.column == "time"
    assert f"{word} ({unit})" in text and "timestamp_units" in text


def test_epoch_imu_clock_beside_a_clock_from_zero_is_refused(turning):
    imu, pro = turning
    _edit(imu, lambda f: f.__setitem__("time", f["time"] + 1.7e9))
    with pytest.raises(ClockError) as info:
        read_runs_dir(imu.parent.parent)
    text = _one_line(info.value)
    assert str(imu) in text and str(pro) in text and "do not overlap" in text


def test_truncated_wheel_file_beside_a_full_imu_file_is_reported_with_what_is_left_out(
        turning):
    # both clocks start at 0, so the overlap is the whole wheel file: the IMU's tail past
    # its end is not used, and the reader says how much
    imu, pro = turning
    _edit(pro, lambda f: f[f["time"] < 9.0])
    (run,), caught = _read(imu.parent.parent)
    assert len(caught) == 1
    text = str(caught[0].message)
    assert "clock_overlap" in text and str(imu) in text
    imu_span = run.streams["imu"][TIME].iloc[-1] - run.streams["imu"][TIME].iloc[0]
    left_out = imu_span - (run.streams["wheels"][TIME].iloc[-1] - 0.0)
    assert left_out > 10.0 and f"left out: imu {left_out:.1f} s" in text
    assert run.meta["warnings"] == [text]


def test_seconds_of_a_stream_left_out_without_a_warning_are_in_the_input_report(turning):
    # ASPHALT/00 runs 51.85 s: a wheel file cut at 49 s leaves 2.9 s of IMU outside the
    # overlap, over 2 s but under a tenth of the 49 s overlap, so no clock_overlap warning
    # (the rule as it is); before, nothing said those seconds were unused (the report read
    # "nothing repaired, dropped or skipped"; ASPHALT/01 cut at 236 s: 20.4 s of IMU)
    imu, pro = turning
    _edit(pro, lambda f: f[f["time"] < 49.0])
    (run,), caught = _read(imu.parent.parent)
    assert [str(w.message) for w in caught] == [] and run.meta["warnings"] == []
    t_imu, t_wheels = (run.streams[k][TIME].to_numpy() for k in ("imu", "wheels"))
    left_out = t_imu[-1] - t_wheels[-1]
    assert 2.5 < left_out < 3.0 and set(run.meta["unused_s"]) == {"imu"}
    assert run.meta["unused_s"]["imu"] == pytest.approx(left_out, abs=1e-9)
    ws = make_windows([run], "all", WindowConfig(rate_hz=50.0))
    assert ws.t_end_s.max() <= t_wheels[-1] + 1e-9       # those seconds are in no window
    report = input_report([run], ws.counts, 2.0)
    row = report.table.iloc[0]
    assert row["unused_imu_s"] == pytest.approx(left_out) and row["unused_wheels_s"] == 0.0
    assert report.metrics()["input_unused_imu_s"] == pytest.approx(left_out)
    assert f"not used: {left_out:.1f} s of imu outside the other stream's span" \
        in report.text()
    assert "nothing repaired, dropped or skipped" not in report.text()
    # a wheel-only selection aligns no IMU: nothing of either stream is cut to the other's
    # span (it said "2.9 s of imu outside the other stream's span" of a stream not read)
    wheels = make_windows([run], "wheels", WindowConfig(rate_hz=50.0))
    assert wheels.counts["streams"] == ["wheels"]
    report = input_report([run], wheels.counts, 2.0)
    row = report.table.iloc[0]
    assert row["unused_imu_s"] == 0.0 and row["unused_wheels_s"] == 0.0
    assert "not used" not in report.text()


def test_dead_sensor_is_reported_and_its_windows_flagged(turning):
    imu, _ = turning
    _edit(imu, lambda f: f.__setitem__("wz", 0.0))
    (run,), caught = _read(imu.parent.parent)
    assert len(caught) == 1 and "imu.wz stuck" in str(caught[0].message)
    assert list(run.meta["stuck"]) == ["imu.wz"]
    ws = make_windows([run], "all", WindowConfig(rate_hz=50.0))
    flags = stuck_window_flags(run.meta["stuck"], ws.t_start_s, ws.t_end_s)
    assert len(ws) > 10 and (flags == "stuck:imu.wz").all()
    report = input_report([run], ws.counts, 2.0)
    assert "stuck or dead sensor channel(s): " in report.text()
    assert report.metrics()["input_stuck_channels"] == 1


def test_stuck_stretch_flags_only_the_windows_holding_it(turning):
    imu, _ = turning
    _edit(imu, lambda f: f.__setitem__("ax", f["ax"].where((f["time"] < 20) | (f["time"] > 23),
                                                           1.5)))
    (run,), caught = _read(imu.parent.parent)
    ((a, b),) = run.meta["stuck"]["imu.ax"]
    assert 19.9 < a < 20.1 and 22.9 < b < 23.1
    t0 = np.arange(0.0, 50.0, 2.0)
    flags = stuck_window_flags(run.meta["stuck"], t0, t0 + 2.0)
    # the stretch's first sample is at 20.0 s: the window [18, 20) ends before it
    assert a == 20.0 and list(t0[flags != ""]) == [20.0, 22.0]


def test_stuck_window_flags_take_windows_as_half_open():
    """A window ``[t_start_s, t_end_s)`` holds the stretch ``[a, b]`` of sample times when
    they share a sample time: as the live service's rule (``StuckWatch.stuck_between``)."""
    stuck = {"wheels.cur_l": [[2.0, 5.0]]}
    t0 = np.array([0.0, 1.0, 3.0, 4.99, 5.0, 5.01])
    flags = stuck_window_flags(stuck, t0, t0 + 2.0)
    assert list(flags) == ["", "stuck:wheels.cur_l", "stuck:wheels.cur_l",
                           "stuck:wheels.cur_l", "stuck:wheels.cur_l", ""]


@pytest.mark.slow
def test_run_shorter_than_one_window_and_gaps_are_reported(runs_by_id, tmp_path):
    imu, pro = _write(runs_by_id["borealtc/ASPHALT/00"], tmp_path)
    _edit(imu, lambda f: f[f["time"] < 1.2])
    _edit(pro, lambda f: f[f["time"] < 1.2])
    other = runs_by_id["borealtc/ASPHALT/01"]
    imu2, pro2 = _write(other, tmp_path)
    _edit(imu2, lambda f: f[(f["time"] <= 10) | (f["time"] >= 14)])
    runs, _ = _read(tmp_path)
    ws = make_windows(runs, "all", WindowConfig(rate_hz=50.0))
    report = input_report(runs, ws.counts, 2.0)
    text = report.text()
    assert "1 run(s) too short (shorter than one 2 s window): ASPHALT/00" in text.replace(
        f"{tmp_path.name}/", "")
    assert "timestamp gap(s)" in text and "spanning a gap" in text
    m = report.metrics()
    assert m["input_runs_too_short"] == 1 and m["input_gaps"] == 1
    assert m["input_windows_dropped_gap"] == ws.counts["dropped_gap"] >= 2


def test_repaired_cells_are_counted_shown_and_become_metrics(turning):
    imu, _ = turning
    _edit(imu, lambda f: f.__setitem__("wy", f["wy"].where(f.index % 7 != 3, np.nan)))
    (run,), _ = _read(imu.parent.parent)
    n = int((np.arange(len(run.streams["imu"])) % 7 == 3).sum())
    assert run.meta["repaired"] == {"imu.wy": n}
    report = input_report([run])
    assert report.metrics()["input_repaired_cells"] == n > 700
    assert f"repaired {n} isolated non-finite cell(s)" in report.text()
    assert report.table.loc[0, "repaired"] == f"imu.wy:{n}"


def test_trailing_comma_on_data_rows_is_a_ragged_row_error(turning):
    imu, _ = turning
    lines = _lines(imu)
    imu.write_text("\n".join([lines[0]] + [ln + "," if ln else ln for ln in lines[1:]]))
    with pytest.raises(RaggedRowError) as info:
        read_runs_dir(imu.parent.parent)
    assert info.value.line == 2 and "trailing comma" in _one_line(info.value)


def test_blank_and_comment_lines_keep_the_file_line_right(turning):
    imu, _ = turning
    lines = _lines(imu)
    lines[30] = lines[30].replace(",", ",oops", 1)  # file line 31 before the insertions
    lines.insert(5, "")
    lines.insert(9, "# operator note")
    imu.write_text("\n".join(lines))
    with pytest.raises(NonNumericError) as info:
        read_runs_dir(imu.parent.parent)
    assert (info.value.column, info.value.line) == ("wx", 33)
    assert _lines(imu)[info.value.line - 1].split(",")[1].startswith("oops")


def test_blank_and_comment_lines_are_skipped_and_counted(turning):
    imu, _ = turning
    lines = _lines(imu)
    lines.insert(5, "")
    lines.insert(9, "# operator note")
    imu.write_text("\n".join(lines))
    (run,), caught = _read(imu.parent.parent)
    assert not caught and run.meta["skipped_lines"] == {"imu.blank": 1, "imu.comment": 1}
    assert "skipped 2 blank/comment line(s)" in input_report([run]).text()


def test_extra_columns_are_not_read_but_counted_and_named(turning):
    imu, pro = turning
    reference, _ = _read(imu.parent.parent)
    _edit(imu, lambda f: f.insert(3, "temperature", 21.5))
    _edit(pro, lambda f: f.assign(mode=1, gear=2))
    (run,), caught = _read(imu.parent.parent)
    assert not caught
    assert run.meta["ignored_columns"] == {"imu": ["temperature"], "wheels": ["mode", "gear"]}
    for name, frame in run.streams.items():  # the read channels are the same as without
        pd.testing.assert_frame_equal(frame, reference[0].streams[name])
    report = input_report([run])
    assert report.table.loc[0, "ignored_columns"] == "imu.temperature,wheels.mode,wheels.gear"
    assert report.metrics()["input_ignored_columns"] == 3.0
    text = report.text()
    assert ("ignored 3 column(s) not read by the readers (imu.temperature, wheels.gear, "
            f"wheels.mode) in {run.run_id}" in text)
    assert "nothing repaired" not in text
    assert input_report(reference).metrics()["input_ignored_columns"] == 0.0


def test_a_column_without_a_name_is_named_by_its_position_in_the_report(turning):
    # a trailing comma on every line, header included: an eighth column with an empty
    # name, reported as "ignored 1 column(s) not read by the readers (imu.)"
    imu, _ = turning
    reference, _ = _read(imu.parent.parent)
    imu.write_text("".join(line + ",\n" for line in imu.read_text().splitlines()))
    (run,), caught = _read(imu.parent.parent)
    assert not caught
    pd.testing.assert_frame_equal(run.streams["imu"], reference[0].streams["imu"])
    assert run.meta["ignored_columns"] == {"imu": ["<unnamed column 8; a trailing comma?>"]}
    report = input_report([run])
    assert report.metrics()["input_ignored_columns"] == 1.0
    assert ("ignored 1 column(s) not read by the readers (imu.<unnamed column 8; a trailing "
            f"comma?>) in {run.run_id}" in report.text())


def test_two_stray_quotes_289_rows_apart_give_a_short_message(turning):
    imu, _ = turning
    lines = _lines(imu)
    lines[10] = '"' + lines[10]
    lines[299] = lines[299] + '"'
    imu.write_text("\n".join(lines))
    with pytest.raises(RaggedRowError) as info:
        read_runs_dir(imu.parent.parent)
    assert info.value.line == 11 and len(_one_line(info.value)) < 300


def test_single_data_row_names_the_file(turning):
    _, pro = turning
    pro.write_text("\n".join(_lines(pro)[:2]) + "\n")
    with pytest.raises(EmptyFileError) as info:
        read_runs_dir(pro.parent.parent)
    assert info.value.path == str(pro) and "single data row" in _one_line(info.value)


def test_many_bad_cells_give_the_first_lines_and_a_count(turning):
    imu, _ = turning
    lines = _lines(imu)
    for i in range(100, 600, 5):
        lines[i] = lines[i].replace(",", ",x", 1)
    imu.write_text("\n".join(lines))
    with pytest.raises(NonNumericError) as info:
        read_runs_dir(imu.parent.parent)
    text = _one_line(info.value)
    assert "100 non-numeric value(s)" in text and "lines 101, 106, 111 and 97 more" in text


def test_a_terrain_folder_reads_like_its_runs_folder(turning):
    imu, _ = turning
    (a,) = read_runs_path(imu.parent.parent)
    (b,) = read_runs_path(imu.parent)
    assert a.run_id == b.run_id and a.streams["imu"].equals(b.streams["imu"])


def test_run_files_beside_terrain_folders_are_refused_not_half_read(turning):
    # a runs folder with stray run files at its top level beside ASPHALT/: predict and
    # estimate read only the top-level run (labelled with the folder's name), the audit
    # and convert only ASPHALT/00, each saying "nothing dropped"
    import shutil
    imu, pro = turning
    root = imu.parent.parent
    shutil.copy(pro, root / "pro_09.csv")
    shutil.copy(imu, root / "imu_09.csv")
    for read in (read_runs_dir, read_runs_path):
        with pytest.raises(DataFormatError) as info:
            read(root)
        text = _one_line(info.value)
        assert info.value.path == str(root) and "imu_09.csv, pro_09.csv" in text
        assert "terrain folders with runs (ASPHALT)" in text
    # the top-level files alone: read as a terrain folder by read_runs_path, and the
    # runs-folder reader says where the files are
    shutil.rmtree(imu.parent)
    (only,) = read_runs_path(root)
    assert only.run_id.endswith(f"{root.name}/09")
    with pytest.raises(DataFormatError, match="lie at its top level"):
        read_runs_dir(root)


@pytest.mark.parametrize("name, words", [
    ("IMU_00.csv", "lower case: rename it to imu_00.csv"),
    ("imu_00.csv.gz", "compressed run files are not read: decompress it to imu_00.csv"),
    ("Meta_00.json", "rename it to meta_00.json"),
    # '-' or spaces for '_' and spaces around the name were left out without a word (io11)
    ("imu-00.csv", "with '_' and hold no space: rename it to imu_00.csv"),
    ("IMU 00.csv", "hold no space: rename it to imu_00.csv"),
    ("imu 00.csv", "rename it to imu_00.csv"),
    ("imu_00.csv ", "rename it to imu_00.csv"),
    ("meta-00.json", "rename it to meta_00.json"),
])
def test_a_file_named_like_a_run_file_that_is_not_read_is_named(turning, name, words):
    # an IMU file named IMU_04.csv or imu_04.csv.gz was left out without a word: the run
    # was read as wheel-only ("nothing repaired, dropped or skipped")
    imu, _ = turning
    target = imu.with_name(name)
    imu.rename(target)
    for read in (read_runs_dir, read_runs_path):
        with pytest.raises(DataFormatError) as info:
            read(imu.parent.parent)
        assert info.value.path == str(target) and words in _one_line(info.value)


def test_one_terrain_folder_is_read_whatever_its_sibling_folders_hold(turning):
    # read_runs_path(<root>/ASPHALT) indexed every folder of <root>: an IMU_01.csv in a
    # sibling folder refused the ASPHALT run it never reads ("run file names are lower case")
    imu, _ = turning
    other = imu.parent.parent / "OTHER"
    other.mkdir()
    (other / "IMU_01.csv").write_text(imu.read_text())
    (run,) = read_runs_path(imu.parent)
    assert run.run_id == f"{imu.parent.parent.name}/ASPHALT/00" and set(run.streams) == {
        "imu", "wheels"}
    with pytest.raises(DataFormatError) as info:   # the whole runs folder: still refused
        read_runs_path(imu.parent.parent)
    assert info.value.path == str(other / "IMU_01.csv")
    (imu.parent.parent / "EMPTY").mkdir()
    with pytest.raises(DataFormatError, match="no run files") as info:
        read_runs_dir(imu.parent.parent, only="EMPTY")
    assert info.value.path == str(imu.parent.parent / "EMPTY")


def test_a_last_line_without_a_line_break_is_a_warning_naming_it(turning):
    # a file cut while being written ("...,-0." of "...,-0.0731"): the partial value
    # parses as a number and was read without a word
    from terrain.errors import DataWarning
    _, pro = turning
    text = pro.read_text()
    n_lines = text.count("\n")
    last = text.rstrip("\n").rsplit(",", 1)[1]
    assert len(last) >= 3                      # a value with digits to cut
    pro.write_text(text.rstrip("\n")[:-2])
    with pytest.warns(DataWarning, match=rf"pro_00.csv: rule last_line: .*line {n_lines}\)"):
        (run,) = read_runs_dir(pro.parent.parent)
    assert any("rule last_line" in w for w in run.meta["warnings"])
    pro.write_text(text)                       # a complete file: no such warning
    (run,) = read_runs_dir(pro.parent.parent)
    assert not any("rule last_line" in w for w in run.meta["warnings"])


def test_data_format_error_message_names_line_not_row():
    err = DataFormatError("bad", "f.csv", "wz", row=3, line=7)
    assert str(err) == "bad (file f.csv, column 'wz', line 7)" and err.row == 3


@pytest.mark.parametrize("content", [b"\xff{}", b"{not json", b"[1, 2]"])
def test_bad_run_metadata_is_a_typed_error_naming_the_file(turning, content):
    imu, _ = turning
    meta = imu.with_name("meta_00.json")
    meta.write_bytes(content)
    with pytest.raises(DataFormatError) as info:
        read_runs_dir(imu.parent.parent)
    assert info.value.path == str(meta)
    _one_line(info.value)


def test_corrupted_shipped_parquet_is_a_typed_error(tmp_path, data_dir):
    import shutil

    from terrain.io.shipped import read_shipped

    copy = tmp_path / "data"
    shutil.copytree(data_dir, copy)
    path = copy / "vulpi" / "imu.parquet"
    data = bytearray(path.read_bytes())
    data[len(data) // 2: len(data) // 2 + 64] = b"\0" * 64
    path.write_bytes(bytes(data))
    with pytest.raises(DataFormatError) as info:
        read_shipped("vulpi", copy)
    assert info.value.path == str(path) and "terrain convert" in _one_line(info.value)


# --- found by the 2026-11-25 review -----------------------------------------------------------

def test_a_terrain_folder_given_as_dot_is_read(turning, tmp_path, monkeypatch):
    # "." has no name and "." as parent: it was refused as a runs folder with run files
    monkeypatch.chdir(turning[0].parent)
    assert [r.run_id for r in read_runs_path(".")] == [f"{tmp_path.name}/ASPHALT/00"]


def test_estimate_reads_the_given_terrain_folder_only(turning, tmp_path):
    # a bad file in a sibling terrain folder aborted terrain estimate on the good one
    from terrain.cli import main
    (tmp_path / "BAD").mkdir()
    (tmp_path / "BAD" / "pro_00.csv").write_text("time,velL,velR,curL,curR\n0,abc,1,1,1\n")
    assert main(["estimate", str(turning[0].parent), "--out", str(tmp_path / "s.csv"),
                 "--slip-model", "ekf"]) == 0


def test_a_meta_file_without_its_run_is_named(turning, tmp_path):
    (turning[0].parent / "meta_05.json").write_text("{}")
    with pytest.raises(DataFormatError) as info:
        read_runs_dir(tmp_path)
    assert "meta_05.json" in _one_line(info.value)


@pytest.mark.parametrize("word", ["-nan", "+nan", "-infinity"])
def test_signed_nan_words_are_repaired_whatever_else_the_file_holds(turning, word):
    # C's printf writes -nan: the fast path read it as NaN, the strict one (taken for an
    # extra column or a comment with '_') refused it
    _, pro = turning
    lines = _lines(pro)
    head, first = lines[0].split(","), lines[2].split(",")
    first[head.index("curL")] = word
    lines[2] = ",".join(first)
    lines = [lines[0] + ",extra_col"] + [x + ",1" if x else x for x in lines[1:]]
    pro.write_text("\n".join(lines))
    runs, _ = _read(pro.parent.parent)
    assert runs[0].meta["repaired"] == {"wheels.cur_l": 1}


def test_check_ranges_takes_file_column_to_canonical_name():
    """``check_ranges``' ``columns`` maps the file's column to the canonical name (what the
    reader passes, :data:`COLUMN_MAPS`); its docstring said the reverse, with which the
    error named the canonical ``vel_r`` instead of the file's ``velR``."""
    from terrain.errors import ImplausibleValueError
    from terrain.io.measured import COLUMN_MAPS
    from terrain.io.plausibility import check_ranges

    frame = pd.DataFrame({"t_s": [0.0, 0.1], "vel_l": [0.1, 0.1], "vel_r": [0.1, 9.0],
                          "cur_l": [1.0, 1.0], "cur_r": [1.0, 1.0]})
    with pytest.raises(ImplausibleValueError) as info:
        check_ranges(frame, "pro_00.csv", COLUMN_MAPS["pro"], np.array([2, 3]))
    assert (info.value.column, info.value.line, info.value.row) == ("velR", 3, 1)


@pytest.mark.parametrize("dtype", ["int64", "int32", "uint16", "uint64"])
def test_check_ranges_checks_integer_and_unsigned_columns(dtype):
    """An integer or unsigned column is judged as a float one is (it was skipped: an int64
    wheel speed of 9 m/s passed), and int64's most negative value, whose ``abs`` overflows
    to itself, is refused too."""
    from terrain.errors import ImplausibleValueError
    from terrain.io.measured import COLUMN_MAPS
    from terrain.io.plausibility import check_ranges

    frame = pd.DataFrame({"t_s": [0.0, 0.1, 0.2], "vel_l": [0, 0, 0], "vel_r": [0, 9, 9],
                          "cur_l": [1, 1, 1], "cur_r": [1, 1, 1]}).astype(
        {c: dtype for c in ("vel_l", "vel_r", "cur_l", "cur_r")})
    with pytest.raises(ImplausibleValueError) as info:
        check_ranges(frame, "pro_00.csv", COLUMN_MAPS["pro"], np.array([2, 3, 4]))
    assert (info.value.path, info.value.column, info.value.line) == ("pro_00.csv", "velR", 3)
    assert str(info.value).startswith("2 value(s) beyond +-5 m/s") and "lines 3, 4" in str(
        info.value)
    if dtype == "int64":
        frame["vel_r"] = np.array([0, 0, np.iinfo(np.int64).min])
        with pytest.raises(ImplausibleValueError, match="1 value"):
            check_ranges(frame, "pro_00.csv", COLUMN_MAPS["pro"], np.array([2, 3, 4]))


def test_stuck_sensor_warning_names_the_file_as_the_other_run_findings_do(turning):
    # it named the run only ('borealtc/ASPHALT/00: imu.wz stuck at one value ...') where
    # every other run-level finding names the file
    from terrain.io.plausibility import check_run

    imu, _ = turning
    _edit(imu, lambda f: f.__setitem__("wz", 0.0))
    (run,), caught = _read(imu.parent.parent)
    (message,) = [str(w.message) for w in caught]
    assert message.startswith(f"{imu}: imu.wz stuck at one value for ")
    assert run.meta["warnings"] == [message]
    # with files given per stream (the shipped reader's '<file> run <id>'), each its own
    streams = {"imu": run.streams["imu"], "wheels": run.streams["wheels"].assign(cur_r=1.0)}
    with pytest.warns(DataWarning):
        found = check_run("r/A/0", streams, "husky", {"imu": "imu.parquet run r/A/0",
                                                      "wheels": "wheels.parquet run r/A/0"})
    assert sorted(w.split(" stuck")[0] for w in found["warnings"]) == [
        "imu.parquet run r/A/0: imu.wz", "wheels.parquet run r/A/0: wheels.cur_r"]


def test_stuck_sensor_warning_names_the_file_column_where_it_differs(turning):
    # 'pro_00.csv: wheels.cur_l stuck ...' named a channel the file does not hold: its
    # column is curL (the reader's column map); a column of the same name stays as it was
    from terrain.io.plausibility import check_run

    imu, pro = turning
    _edit(pro, lambda f: f.__setitem__("curL", 3.25))
    _edit(imu, lambda f: f.__setitem__("wz", 0.0))
    (run,), caught = _read(pro.parent.parent)
    messages = sorted(str(w.message) for w in caught)
    assert [m.split(" stuck at one value for ")[0] for m in messages] == [
        f"{imu}: imu.wz", f"{pro}: column 'curL' (wheels.cur_l)"]
    assert sorted(run.meta["stuck"]) == ["imu.wz", "wheels.cur_l"]   # keys stay canonical
    # any column map: the file's name leads, the canonical channel follows
    with pytest.warns(DataWarning, match=r"column 'angular_velocity_z' \(imu\.wz\) stuck"):
        check_run("r", {"imu": run.streams["imu"]}, "husky", {"imu": "log.csv"},
                  columns={"imu": {"time": TIME, "angular_velocity_z": "wz"}})


# --- the plausibility rules' thresholds, on synthetic streams -------------------------------


def test_gyro_in_deg_s_mounted_upside_down_is_refused_too(turning):
    """The yaw rule judges |slope| and |corr|: an IMU mounted upside down (wz = -yaw rate)
    in deg/s is as certainly in deg/s as one mounted upright."""
    imu, _ = turning
    _edit(imu, lambda f: f.__setitem__(["wx", "wy", "wz"],
                                       -np.degrees(f[["wx", "wy", "wz"]])))
    with pytest.raises(UnitError, match="gyro_units") as info:
        read_runs_dir(imu.parent.parent)
    slope = re.search(r"speed difference is (-?[0-9.]+) 1/m", info.value.message)
    assert info.value.column == "wz" and float(slope.group(1)) < -15.0


@pytest.mark.parametrize("step_s, n_same, stuck", [
    (0.1, 11, True),       # 1.0 s exactly, 11 samples: stuck (both bounds inclusive)
    (0.125, 10, True),     # 10 samples exactly, over 1.125 s: stuck
    (0.125, 9, False),     # 9 samples over 1.0 s: too few samples
    (0.05, 20, False),     # 20 samples over 0.95 s: too short
])
def test_stuck_sensor_bounds_are_inclusive(step_s, n_same, stuck):
    """Rule ``stuck_sensor`` for the IMU: at least :data:`STUCK_IMU_S` (1 s) from the
    stretch's first to its last sample and at least :data:`STUCK_MIN_SAMPLES` (10) samples
    of one exact value."""
    from terrain.io.plausibility import stuck_stretches

    n = 60
    t = np.arange(n) * step_s
    wz = np.sin(np.arange(n) + 0.5)
    wz[20:20 + n_same] = 0.25
    got = stuck_stretches({"imu": pd.DataFrame({TIME: t, "wz": wz})})
    want = {"imu.wz": [[t[20], t[20 + n_same - 1]]]} if stuck else {}
    assert got == want


@pytest.mark.parametrize("stream, rate_hz, unit", [
    ("imu", 2.0, None),        # slow (a warning), not ten times below 10 Hz: not in ms
    ("imu", 0.1, "ms"),        # 100 Hz in ms
    ("wheels", 0.5, None),     # half the lowest wheel rate: slow, not ms
    ("wheels", 0.0065, "ms"),  # the 6.5 Hz wheel stream in ms
])
def test_timestamp_unit_is_judged_only_ten_times_below_the_nominal_rate(stream, rate_hz,
                                                                        unit):
    from terrain.io.plausibility import timestamp_unit

    assert timestamp_unit(rate_hz, stream) == unit


@pytest.mark.parametrize("stream, rate_hz", [("imu", 10.0), ("imu", 2000.0),
                                             ("wheels", 1.0), ("wheels", 1000.0)])
def test_a_rate_on_a_nominal_bound_is_no_warning(stream, rate_hz):
    from terrain.io.plausibility import check_rate

    found = []
    check_rate(np.arange(50) / rate_hz, stream, "f.csv", found=found)
    assert found == []
    check_rate(np.arange(50) / (0.9 * rate_hz if rate_hz < 100 else 1.1 * rate_hz), stream,
               "f.csv", found=found)
    assert len(found) == 1 and "outside the nominal" in found[0]


def _imu_frame(t, ax=None):
    ax = np.zeros(t.size) if ax is None else ax
    rng = np.random.default_rng(0)
    return pd.DataFrame({TIME: t, **{c: 0.01 * rng.standard_normal(t.size)
                                     for c in ("wx", "wy", "wz", "ay")},
                         "ax": ax, "az": 9.81 + 0.01 * rng.standard_normal(t.size)})


def test_streams_meeting_at_one_instant_do_not_overlap():
    """An IMU clock ending where the wheel clock starts overlaps for 0 s: refused as
    clocks that do not overlap, not aligned onto a one-point grid."""
    from terrain.io.plausibility import check_run

    imu = _imu_frame(np.arange(0, 251) / 50.0)                      # 0 .. 5 s
    t_w = 5.0 + np.arange(0, 51) / 10.0                              # 5 .. 10 s
    wheels = pd.DataFrame({TIME: t_w, "vel_l": 0.5, "vel_r": 0.5, "cur_l": 5.0 + t_w,
                           "cur_r": 6.0 + t_w})
    with pytest.raises(ClockError, match="do not overlap"):
        check_run("r", {"imu": imu, "wheels": wheels}, "husky", {})


@pytest.mark.parametrize("scale, warned", [(1.0, False), (3.0, True)])
def test_wheel_speeds_rising_faster_than_the_acceleration_are_probably_km_h(scale, warned):
    """Rule ``wheel_speed_units``'s second evidence: the slope of d(wheel speed)/dt on the
    forward acceleration is about 1 in m/s and 3.6 in km/h; above 2.5 the speeds are
    probably in km/h, even when they are slow (0.5 m/s at most here, under 1.2 x the
    Husky's top speed)."""
    from terrain.io.plausibility import check_run

    t_i = np.arange(0, 3001) / 50.0
    f = 0.1
    ax = 0.05 * np.sin(2 * np.pi * f * t_i)
    t_w = np.arange(0, 601) / 10.0
    v = scale * 0.05 / (2 * np.pi * f) * (1.0 - np.cos(2 * np.pi * f * t_w))   # integral of ax
    wheels = pd.DataFrame({TIME: t_w, "vel_l": v, "vel_r": v, "cur_l": 5.0 + np.sin(t_w),
                           "cur_r": 6.0 + np.cos(t_w)})
    assert v.max() < 1.2 * 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        out = check_run("r", {"imu": _imu_frame(t_i, ax), "wheels": wheels}, "husky", {})
    found = [w for w in out["warnings"] if "wheel_speed_units" in w]
    assert len(found) == warned
    if warned:
        assert f"slope {scale:.2f}" in found[0] and "probably in km/h" in found[0]


@pytest.mark.parametrize("median, in_g", [(0.2, False), (0.5, True), (1.0, True),
                                          (2.99, True), (3.0, False), (9.81, False)])
def test_accel_in_g_is_the_band_between_a_dead_sensor_and_gravity(median, in_g):
    from terrain.io.plausibility import accel_in_g

    assert accel_in_g(median) is in_g


def test_a_runs_path_that_is_a_symbolic_link_loop_is_a_data_format_error(tmp_path):
    # terrain estimate LOOP raised Path.resolve's RuntimeError('Symlink loop'), which the
    # CLI reported as an internal error of terrain
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    with pytest.raises(DataFormatError) as info:
        read_runs_path(loop)
    assert info.value.path == str(loop) and "not a folder of runs" in str(info.value)


@pytest.mark.slow
def test_a_header_repeated_inside_the_file_is_named_as_such(turning):
    # two logs joined into one file: the second header was a "non-numeric value 'time'" at
    # its line, without a word about why
    imu, _ = turning
    lines = _lines(imu)
    lines.insert(40, lines[0])
    imu.write_text("\n".join(lines) + "\n")
    with pytest.raises(NonNumericError) as info:
        read_runs_dir(imu.parent.parent)
    assert info.value.line == 41
    assert "line 41 repeats the header (two logs joined into one file?)" in str(info.value)
    # a word in a data row is no repeated header: no such hint
    lines = _lines(imu)
    del lines[40]
    lines[40] = lines[40].replace(",", ",oops", 1)
    imu.write_text("\n".join(lines) + "\n")
    with pytest.raises(NonNumericError) as info:
        read_runs_dir(imu.parent.parent)
    assert "repeats the header" not in str(info.value)


def test_a_quoted_decimal_comma_is_named_as_such(turning):
    # a spreadsheet in a comma-decimal locale writes "0,25" quoted: it was only a
    # "non-numeric value '0,25'"
    imu, _ = turning
    lines = _lines(imu)
    fields = lines[10].split(",")
    fields[1] = '"' + fields[1].replace(".", ",") + '"'
    lines[10] = ",".join(fields)
    imu.write_text("\n".join(lines) + "\n")
    with pytest.raises(NonNumericError) as info:
        read_runs_dir(imu.parent.parent)
    assert info.value.line == 11 and info.value.column == "wx"
    assert "a decimal comma?" in str(info.value)
