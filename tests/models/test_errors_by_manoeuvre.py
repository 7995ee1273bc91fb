"""Windows split into straight and turning by benchmarks/errors_by_manoeuvre.py."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pandas as pd

from terrain.run import Run

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "errors_by_manoeuvre.py"


def test_mean_abs_yaw_rate_of_each_window():
    mean_abs_yaw_rate = runpy.run_path(str(SCRIPT))["mean_abs_yaw_rate"]
    t = np.arange(0.0, 20.0, 0.01)
    wz = np.where(t < 10.0, -0.3, 0.0)                    # a left spin, then straight
    imu = pd.DataFrame({"t_s": t, "wz": wz})
    runs = [Run("x/A/0", "x", "A", {"imu": imu}),
            Run("x/A/1", "x", "A", {"wheels": imu.rename(columns={"wz": "vel_l"})})]
    pred = pd.DataFrame({"run": ["x/A/0", "x/A/0", "x/A/0", "x/A/1"],
                         "t_start_s": [2.0, 9.0, 14.0, 2.0], "t_end_s": [4.0, 11.0, 16.0, 4.0]})
    out = mean_abs_yaw_rate(pred, runs)
    np.testing.assert_allclose(out[:3], [0.3, 0.15, 0.0], atol=1e-12)
    assert np.isnan(out[3])                                # no IMU: unknown, not straight


def _main(tmp_path, monkeypatch, capsys, *options):
    import sys
    from types import SimpleNamespace

    script = runpy.run_path(str(SCRIPT))
    t = np.arange(0.0, 20.0, 0.01)
    imu = pd.DataFrame({"t_s": t, "wz": np.where(t < 10.0, -0.3, 0.0)})
    csv = tmp_path / "predictions.csv"
    pd.DataFrame({"run": ["x/A/0"] * 3, "t_start_s": [2.0, 9.0, 14.0],
                  "t_end_s": [4.0, 11.0, 16.0], "true": ["A"] * 3,
                  "predicted": ["A", "B", "B"]}).to_csv(csv, index=False)
    env = script["main"].__globals__
    monkeypatch.setitem(env, "activate_store", lambda: None)
    monkeypatch.setitem(env, "mlflow", SimpleNamespace(artifacts=SimpleNamespace(
        download_artifacts=lambda **k: str(csv))))
    runs = [Run("x/A/0", "x", "A", {"imu": imu})]
    monkeypatch.setitem(env, "load_dataset", lambda name: runs)
    monkeypatch.setattr(sys, "argv", ["errors_by_manoeuvre.py", "RUN", *options])
    assert script["main"]() == 0
    return capsys.readouterr().out


def test_windows_above_the_threshold_are_turning(tmp_path, monkeypatch, capsys):
    # mean |wz| 0.3 (right), 0.15 (wrong), 0.0 (wrong)
    out = _main(tmp_path, monkeypatch, capsys, "--turning-rad-s", "0.1")
    assert "accuracy straight 0.000, turning 0.500" in out
    out = _main(tmp_path, monkeypatch, capsys, "--turning-rad-s", "0.2")
    assert "accuracy straight 0.000, turning 1.000" in out


def test_no_turning_window_is_no_keyerror(tmp_path, monkeypatch, capsys):
    # `--turning-rad-s 1` on these windows ended in "KeyError: 'turning'"
    out = _main(tmp_path, monkeypatch, capsys, "--turning-rad-s", "1")
    assert "accuracy straight 0.333, turning nan" in out


def _refused(monkeypatch, capsys, download, runs) -> str:
    import sys
    from types import SimpleNamespace

    import pytest

    script = runpy.run_path(str(SCRIPT))
    env = script["main"].__globals__
    monkeypatch.setitem(env, "activate_store", lambda: None)
    monkeypatch.setitem(env, "mlflow", SimpleNamespace(artifacts=SimpleNamespace(
        download_artifacts=download)))
    monkeypatch.setitem(env, "load_dataset", lambda name: runs)
    monkeypatch.setattr(sys, "argv", ["errors_by_manoeuvre.py", "RUN", "--dataset", "vulpi"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    return capsys.readouterr().err


def test_a_run_id_without_predictions_is_a_usage_error(monkeypatch, capsys):
    # an unknown run id was MLflow's "Run with id=... not found" traceback
    from mlflow.exceptions import MlflowException

    def missing(**kwargs):
        raise MlflowException("Run with id=RUN not found")

    err = _refused(monkeypatch, capsys, missing, [])
    assert "RUN" in err and "predictions.csv" in err and "not found" in err


def test_predictions_of_another_dataset_are_a_usage_error(tmp_path, monkeypatch, capsys):
    # a BorealTC cv run read with --dataset vulpi: every window was counted "without IMU"
    # and the accuracies printed as nan
    csv = tmp_path / "predictions.csv"
    pd.DataFrame({"run": ["x/A/0", "x/B/0"], "t_start_s": [2.0, 2.0], "t_end_s": [4.0, 4.0],
                  "true": ["A", "B"], "predicted": ["A", "B"]}).to_csv(csv, index=False)
    imu = pd.DataFrame({"t_s": np.arange(0.0, 5.0, 0.01), "wz": 0.0})
    err = _refused(monkeypatch, capsys, lambda **k: str(csv),
                   [Run("x/A/0", "x", "A", {"imu": imu})])
    assert "--dataset: vulpi does not hold 1 of the runs" in err and "(x/B/0)" in err
