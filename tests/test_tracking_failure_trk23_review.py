"""Review trk23: what :func:`terrain.tracking.tracked_run` leaves in the store when its
block fails (an error, Ctrl-C, SIGTERM's unwinding), alone and nested (a parent run with
child runs, as ``terrain compare`` logs them): every run ends, none ``RUNNING``, none
``FINISHED`` unless its block completed, and MLflow's active-run stack is as it was.

Each test copies a SQLite store created once for the module into its ``tmp_path`` (MLflow
creates a store's tables in seconds).
"""

from __future__ import annotations

import shutil

import mlflow
import pytest

from terrain.tracking import tracked_run, tracking_uri


@pytest.fixture(scope="module")
def empty_store(tmp_path_factory):
    """A new SQLite MLflow store, its tables created."""
    folder = tmp_path_factory.mktemp("store")
    mlflow.MlflowClient(tracking_uri=f"sqlite:///{folder / 'mlflow.db'}").search_experiments()
    return folder / "mlflow.db"


@pytest.fixture(params=[True, False], ids=["fluent", "client-only"])
def store(request, tmp_path, monkeypatch, empty_store):
    """The embedded store in ``tmp_path``; ``fluent``: it is also MLflow's process-wide
    store (as in a ``terrain`` command, :func:`terrain.tracking.activate_store`), so runs
    are MLflow's active runs and nest."""
    shutil.copy(empty_store, tmp_path / "mlflow.db")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    previous = mlflow.get_tracking_uri()
    # set_tracking_uri exports the variable: monkeypatch owns it so that it leaves with the
    # test; client-only: MLflow's process-wide store is another one
    uri = tracking_uri()
    mlflow.set_tracking_uri(uri if request.param else f"sqlite:///{tmp_path / 'other.db'}")
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    yield request.param
    while mlflow.active_run() is not None:     # a test that failed leaves none behind
        mlflow.end_run()
    mlflow.set_tracking_uri(previous)


def _runs(experiment="terrain-test"):
    """run name -> (status, parent run id or None, metrics)."""
    client = mlflow.MlflowClient(tracking_uri=tracking_uri())
    exp = client.get_experiment_by_name(experiment)
    return {r.info.run_name: (r.info.status, r.data.tags.get("mlflow.parentRunId"),
                              r.data.metrics)
            for r in client.search_runs([exp.experiment_id])}


@pytest.mark.slow
@pytest.mark.parametrize("error", [RuntimeError("fit failed"), KeyboardInterrupt(),
                                   SystemExit(3), GeneratorExit()])
def test_a_block_that_raises_anything_ends_its_run_failed(store, error):
    with pytest.raises(type(error)):
        with tracked_run("terrain-test", run_name="alone", announce=False) as run:
            run.log_metrics({"fold_1_accuracy": 0.5})
            raise error
    assert mlflow.active_run() is None
    status, _, metrics = _runs()["alone"]
    assert status == "FAILED"
    # what was logged before the failure stays, under a run marked FAILED
    assert metrics == {"fold_1_accuracy": 0.5}


@pytest.mark.parametrize("error", [RuntimeError("cell failed"), KeyboardInterrupt()])
def test_a_child_that_fails_fails_its_parent_and_ends_both(store, error):
    """A failing child (``terrain compare``'s cell) ends itself and its parent ``FAILED``;
    a child that finished before stays ``FINISHED`` (its cell is whole)."""
    with pytest.raises(type(error)):
        with tracked_run("terrain-test", run_name="parent", announce=False) as parent:
            with tracked_run("terrain-test", run_name="done", announce=False):
                pass
            with tracked_run("terrain-test", run_name="failing", announce=False):
                raise error
    assert mlflow.active_run() is None
    runs = _runs()
    expected_parent = parent.run_id if store else None
    assert runs == {"parent": ("FAILED", None, {}),
                    "done": ("FINISHED", expected_parent, {}),
                    "failing": ("FAILED", expected_parent, {})}


def test_a_parent_that_fails_after_its_children_ends_failed_and_the_children_as_they_were(
        store):
    with pytest.raises(ZeroDivisionError):
        with tracked_run("terrain-test", run_name="parent", announce=False):
            for name in ("a", "b"):
                with tracked_run("terrain-test", run_name=name, announce=False) as child:
                    child.log_metrics({"accuracy": 0.75})
            1 / 0
    runs = _runs()
    assert {name: status for name, (status, _, _) in runs.items()} == {
        "parent": "FAILED", "a": "FINISHED", "b": "FINISHED"}
    assert mlflow.active_run() is None


def test_a_child_caught_by_its_caller_leaves_the_parent_active_and_running(store):
    """A child's failure that the caller handles (a cell skipped) ends the child
    ``FAILED``; the parent goes on (the active run again in a fluent store) and finishes."""
    with tracked_run("terrain-test", run_name="parent", announce=False) as parent:
        with pytest.raises(ValueError):
            with tracked_run("terrain-test", run_name="child", announce=False):
                raise ValueError("bad cell")
        if store:
            assert mlflow.active_run().info.run_id == parent.run_id
        client = mlflow.MlflowClient(tracking_uri=tracking_uri())
        assert client.get_run(parent.run_id).info.status == "RUNNING"
    runs = _runs()
    assert runs["parent"][0] == "FINISHED" and runs["child"][0] == "FAILED"


def test_a_failure_while_logging_the_start_parameters_ends_the_run_failed(store):
    """The run exists once created: a parameter MLflow refuses (a name it does not take)
    ends it ``FAILED`` rather than leaving it ``RUNNING``."""
    from mlflow.exceptions import MlflowException

    with pytest.raises(MlflowException):
        with tracked_run("terrain-test", run_name="bad-param", announce=False,
                         params={"bad name?!": 1}):
            pass
    assert _runs()["bad-param"][0] == "FAILED"
    assert mlflow.active_run() is None
