"""Every model kind is served by the same MLflow inference pipeline (round trip, CNN)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.io.shipped import read_shipped
from terrain.models.experiment import ExperimentConfig, fit_pipeline
from terrain.serving.pyfunc import load_model, pip_requirements, runs_to_model_input, save_model

RUNS = ("vulpi/CONCRETE/1", "vulpi/PLOUGHED/3", "vulpi/UNPLOUGHED/1")


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """Run in an empty folder with the embedded MLflow store."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


@pytest.mark.parametrize("kind, window_ekf", [("cnn", False), ("ensemble3", False),
                                              ("cnn-spectrogram", True)])
def test_cnn_model_round_trip_raw_samples_in_probabilities_out(workdir, kind, window_ekf):
    runs = [r for r in read_shipped("vulpi") if r.run_id in RUNS]
    config = ExperimentConfig(dataset="vulpi", model=kind, max_epochs=3, n_threads=1,
                              seeds=(0,), window_ekf=window_ekf)
    model, ws, info = fit_pipeline(config, runs=runs)
    assert info["model"] == kind
    classes = [str(c) for c in np.unique(ws.labels.astype(str))]
    window = config.window_config()
    path = save_model(workdir / "model", model, ws.channels, window, classes,
                      {"model": kind, "dataset": "vulpi"})
    reqs = pip_requirements(model)
    assert any(r.startswith("torch==") for r in reqs) and any(r.startswith("skorch==")
                                                              for r in reqs)
    # the window EKF's compiled loop needs numba; models without it do not list it
    assert any(r.startswith("numba==") for r in reqs) == window_ekf
    served, meta = load_model(path)
    assert meta["model"] == kind and meta["channels"] == list(ws.channels)
    samples, skipped = runs_to_model_input(runs, meta["channels"], float(meta["rate_hz"]))
    assert skipped == []
    pred = served.predict(samples)
    assert len(pred) == len(ws)
    proba = pred[[f"proba_{c}" for c in classes]].to_numpy()
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-6)
    # the served pipeline (raw samples -> windows -> CNN) equals the model on the windows
    order = np.lexsort((ws.t_start_s, ws.run_ids))
    direct = model.predict_proba(ws.X[order])
    served_sorted = proba[np.lexsort((pred["t_start_s"].to_numpy(), pred["run"].to_numpy()))]
    np.testing.assert_allclose(served_sorted, direct, atol=1e-5)
