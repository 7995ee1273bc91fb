"""``terrain estimate RUN_DIR --out states.csv`` on runs written by the simulator."""

from __future__ import annotations

import re
import shutil

import numpy as np
import pandas as pd
import pytest

from terrain.cli import main
from pipelines.validation.harness import FINE_ENCODER
from terrain.io.writer import write_run
from terrain.sim import Effects, SimConfig, simulate


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    write_run(simulate(SimConfig(vehicle="agrimaro", terrains=("GRASS",),
                                 scenario="straight_accel", duration_s=8.0, seed=1,
                                 sensors=FINE_ENCODER)), root)
    write_run(simulate(SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="random",
                                 duration_s=10.0, seed=2,
                                 effects=Effects(icr_expansion=1.4))), root)
    return root


@pytest.mark.slow
def test_one_file_per_run_with_states_slip_innovations_and_nis(run_dir, tmp_path, capsys):
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "states.csv")]) == 0
    agri = pd.read_csv(tmp_path / "states_GRASS_00.csv")
    husky = pd.read_csv(tmp_path / "states_ASPHALT_00.csv")
    for frame in (agri, husky):
        assert frame.columns[0] == "t_s" and np.all(np.diff(frame["t_s"]) > 0)
        assert {"nis", "nis_dof"} <= set(frame.columns)
        assert any(c.startswith("innov_") for c in frame.columns)
    assert {"v_bx", "v_by", "yaw_rate", "gyro_bias", "delta_3", "slip_1", "slip_2",
            "slip_3", "innov_v_cx"} <= set(agri.columns)
    assert {"v_bx", "yaw_rate", "gyro_bias", "log_icr_chi", "icr_chi", "slip_1", "slip_2",
            "innov_vel_l", "innov_wz"} <= set(husky.columns)
    assert "slip_3" not in husky.columns
    truth = pd.read_csv(run_dir / "GRASS" / "truth_00.csv")
    late = agri["t_s"] > 5
    assert agri.loc[late, "slip_1"].mean() == pytest.approx(
        truth.loc[truth["time"] > 5, "slip_1"].mean(), abs=0.01)
    out = capsys.readouterr().out
    assert "(agrimaro)" in out and "(husky)" in out


@pytest.mark.slow
def test_select_one_run_or_a_terrain_folder(run_dir, tmp_path):
    out = tmp_path / "one.csv"
    assert main(["estimate", str(run_dir), "--run", "ASPHALT/00", "--out", str(out)]) == 0
    assert "log_icr_chi" in pd.read_csv(out).columns
    out2 = tmp_path / "two.csv"
    assert main(["estimate", str(run_dir / "GRASS"), "--out", str(out2), "--lag", "none",
                 "--tuning", "thesis", "--gate", "0.999"]) == 0
    assert "slip_3" in pd.read_csv(out2).columns


def test_unknown_run_is_a_clear_error(run_dir, tmp_path, capsys):
    assert main(["estimate", str(run_dir), "--run", "SNOW/07", "--out",
                 str(tmp_path / "x.csv")]) == 2
    assert "no run 'SNOW/07'" in capsys.readouterr().err


@pytest.mark.slow
def test_the_lag_note_counts_the_runs_as_their_summaries_say(run_dir, tmp_path, capsys):
    # the closing note counts each run by what its own summary line says about the lag; a
    # summary says "encoder lag 0.032 s" when applied (the test looked for "encoder lag
    # applied", found none, and with both fixture runs applied it only checked that no note
    # was printed): an 8 s SNOW orchard run's peak is not a clear one, so the note is printed
    root = tmp_path / "runs"
    shutil.copytree(run_dir, root)
    write_run(simulate(SimConfig(vehicle="agrimaro", terrains=("SNOW",), scenario="orchard",
                                 duration_s=8.0, seed=0)), root)
    assert main(["estimate", str(root), "--out", str(tmp_path / "s.csv"),
                 "--slip-model", "ekf"]) == 0
    lines = capsys.readouterr().out.splitlines()
    summaries = [line for line in lines if " -> " in line and "steps at" in line]
    assert len(summaries) == 3
    applied = sum(re.search(r"encoder lag [-+]?\d", line) is not None for line in summaries)
    not_applied = sum("encoder lag not applied" in line for line in summaries)
    assert (applied, not_applied) == (2, 1)
    note = [line for line in lines if line.startswith("note: encoder lag applied on")]
    assert note == ["note: encoder lag applied on 2 of 3 runs, not applied on 1 (no clear "
                    "cross-correlation peak), not estimated on 0"]
    # the fixture's two runs alone: both applied, no note
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "t.csv"),
                 "--slip-model", "ekf"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert sum(re.search(r"encoder lag [-+]?\d", line) is not None for line in lines) == 2
    assert not [line for line in lines if line.startswith("note: encoder lag applied on")]


def test_tuning_option_reaches_the_agrimaro_filter(run_dir, tmp_path):
    # --tuning thesis and the default (noise-derived) tuning filter the same run differently;
    # --tuning noise is the default itself
    frames = {}
    for name, extra in {"default": [], "noise": ["--tuning", "noise"],
                        "thesis": ["--tuning", "thesis"]}.items():
        out = tmp_path / f"{name}.csv"
        assert main(["estimate", str(run_dir / "GRASS"), "--out", str(out), "--lag", "none",
                     *extra]) == 0
        frames[name] = pd.read_csv(out)
    pd.testing.assert_frame_equal(frames["default"], frames["noise"])
    std = [c for c in frames["default"].columns if c.startswith("std_")]
    assert not np.allclose(frames["default"][std].to_numpy(), frames["thesis"][std].to_numpy(),
                           equal_nan=True)


@pytest.mark.slow
def test_a_run_the_estimator_refuses_leaves_the_others_their_tables(
        run_dir, tmp_path, capsys, monkeypatch):
    # the readers refuse a bad folder before any run is estimated; a refusal of the estimator
    # itself (here a grid over its step bound, as a 2 h log at --rate-hz 1000 asks) stopped
    # the command at that run, leaving the runs after it unestimated and unnamed
    import pipelines.estimate as command
    from terrain.errors import TimeStepError
    real = command.estimate_skid_steer_slip_run

    def refuse_asphalt(run, *args, **kwargs):
        if run.run_id.endswith("ASPHALT/00"):
            raise TimeStepError("a grid at 1000 Hz over 7200 s has 7200001 steps")
        return real(run, *args, **kwargs)

    monkeypatch.setattr(command, "estimate_skid_steer_slip_run", refuse_asphalt)
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv")]) == 0
    assert (tmp_path / "s_GRASS_00.csv").is_file()
    assert not (tmp_path / "s_ASPHALT_00.csv").exists()
    out = capsys.readouterr().out
    assert re.search(r"error: run \S*ASPHALT/00 not estimated: a grid at 1000 Hz", out)
    assert re.search(r"note: 1 of 2 runs not estimated, no table written for them: "
                     r"\S*ASPHALT/00 \(a grid at 1000 Hz", out)
    # one run selected, or every run refused: the command fails naming them
    assert main(["estimate", str(run_dir), "--run", "ASPHALT/00", "--out",
                 str(tmp_path / "one.csv")]) == 2
    assert "7200001 steps" in capsys.readouterr().err
    assert main(["estimate", str(run_dir / "ASPHALT"), "--out", str(tmp_path / "a.csv")]) == 2
    assert "7200001 steps" in capsys.readouterr().err

    # several runs, every one refused: an error naming each
    def refuse(run, *args, **kwargs):
        raise TimeStepError(f"{run.run_id.split('/')[-2]} too long")

    monkeypatch.setattr(command, "estimate_run", refuse)
    monkeypatch.setattr(command, "estimate_skid_steer_slip_run", refuse)
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "b.csv")]) == 2
    err = capsys.readouterr().err
    assert "no run of" in err and "ASPHALT too long" in err and "GRASS too long" in err
