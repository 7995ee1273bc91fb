"""Second review pass of the data readers (terrain.io): behaviours found unpinned by hand
mutants, and defects found on the way."""

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError
from terrain.io.measured import list_run_files, read_folder_run
from terrain.run import TIME


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kwargs)


PRO = ["time", "velL", "velR", "curL", "curR"]


@pytest.mark.parametrize("columns", [
    PRO,                                           # the pro layout: a bare KeyError 'vel_r'
    ["time", "vel_l", "vel_r", "cur_l", "cur_r"],  # canonical names: taken without a word
    ["time", "note", "velR", "curL", "curR"],      # another layout: a bare KeyError
])
def test_a_stream_file_named_wheels_beside_the_pro_file_is_refused(
        tmp_path, write_run, synth_imu, synth_pro, columns):
    # pro_XX.csv is read as stream 'wheels' and wheels_XX.csv as an extra stream of the same
    # name, read after it (kinds in name order): it replaced the run's wheel stream without
    # a word, or raised a bare KeyError in the plausibility rules
    root = tmp_path / "runs"
    write_run(root, "ASPHALT", "00", synth_imu(duration_s=3.0), synth_pro(duration_s=3.0))
    other = synth_pro(duration_s=3.0, seed=7).rename(columns=dict(zip(PRO, columns)))
    other.to_csv(root / "ASPHALT" / "wheels_00.csv", index=False)
    for read in (lambda: read_folder_run(root / "ASPHALT"), lambda: list_run_files(root)):
        with pytest.raises(DataFormatError, match=r"read from pro_00\.csv") as err:
            _quiet(read)
        assert err.value.path == str(root / "ASPHALT" / "wheels_00.csv")


def test_the_stuck_rule_judges_imu_channels_and_currents_of_their_own_streams():
    # the IMU channels of the wheel stream and the currents of the IMU stream are not
    # judged; a stream of another name (a served window) by its channel names alone
    from terrain.io.plausibility import STUCK_CURRENT_S, STUCK_IMU_S, stuck_limit_s

    assert [stuck_limit_s("imu", c) for c in ("wx", "az", "cur_l", "vel_l")] == \
        [STUCK_IMU_S, STUCK_IMU_S, None, None]
    assert [stuck_limit_s("wheels", c) for c in ("wz", "ax", "cur_r", "vel_r")] == \
        [None, None, STUCK_CURRENT_S, None]
    assert [stuck_limit_s("window", c) for c in ("wz", "cur_l", "vel_l")] == \
        [STUCK_IMU_S, STUCK_CURRENT_S, None]


def test_a_long_timestamp_gap_does_not_change_the_implied_rate():
    # 10 Hz wheel samples around a 300 s gap: the median step is the rate; the mean step
    # (14.4 s) would read as 0.069 Hz, i.e. 69 Hz in ms, and refuse the file
    from terrain.io.plausibility import check_rate, implied_rate_hz

    t = np.r_[np.arange(11) / 10.0, 301.0 + np.arange(11) / 10.0]
    assert implied_rate_hz(t) == 10.0
    found = []
    check_rate(t, "wheels", "pro_00.csv", found=found)
    assert found == []


@pytest.mark.parametrize("imu_hz, warned", [(60.0, True), (52.0, False), (40.0, True)])
def test_converting_an_imu_more_than_a_tenth_off_the_datasets_rate_warns(
        tmp_path, write_run, synth_imu, synth_pro, imu_hz, warned):
    # Vulpi's windows are aligned at 50 Hz: a 60 Hz IMU converted under it loses its
    # 25-30 Hz band; the warning's band is 10 % of the native rate, not only 2x off
    from terrain.io.shipped import convert_dataset

    root = tmp_path / "csv"
    write_run(root, "ASPHALT", "00", synth_imu(duration_s=3.0, rate_hz=imu_hz),
              synth_pro(duration_s=3.0))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        convert_dataset(root, "vulpi", tmp_path / "data")
    said = [str(w.message) for w in seen if "IMU runs at" in str(w.message)]
    assert said == ([f"{root}: the IMU runs at {imu_hz:g} Hz, dataset 'vulpi' at 50 Hz: its "
                     "windows will be aligned at 50 Hz (the IMU resampled); convert the runs "
                     "under the dataset they come from"] if warned else [])


def test_the_gaps_of_a_run_are_keyed_by_stream_name(tmp_path, write_run, synth_imu, synth_pro):
    # Run.meta["gaps"] is read by stream ('wheels', not the file's 'pro'): the audit
    # leaves the wheel stream's gaps out of its current scoring through that key
    pro = synth_pro(duration_s=6.0).drop(index=range(21, 31))      # 2.0 s -> 3.1 s: a gap
    imu = synth_imu(duration_s=6.0)
    imu = imu[(imu["time"] < 4.0) | (imu["time"] > 4.5)]            # 3.99 s -> 4.51 s
    write_run(tmp_path / "runs", "ASPHALT", "00", imu, pro)
    run = _quiet(read_folder_run, tmp_path / "runs" / "ASPHALT")
    assert run.meta["gaps"] == {"imu": [(3.99, 4.51)], "wheels": [(2.0, 3.1)]}


@pytest.mark.parametrize("norm, dead", [(0.0, True), (0.45, True), (0.2, True), (9.81, False)])
def test_an_accelerometer_below_half_a_g_in_g_units_is_warned_dead(norm, dead):
    # below 0.5 (half of gravity in g) the sensor sees gravity in neither unit: a warning
    # (assumed m/s^2) for every such median, not only for an all-zero sensor
    from terrain.io.plausibility import check_accel_units

    rng = np.random.default_rng(5)
    t = np.arange(300) / 100.0
    az = norm + 0.01 * rng.standard_normal(t.size) if norm else 0.0 * t + 1e-3 * (t % 0.02)
    frame = pd.DataFrame({TIME: t, "ax": 0.0 * t + 1e-4 * rng.standard_normal(t.size),
                          "ay": 1e-4 * rng.standard_normal(t.size), "az": az})
    found = []
    check_accel_units(frame, "imu_00.csv", found=found)
    assert len(found) == dead
    if dead:
        assert "rule accel_units" in found[0] and "dead or disconnected" in found[0]


def test_a_two_row_file_in_milliseconds_is_refused():
    # two rows are the readers' minimum: their one step is judged too (100 ms read as 100 s)
    from terrain.errors import UnitError
    from terrain.io.plausibility import check_rate

    with pytest.raises(UnitError, match=r"milliseconds \(ms\)") as err:
        check_rate(np.array([0.0, 100.0]), "wheels", "pro_00.csv")
    assert err.value.column == "time"


def test_a_deg_s_gyro_is_refused_when_the_wheels_turn_just_enough():
    # the wheels turn when std(v_R - v_L) >= 0.02 m/s: here 0.025 m/s, and the yaw rate is
    # 1 / (chi B) = 1.5 1/m times that, in deg/s (x 57.3): certain, refused
    from terrain.errors import UnitError
    from terrain.io.plausibility import check_run

    rng = np.random.default_rng(2)
    t_w = np.arange(201) / 10.0
    dv = 0.035 * np.sin(2 * np.pi * t_w / 5.0)
    assert 0.02 <= dv.std() < 0.03
    wheels = pd.DataFrame({TIME: t_w, "vel_l": 0.5 - dv / 2, "vel_r": 0.5 + dv / 2,
                           "cur_l": 5 + rng.standard_normal(t_w.size),
                           "cur_r": 6 + rng.standard_normal(t_w.size)})
    t_i = np.arange(2001) / 100.0
    wz = np.degrees(1.5 * np.interp(t_i, t_w, dv)) + 0.01 * rng.standard_normal(t_i.size)
    imu = pd.DataFrame({TIME: t_i, "wx": 0.01 * rng.standard_normal(t_i.size),
                        "wy": 0.01 * rng.standard_normal(t_i.size), "wz": wz,
                        "ax": 0.1 * rng.standard_normal(t_i.size),
                        "ay": 0.1 * rng.standard_normal(t_i.size),
                        "az": 9.81 + 0.1 * rng.standard_normal(t_i.size)})
    with pytest.raises(UnitError, match="rule gyro_units") as err:
        _quiet(check_run, "x/A/00", {"imu": imu, "wheels": wheels}, "husky",
               {"imu": "imu_00.csv", "wheels": "pro_00.csv"})
    assert (err.value.path, err.value.column) == ("imu_00.csv", "wz")


def test_a_stuck_channel_is_reported_with_the_time_of_all_its_stretches():
    # two stuck stretches of ax (1.5 s and 2.0 s): the warning gives their total, and
    # Run.meta["stuck"] both stretches, each from its first to its last sample
    from terrain.io.plausibility import check_run

    rng = np.random.default_rng(4)
    t = np.arange(1001) / 100.0
    imu = pd.DataFrame({TIME: t, **{c: 0.05 * rng.standard_normal(t.size)
                                    for c in ("wx", "wy", "wz", "ax", "ay")},
                        "az": 9.81 + 0.05 * rng.standard_normal(t.size)})
    imu.loc[(t >= 1.0) & (t <= 2.5), "ax"] = 0.25
    imu.loc[(t >= 6.0) & (t <= 8.0), "ax"] = -0.5
    found = _quiet(check_run, "x/A/00", {"imu": imu}, "husky", {"imu": "imu_00.csv"})
    assert found["stuck"] == {"imu.ax": [[1.0, 2.5], [6.0, 8.0]]}
    assert found["warnings"] == ["imu_00.csv: imu.ax stuck at one value for 3.5 s (2 "
                                 "stretch(es), first from t = 1.0 s): dead or stuck sensor; "
                                 "windows holding it are flagged"]


def test_a_value_beyond_range_in_a_stream_cut_from_a_table_names_the_tables_row():
    # a served request's IMU columns are judged on their own: the error names the row of
    # the request (``rows``), not the position in the cut
    from terrain.errors import ImplausibleValueError
    from terrain.io.plausibility import check_ranges

    frame = pd.DataFrame({TIME: [0.0, 0.01, 0.02], "wz": [0.1, 40.0, 0.2]})
    with pytest.raises(ImplausibleValueError, match=r"first 40 at row 11") as err:
        check_ranges(frame, "request", {"t_s": TIME, "wz": "wz"}, rows=np.array([10, 11, 12]))
    assert (err.value.column, err.value.row, err.value.line) == ("wz", 11, None)


def test_km_h_wheel_speeds_are_warned_when_noise_leaves_a_correlation_over_one_half():
    # the speed-derivative / acceleration slope counts as evidence from a correlation of
    # 0.5 (1 s averages): noisy speeds in km/h (correlation 0.69, slope 3.8) are warned
    from terrain.io.plausibility import check_run

    rng = np.random.default_rng(0)
    t_i = np.arange(0, 3001) / 50.0
    t_w = np.arange(0, 601) / 10.0
    ax = 0.05 * np.sin(2 * np.pi * 0.1 * t_i)
    v = 3.6 * 0.05 / (2 * np.pi * 0.1) * (1.0 - np.cos(2 * np.pi * 0.1 * t_w)) \
        + 0.12 * rng.standard_normal(t_w.size)
    wheels = pd.DataFrame({TIME: t_w, "vel_l": v, "vel_r": v, "cur_l": 5.0 + np.sin(t_w),
                           "cur_r": 6.0 + np.cos(t_w)})
    imu = pd.DataFrame({TIME: t_i, **{c: 0.01 * np.random.default_rng(k).standard_normal(
        t_i.size) for k, c in enumerate(("wx", "wy", "wz", "ay"))}, "ax": ax,
        "az": 9.81 + 0.01 * np.random.default_rng(9).standard_normal(t_i.size)})
    out = _quiet(check_run, "r", {"imu": imu, "wheels": wheels}, "husky",
                 {"wheels": "pro_00.csv"})
    found = [w for w in out["warnings"] if "wheel_speed_units" in w]
    assert len(found) == 1 and "slope 3.78" in found[0]
    assert "99th-percentile" not in found[0]     # slow enough: the slope alone says it


def test_a_shipped_run_keeps_the_file_warnings_of_its_csv_files(tmp_path, write_run,
                                                                synth_imu, synth_pro):
    # Run.meta['file_warnings'] of the shipped copy is the CSV run's (a pro file without a
    # line break after its last line), besides their place at the head of 'warnings'
    from terrain.io.shipped import convert_dataset, read_shipped

    root = tmp_path / "csv"
    paths = write_run(root, "ASPHALT", "00", synth_imu(duration_s=3.0),
                      synth_pro(duration_s=3.0))
    paths["pro"].write_text(paths["pro"].read_text().rstrip("\n"))
    csv_run = _quiet(read_folder_run, root / "ASPHALT")
    _quiet(convert_dataset, root, "borealtc", tmp_path / "data")
    (run,) = _quiet(read_shipped, "borealtc", tmp_path / "data")
    assert len(csv_run.meta["file_warnings"]) == 1
    assert "rule last_line" in csv_run.meta["file_warnings"][0]
    assert run.meta["file_warnings"] == csv_run.meta["file_warnings"]
    assert run.meta["warnings"][:1] == csv_run.meta["file_warnings"]


def test_converting_runs_with_extra_streams_warns_of_the_files_left_out(
        tmp_path, write_run, synth_imu, synth_pro):
    # the shipped format keeps the IMU and wheel streams: a truth_XX.csv beside them is
    # dropped on conversion, and said so, counted per kind
    from terrain.errors import DataWarning
    from terrain.io.shipped import convert_dataset

    root = tmp_path / "csv"
    for index in ("00", "01"):
        write_run(root, "ASPHALT", index, synth_imu(duration_s=3.0), synth_pro(duration_s=3.0))
    pd.DataFrame({"time": np.arange(31) / 10.0, "slip": np.linspace(0, 0.3, 31)}).to_csv(
        root / "ASPHALT" / "truth_01.csv", index=False)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        entry = convert_dataset(root, "borealtc", tmp_path / "data")
    said = [str(w.message) for w in seen if issubclass(w.category, DataWarning)
            and "left out" in str(w.message)]
    assert said == [f"{root}: stream file(s) left out, the shipped format keeps the IMU and "
                    "wheel streams only: truth (1 run(s))"]
    assert [sorted(r["samples"]) for r in entry["runs"]] == [["imu", "wheels"],
                                                             ["imu", "truth", "wheels"]]


def test_an_indented_comment_line_is_skipped_counted_and_kept_out_of_the_line_numbers(
        tmp_path):
    # a comment line is one whose first non-blank character is '#', indented or not; the
    # lines below it keep their file line numbers
    from terrain.errors import NonNumericError
    from terrain.io.measured import read_stream_csv

    rows = [f"{i * 0.01:.2f},0.1,0.2,0.3,0.1,0.2,{9.8 + 0.01 * (i % 3):.2f}\n"
            for i in range(30)]
    rows.insert(10, "   # logger paused\n")
    path = tmp_path / "imu_00.csv"
    path.write_text("time,wx,wy,wz,ax,ay,az\n" + "".join(rows))
    frame, report = _quiet(read_stream_csv, path, "imu")
    assert len(frame) == 30 and report.skipped_lines == {"blank": 0, "comment": 1}
    rows[20] = rows[20].replace(",0.1,0.2,0.3,", ",x,0.2,0.3,")   # data row 19: line 22
    path.write_text("time,wx,wy,wz,ax,ay,az\n" + "".join(rows))
    with pytest.raises(NonNumericError) as err:
        _quiet(read_stream_csv, path, "imu")
    assert (err.value.column, err.value.row, err.value.line) == ("wx", 19, 22)
