"""``terrain audit``: JSON and Markdown outputs, MLflow logging, bad input."""

from __future__ import annotations

import json

import pytest

from audit_helpers import simulated_streams, write_signal_files
from terrain.audit import EFFECT_VOCABULARY
from terrain.cli import main as cli_main

REQUIRED = {"name", "terrain", "params", "heldout_gain", "supported"}


@pytest.fixture(scope="module")
def runs_dir(tmp_path_factory):
    """Two terrains of simulated runs (signal files only), a planted gyro bias on one."""
    root = tmp_path_factory.mktemp("cli_runs")
    for i, (imu, pro) in enumerate(simulated_streams({"gyro_bias": 0.03}, seeds=(61, 62),
                                                     duration_s=40.0)):
        write_signal_files(root, "ASPHALT", i, imu, pro)
    for i, (imu, pro) in enumerate(simulated_streams(None, seeds=(63, 64), terrain="ICE",
                                                     duration_s=40.0)):
        write_signal_files(root, "ICE", i, imu, pro)
    return root


def _args(runs_dir, out, *extra):
    return ["audit", str(runs_dir), "--json", str(out / "a.json"), "--md", str(out / "a.md"),
            "--bootstrap", "200", "--param-bootstrap", "20", *extra]


@pytest.mark.slow
def test_cli_writes_json_and_markdown(runs_dir, tmp_path, capsys):
    assert cli_main(_args(runs_dir, tmp_path, "--no-mlflow")) == 0
    report = json.loads((tmp_path / "a.json").read_text())
    assert report["terrains"] == ["ASPHALT", "ICE"]
    effects = report["effects"]
    assert {e["terrain"] for e in effects} == {"ASPHALT", "ICE", "all"}
    for e in effects:
        assert REQUIRED <= set(e)
        assert isinstance(e["supported"], bool)
        assert set(e["params"]) <= {EFFECT_VOCABULARY[e["name"]].param}
        if e["params"]:
            assert e["heldout_gain"] is not None
    assert len([e for e in effects if e["terrain"] == "ICE"]) == len(EFFECT_VOCABULARY)
    bias = next(e for e in effects if e["name"] == "gyro_bias" and e["terrain"] == "ASPHALT")
    assert bias["supported"] and bias["params"]["bias_rad_s"] == pytest.approx(0.03, abs=0.005)
    assert "gyro_bias" in report["supported"]["ASPHALT"]
    assert report["supported"]["ICE"] == ["none"]
    md = (tmp_path / "a.md").read_text()
    assert "## Effects" in md and "gyro_bias" in md and "terrain audit" in md
    # every figure written is linked from the page, and every link names a written figure
    linked = {line.split("](")[1].rstrip(")") for line in md.splitlines()
              if line.startswith("![")}
    written = {f"a_figures/{p.name}" for p in (tmp_path / "a_figures").glob("*.png")}
    assert linked and linked == written
    assert "ASPHALT: gyro_bias" in capsys.readouterr().out


@pytest.mark.slow
def test_cli_logs_to_mlflow(runs_dir, tmp_path, monkeypatch):
    mlflow = pytest.importorskip("mlflow")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    assert cli_main(_args(runs_dir, tmp_path, "--no-pooled")) == 0
    report = json.loads((tmp_path / "a.json").read_text())
    mlflow.set_tracking_uri(f"sqlite:///{tmp_path / 'mlflow.db'}")
    run = mlflow.get_run(report["mlflow_run_id"])
    assert run.data.params["selection.min_gain"] == "0.02"
    assert "gain__gyro_bias__ASPHALT" in run.data.metrics
    names = {a.path for a in mlflow.MlflowClient().list_artifacts(run.info.run_id)}
    assert {"audit.json", "audit.md", "figures", "residuals.csv"} <= names


def test_cli_bad_input_exits_2(tmp_path, capsys):
    assert cli_main(["audit", str(tmp_path / "missing"), "--json",
                     str(tmp_path / "a.json"), "--no-mlflow"]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert cli_main(["audit", str(tmp_path), "--dataset", "borealtc", "--json",
                     str(tmp_path / "a.json"), "--no-mlflow"]) == 2
    assert "exactly one" in capsys.readouterr().err
    (tmp_path / "LAVA").mkdir()
    write_signal_files(tmp_path, "LAVA", 0, *simulated_streams(seeds=(1,),
                                                               duration_s=10.0)[0])
    assert cli_main(["audit", str(tmp_path), "--json", str(tmp_path / "a.json"),
                     "--no-mlflow"]) == 2
    assert "no run could be audited" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("flag, value, message", [
    ("--min-gain", "nan", "argument --min-gain: must be a fraction of the baseline RMSE in "
                          "[0, 1), got nan"),
    ("--min-gain", "-5", "argument --min-gain: must be a fraction of the baseline RMSE in "
                         "[0, 1), got -5"),
])
def test_cli_refuses_settings_that_would_change_the_answer_silently(runs_dir, tmp_path,
                                                                    capsys, flag, value,
                                                                    message):
    # a NaN threshold supports no effect at all: the audit would answer "none"; refused as
    # the option (it was SelectionSettings' "min_gain must be in [0, 1)")
    with pytest.raises(SystemExit) as exit_info:
        cli_main(_args(runs_dir, tmp_path, "--no-mlflow", flag, value))
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith(message)
    assert not (tmp_path / "a.json").exists()


@pytest.mark.slow
def test_cli_names_a_replay_low_pass_clipped_below_the_asked_cut_off(runs_dir, tmp_path,
                                                                     capsys):
    # 1000 Hz asks for no smoothing of the 6.5 Hz wheel record; the filter is clipped to
    # 0.45 of the rate (2.925 Hz, printed 2.92; 2.93 at the simulator's former 6.50195 Hz),
    # which smooths it, and nothing said so
    assert cli_main(_args(runs_dir, tmp_path, "--no-mlflow", "--replay-input-lowpass-hz",
                          "1000")) == 0
    out = capsys.readouterr().out
    assert ("note: --replay-input-lowpass-hz 1000 is above 0.45 of the wheel rate of 4 "
            "run(s) (6.5 Hz): their low-pass is clipped to 0.45 of each run's rate "
            "(2.92 Hz)") in out
    assert cli_main(_args(runs_dir, tmp_path, "--no-mlflow", "--replay-input-lowpass-hz",
                          "2")) == 0
    assert "clipped" not in capsys.readouterr().out


def test_cli_refuses_a_seed_outside_numpys_range_as_a_usage_error(runs_dir, tmp_path,
                                                                  capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli_main(_args(runs_dir, tmp_path, "--no-mlflow", "--seed", "-1"))
    assert exit_info.value.code == 2
    assert "argument --seed: a seed is an integer in 0-4294967295" in capsys.readouterr().err
    assert not (tmp_path / "a.json").exists()


def test_cli_names_a_run_too_short_to_score(tmp_path, capsys):
    # every sample of a 3 s run lies within the unscored 2 s at either end
    write_signal_files(tmp_path, "ICE", 0, *simulated_streams(seeds=(5,), duration_s=3.0)[0])
    assert cli_main(["audit", str(tmp_path), "--json", str(tmp_path / "a.json"),
                     "--no-mlflow", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "no run could be audited" in err and "ICE/00: no sample to score: 2.9 s long" in err


def test_a_run_too_short_to_segment_is_named_not_called_missing(tmp_path):
    # a 4.3 s run keeps 1 scored sample (audited), but its segments leave fewer than 2
    # scorable units; every effect said "no run with IMU samples to score" (before), as if
    # the terrain had no run. (A 4.5 s run kept 2 until 2026-11-30; with the simulated wheel
    # stream at BorealTC's 6.5 Hz it keeps 4, enough for the current group to name another
    # reason first; no duration keeps exactly 2: 1 up to 4.30 s, 3 from 4.31 s.)
    from audit_helpers import audit_folder

    write_signal_files(tmp_path, "ICE", 0, *simulated_streams(seeds=(5,), duration_s=4.3)[0])
    result = audit_folder(tmp_path)
    assert len(result.frames) == 1 and result.frames[0].score_imu.any()
    frame = result.frames[0]
    for group, what, scored in (("timing", "IMU", frame.score_imu),
                                ("yaw", "IMU", frame.score_imu),
                                ("current", "current", frame.score_cur)):
        reason = result.groups[("ICE", group)].effects[0].reason
        assert "no run with" not in reason
        assert "too short to cut into 2 scorable segments" in reason
        t = frame.t_s[scored]                    # the span of the scored samples, not an end
        assert t.size == 1
        assert (f"{frame.run_id} ({t.size} {what} samples scored over "
                f"{t[-1] - t[0]:.1f} s)") in reason


def _strict_json(text: str):
    """``text`` parsed as strict JSON (``json.loads`` accepts NaN and Infinity by default;
    JavaScript's JSON.parse and most other readers do not)."""
    def refuse(name):
        raise ValueError(f"{name} is not JSON")
    return json.loads(text, parse_constant=refuse)


@pytest.mark.slow
def test_cli_physics_comparison_of_a_one_run_terrain_is_strict_json(tmp_path):
    # one run: its gain has no run-bootstrap interval (gain_lo/gain_hi NaN in the table);
    # the records skipped json_ready and went out as bare NaN (before: 96 NaN in this file,
    # gain_lo and gain_hi of all 48 records; json.loads read them, JSON.parse does not)
    write_signal_files(tmp_path, "ASPHALT", 0, *simulated_streams(seeds=(65,),
                                                                  duration_s=40.0)[0])
    out = tmp_path / "out"
    assert cli_main(["audit", str(tmp_path), "--json", str(out / "a.json"), "--bootstrap",
                     "50", "--param-bootstrap", "0", "--compare-physics", "--no-pooled",
                     "--no-mlflow", "--no-progress"]) == 0
    report = _strict_json((out / "a.json").read_text())
    records = report["physics_comparison"]["records"]
    assert records and all(r["n_runs"] == 1 for r in records)
    assert all(r["gain_lo"] is None and r["gain_hi"] is None for r in records)
    assert all(isinstance(r["gain"], float) for r in records)


@pytest.mark.slow
def test_cli_physics_comparison_shows_the_runs_it_skipped(tmp_path, monkeypatch, capsys):
    # a run whose v2 replay fails (v1, the audited physics, replays it) was dropped from the
    # comparison's table with no word: per_run_errors returned it and the pipeline threw it
    # away (before: no note printed, no trace in the JSON; the records just count one run)
    import terrain.audit.physics as physics
    from terrain.errors import DataFormatError

    for i, streams in enumerate(simulated_streams(seeds=(66, 67), duration_s=20.0)):
        write_signal_files(tmp_path / "runs", "ASPHALT", i, *streams)
    replay = physics.replay_run

    def failing(run, settings):
        if run.run_id == "runs/ASPHALT/01" and settings.physics == "v2":
            raise DataFormatError("planted v2 failure")
        return replay(run, settings)

    monkeypatch.setattr(physics, "replay_run", failing)
    out = tmp_path / "out"
    assert cli_main(["audit", str(tmp_path / "runs"), "--json", str(out / "a.json"), "--md",
                     str(out / "a.md"), "--bootstrap", "50", "--param-bootstrap", "0",
                     "--compare-physics", "--no-pooled", "--no-mlflow", "--no-progress"]) == 0
    report = _strict_json((out / "a.json").read_text())
    assert report["runs"]["audited"] == ["runs/ASPHALT/00", "runs/ASPHALT/01"]
    comparison = report["physics_comparison"]
    assert comparison["skipped"] == {"runs/ASPHALT/01": "planted v2 failure"}
    assert comparison["records"] and all(r["n_runs"] == 1 for r in comparison["records"])
    assert set(comparison["records"][0]) == {"terrain", "signal", "scope", "n_runs", "n",
                                             "rmse_ref", "rmse_new", "gain", "gain_lo",
                                             "gain_hi"}
    printed = capsys.readouterr().out
    assert "1 run(s) left out of the physics comparison" in printed
    assert "runs/ASPHALT/01 (planted v2 failure)" in printed
    assert "runs/ASPHALT/01 (planted v2 failure)" in (out / "a.md").read_text()


def test_report_json_refuses_non_finite_numbers():
    from pipelines.audit import report_json

    assert _strict_json(report_json({"gain": 0.5, "lo": None})) == {"gain": 0.5, "lo": None}
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError):
            report_json({"records": [{"gain_lo": bad}]})


@pytest.mark.slow
def test_cli_with_progress_reports_the_replay_time(tmp_path):
    # with the progress bar (the default) the runs were replayed before run_audit, which was
    # given the frames and timed nothing: every committed report said replay_s 0.0
    write_signal_files(tmp_path, "ASPHALT", 0, *simulated_streams(seeds=(66,),
                                                                  duration_s=20.0)[0])
    out = tmp_path / "out"
    assert cli_main(["audit", str(tmp_path), "--json", str(out / "a.json"), "--bootstrap",
                     "50", "--param-bootstrap", "0", "--no-pooled", "--no-mlflow"]) == 0
    timings = json.loads((out / "a.json").read_text())["timings_s"]
    assert timings["replay_s"] > 0.01               # a 20 s run's replay takes ~0.3 s


def test_cli_refuses_a_figures_folder_it_cannot_create_before_the_audit(runs_dir, tmp_path,
                                                                        capsys, monkeypatch):
    # --md a.md beside a file a_figures: the whole audit ran, a.json was written, and then
    # "error: File exists: .../a_figures" (naming no option) left a.json behind
    import pipelines.audit as audit

    (tmp_path / "a_figures").write_text("not a folder")
    monkeypatch.setattr(audit, "read_runs_dir", lambda *a, **k: pytest.fail("runs were read"))
    assert cli_main(_args(runs_dir, tmp_path, "--no-mlflow")) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    # the file is named by its path: "a_figures" alone is also in tmp_path (this test's name)
    assert err.startswith("terrain audit: error: --md: ")
    assert err.endswith(f"{str(tmp_path / 'a_figures')!r} is a file")
    assert not (tmp_path / "a.json").exists()
