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


def test_a_manifest_duration_off_by_a_millisecond_is_refused(tmp_path, data_dir):
    # convert_dataset writes duration_s to 3 decimals and read_shipped compares it at 3:
    # a run whose last sample is gone (one 50 Hz step) or a hand-edited figure is refused
    import json
    import shutil

    from terrain.io.shipped import read_shipped

    copy = tmp_path / "data"
    shutil.copytree(data_dir, copy)
    path = copy / "manifest.json"
    manifest = json.loads(path.read_text())
    run = manifest["datasets"]["vulpi"]["runs"][1]
    run["duration_s"] = round(run["duration_s"] + 0.001, 3)
    path.write_text(json.dumps(manifest))
    with pytest.raises(DataFormatError, match=r"runs\[1\]\.duration_s' says"):
        _quiet(read_shipped, "vulpi", copy)


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


def test_a_run_labelled_with_another_terrain_than_its_folder_is_refused(tmp_path, data_dir):
    # the label of a shipped run is the manifest's 'terrain'; one edited to another class
    # of the dataset (vulpi/CONCRETE/1 as DIRT_ROAD) was read as that class without a word
    import json
    import shutil

    from terrain.io.shipped import read_shipped

    copy = tmp_path / "data"
    shutil.copytree(data_dir, copy)
    path = copy / "manifest.json"
    manifest = json.loads(path.read_text())
    run = manifest["datasets"]["vulpi"]["runs"][0]
    assert (run["run_id"], run["terrain"]) == ("vulpi/CONCRETE/1", "CONCRETE")
    run["terrain"] = "DIRT_ROAD"
    path.write_text(json.dumps(manifest))
    with pytest.raises(DataFormatError, match=r"'datasets\.vulpi\.runs\[0\]\.terrain' is "
                       r"'DIRT_ROAD' but run 'vulpi/CONCRETE/1' lies in terrain folder "
                       r"'CONCRETE'") as err:
        _quiet(read_shipped, "vulpi", copy)
    assert err.value.path == str(path)
