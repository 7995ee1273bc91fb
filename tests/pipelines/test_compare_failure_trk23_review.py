"""Review trk23: a ``terrain compare`` grid that stops on an error (a worker lost, Ctrl-C):
its MLflow parent run and child runs, and what its ``--out`` folder holds after."""

from __future__ import annotations

import shutil

import mlflow
import pandas as pd
import pytest

import pipelines.compare as compare
from terrain.cli import main

CELL = {"model": "svm", "dataset": "vulpi", "signals": "all", "window_s": 2.0, "seed": 0,
        "protocol": "grouped", "train_hop_s": None}
ROW = {"model": "svm", "dataset": "vulpi", "signals": "all", "window_s": 2.0, "seed": 0,
       "history": 1, "accuracy": 0.9, "balanced_accuracy": 0.85, "macro_f1": 0.8,
       "run_vote_accuracy": 1.0, "fit_s_per_fold": 1.5, "infer_ms_per_window": 0.2,
       "n_windows_dropped": 0}
EARLIER = ("compare_table.md", "compare_table.csv", "compare.png", "predictions.csv",
           "compare_grid.png", "compare_grid.md")


@pytest.fixture(scope="module")
def empty_store(tmp_path_factory):
    """A new SQLite MLflow store, its tables created (MLflow's migrations take seconds)."""
    folder = tmp_path_factory.mktemp("store")
    mlflow.MlflowClient(tracking_uri=f"sqlite:///{folder / 'mlflow.db'}").search_experiments()
    return folder / "mlflow.db"


@pytest.mark.slow
@pytest.mark.parametrize("error, code", [(RuntimeError("worker lost"), 1),
                                         (KeyboardInterrupt(), 130)])
def test_a_grid_that_stops_keeps_its_cells_and_no_summary_of_an_earlier_grid(
        tmp_path, monkeypatch, empty_store, capsys, error, code):
    # the first finished cell rewrote compare_cells.csv; the table, figures and predictions
    # of the earlier grid in the same --out stayed beside it when the grid stopped, as if
    # they summarised these cells
    shutil.copy(empty_store, tmp_path / "mlflow.db")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", "")   # the entry point exports it; restored
    previous = mlflow.get_tracking_uri()
    out = tmp_path / "cmp"
    out.mkdir()
    for name in EARLIER:
        (out / name).write_text("an earlier grid")

    def grid(config, n_jobs):
        yield {"cell": CELL, "rows": [ROW],
               "predictions": pd.DataFrame({"run": ["r"], "predicted": ["ICE"]})}
        raise error

    monkeypatch.setattr(compare, "iter_grid", grid)
    try:
        assert main(["compare", "--models", "svm", "--datasets", "vulpi", "--signals", "all",
                     "--windows-s", "2", "--seeds", "0", "--n-jobs", "1", "--no-progress",
                     "--out", str(out)]) == code
    finally:
        mlflow.set_tracking_uri(previous)
    cells = pd.read_csv(out / "compare_cells.csv")
    assert len(cells) == 1 and cells["accuracy"].tolist() == [0.9]
    left = sorted(p.name for p in out.iterdir())
    assert left == ["compare_cells.csv"], left
    # MLflow: the parent FAILED, its one finished cell FINISHED, nothing left RUNNING
    # (the store named, not read back from the environment: the entry point set MLflow's
    # process-wide URI, which MLflow exports, and the finally above set it back to another
    # test's store where an earlier test of the suite had set one)
    client = mlflow.MlflowClient(tracking_uri=f"sqlite:///{tmp_path / 'mlflow.db'}")
    runs = client.search_runs([client.get_experiment_by_name("terrain-compare").experiment_id])
    status = {r.info.run_name: r.info.status for r in runs}
    assert status == {"compare": "FAILED", "svm-vulpi-all-2s-seed0": "FINISHED"}
    assert mlflow.active_run() is None


@pytest.mark.slow
def test_a_summary_that_fails_half_way_leaves_no_part_of_itself(
        tmp_path, monkeypatch, empty_store, capsys):
    # the table and figure were written into --out one by one, so a failure while joining
    # the predictions left a compare_table.md/csv and compare.png without predictions.csv,
    # a summary a later reader takes as whole; now the summary lands all together or not
    shutil.copy(empty_store, tmp_path / "mlflow.db")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", "")   # the entry point exports it; restored
    previous = mlflow.get_tracking_uri()
    out = tmp_path / "cmp"

    def grid(config, n_jobs):
        yield {"cell": CELL, "rows": [ROW], "predictions": None}   # pd.concat refuses it

    monkeypatch.setattr(compare, "iter_grid", grid)
    try:
        assert main(["compare", "--models", "svm", "--datasets", "vulpi", "--signals", "all",
                     "--windows-s", "2", "--seeds", "0", "--n-jobs", "1", "--no-progress",
                     "--out", str(out)]) == 1
    finally:
        mlflow.set_tracking_uri(previous)
    assert sorted(p.name for p in out.iterdir()) == ["compare_cells.csv"]
