"""End-to-end tests of the command-line contract (cv, train, predict, convert, --help)."""

from __future__ import annotations

import json
import numpy as np
import pandas as pd
import pytest

from terrain.cli import SUBCOMMANDS, build_parser, main
from terrain.io.shipped import read_shipped


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """Run commands in an empty folder with the embedded MLflow store."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


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
    assert (workdir / "mlflow.db").exists()
    import mlflow
    mlflow.set_tracking_uri(f"sqlite:///{workdir / 'mlflow.db'}")
    run = mlflow.get_run(report["mlflow_run_id"])
    assert run.data.params["dataset"] == "vulpi"
    assert "code_version" in run.data.tags
    arts = {a.path for a in mlflow.MlflowClient().list_artifacts(run.info.run_id)}
    assert {"confusion_matrix.png", "confusion_matrix.csv", "predictions.csv"} <= arts


def test_train_then_predict_on_measured_layout(workdir, capsys):
    model_dir = workdir / "model"
    assert main(["train", "--dataset", "vulpi", "--model-out", str(model_dir),
                 "--no-progress"]) == 0
    assert (model_dir / "MLmodel").exists()
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


def test_bad_dataset_is_rejected(capsys):
    with pytest.raises(SystemExit):
        main(["cv", "--dataset", "mars"])
    assert "invalid choice" in capsys.readouterr().err


def test_predict_on_folder_without_runs_is_a_clear_error(workdir, capsys):
    (workdir / "empty").mkdir()
    code = main(["predict", "--model", str(workdir / "nope"), str(workdir / "empty"),
                 "--out", "x.csv"])
    assert code == 2
    err = capsys.readouterr().err
    assert "no run files" in err and "empty" in err


def test_train_refuses_ekf_channels_the_served_model_cannot_compute(workdir, capsys):
    code = main(["train", "--dataset", "vulpi", "--signals", "all+ekf", "--no-progress"])
    assert code == 2
    assert "EKF-derived channels" in capsys.readouterr().err


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
    runs = [r for r in read_shipped("vulpi") if r.run_id == "vulpi/PLOUGHED/3"]
    write_runs_layout(runs, workdir / "runs")
    out = workdir / "pred.csv"
    assert main(["predict", "--model", str(model_dir), str(workdir / "runs"),
                 "--out", str(out)]) == 0
    pred = pd.read_csv(out)
    assert len(pred) > 5 and pred["predicted"].value_counts().index[0] == "PLOUGHED"


def test_window_ekf_needs_the_filter_inputs(workdir, capsys):
    assert main(["train", "--dataset", "vulpi", "--signals", "wheels", "--window-ekf",
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--window-ekf" in err and "wz" in err and "Traceback" not in err
