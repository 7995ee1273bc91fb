"""Review io20 of terrain.io.measured: the CSV readers and the shipped copy of the same runs
agree (order of the runs, what they report)."""

from __future__ import annotations

import warnings

import pytest

from terrain.io.measured import read_runs_dir, read_runs_path
from terrain.io.shipped import convert_dataset, read_shipped


@pytest.mark.parametrize("folders", [("SAND", "SAND-WET"), ("ICE", "ICE.2", "ICE+SNOW"),
                                     ("A B", "A", "AB")])
def test_runs_read_from_csv_are_sorted_by_run_id_as_the_shipped_copy(tmp_path, synth_imu,
                                                                     synth_pro, write_run,
                                                                     folders):
    # read_runs_dir sorted by (folder, index) while its docstring, and read_shipped, sort by
    # run id: 'SAND' < 'SAND-WET' as folders but 'x/SAND-WET/00' < 'x/SAND/00' as ids ('-'
    # sorts before '/'), so the CSV folder and its shipped copy gave the runs in two orders
    src = tmp_path / "borealtc"
    for k, folder in enumerate(folders):
        for index in ("00", "01"):
            write_run(src, folder, index, synth_imu(duration_s=3.0, seed=k),
                      synth_pro(duration_s=3.0, seed=k))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        csv_ids = [r.run_id for r in read_runs_dir(src)]
        path_ids = [r.run_id for r in read_runs_path(src)]
        convert_dataset(src, "borealtc", tmp_path / "data")
        shipped_ids = [r.run_id for r in read_shipped("borealtc", tmp_path / "data")]
    assert csv_ids == sorted(csv_ids) == path_ids
    assert shipped_ids == csv_ids
