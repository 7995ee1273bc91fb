"""Review trk25: what tracking does to the process (MLflow's process-wide store, the
environment) and what happens when two threads log at once."""

from __future__ import annotations

import os
import threading
import time

import mlflow
import pytest

from terrain.tracking import TrackedRun, activate_store, tracked_run


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return tmp_path


def _slow_first_set_tag(client, monkeypatch, seconds=0.3):
    """The first ``set_tag`` through ``client`` waits ``seconds`` before writing: the window
    in which another thread's later call reads and writes the tag."""
    original = client.set_tag
    calls = []

    def set_tag(*args, **kwargs):
        calls.append(args)
        if len(calls) == 1:
            time.sleep(seconds)
        return original(*args, **kwargs)
    monkeypatch.setattr(client, "set_tag", set_tag)


def _together(*jobs):
    barrier = threading.Barrier(len(jobs))
    errors = []

    def start(job, delay):
        try:
            barrier.wait()
            time.sleep(delay)
            job()
        except BaseException as exc:      # pragma: no cover - reported below
            errors.append(exc)
    threads = [threading.Thread(target=start, args=(job, 0.1 * i))
               for i, job in enumerate(jobs)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors


@pytest.mark.slow
@pytest.mark.parametrize("handles", ["one", "two"])
def test_non_finite_metrics_logged_by_two_threads_are_all_listed(store, monkeypatch, handles):
    # the tag is read, merged and written back: a thread that wrote a list made before the
    # other thread's names were added erased them (non_finite_metrics 'a' for 'a' and 'b')
    with tracked_run("terrain-test", announce=False) as run:
        other = run if handles == "one" else TrackedRun(run.run_id, run.experiment, run.uri,
                                                        run.client)
        _slow_first_set_tag(run.client, monkeypatch)
        _together(lambda: run.log_metrics({"a": float("nan")}),
                  lambda: other.log_metrics({"b": float("inf")}))
        tag = run.client.get_run(run.run_id).data.tags["non_finite_metrics"]
    assert tag == "a,b"


def test_activating_the_embedded_store_leaves_the_environment_as_it_was(tmp_path, monkeypatch):
    # in a folder where MLflow's own default is another store (an old ./mlruns), or after a
    # caller chose another store, activate_store set MLflow's URI, and MLflow exported
    # MLFLOW_TRACKING_URI=sqlite:///<that folder>/mlflow.db: a later command run in-process
    # in another folder read the variable and logged into the first folder's store
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir()
    second.mkdir()
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    previous = mlflow.get_tracking_uri()
    try:
        mlflow.set_tracking_uri(f"sqlite:///{tmp_path / 'other.db'}")
        monkeypatch.delenv("MLFLOW_TRACKING_URI")      # (set_tracking_uri exported it)
        monkeypatch.chdir(first)
        assert activate_store() == (f"sqlite:///{first / 'mlflow.db'}", True)
        assert mlflow.get_tracking_uri() == f"sqlite:///{first / 'mlflow.db'}"
        assert "MLFLOW_TRACKING_URI" not in os.environ
        monkeypatch.chdir(second)
        assert activate_store() == (f"sqlite:///{second / 'mlflow.db'}", True)
        assert mlflow.get_tracking_uri() == f"sqlite:///{second / 'mlflow.db'}"
        assert "MLFLOW_TRACKING_URI" not in os.environ
    finally:
        mlflow.set_tracking_uri(previous)
        os.environ.pop("MLFLOW_TRACKING_URI", None)


def test_activating_a_store_named_by_the_environment_keeps_it(tmp_path, monkeypatch):
    uri = f"sqlite:///{tmp_path / 'named.db'}"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    previous = mlflow.get_tracking_uri()
    try:
        mlflow.set_tracking_uri(f"sqlite:///{tmp_path / 'other.db'}")
        monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
        assert activate_store() == (uri, False)
        assert mlflow.get_tracking_uri() == uri
        assert os.environ["MLFLOW_TRACKING_URI"] == uri
    finally:
        mlflow.set_tracking_uri(previous)


@pytest.mark.slow
def test_an_experiment_created_by_another_process_meanwhile_is_used(tmp_path, monkeypatch):
    # a store that is not locked (a tracking server): two commands started together both
    # found no experiment and both created it; the second got MLflow's "already exists"
    # (RESOURCE_ALREADY_EXISTS) and failed instead of logging into it
    from terrain.tracking import _experiment_id

    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    client = mlflow.MlflowClient(tracking_uri=uri)
    client.search_experiments()            # (the tables, before the threads)
    original = client.get_experiment_by_name
    looked = []

    def get_experiment_by_name(name):
        found = original(name)
        looked.append(name)
        if len(looked) <= 2:
            time.sleep(0.3)                # both have looked before either creates it
        return found
    monkeypatch.setattr(client, "get_experiment_by_name", get_experiment_by_name)
    ids = []
    _together(lambda: ids.append(_experiment_id(client, "terrain-test", uri)),
              lambda: ids.append(_experiment_id(client, "terrain-test", uri)))
    assert len(ids) == 2 and ids[0] == ids[1]
    assert [e.name for e in client.search_experiments()].count("terrain-test") == 1
