"""Reader of the measured-run CSV layout: typed errors, the one repair rule, gaps, layouts."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from features.windows import WindowConfig, make_windows
from terrain.errors import (ConfigError, DataFormatError, EmptyFileError, EncodingError,
                            MissingColumnError, NonFiniteError, NonNumericError,
                            OrphanFileError, TimestampError)
from terrain.io.align import align_streams
from terrain.io.measured import (list_run_files, read_folder_run, read_runs_dir,
                                 read_stream_csv)
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS

BOREALTC_PRO = ["time", "curL", "curR", "velL", "velR"]
VULPI_PRO = ["time", "velL", "velR", "curL", "curR"]


def _write(tmp_path, frame, name="imu_00.csv"):
    path = tmp_path / name
    frame.to_csv(path, index=False)
    return path


def _set(frame, row, col, value):
    """Copy of ``frame`` (as text) with one cell replaced."""
    out = frame.astype(object)
    out.loc[row, col] = value
    return out


# --- columns -----------------------------------------------------------------------------

def test_valid_imu_file_reads_to_canonical_frame(tmp_path, synth_imu):
    src = synth_imu(duration_s=2.0)
    frame, report = read_stream_csv(_write(tmp_path, src), "imu")
    assert list(frame.columns) == [TIME, *IMU_CHANNELS]
    assert (frame.dtypes == np.float64).all()
    np.testing.assert_array_equal(frame.to_numpy(), src.to_numpy())
    assert report.repaired == {} and report.gaps == []


@pytest.mark.parametrize("kind, name, renamed", [
    ("imu", "imu_00.csv", "wz"),
    ("imu", "imu_00.csv", "time"),
    ("pro", "pro_00.csv", "velL"),
    ("pro", "pro_00.csv", "curR"),
])
def test_renamed_column_raises_missing_column(tmp_path, synth_imu, synth_pro, kind, name,
                                              renamed):
    src = synth_imu(duration_s=1.0) if kind == "imu" else synth_pro(duration_s=1.0)
    path = _write(tmp_path, src.rename(columns={renamed: renamed + "_renamed"}), name)
    with pytest.raises(MissingColumnError) as info:
        read_stream_csv(path, kind)
    assert info.value.path == str(path)
    assert info.value.column == renamed
    assert info.value.row is None
    # the name alone was found in the header list ('wz_renamed') and in the expected one
    assert f"missing column(s) {[renamed]};" in str(info.value) and str(path) in str(info.value)


def test_dropped_column_raises_missing_column(tmp_path, synth_imu):
    path = _write(tmp_path, synth_imu(duration_s=1.0).drop(columns=["ay"]))
    with pytest.raises(MissingColumnError) as info:
        read_stream_csv(path, "imu")
    assert (info.value.path, info.value.column) == (str(path), "ay")


@pytest.mark.parametrize("sep, quoting, hint", [
    ("\t", 0, "separated by tabs; the readers take commas only"),
    (";", 0, "separated by semicolons; the readers take commas only"),
    (",", 1, "the names are quoted; the readers take them unquoted"),
])
def test_another_csv_dialect_is_named_in_the_missing_column_error(tmp_path, synth_pro, sep,
                                                                  quoting, hint):
    # a spreadsheet export (semicolons), a tab-separated log, or quoted names: the error
    # listed the one long "column" it found and left the user to see why
    path = tmp_path / "pro_00.csv"
    synth_pro(duration_s=1.0).to_csv(path, index=False, sep=sep, quoting=quoting)
    with pytest.raises(MissingColumnError, match=re.escape(hint)):
        read_stream_csv(path, "pro")
    plain = tmp_path / "plain.csv"
    synth_pro(duration_s=1.0).rename(columns={"curR": "cur_R"}).to_csv(plain, index=False)
    with pytest.raises(MissingColumnError) as info:
        read_stream_csv(plain, "pro")
    assert "readers take" not in str(info.value)


# --- values --------------------------------------------------------------------------------

@pytest.mark.parametrize("col, row, value", [("wz", 17, "abc"), ("time", 5, "0.05s"),
                                             ("ax", 0, "1,5")])
def test_non_numeric_value_names_file_column_row(tmp_path, synth_imu, col, row, value):
    path = _write(tmp_path, _set(synth_imu(duration_s=1.0), row, col, value))
    with pytest.raises(NonNumericError) as info:
        read_stream_csv(path, "imu")
    assert (info.value.path, info.value.column, info.value.row) == (str(path), col, row)
    assert value in str(info.value)


def test_non_numeric_in_pro_file_reports_file_column_name(tmp_path, synth_pro):
    path = _write(tmp_path, _set(synth_pro(), 12, "curL", "n/a"), "pro_00.csv")
    with pytest.raises(NonNumericError) as info:
        read_stream_csv(path, "pro")
    assert (info.value.column, info.value.row) == ("curL", 12)


def test_decreasing_timestamp_raises_with_row(tmp_path, synth_imu):
    src = synth_imu(duration_s=1.0)
    src.loc[40, "time"] = src.loc[38, "time"]  # goes back
    path = _write(tmp_path, src)
    with pytest.raises(TimestampError) as info:
        read_stream_csv(path, "imu")
    assert (info.value.path, info.value.column, info.value.row) == (str(path), "time", 40)
    # the message itself (the path holds the test's name, "test_decreasing_...")
    assert info.value.message.startswith("decreasing timestamp")


def test_duplicated_timestamp_raises_with_row(tmp_path, synth_pro):
    src = synth_pro()
    src.loc[25, "time"] = src.loc[24, "time"]
    path = _write(tmp_path, src, "pro_00.csv")
    with pytest.raises(TimestampError) as info:
        read_stream_csv(path, "pro")
    assert (info.value.column, info.value.row) == ("time", 25)
    assert info.value.message.startswith("duplicated timestamp")


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", ""])
def test_burst_longer_than_max_repair_run_is_rejected(tmp_path, synth_imu, bad):
    src = synth_imu(duration_s=1.0).astype(object)
    src.loc[20:22, "ax"] = bad  # 3 consecutive rows
    path = _write(tmp_path, src)
    with pytest.raises(NonFiniteError) as info:
        read_stream_csv(path, "imu", max_repair_run=2)
    assert (info.value.path, info.value.column, info.value.row) == (str(path), "ax", 20)
    assert info.value.line == 22      # the burst's first line (header on line 1)


def test_burst_within_max_repair_run_is_repaired_and_counted(tmp_path, synth_imu):
    src = synth_imu(duration_s=1.0)
    text = src.astype(object)
    text.loc[20:22, "ax"] = "nan"
    frame, report = read_stream_csv(_write(tmp_path, text), "imu", max_repair_run=3)
    expected = np.interp([20, 21, 22], [19, 23], src["ax"].to_numpy()[[19, 23]])
    np.testing.assert_allclose(frame["ax"].to_numpy()[20:23], expected)
    assert report.repaired == {"ax": 3}


def test_non_finite_at_file_edge_is_rejected(tmp_path, synth_imu):
    path = _write(tmp_path, _set(synth_imu(duration_s=1.0), 100, "wy", "nan"))  # last row
    with pytest.raises(NonFiniteError) as info:
        read_stream_csv(path, "imu")
    assert (info.value.column, info.value.row) == ("wy", 100)


def test_non_finite_timestamp_is_rejected(tmp_path, synth_imu):
    path = _write(tmp_path, _set(synth_imu(duration_s=1.0), 30, "time", "nan"))
    with pytest.raises(NonFiniteError) as info:
        read_stream_csv(path, "imu")
    assert (info.value.column, info.value.row) == ("time", 30)


def test_isolated_nan_is_interpolated_and_counted_in_run_meta(tmp_path, synth_imu,
                                                              synth_pro, write_run):
    imu = synth_imu(duration_s=2.0)
    pro = synth_pro(duration_s=2.0)
    write_run(tmp_path, "ASPHALT", "00", _set(imu, 50, "wz", "NaN"),
              _set(_set(pro, 7, "velR", "nan"), 12, "velR", "inf"))
    (run,) = read_runs_dir(tmp_path, "borealtc")
    wz = run.streams["imu"]["wz"].to_numpy()
    assert np.isfinite(wz).all()
    assert wz[50] == pytest.approx(0.5 * (imu["wz"][49] + imu["wz"][51]))
    # everything else is untouched
    np.testing.assert_array_equal(np.delete(wz, 50), np.delete(imu["wz"].to_numpy(), 50))
    vel_r = run.streams["wheels"]["vel_r"].to_numpy()
    assert vel_r[7] == pytest.approx(0.5 * (pro["velR"][6] + pro["velR"][8]))
    assert vel_r[12] == pytest.approx(0.5 * (pro["velR"][11] + pro["velR"][13]))
    assert run.meta["repaired"] == {"imu.wz": 1, "wheels.vel_r": 2}


def _wheel_file(tmp_path, t, vel, name="pro_00.csv"):
    """A pro file with timestamps ``t``, both wheel speeds ``vel`` (text cells allowed)."""
    frame = pd.DataFrame({"time": t, "curL": 5.0, "curR": 5.0, "velL": vel, "velR": 0.5})
    return _write(tmp_path, frame, name)


def test_a_non_finite_sample_next_to_a_timestamp_gap_is_refused(tmp_path):
    # 10 Hz wheels with a gap 4.9 -> 10.0 s, speed 0.2 m/s before and 0.9 after; a NaN at
    # the first sample after the gap was "repaired" to 0.55 from the row before the gap
    # and the row after it (by row index, across the 5.1 s gap)
    t = np.r_[np.arange(0, 5, 0.1), np.arange(10, 15, 0.1)].round(3)
    vel = np.where(t < 7, 0.2, 0.9).astype(object)
    for row in (49, 50):                  # last before the gap, first after it
        cells = vel.copy()
        cells[row] = "nan"
        path = _wheel_file(tmp_path, t, cells)
        with pytest.raises(NonFiniteError) as info:
            read_stream_csv(path, "pro")
        err = info.value
        assert (err.column, err.row, err.line) == ("velL", row, row + 2)
        assert "timestamp gap (4.9 -> 10 s)" in str(err)
    cells = vel.copy()
    cells[60] = "nan"                     # inside the second stretch: repaired
    frame, report = read_stream_csv(_wheel_file(tmp_path, t, cells), "pro")
    assert frame["vel_l"][60] == 0.9 and report.repaired == {"vel_l": 1}
    assert report.gaps == [(4.9, 10.0)]


def test_a_gap_is_a_step_longer_than_gap_factor_median_steps(tmp_path):
    """The gap rule is ``step > gap_factor x median step``, the median so that a long pause
    does not hide a shorter gap: at 0.125 s steps (exact in binary) a 0.375 s step (3 x, on
    the threshold) is no gap, a 0.5 s step is one, and so is it beside a 20 s pause that
    lifts the mean step to about 1 s (3 x the mean would hide it)."""
    d = 0.125

    def times(*big):
        steps = [d] * 10
        for k, step in big:
            steps[k] = step
        return np.r_[0.0, np.cumsum(steps)]

    _, report = read_stream_csv(_wheel_file(tmp_path, times((4, 3 * d)), 0.5), "pro")
    assert report.gaps == []
    t = times((4, 4 * d))
    _, report = read_stream_csv(_wheel_file(tmp_path, t, 0.5), "pro")
    assert report.gaps == [(t[4], t[5])]
    t = times((4, 4 * d), (7, 20.0))
    _, report = read_stream_csv(_wheel_file(tmp_path, t, 0.5), "pro")
    assert report.gaps == [(t[4], t[5]), (t[7], t[8])]
    _, report = read_stream_csv(_wheel_file(tmp_path, t, 0.5), "pro", gap_factor=5.0)
    assert report.gaps == [(t[7], t[8])]


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(steps=st.lists(st.floats(0.06, 0.14), min_size=8, max_size=40),
       picks=st.sets(st.integers(1, 38), min_size=1, max_size=6),
       a=st.floats(-1.0, 1.0), b=st.floats(-0.5, 0.5))
def test_isolated_non_finite_samples_are_interpolated_in_time(tmp_path, steps, picks, a, b):
    """A wheel speed linear in time, sampled with uneven steps (0.06-0.14 s: no gap at 3 x
    the median) and isolated NaN: the repair gives the line itself. Before, it interpolated
    by row index: at t = 0, 0.06, 0.2 (NaN), 0.26 the repair was off by 0.04 x b."""
    t = np.r_[0.0, np.cumsum(steps)].round(6)
    rows = sorted(i for i in picks if i < len(t) - 1 and i - 1 not in picks)
    vel = (a + b * t).round(9)
    cells = vel.astype(object)
    cells[rows] = "nan"
    frame, report = read_stream_csv(_wheel_file(tmp_path, t, cells), "pro",
                                    max_repair_run=1)
    np.testing.assert_allclose(frame["vel_l"].to_numpy(), vel, rtol=0, atol=1e-8)
    assert report.repaired == ({"vel_l": len(rows)} if rows else {}) and report.gaps == []


@pytest.mark.parametrize("end", ["\r\n", "\r"])
def test_cr_lf_and_lone_cr_line_ends_read_as_lf(tmp_path, synth_imu, end):
    # a CR-only file (classic Mac OS) was one line: "file has a header but no data rows",
    # while the streaming service reads CR-only CSV bodies
    lf = _write(tmp_path, synth_imu(duration_s=1.0), "lf.csv")
    text = lf.read_text()
    want, _ = read_stream_csv(lf, "imu")
    other = tmp_path / "other.csv"
    other.write_bytes(text.replace("\n", end).encode())
    got, report = read_stream_csv(other, "imu")
    pd.testing.assert_frame_equal(got, want)
    assert len(got) == 101 and report.warnings == []
    # errors name the line an editor shows: file line 31 is data row 29
    lines = text.split("\n")
    lines[30] = lines[30].replace(",", ",x", 1)
    other.write_bytes(end.join(lines).encode())
    with pytest.raises(NonNumericError) as info:
        read_stream_csv(other, "imu")
    assert (info.value.row, info.value.line) == (29, 31)
    lines = text.split("\n")
    lines[40] += "\xe9"
    other.write_bytes(end.join(lines).encode("latin-1"))
    with pytest.raises(EncodingError) as info:
        read_stream_csv(other, "imu")
    assert info.value.line == 41
    other.write_bytes(text.rstrip("\n").replace("\n", end).encode())   # no line end last
    _, report = read_stream_csv(other, "imu")
    assert [w.split(": ", 1)[1][:38] for w in report.warnings] == [
        "rule last_line: no line break after th"] and "(line 102)" in report.warnings[0]


# --- empty files ---------------------------------------------------------------------------

def test_empty_file_raises_empty_file_error(tmp_path):
    path = tmp_path / "imu_00.csv"
    path.write_text("")
    with pytest.raises(EmptyFileError) as info:
        read_stream_csv(path, "imu")
    assert info.value.path == str(path)


@pytest.mark.parametrize("text, counts", [
    ("# exported by logger v2\n# units: SI\n\n", "3 lines were all skipped (2 comment, 1 blank)"),
    ("\n\n", "2 lines were all skipped (0 comment, 2 blank)"),
    ("# only a comment", "1 line was all skipped (1 comment, 0 blank)")])
def test_comment_only_file_says_no_header_line(tmp_path, text, counts):
    # such a file said "file is empty", though it has lines
    path = tmp_path / "imu_00.csv"
    path.write_text(text)
    with pytest.raises(EmptyFileError) as info:
        read_stream_csv(path, "imu")
    msg = str(info.value)
    assert "no header line" in msg and counts in msg and "is empty" not in msg
    assert info.value.path == str(path)


def test_header_only_file_raises_empty_file_error(tmp_path):
    path = tmp_path / "pro_00.csv"
    path.write_text(",".join(BOREALTC_PRO) + "\n")
    with pytest.raises(EmptyFileError) as info:
        read_stream_csv(path, "pro")
    assert info.value.path == str(path)
    assert "no data rows" in str(info.value)


def test_empty_file_error_propagates_from_runs_dir(tmp_path, synth_pro, write_run):
    write_run(tmp_path, "ICE", "01", pro=synth_pro())
    (tmp_path / "ICE" / "imu_01.csv").write_text("")
    with pytest.raises(EmptyFileError) as info:
        read_runs_dir(tmp_path)
    assert info.value.path == str(tmp_path / "ICE" / "imu_01.csv")


# --- run-level rules -----------------------------------------------------------------------

def test_imu_file_without_pro_file_is_an_orphan(tmp_path, synth_imu, synth_pro, write_run):
    write_run(tmp_path, "SNOW", "00", synth_imu(), synth_pro())
    orphan = write_run(tmp_path, "SNOW", "03", imu=synth_imu())["imu"]
    with pytest.raises(OrphanFileError) as info:
        read_runs_dir(tmp_path)
    assert info.value.path == str(orphan)


def test_gyro_in_degrees_per_second_is_rejected(tmp_path, synth_imu):
    src = synth_imu(duration_s=2.0)
    src["wz"] = np.degrees(src["wz"] + 0.7 * np.sin(np.arange(len(src)) / 10.0))
    first = int(np.flatnonzero(np.abs(src["wz"].to_numpy()) > 35.0)[0])
    path = _write(tmp_path, src)
    with pytest.raises(DataFormatError) as info:
        read_stream_csv(path, "imu")
    assert (info.value.path, info.value.column, info.value.row) == (str(path), "wz", first)
    assert "deg/s" in str(info.value)


def test_accelerometer_in_g_is_rejected(tmp_path, synth_imu):
    src = synth_imu(duration_s=2.0)
    src[["ax", "ay", "az"]] /= 9.81
    path = _write(tmp_path, src)
    with pytest.raises(DataFormatError) as info:
        read_stream_csv(path, "imu")
    assert info.value.path == str(path) and info.value.column == "az"
    assert "units of g" in str(info.value)


def test_both_pro_column_orders_give_identical_canonical_frames(tmp_path, synth_pro):
    src = synth_pro(columns=BOREALTC_PRO)
    boreal = _write(tmp_path, src[BOREALTC_PRO], "pro_00.csv")
    vulpi = _write(tmp_path, src[VULPI_PRO], "pro_01.csv")
    a, _ = read_stream_csv(boreal, "pro")
    b, _ = read_stream_csv(vulpi, "pro")
    pd.testing.assert_frame_equal(a, b)
    assert list(a.columns) == [TIME, *WHEEL_CHANNELS]
    # mapped by name, not by position
    for canon, col in {"vel_l": "velL", "vel_r": "velR", "cur_l": "curL", "cur_r": "curR"}.items():
        np.testing.assert_array_equal(a[canon].to_numpy(), src[col].to_numpy())


def test_real_rows_of_both_datasets_read_back_by_name(tmp_path, borealtc_runs, vulpi_runs,
                                                      to_file_frame):
    for runs, order in ((borealtc_runs, BOREALTC_PRO), (vulpi_runs, VULPI_PRO)):
        wheels = runs[0].streams["wheels"].iloc[:200]
        path = _write(tmp_path, to_file_frame(wheels, order), "pro_00.csv")
        frame, _ = read_stream_csv(path, "pro")
        pd.testing.assert_frame_equal(frame, wheels.reset_index(drop=True))


def test_run_without_imu_loads_wheel_only(tmp_path, synth_imu, synth_pro, write_run):
    write_run(tmp_path, "FLOORING", "00", synth_imu(), synth_pro())
    write_run(tmp_path, "FLOORING", "04", pro=synth_pro())
    runs = read_runs_dir(tmp_path, "borealtc")
    assert [r.run_id for r in runs] == ["borealtc/FLOORING/00", "borealtc/FLOORING/04"]
    wheel_only = runs[1]
    assert not wheel_only.has_imu and set(wheel_only.streams) == {"wheels"}
    assert wheel_only.terrain == "FLOORING"
    frame = align_streams(wheel_only)
    assert list(frame.columns) == [TIME, *WHEEL_CHANNELS]
    assert runs[0].has_imu


def test_list_run_files_indexes_by_terrain_and_index(tmp_path, synth_imu, synth_pro,
                                                     write_run):
    write_run(tmp_path, "ICE", "01", synth_imu(duration_s=1.0), synth_pro(duration_s=1.0))
    (tmp_path / "ICE" / "notes.txt").write_text("ignored")
    files = list_run_files(tmp_path)
    assert set(files) == {("ICE", "01")}
    assert set(files[("ICE", "01")]) == {"imu", "pro"}


def test_read_folder_run_reads_the_chosen_run_labelled_by_its_folder(tmp_path, synth_imu,
                                                                     synth_pro, write_run):
    for index in ("01", "02"):
        write_run(tmp_path / "husky", "ICE", index, synth_imu(duration_s=1.0 + int(index)),
                  synth_pro(duration_s=1.0 + int(index)))
    run = read_folder_run(tmp_path / "husky" / "ICE", "02")
    assert run.run_id == "ICE/02" and run.terrain == "ICE" and run.dataset == "husky"
    assert run.streams["imu"]["t_s"].iloc[-1] > 2.5        # run 02, not 01 (1 s longer)
    with pytest.raises(ConfigError, match=r"holds runs \['01', '02'\]: choose one"):
        read_folder_run(tmp_path / "husky" / "ICE")
    with pytest.raises(ConfigError, match=r"no run '03' in .*available: \['01', '02'\]"):
        read_folder_run(tmp_path / "husky" / "ICE", "03")
    # the runs folder one level up: the message names the terrain folder to pass
    with pytest.raises(ConfigError, match=r"holds no run files .*; its terrain folder\(s\) "
                                          r"ICE do: pass one of them, e.g. .*husky/ICE"):
        read_folder_run(tmp_path / "husky")
    with pytest.raises(ConfigError, match=r"holds no run files \(imu_XX.csv, pro_XX.csv\)$"):
        read_folder_run(tmp_path)
    with pytest.raises(ConfigError, match="does not exist or is not a folder"):
        read_folder_run(tmp_path / "husky" / "SNOW")


def test_read_folder_run_refuses_an_empty_index_instead_of_taking_the_first_run(
        tmp_path, synth_imu, synth_pro, write_run):
    # terrain stream RUN_DIR --index "" took run 01 of two without a word
    for index in ("01", "02"):
        write_run(tmp_path / "husky", "ICE", index, synth_imu(duration_s=1.0),
                  synth_pro(duration_s=1.0))
    with pytest.raises(ConfigError, match=r"no run '' in .*available: \['01', '02'\]"):
        read_folder_run(tmp_path / "husky" / "ICE", "")


def test_empty_runs_folder_is_rejected(tmp_path):
    with pytest.raises(DataFormatError):
        list_run_files(tmp_path)
    with pytest.raises(DataFormatError):
        list_run_files(tmp_path / "missing")


# --- gaps ----------------------------------------------------------------------------------

@pytest.fixture
def gap_run(tmp_path, synth_imu, synth_pro, write_run):
    """A 12 s run whose IMU file has no sample strictly between t = 3 s and t = 4 s."""
    imu = synth_imu(duration_s=12.0)
    t = imu["time"].to_numpy()
    imu = imu[~((t > 3.0) & (t < 4.0))].reset_index(drop=True)
    write_run(tmp_path, "ASPHALT", "00", imu, synth_pro(duration_s=12.0))
    (run,) = read_runs_dir(tmp_path, "borealtc")
    return run, len(imu)


def test_gap_is_reported_and_not_filled(gap_run):
    run, n_rows = gap_run
    assert run.meta["gaps"] == {"imu": [(3.0, 4.0)]}
    frame = run.streams["imu"]
    assert len(frame) == n_rows  # nothing interpolated into the file's gap
    t = frame[TIME].to_numpy()
    assert not ((t > 3.0) & (t < 4.0)).any()
    assert run.meta["repaired"] == {}


def test_align_puts_nan_inside_gap_only(gap_run):
    run, _ = gap_run
    frame = align_streams(run, rate_hz=50.0)
    t = frame[TIME].to_numpy()
    inside = (t > 3.0) & (t < 4.0)
    assert inside.sum() == 49  # grid points 3.02 .. 3.98
    imu = frame[list(IMU_CHANNELS)].to_numpy()
    assert np.isnan(imu[inside]).all()
    assert np.isfinite(imu[~inside]).all()
    assert np.isfinite(frame[list(WHEEL_CHANNELS)].to_numpy()).all()


def test_windows_spanning_gap_are_dropped_and_counted(gap_run):
    run, _ = gap_run
    ws = make_windows([run], "all", WindowConfig(window_s=1.0, hop_s=0.5, rate_hz=50.0))
    # window starts 0, 0.5, ..., 11.0 (23 windows); those starting at 2.5, 3.0 and 3.5 s
    # hold a grid point inside (3, 4) s
    assert ws.counts["dropped_gap"] == 3
    assert len(ws) == 20 and ws.counts["windows"] == 20
    assert np.isfinite(ws.X).all()
    starts = np.round(ws.t_start_s, 6)
    assert not np.isin([2.5, 3.0, 3.5], starts).any()
    assert np.isin([2.0, 4.0], starts).all()


# --- extra streams and run metadata ----------------------------------------------------------

def test_extra_stream_reads_time_first_and_keeps_string_labels(tmp_path):
    path = tmp_path / "truth_00.csv"
    path.write_text("x,time,terrain\n1.0,0.0,ICE\n2.0,0.1,ICE\n3.0,0.2,SNOW\n")
    frame, _ = read_stream_csv(path, "truth")
    assert list(frame.columns) == [TIME, "x", "terrain"]
    np.testing.assert_array_equal(frame[TIME], [0.0, 0.1, 0.2])
    assert list(frame["terrain"]) == ["ICE", "ICE", "SNOW"]


def test_a_t_s_column_of_an_extra_stream_is_reported_not_taken_for_its_clock(tmp_path):
    # both mapped to t_s, the later column replaced the file's 'time' without a word
    path = tmp_path / "truth_00.csv"
    path.write_text("time,t_s,x\n0.0,100.0,1.0\n0.1,100.1,2.0\n0.2,100.2,3.0\n")
    frame, report = read_stream_csv(path, "truth")
    assert list(frame.columns) == [TIME, "x"]
    np.testing.assert_array_equal(frame[TIME], [0.0, 0.1, 0.2])
    assert report.ignored_columns == ["t_s"]


def test_extra_stream_without_time_column_is_rejected(tmp_path):
    path = tmp_path / "truth_00.csv"
    path.write_text("t,x\n0.0,1.0\n0.1,2.0\n")
    with pytest.raises(MissingColumnError) as info:
        read_stream_csv(path, "truth")
    assert (info.value.path, info.value.column) == (str(path), "time")


def test_extra_stream_and_meta_are_loaded_with_the_run(tmp_path, synth_pro, write_run):
    write_run(tmp_path, "ICE", "00", pro=synth_pro(duration_s=1.0))
    (tmp_path / "ICE" / "truth_00.csv").write_text("time,slip_1\n0.0,0.1\n0.5,0.2\n1.0,0.3\n")
    (tmp_path / "ICE" / "meta_00.json").write_text('{"vehicle": "agrimaro", "seed": 3}')
    (run,) = read_runs_dir(tmp_path, "sim")
    assert set(run.streams) == {"wheels", "truth"}
    assert run.vehicle == "agrimaro" and run.meta["seed"] == 3
    np.testing.assert_array_equal(run.streams["truth"]["slip_1"], [0.1, 0.2, 0.3])


@pytest.mark.parametrize("text", ["{not json", "[1, 2]"])
def test_bad_run_metadata_is_a_typed_error(tmp_path, synth_pro, write_run, text):
    write_run(tmp_path, "ICE", "00", pro=synth_pro(duration_s=1.0))
    meta = tmp_path / "ICE" / "meta_00.json"
    meta.write_text(text)
    with pytest.raises(DataFormatError) as info:
        read_runs_dir(tmp_path)
    assert info.value.path == str(meta)


def test_invalid_run_metadata_json_names_its_line_and_column(tmp_path, synth_pro, write_run):
    write_run(tmp_path, "ICE", "00", pro=synth_pro(duration_s=1.0))
    meta = tmp_path / "ICE" / "meta_00.json"
    meta.write_text('{\n "vehicle": "husky",\n "seed": 3,,\n}\n')
    with pytest.raises(DataFormatError, match=r"invalid JSON: .*, column 12") as info:
        read_runs_dir(tmp_path)
    assert info.value.path == str(meta) and info.value.line == 3


@pytest.mark.parametrize("vehicle", ['"tank"', "5", "null"])
def test_unknown_vehicle_in_run_metadata_is_refused_not_left_unchecked(tmp_path, synth_pro,
                                                                       write_run, vehicle):
    # an unknown vehicle has no plausibility limits: accepting it would switch the rules off
    write_run(tmp_path, "ICE", "00", pro=synth_pro(duration_s=1.0))
    meta = tmp_path / "ICE" / "meta_00.json"
    meta.write_text('{"vehicle": %s}' % vehicle)
    with pytest.raises(DataFormatError, match="key 'vehicle': unknown vehicle") as info:
        read_runs_dir(tmp_path)
    assert info.value.path == str(meta) and "husky" in str(info.value)


def test_vehicle_name_in_run_metadata_is_case_insensitive(tmp_path, synth_pro, write_run):
    write_run(tmp_path, "ICE", "00", pro=synth_pro(duration_s=1.0))
    (tmp_path / "ICE" / "meta_00.json").write_text('{"vehicle": "Husky"}')
    (run,) = read_runs_dir(tmp_path)
    assert run.vehicle == "husky"


def test_a_file_given_as_the_runs_folder_is_named_as_a_file(tmp_path):
    path = tmp_path / "pro_00.csv"
    path.write_text("time,velL\n")
    with pytest.raises(DataFormatError, match="runs folder is a file") as info:
        read_runs_dir(path)
    assert info.value.path == str(path)
    with pytest.raises(DataFormatError, match="runs folder does not exist"):
        read_runs_dir(tmp_path / "absent")
