"""End-to-end tests of the command-line contract (cv, train, predict, convert, --help)."""

from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig, make_windows
from terrain.cli import SUBCOMMANDS, build_parser, main
from terrain.io.shipped import read_shipped
from terrain.models.experiment import inference_pipeline
from terrain.models.svm import SVMConfig
from terrain.serving.pyfunc import save_model


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """Run commands in an empty folder with the embedded MLflow store."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


@pytest.fixture(scope="module")
def small_model(tmp_path_factory):
    """A wheel-only SVM fitted on six Vulpi runs, saved as a model directory (seconds)."""
    runs = read_shipped("vulpi")[:6]
    config = WindowConfig(window_s=2.0, rate_hz=50.0)
    ws = make_windows(runs, "wheels", config)
    pipe = inference_pipeline(ws, SVMConfig(probability=True)).fit(ws.X, ws.labels.astype(str))
    path = tmp_path_factory.mktemp("small") / "model"
    save_model(path, pipe, ws.channels, config, sorted({str(c) for c in ws.labels}),
               {"dataset": "vulpi"}, progress=False)
    return path


def write_runs_layout(runs, root):
    """Write runs back to the measured CSV layout (borealtc column names)."""
    for run in runs:
        _, terrain, index = run.run_id.split("/")
        folder = root / terrain
        folder.mkdir(parents=True, exist_ok=True)
        w = run.streams["wheels"].rename(columns={"t_s": "time", "vel_l": "velL",
                                                  "vel_r": "velR", "cur_l": "curL",
                                                  "cur_r": "curR"})
        w[["time", "velL", "velR", "curL", "curR"]].to_csv(folder / f"pro_{index}.csv",
                                                           index=False)
        if "imu" in run.streams:
            run.streams["imu"].rename(columns={"t_s": "time"}).to_csv(
                folder / f"imu_{index}.csv", index=False)


def test_every_subcommand_has_help(capsys):
    parser = build_parser()
    names = set(parser._subparsers._group_actions[0].choices)
    assert {"cv", "train", "predict", "convert"} <= names
    for name in names:
        with pytest.raises(SystemExit) as exc:
            main([name, "--help"])
        assert exc.value.code == 0
        assert "usage: terrain " + name in capsys.readouterr().out
    assert set(names) <= set(SUBCOMMANDS)


#: subcommand -> the name its help (and README) gives its positional folder argument
_POSITIONAL_NAMES = {"predict": "RUNS_DIR", "audit": "[RUNS_DIR]", "estimate": "RUN_DIR",
                     "stream": "RUN_DIR", "convert": "CSV_DIR"}


def test_positional_arguments_show_in_usage_as_their_help_names_them():
    # `terrain estimate --help` printed "usage: terrain estimate [-h] ... run_dir" above
    # "select one run when RUN_DIR holds several" (audit: "[runs_dir]" / "RUNS_DIR")
    parser = build_parser()
    for name, sp in parser._subparsers._group_actions[0].choices.items():
        usage = " ".join(sp.format_usage().split())
        for action in sp._actions:
            if action.option_strings or action.choices is not None:
                continue    # options, and a positional shown as its {choices}
            shown = action.metavar or action.dest
            assert shown.isupper() and re.search(rf"\b{shown}\b", usage), (name, usage)
            assert not re.search(rf"\b{action.dest}\b", usage), (name, usage)
        if name in _POSITIONAL_NAMES:
            assert f" {_POSITIONAL_NAMES[name]}" in usage, (name, usage)


@pytest.mark.slow
def test_cv_vulpi_reports_grouped_metrics_and_logs_mlflow(workdir, capsys):
    out = workdir / "cv.json"
    assert main(["cv", "--dataset", "vulpi", "--json", str(out), "--no-progress"]) == 0
    report = json.loads(out.read_text())
    assert report["headline"] is True
    assert report["classes"] == ["CONCRETE", "DIRT_ROAD", "PLOUGHED", "UNPLOUGHED"]
    assert report["n_runs"] == 15
    for k in ("accuracy", "balanced_accuracy", "macro_f1", "run_majority_accuracy"):
        assert 0.0 <= report["metrics"][k]["min"] <= report["metrics"][k]["max"] <= 1.0
    # far above the 4-class chance level, grouped by run
    assert report["pooled"]["accuracy"]["mean"] > 0.75
    assert any("DIRT_ROAD" in n for n in report["notes"])
    assert np.asarray(report["confusion"]["counts"]).sum() == 3 * report["n_windows"]
    printed = capsys.readouterr().out
    assert "MLflow run" in printed
    # each class's recall says over how many of the folds it is averaged (those testing it)
    n_folds = {k[7:]: v["n_folds"] for k, v in report["metrics"].items()
               if k.startswith("recall_")}
    assert set(n_folds) == set(report["classes"]) and max(n_folds.values()) == 15
    line = next(ln for ln in printed.splitlines() if "per-class recall, mean over" in ln)
    assert all(f"({n} of 15 folds)" in line for n in n_folds.values() if n < 15)
    assert (workdir / "mlflow.db").exists()
    import mlflow
    mlflow.set_tracking_uri(f"sqlite:///{workdir / 'mlflow.db'}")
    run = mlflow.get_run(report["mlflow_run_id"])
    assert run.data.params["dataset"] == "vulpi"
    assert {f"recall_{c}_n_folds" for c in n_folds} <= set(run.data.metrics)
    assert "code_version" in run.data.tags
    arts = {a.path for a in mlflow.MlflowClient().list_artifacts(run.info.run_id)}
    assert {"confusion_matrix.png", "confusion_matrix.csv", "predictions.csv"} <= arts


@pytest.mark.slow
def test_cv_names_each_skipped_run_once_and_keeps_the_note_in_json(workdir, capsys,
                                                                   monkeypatch):
    """Two FLOORING runs lack a stream: the printed input report says so once, not again as
    a note; the JSON report keeps the note."""
    import pipelines.cv
    runs = [r for r in read_shipped("borealtc")
            if r.run_id.split("/")[1] in ("ASPHALT", "FLOORING")]
    monkeypatch.setattr(pipelines.cv, "load_dataset", lambda name: runs)
    out = workdir / "cv.json"
    assert main(["cv", "--dataset", "borealtc", "--seeds", "0", "--json", str(out),
                 "--no-progress"]) == 0
    report = json.loads(out.read_text())
    skipped = [n for n in report["notes"] if "skipped for a missing stream" in n]
    assert len(skipped) == 1 and "borealtc/FLOORING/04" in skipped[0]
    printed = capsys.readouterr().out
    assert printed.count("borealtc/FLOORING/04") == 1
    assert "run(s) skipped" in printed


@pytest.mark.slow
def test_train_then_predict_on_measured_layout(workdir, capfd):
    model_dir = workdir / "model"
    assert main(["train", "--dataset", "vulpi", "--model-out", str(model_dir),
                 "--no-progress"]) == 0
    assert (model_dir / "MLmodel").exists()
    # --no-progress also hides MLflow's artifact bars (logging and saving validate the
    # input example by downloading the model)
    assert "Downloading artifacts" not in capfd.readouterr().err
    runs = [r for r in read_shipped("vulpi") if r.run_id in
            ("vulpi/CONCRETE/1", "vulpi/PLOUGHED/3")]
    runs_dir = workdir / "runs"
    write_runs_layout(runs, runs_dir)
    # folder names are ignored for prediction: rename them
    (runs_dir / "CONCRETE").rename(runs_dir / "UNKNOWN_A")
    (runs_dir / "PLOUGHED").rename(runs_dir / "UNKNOWN_B")
    out = workdir / "pred.csv"
    assert main(["predict", "--model", str(model_dir), str(runs_dir), "--out", str(out)]) == 0
    pred = pd.read_csv(out)
    assert list(pred.columns[:4]) == ["run", "t_start_s", "t_end_s", "predicted"]
    proba = pred[[c for c in pred.columns if c.startswith("proba_")]]
    assert list(proba.columns) == ["proba_CONCRETE", "proba_DIRT_ROAD", "proba_PLOUGHED",
                                   "proba_UNPLOUGHED"]
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(pred["t_end_s"] - pred["t_start_s"], 2.0, atol=1e-9)
    assert set(pred["run"]) == {"runs/UNKNOWN_A/1", "runs/UNKNOWN_B/3"}
    # runs seen in training: the model must recover their terrain by majority
    vote = pred.groupby("run")["predicted"].agg(lambda s: s.value_counts().index[0])
    assert vote["runs/UNKNOWN_A/1"] == "CONCRETE"
    assert vote["runs/UNKNOWN_B/3"] == "PLOUGHED"
    # the model names the vehicle of its training runs; a run of another one is said
    from terrain.serving.model import read_model_metadata
    assert read_model_metadata(model_dir)["vehicle"] == "husky"
    # and its channels' sample steps in the training runs (Vulpi: IMU 50 Hz, wheels 15 Hz),
    # against which a live stream's first steps are judged
    steps = read_model_metadata(model_dir)["channel_steps_s"]
    assert steps["wz"] == pytest.approx(0.02, rel=0.05)
    assert steps["vel_l"] == pytest.approx(1 / 15, rel=0.05)
    assert "another vehicle" not in capfd.readouterr().out
    (runs_dir / "UNKNOWN_A" / "meta_1.json").write_text('{"vehicle": "agrimaro"}')
    assert main(["predict", "--model", str(model_dir), str(runs_dir), "--out", str(out)]) == 0
    notes = [line for line in capfd.readouterr().out.splitlines() if "another vehicle" in line]
    assert len(notes) == 1 and "runs/UNKNOWN_A/1" in notes[0] and "'agrimaro'" in notes[0]


@pytest.mark.slow
def test_train_names_classes_without_slip_targets_and_stream_says_why(workdir, capsys,
                                                                      monkeypatch):
    # runs converted from folders of the user's own names: train takes any label; stream
    # needs a desired slip per class (the catalogue's curves) and said only "unknown terrain"
    from dataclasses import replace

    import pipelines.train

    runs = [r if r.terrain != "CONCRETE" else replace(r, terrain="MY_YARD")
            for r in read_shipped("vulpi")]
    monkeypatch.setattr(pipelines.train, "load_dataset", lambda name: runs)
    assert main(["train", "--dataset", "vulpi", "--model", "svm", "--model-out", "m",
                 "--no-progress", "--no-register"]) == 0
    out = capsys.readouterr().out
    assert "note: class(es) ['MY_YARD'] not in the terrain catalogue" in out
    write_runs_layout([runs[0]], workdir / "runs")
    (folder,) = (workdir / "runs").iterdir()
    assert main(["stream", "--model", "m", str(folder), "--out", "d.csv"]) == 2
    err = capsys.readouterr().err
    assert "no desired slip for class(es) ['MY_YARD']" in err and "Traceback" not in err


def test_convert_regenerates_identical_data(workdir):
    runs = read_shipped("vulpi")[:4]
    src = workdir / "src"
    write_runs_layout(runs, src)
    assert main(["convert", str(src), "--dataset", "vulpi", "--data-dir",
                 str(workdir / "data")]) == 0
    again = read_shipped("vulpi", workdir / "data")
    assert [r.run_id for r in again] == [r.run_id for r in runs]
    for a, b in zip(again, runs):
        for name in b.streams:
            pd.testing.assert_frame_equal(a.streams[name], b.streams[name])


@pytest.mark.slow
def test_convert_names_what_the_shipped_format_leaves_out_and_refuses_another_robot(
        workdir, capsys):
    # simulated runs carry a truth stream (the AgriMaRo's also cam, steer, omega, cur): the
    # shipped format keeps the IMU and wheels only, and both datasets are the Husky's; the
    # conversion said "nothing repaired, dropped or skipped" and dropped them
    from terrain.io.writer import write_run
    from terrain.sim import SimConfig, simulate

    husky, agri = workdir / "husky", workdir / "agri"
    for seed in (1, 2):
        write_run(simulate(SimConfig(vehicle="husky", terrains=("SNOW",),
                                     scenario="straight_accel", duration_s=3.0, seed=seed)),
                  husky)
    assert main(["convert", str(husky), "--dataset", "borealtc", "--data-dir",
                 str(workdir / "data")]) == 0
    assert ("stream file(s) left out, the shipped format keeps the IMU and wheel streams "
            "only: truth (2 run(s))") in capsys.readouterr().err
    write_run(simulate(SimConfig(vehicle="agrimaro", terrains=("SNOW",),
                                 scenario="straight_accel", duration_s=3.0, seed=1)), agri)
    assert main(["convert", str(agri), "--dataset", "vulpi", "--data-dir",
                 str(workdir / "data2")]) == 2
    err = capsys.readouterr().err
    assert "recorded by vehicle 'agrimaro'" in err and "dataset 'vulpi' is the husky's" in err


def test_bad_dataset_is_rejected(capsys):
    with pytest.raises(SystemExit):
        main(["cv", "--dataset", "mars"])
    assert "invalid choice" in capsys.readouterr().err


def test_predict_on_folder_without_runs_is_a_clear_error(workdir, capsys, small_model):
    (workdir / "empty").mkdir()
    code = main(["predict", "--model", str(small_model), str(workdir / "empty"),
                 "--out", "x.csv"])
    assert code == 2
    err = capsys.readouterr().err
    assert "no run files" in err and "empty" in err


def test_predict_checks_the_model_before_reading_the_runs(workdir, capfd):
    write_runs_layout(read_shipped("vulpi")[:2], workdir / "runs")
    code = main(["predict", "--model", str(workdir / "nope"), str(workdir / "runs"),
                 "--out", "x.csv"])   # progress bars on: reading the runs would show one
    assert code == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "reading runs" not in err
    assert "cannot load model" in err and "nope does not exist" in err


@pytest.mark.slow
def test_predict_reports_one_hole_in_every_stream_once(workdir, capsys, small_model):
    """A 1000 s hole in both files of a run: one gap of its length, at most the two windows
    at its edges dropped, the window positions inside it said to hold no data."""
    run = read_shipped("vulpi")[0]
    write_runs_layout([run], workdir / "runs")
    middle = run.duration_s / 2
    for path in (workdir / "runs").rglob("*.csv"):
        frame = pd.read_csv(path)
        frame.loc[frame["time"] > middle, "time"] += 1000.0
        frame.to_csv(path, index=False)
    assert main(["predict", "--model", str(small_model), str(workdir / "runs"),
                 "--out", "p.csv", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"  1 timestamp gap\(s\) \(100\d\.\d s\) in runs/", out)
    dropped = int(re.search(r"dropped windows: (\d+) spanning a gap", out).group(1))
    assert 1 <= dropped <= 2
    inside = int(re.search(r"(\d+) window position\(s\) wholly inside a gap", out).group(1))
    assert 495 <= inside <= 500   # 2 s windows back to back over ~1000 s
    pred = pd.read_csv(workdir / "p.csv")
    assert len(pred) + dropped + inside == pytest.approx((run.duration_s + 1000) / 2, abs=2)


def test_train_refuses_ekf_channels_the_served_model_cannot_compute(workdir, capsys):
    code = main(["train", "--dataset", "vulpi", "--signals", "all+ekf", "--no-progress"])
    assert code == 2
    assert "EKF-derived channels" in capsys.readouterr().err


def _assert_predicts_ploughed(model_dir, workdir):
    """``terrain predict`` with the model on the measured layout of vulpi/PLOUGHED/3 names
    PLOUGHED most often."""
    runs = [r for r in read_shipped("vulpi") if r.run_id == "vulpi/PLOUGHED/3"]
    write_runs_layout(runs, workdir / "runs")
    out = workdir / "pred.csv"
    assert main(["predict", "--model", str(model_dir), str(workdir / "runs"),
                 "--out", str(out)]) == 0
    pred = pd.read_csv(out)
    assert len(pred) > 5 and pred["predicted"].value_counts().index[0] == "PLOUGHED"


@pytest.mark.slow
def test_train_with_window_ekf_serves_raw_signals(workdir, capsys):
    model_dir = workdir / "model"
    assert main(["train", "--dataset", "vulpi", "--model", "svm", "--window-ekf",
                 "--model-out", str(model_dir), "--no-progress"]) == 0
    from terrain.models.window_ekf import WindowEKFClassifier
    from terrain.serving.model import load_stream_model

    model = load_stream_model(model_dir)
    # the served model takes the raw channels; the EKF channels are computed inside
    assert isinstance(model.pipeline, WindowEKFClassifier)
    assert not any(c.startswith("ekf_") for c in model.channels)
    assert model.pipeline.estimator_.steps[0][1].channels[-1] == "ekf_slip_r"
    _assert_predicts_ploughed(model_dir, workdir)


def test_window_ekf_needs_the_filter_inputs(workdir, capsys):
    assert main(["train", "--dataset", "vulpi", "--signals", "wheels", "--window-ekf",
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--window-ekf" in err and "wz" in err and "Traceback" not in err


@pytest.mark.slow
def test_train_run_balanced_serves_the_wrapped_model(workdir, capsys):
    model_dir = workdir / "model"
    assert main(["train", "--dataset", "vulpi", "--model", "svm", "--run-balanced",
                 "--model-out", str(model_dir), "--no-progress"]) == 0
    from terrain.models.weighting import RunBalancedClassifier
    from terrain.serving.model import load_stream_model

    model = load_stream_model(model_dir)
    assert isinstance(model.pipeline, RunBalancedClassifier)
    import mlflow
    mlflow.set_tracking_uri(f"sqlite:///{workdir / 'mlflow.db'}")
    (train_run,) = mlflow.search_runs(experiment_names=["terrain-train"],
                                      output_format="list")
    assert train_run.data.params["run_balanced"] == "True"
    assert train_run.info.run_name.endswith("+run-balanced")
    _assert_predicts_ploughed(model_dir, workdir)


def test_simulate_help_gives_each_effects_unit_and_range(capsys):
    # the help listed the effect names only; their units (rad/s, s, A, A/rad) and ranges
    # came out only when a value was refused
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for piece in ("icr_expansion [1, 20] (dimensionless)", "gyro_bias [-0.5, 0.5] rad/s",
                  "wheel_lag [0, 2] s", "turning_resistance [0, 50] A",
                  "current_offset [-20, 20] A", "grade_resistance [0, 200] A/rad"):
        assert piece in text, piece


def test_every_flag_says_what_it_does_in_help():
    # `terrain slip-fit --help` listed --no-register with a blank help line: a flag shows
    # no default, so nothing at all said what it does
    from terrain.cli import _NO_HELP, build_parser

    parser = build_parser()
    silent = [f"{name} {action.option_strings[0]}"
              for name, command in parser._subparsers._group_actions[0].choices.items()
              for action in command._actions
              if action.nargs == 0 and action.option_strings
              and not (action.help or "").replace(_NO_HELP, "").strip()]
    assert silent == []
