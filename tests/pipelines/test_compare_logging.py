"""`terrain compare`'s child runs follow the project's MLflow rules (terrain.tracking)."""

from __future__ import annotations

import math

import mlflow
import pytest

from pipelines.compare import EXPERIMENT, log_cell
from terrain.tracking import code_version, tracked_run, tracking_uri


def _log_cells(tmp_path, monkeypatch, cell, rows):
    """Log one cell under a ``compare`` parent run; its child run."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    uri = tracking_uri()
    # MLflow's set_tracking_uri also exports MLFLOW_TRACKING_URI: monkeypatch owns the
    # variable so that it leaves with the test (it leaked this store into the next tests)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    previous = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(uri)                   # as `terrain` does (activate_store)
    try:
        with tracked_run(EXPERIMENT, run_name="compare", announce=False) as parent:
            log_cell({"cell": cell, "rows": rows})
    finally:
        mlflow.set_tracking_uri(previous)
    client = mlflow.MlflowClient(tracking_uri=uri)
    children = client.search_runs([client.get_experiment_by_name(EXPERIMENT).experiment_id],
                                  f"tags.mlflow.parentRunId = '{parent.run_id}'")
    assert len(children) == 1
    return children[0]


@pytest.mark.slow
def test_a_cells_non_finite_metric_is_skipped_and_listed_not_logged_as_nan(tmp_path,
                                                                           monkeypatch):
    # log_cell called mlflow.log_metrics itself: a cell whose run vote is undefined logged
    # run_vote_accuracy_k1 = nan as a number (every other pipeline skips it and lists it
    # in the tag non_finite_metrics)
    cell = {"model": "svm", "dataset": "vulpi", "signals": "all", "window_s": 2.0, "seed": 0,
            "protocol": "grouped", "train_hop_s": None}
    row = {"history": 1, "accuracy": 0.9, "balanced_accuracy": 0.85, "macro_f1": 0.8,
           "run_vote_accuracy": float("nan"), "fit_s_per_fold": 1.5,
           "infer_ms_per_window": 0.2, "n_windows_dropped": 3}
    child = _log_cells(tmp_path, monkeypatch, cell, [row])
    assert child.info.run_name == "svm-vulpi-all-2s-seed0"
    assert all(math.isfinite(v) for v in child.data.metrics.values())
    assert child.data.metrics == {"accuracy_k1": 0.9, "balanced_accuracy_k1": 0.85,
                                  "macro_f1_k1": 0.8, "fit_s_per_fold": 1.5,
                                  "infer_ms_per_window": 0.2, "n_windows_dropped": 3.0}
    assert child.data.tags["non_finite_metrics"] == "run_vote_accuracy_k1"
    assert child.data.params["model"] == "svm"
    assert child.data.params["code_version"] == code_version()


@pytest.mark.slow
def test_compare_child_run_names_the_training_hop_and_protocol_and_each_history(
        tmp_path, monkeypatch):
    # a cell fitted on 0.5 s hops of 2 s windows under the leaky paper protocol: both in
    # the name (the hop once named the window length); one metric per history k
    cell = {"model": "svm", "dataset": "vulpi", "signals": "all", "window_s": 2.0, "seed": 1,
            "protocol": "paper", "train_hop_s": 0.5}
    rows = [{"history": k, "accuracy": acc, "balanced_accuracy": 0.5, "macro_f1": 0.4,
             "run_vote_accuracy": 0.6, "fit_s_per_fold": 1.0, "infer_ms_per_window": 0.1,
             "n_windows_dropped": 2} for k, acc in ((1, 0.7), (5, 0.8))]
    child = _log_cells(tmp_path, monkeypatch, cell, rows)
    assert child.info.run_name == "svm-vulpi-all-2s-seed1-paper-LEAKY-trainhop0.5s"
    assert child.data.metrics["accuracy_k1"] == 0.7
    assert child.data.metrics["accuracy_k5"] == 0.8
    assert child.data.metrics["n_windows_dropped"] == 2.0
