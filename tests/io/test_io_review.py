"""Review tests of terrain.io: behaviours the other io tests left unpinned (hand mutants)."""

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError, NonFiniteError, NonNumericError, TimestampError
from terrain.io.align import overlap_grid
from terrain.io.measured import (read_folder_run, read_runs_dir, read_runs_path,
                                 read_stream_csv)
from terrain.io.writer import write_run
from terrain.run import TIME, Run

HEADER = "time,wx,wy,wz,ax,ay,az"


def _imu_rows(n=40, extra=""):
    """``n`` rows of a plausible 100 Hz IMU file (gravity on az), ``extra`` appended."""
    return "".join(f"{i * 0.01:.2f},0.1,0.2,0.3,0.1,0.2,9.8{extra}\n" for i in range(n))


def _write(tmp_path, text, name="imu_00.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_touching_spans_have_no_overlap_grid():
    # spans that share one instant overlap for 0 s: the plausibility rule clock_overlap
    # refuses that as no overlap, so the grid is empty rather than one point
    grid = overlap_grid([np.array([0.0, 0.5, 1.0]), np.array([1.0, 1.5, 2.0])], 10.0)
    assert grid.size == 0
    assert overlap_grid([np.array([0.0, 1.0]), np.array([0.9, 2.0])], 10.0).tolist() == \
        pytest.approx([0.9, 1.0])


def test_an_underscored_number_is_refused_naming_column_and_line(tmp_path):
    # NumPy's fast parser reads "1_000" as 1000; the reader must not
    rows = _imu_rows().replace("9.8\n", "1_000\n", 1)
    with pytest.raises(NonNumericError) as err:
        read_stream_csv(_write(tmp_path, f"{HEADER}\n{rows}"), "imu")
    assert err.value.column == "az" and err.value.line == 2
    assert "'1_000'" in str(err.value)


def test_a_capitalised_nan_on_the_per_column_path_is_repaired_and_counted(tmp_path):
    # an ignored extra column sends the file down the per-column path; "NaN" is a
    # non-finite word there too (any case), so it is repaired, not refused as text
    rows = _imu_rows(extra=",x").splitlines(keepends=True)
    rows[5] = rows[5].replace(",0.1,0.2,9.8", ",NaN,0.2,9.8")
    frame, report = read_stream_csv(_write(tmp_path, f"{HEADER},extra\n" + "".join(rows)), "imu")
    assert report.repaired == {"ax": 1}
    assert report.ignored_columns == ["extra"]
    assert frame["ax"].iloc[5] == pytest.approx(0.1)
    assert "extra" not in frame.columns


def test_an_infinite_last_timestamp_is_refused_not_read_as_a_gap(tmp_path):
    rows = _imu_rows().splitlines(keepends=True)
    rows[-1] = "inf" + rows[-1][rows[-1].index(","):]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(NonFiniteError) as err:
            read_stream_csv(_write(tmp_path, HEADER + "\n" + "".join(rows)), "imu")
    assert err.value.column == "time" and err.value.line == 41


@pytest.mark.parametrize("labelled, terrains", [(True, ["ASPHALT", "SNOW"]),
                                                (False, [None, None])])
def test_unlabelled_runs_have_no_terrain_and_keep_their_ids(tmp_path, write_run, synth_imu,
                                                            synth_pro, labelled, terrains):
    # terrain predict reads runs unlabelled: a folder name must not become their label
    root = tmp_path / "runs"
    write_run(root, "ASPHALT", "00", synth_imu(duration_s=2.0), synth_pro(duration_s=2.0))
    write_run(root, "SNOW", "03", None, synth_pro(duration_s=2.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        runs = read_runs_dir(root, labelled=labelled)
        one = read_runs_path(root / "SNOW", labelled=labelled)
    assert [r.run_id for r in runs] == ["runs/ASPHALT/00", "runs/SNOW/03"]
    assert [r.terrain for r in runs] == terrains
    assert [(r.run_id, r.terrain) for r in one] == [("runs/SNOW/03", terrains[1])]


def test_the_first_run_written_to_an_empty_folder_is_index_00(tmp_path, make_run):
    t = np.arange(30) / 10.0
    wheels = pd.DataFrame({TIME: t, "vel_l": 0.5 + 0 * t, "vel_r": 0.5 + 0 * t,
                           "cur_l": 5 + t, "cur_r": 6 + t})
    run = make_run({"wheels": wheels})
    first = write_run(run, tmp_path)
    second = write_run(run, tmp_path)
    assert {k: p.name for k, p in first.items()} == {"pro": "pro_00.csv",
                                                     "meta": "meta_00.json"}
    assert second["pro"].name == "pro_01.csv"


def _wheel_run(make_run, speed=0.5):
    t = np.arange(30) / 10.0
    return make_run({"wheels": pd.DataFrame({TIME: t, "vel_l": speed + 0 * t,
                                             "vel_r": speed + 0 * t, "cur_l": 5 + t,
                                             "cur_r": 6 + t})})


def test_an_index_in_use_is_refused_and_the_run_there_is_kept(tmp_path, make_run):
    from terrain.errors import ConfigError

    written = write_run(_wheel_run(make_run, 0.5), tmp_path, 7)
    before = written["pro"].read_text()
    with pytest.raises(ConfigError, match="run index 07 already used"):
        write_run(_wheel_run(make_run, 0.25), tmp_path, 7)
    assert written["pro"].read_text() == before


@pytest.mark.parametrize("index", [-1, 100])
def test_an_index_outside_the_two_digit_layout_is_refused(tmp_path, make_run, index):
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match=r"must be an integer in \[0, 99\]"):
        write_run(_wheel_run(make_run), tmp_path, index)
    # nothing is written then, not even the terrain folder (an empty ASPHALT/ was left)
    assert not (tmp_path / "ASPHALT").exists()


def test_a_gap_inside_a_longer_one_of_another_stream_keeps_the_longer_end():
    from terrain.io.report import merged_gaps

    gaps = {"imu": [(1.0, 5.0), (9.0, 10.0)], "wheels": [(2.0, 3.0), (4.5, 6.0)]}
    assert merged_gaps(gaps) == [(1.0, 6.0), (9.0, 10.0)]
    assert merged_gaps({"imu": [(1.0, 5.0)], "wheels": [(2.0, 3.0)]}) == [(1.0, 5.0)]


def test_ignored_columns_are_counted_one_each(make_run):
    from terrain.io.report import input_report

    t = np.arange(5) / 10.0
    frame = pd.DataFrame({TIME: t, "vel_l": t, "vel_r": t, "cur_l": t, "cur_r": t})
    runs = [make_run({"wheels": frame}, run_id=f"x/ASPHALT/0{i}") for i in range(3)]
    runs = [Run(r.run_id, r.dataset, r.terrain, r.streams, meta={"ignored_columns": cols})
            for r, cols in zip(runs, ({"imu": ["extra"]},
                                      {"imu": ["extra", "t_s"], "wheels": ["note"]}, {}))]
    report = input_report(runs)
    assert report.metrics()["input_ignored_columns"] == 4.0
    assert ("ignored 4 column(s) not read by the readers (imu.extra, imu.t_s, wheels.note) "
            "in x/ASPHALT/00, x/ASPHALT/01") in report.text()


def test_a_streams_rate_is_its_median_not_mean_rate_across_a_gap(make_run):
    t = np.r_[np.arange(100), np.arange(200, 300)] / 100.0   # 100 Hz with a 1 s gap
    imu = pd.DataFrame({TIME: t, **{c: 0 * t for c in ("wx", "wy", "wz", "ax", "ay")},
                        "az": 9.81 + 0 * t})
    assert make_run({"imu": imu}).rate_hz("imu") == pytest.approx(100.0)


def test_require_columns_names_a_missing_clock(make_run):
    from terrain.errors import MissingColumnError

    run = make_run({"wheels": pd.DataFrame({"time": [0.0, 0.1], "vel_l": [0.5, 0.5]})})
    with pytest.raises(MissingColumnError) as err:
        run.require_columns("wheels", ["vel_l"])
    assert err.value.column == TIME


@pytest.mark.parametrize("value, what", [("0.03", "duplicated"), ("0.01", "decreasing")])
def test_a_timestamp_error_names_the_line_of_the_offending_row(tmp_path, value, what):
    rows = _imu_rows().splitlines(keepends=True)
    rows[4] = value + rows[4][rows[4].index(","):]     # data row 4: file line 7 (header, comment)
    text = HEADER + "\n# a comment\n" + "".join(rows)
    with pytest.raises(TimestampError, match=what) as err:
        read_stream_csv(_write(tmp_path, text), "imu")
    assert (err.value.column, err.value.row, err.value.line) == ("time", 4, 7)


def test_a_terrain_folder_read_alone_is_labelled_in_upper_case(tmp_path, write_run, synth_imu,
                                                               synth_pro):
    write_run(tmp_path / "runs", "snow", "02", synth_imu(duration_s=2.0),
              synth_pro(duration_s=2.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = read_folder_run(tmp_path / "runs" / "snow")
    assert (run.run_id, run.terrain, run.dataset) == ("snow/02", "SNOW", "runs")


def test_a_short_overlap_is_warned_even_when_little_is_left_out():
    # IMU 0..3 s, wheels 1.8..4.6 s: 1.8 s and 1.6 s left out (under the 2 s of the
    # left-out rule) but the overlap, 1.2 s, is under half the shorter span (2.8 s)
    from terrain.io.plausibility import check_run

    rng = np.random.default_rng(3)
    t_i = np.arange(301) / 100.0
    imu = pd.DataFrame({TIME: t_i, **{c: 0.01 * rng.standard_normal(t_i.size)
                                      for c in ("wx", "wy", "wz", "ax", "ay")},
                        "az": 9.81 + 0.01 * rng.standard_normal(t_i.size)})
    t_w = 1.8 + np.arange(29) / 10.0
    wheels = pd.DataFrame({TIME: t_w, **{c: 0.5 + 0.001 * rng.standard_normal(t_w.size)
                                         for c in ("vel_l", "vel_r")},
                           **{c: 5.0 + rng.standard_normal(t_w.size)
                              for c in ("cur_l", "cur_r")}})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = check_run("x/A/00", {"imu": imu, "wheels": wheels}, "husky", {})
    assert found["unused_s"] == {"imu": pytest.approx(1.8), "wheels": pytest.approx(1.6)}
    (msg,) = [w for w in found["warnings"] if "clock_overlap" in w]
    assert "overlap for 1.2 s only" in msg


def test_a_dataset_with_an_empty_terrain_list_is_refused():
    from terrain.errors import DataFormatError
    from terrain.io.shipped import manifest_terrains

    with pytest.raises(DataFormatError, match=r"'datasets.vulpi.terrains' is an empty list"):
        manifest_terrains({"datasets": {"vulpi": {"terrains": []}}}, "manifest.json")


@pytest.mark.parametrize("options, named", [
    ({"gap_factor": 0.5}, "gap_factor"),          # nearly every step a gap
    ({"gap_factor": float("nan")}, "gap_factor"),  # no step a gap, repairs across gaps
    ({"gap_factor": float("inf")}, "gap_factor"),
    ({"max_repair_run": -1}, "max_repair_run"),    # every burst refused, said as too long
    ({"max_repair_run": 1.5}, "max_repair_run"),
    ({"max_repair_run": True}, "max_repair_run"),
])
def test_reader_options_out_of_range_are_refused_by_name(tmp_path, options, named):
    # before, gap_factor NaN read every timestamp gap as no gap (a NaN burst across one was
    # interpolated) and max_repair_run -1 refused a single NaN as a burst too long to repair
    path = _write(tmp_path, HEADER + "\n" + _imu_rows())
    with pytest.raises(ConfigError, match=named):
        read_stream_csv(path, "imu", **options)


def test_reader_option_bounds_still_read(tmp_path):
    # max_repair_run 0 repairs nothing (a NaN is refused); a factor just above 1 is allowed
    text = HEADER + "\n" + _imu_rows(20) + "".join(
        f"{0.2 + i * 0.01:.2f},{'nan' if i == 1 else '0.1'},0.2,0.3,0.1,0.2,9.8\n"
        for i in range(20))
    path = _write(tmp_path, text)
    frame, report = read_stream_csv(path, "imu", gap_factor=1.01)
    assert report.repaired == {"wx": 1} and np.isfinite(frame["wx"]).all()
    with pytest.raises(NonFiniteError):
        read_stream_csv(path, "imu", max_repair_run=0)
