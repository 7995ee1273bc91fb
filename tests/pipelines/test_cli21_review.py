"""Review cli21: what the commands print about the input agrees with what they did, and
options shared by several commands take and refuse the same values."""

from __future__ import annotations

import json

import pytest

from terrain.cli import main


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """Run commands in an empty folder with the embedded MLflow store."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


def _simulate(vehicle: str, terrain: str, seed: int) -> None:
    assert main(["simulate", "--vehicle", vehicle, "--terrain", terrain, "--duration-s", "5",
                 "--scenario", "straight_accel", "--seed", str(seed), "--out", "runs"]) == 0


@pytest.mark.slow
def test_audit_input_report_counts_the_runs_the_audit_skipped(workdir, capsys):
    # an AgriMaRo run among Husky runs is skipped by the audit (it replays skid-steers
    # only): the input report said "input: 2 run(s), 2 used" (MLflow input_runs_used 2) above
    # "audited 1 runs ..., skipped 1", and its jittery wheel record (never replayed) was
    # counted in the note that the replay drives the motors with it
    _simulate("husky", "ICE", 0)
    _simulate("agrimaro", "GRASS", 3)
    capsys.readouterr()
    assert main(["audit", "runs", "--json", "a.json", "--no-mlflow", "--no-progress",
                 "--bootstrap", "10", "--param-bootstrap", "0"]) == 0
    out = capsys.readouterr().out
    report = json.loads((workdir / "a.json").read_text())
    assert list(report["runs"]["skipped"]) == ["runs/GRASS/00"]
    assert "input: 2 run(s), 1 used" in out
    assert "1 run(s) skipped (the audit replays skid-steer vehicles only" in out
    assert "runs/GRASS/00" in out.split("input:")[1].split("audited")[0]
    assert report["jittery_wheel_records"]["runs"] == {}
    assert "jittery wheel-speed record" not in out


@pytest.mark.parametrize("argv", [
    ["control-sim", "--vehicle", "{v}", "--terrain", "ICE", "--scenario", "straight_accel",
     "--controller", "off", "--json", "c.json"],
    ["control-grid", "--vehicles", "{v}", "--terrains", "ICE", "--out", "g"],
])
def test_the_vehicle_is_read_in_any_case_as_simulate_reads_it(argv, monkeypatch, workdir):
    # `terrain simulate --vehicle HUSKY` (and every terrain option) reads names in any
    # case; control-sim refused "Husky" (invalid choice) and control-grid refused it ("the
    # traction control loop supports vehicles agrimaro, husky, got 'Husky'")
    import pipelines.control_grid
    import pipelines.control_sim

    seen = []

    def stop(args):
        seen.append(args)
        return 0

    monkeypatch.setattr(pipelines.control_sim, "main", stop)
    monkeypatch.setattr(pipelines.control_grid, "main", stop)
    for name in ("husky", "Husky", "HUSKY"):
        assert main([a.format(v=name) for a in argv]) == 0
    assert {str(getattr(a, "vehicle", None) or a.vehicles) for a in seen} in (
        {"husky"}, {"['husky']"})


def test_control_grid_checks_a_vehicle_in_any_case():
    # check_grid takes the lower-cased vehicle (a repeat in another case is a repeat)
    from terrain.cli import build_parser

    parser = build_parser()
    args = parser.parse_args(["control-grid", "--vehicles", "HUSKY", "--terrains", "ICE",
                              "--out", "g", "--husky-estimator", "observer"])
    assert args.vehicles == ["husky"]
    import pipelines.control_grid
    pipelines.control_grid.check_grid(args)      # the Husky's estimator: a Husky is there
    args = parser.parse_args(["control-grid", "--vehicles", "husky", "Husky", "--out", "g"])
    with pytest.raises(Exception, match=r"vehicles: \['husky'\] given more than once"):
        pipelines.control_grid.check_grid(args)


@pytest.mark.slow
def test_stream_eval_hides_its_progress_bars_with_no_progress(workdir, monkeypatch, capsys):
    # cv, train, predict, audit and compare take --no-progress; stream-eval drew its
    # held-out streams' progress bar over the folds whatever one asked (a usage error)
    import pandas as pd

    import pipelines.stream_eval
    from cli_helpers import RecordingRun

    given = []

    def fake(runs, recipe, seed, smoothings, progress=False, **kwargs):
        given.append(progress)
        return pd.DataFrame(columns=["fold", "smoothing"])

    monkeypatch.setattr(pipelines.stream_eval, "held_out_streams", fake)
    monkeypatch.setattr(pipelines.stream_eval, "tracked_run", RecordingRun())
    monkeypatch.setattr(pipelines.stream_eval, "encode_stream_scores", lambda frame: frame)
    for flag, shown in (([], True), (["--no-progress"], False)):
        given.clear()
        assert main(["stream-eval", "--part", "streams", "--kinds", "wheels", "--seeds", "0",
                     *flag]) == 0
        assert given == [shown]


@pytest.mark.parametrize("argv", [
    ["cv", "--hop-s", "1e308"],
    ["cv", "--train-hop-s", "1e308"],
    ["train", "--dataset", "vulpi", "--model", "svm", "--train-hop-s", "1e308"],
    ["compare", "--models", "svm", "--train-hop-s", "1e308"],
    ["stream-eval", "--part", "wheel-cv", "--hop-s", "1e308"],
])
def test_a_finite_hop_too_long_to_count_in_samples_is_an_input_error(argv, workdir, capsys):
    # a finite hop > 0 (what the option's type takes) whose sample count overflows (1e308 s
    # at 100 Hz) ended in "internal error: OverflowError: cannot convert float infinity to
    # integer" (exit 1), where 1e300 was taken; --window-s 1e308 is an input error
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err and "hop" in err and len(err.splitlines()) == 1, err


@pytest.mark.slow
def test_audit_refuses_a_low_pass_too_low_to_compute_as_an_input_error(workdir, capsys):
    # --replay-input-lowpass-hz 1e-12 (a finite number > 0, what its type takes) ended in
    # "internal error: LinAlgError: Singular matrix" (exit 1) from scipy's filter start
    _simulate("husky", "ICE", 0)
    capsys.readouterr()
    assert main(["audit", "runs", "--json", "a.json", "--no-mlflow", "--no-progress",
                 "--bootstrap", "10", "--param-bootstrap", "0",
                 "--replay-input-lowpass-hz", "1e-12"]) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err and "cut-off" in err and len(err.splitlines()) == 1


@pytest.mark.parametrize("argv", [
    ["stream", "runs/ICE", "--out", "o.csv"],
    ["serve"],
    ["control-sim", "--vehicle", "husky", "--terrain", "ICE", "--scenario", "straight_accel",
     "--controller", "off", "--json", "c.json"],
    ["control-grid", "--terrain-source", "model", "--out", "g"],
])
def test_every_command_reading_a_model_directory_refuses_a_model_uri_alike(argv, workdir,
                                                                           capsys):
    # control-sim and control-grid load --model as a directory only (load_stream_model), as
    # stream and serve do, yet took a URI as a path: "model directory
    # models:/terrain-borealtc/latest does not exist", after the option checks
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--model", "models:/terrain-borealtc/latest"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "argument --model: 'models:/terrain-borealtc/latest' is a URI" in err
    assert "terrain predict reads models:/" in err


def test_a_terrain_list_of_one_terrain_is_that_terrain_s_run(workdir, capsys):
    # --terrain ICE,ice said "one terrain (ICE) along the whole path" but wrote the run to
    # MIXED/ with the label MIXED (a class no model or catalogue knows), where --terrain ICE
    # writes ICE/: the same run, read back under another label
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--duration-s", "1",
                 "--out", "one"]) == 0
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE,ice", "--duration-s",
                 "1", "--out", "two"]) == 0
    assert sorted(p.name for p in (workdir / "two").iterdir()) == ["ICE"]
    for name in ("imu_00.csv", "pro_00.csv", "truth_00.csv"):
        assert (workdir / "one/ICE" / name).read_bytes() == (workdir / "two/ICE" / name
                                                             ).read_bytes()
    meta = json.loads((workdir / "two/ICE/meta_00.json").read_text())
    assert meta["terrain"] == "ICE"
