"""Review tests of terrain.io (pass io6): on/off settings of the run readers, the grid
tail's count, and behaviours hand mutants showed unpinned."""

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError
from terrain.io.align import overlap_grid, overlap_grid_tail
from terrain.io.measured import read_runs_dir, read_runs_path
from terrain.io.plausibility import STUCK_IMU_S, STUCK_MIN_SAMPLES, stuck_stretches
from terrain.io.report import input_report
from terrain.run import Run

IMU = "time,wx,wy,wz,ax,ay,az\n" + "".join(
    f"{i * 0.01:.2f},0.1,0.2,0.3,0.1,0.2,9.8\n" for i in range(300))
PRO = "time,velL,velR,curL,curR\n" + "".join(
    f"{i * 0.1:.1f},0.5,0.5,2.0,2.1\n" for i in range(30))


def _runs_folder(tmp_path):
    folder = tmp_path / "runs" / "GRASS"
    folder.mkdir(parents=True)
    (folder / "imu_00.csv").write_text(IMU)
    (folder / "pro_00.csv").write_text(PRO)
    return tmp_path / "runs"


@pytest.mark.parametrize("reader", [read_runs_dir, read_runs_path])
@pytest.mark.parametrize("option", ["labelled", "progress"])
@pytest.mark.parametrize("value", ["no", "false", 0, 1, None])
def test_reader_flags_refuse_text_and_numbers(tmp_path, reader, option, value):
    # labelled="no" (a config file's text) was read by truthiness: the runs were labelled
    root = _runs_folder(tmp_path)
    message = rf"{reader.__name__}\.{option} must be True or False"
    with pytest.raises(ConfigError, match=message):
        reader(root, **{option: value})


@pytest.mark.parametrize("reader", [read_runs_dir, read_runs_path])
def test_reader_flags_take_booleans(tmp_path, reader):
    root = _runs_folder(tmp_path)
    assert [r.terrain for r in reader(root, labelled=True)] == ["GRASS"]
    assert [r.terrain for r in reader(root, labelled=False)] == [None]


@pytest.mark.parametrize("n_last", [2.5, True, -1, "3", None])
def test_overlap_grid_tail_refuses_a_count_that_is_not_a_whole_number(n_last):
    # n_last=2.5 returned [4.975, 4.985, 4.995] at 100 Hz: points that are not on the grid
    # its docstring promises (overlap_grid's values); "3" was a bare TypeError
    t = np.arange(0.0, 10.0, 0.01)
    with pytest.raises(ConfigError, match=r"overlap_grid_tail\.n_last must be an integer"):
        overlap_grid_tail([t], 100.0, 5.0, n_last)


def test_overlap_grid_tail_is_the_end_of_the_grid():
    t = np.arange(0.0, 10.0, 0.01)
    grid = overlap_grid([t], 100.0)
    tail, end = overlap_grid_tail([t], 100.0, 5.0, 3)
    assert end == 500
    np.testing.assert_array_equal(tail, grid[497:500])
    assert overlap_grid_tail([t], 100.0, 5.0, 0)[0].size == 0


def test_windows_dropped_in_a_run_left_with_none_are_counted():
    # a run whose every window spans a gap has 0 windows but its drops count (a mutant that
    # took only runs with windows > 0 lost them from the metrics and the text)
    run = Run("r/gappy", "runs", None, {}, meta={})
    counts = {"per_run": {"r/gappy": {"windows": 0, "dropped_gap": 4, "dropped_unsteady": 1,
                                      "window_tail_s": 0.5}}}
    report = input_report([run], counts)
    m = report.metrics("")
    assert (m["windows_dropped_gap"], m["windows_dropped_unsteady"]) == (4.0, 1.0)
    assert m["window_tail_s"] == 0.5
    assert "4 spanning a gap, 1 unsteady" in report.text()


def test_a_short_stream_with_one_stuck_value_is_found():
    # 12 samples at 10 Hz of one exact wx value span 1.1 s >= STUCK_IMU_S with
    # STUCK_MIN_SAMPLES (10) samples: stuck, though the stream is short
    n = 12
    assert n >= STUCK_MIN_SAMPLES and (n - 1) * 0.1 >= STUCK_IMU_S
    t = np.arange(n) * 0.1
    frame = pd.DataFrame({"t_s": t, "wx": np.full(n, 0.25), "wy": np.sin(t),
                          "wz": np.cos(t), "ax": t, "ay": -t, "az": 9.8 + t})
    stuck = stuck_stretches({"imu": frame})
    assert list(stuck) == ["imu.wx"]
    assert stuck["imu.wx"] == [[0.0, pytest.approx(1.1)]]
