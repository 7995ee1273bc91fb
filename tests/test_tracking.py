"""MLflow conventions: embedded store in the working directory, remote one env var away."""

from __future__ import annotations

import os

import mlflow

from terrain.tracking import code_version, tracked_run, tracking_uri


def test_embedded_store_lives_in_the_working_directory(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    process_wide = mlflow.get_tracking_uri()
    with tracked_run("terrain-test", params={"alpha": 1}) as run:
        run.log_metrics({"accuracy": 0.5, "bad": float("nan")})
        run.log_dict({"x": 1}, "report.json")
    assert "MLFLOW_TRACKING_URI" not in os.environ  # the user's environment is unchanged
    assert mlflow.get_tracking_uri() == process_wide  # and MLflow's process-wide store
    assert (tmp_path / "mlflow.db").exists()
    client = mlflow.MlflowClient(tracking_uri=tracking_uri())
    exp = client.get_experiment_by_name("terrain-test")
    assert exp.artifact_location == (tmp_path / "mlartifacts" / "terrain-test").as_uri()
    assert (tmp_path / "mlartifacts" / "terrain-test" / run.run_id / "artifacts" /
            "report.json").exists()
    logged = client.get_run(run.run_id)
    assert logged.info.status == "FINISHED"
    assert logged.data.params["alpha"] == "1"
    assert logged.data.params["code_version"] == code_version()
    assert logged.data.metrics == {"accuracy": 0.5}
    assert logged.data.tags["non_finite_metrics"] == "bad"
    assert run.run_id in capsys.readouterr().out


def test_environment_variable_selects_another_store(tmp_path, monkeypatch):
    other = tmp_path / "elsewhere.db"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{other}")
    monkeypatch.chdir(tmp_path)
    assert tracking_uri() == f"sqlite:///{other}"
    with tracked_run("terrain-test", announce=False):
        pass
    assert other.exists() and not (tmp_path / "mlflow.db").exists()
