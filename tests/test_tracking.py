"""MLflow conventions: embedded store in the working directory, remote one env var away."""

from __future__ import annotations

import http.server
import os
import socket
import threading
import time

import mlflow
import pandas as pd
import pytest

from pipelines.slip_model import resolve_slip_model
from terrain.cli import main
from terrain.errors import ConfigError
from terrain.tracking import check_store, code_version, tracked_run, tracking_uri


@pytest.fixture
def closed_port() -> int:
    """A loopback port nothing listens on."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.mark.slow
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


@pytest.mark.slow
def test_a_run_opened_inside_a_callers_active_run_is_its_child(tmp_path, monkeypatch):
    # inside a caller's active run, the run was a sibling (no parent tag) and not active:
    # fluent calls in the block (model logging) landed in the caller's run
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    previous = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(tracking_uri())     # the caller's store is the run's
    try:
        client = mlflow.MlflowClient(tracking_uri=tracking_uri())
        outer = client.create_run(client.create_experiment("caller")).info.run_id
        with mlflow.start_run(run_id=outer):
            with tracked_run("terrain-test", announce=False) as run:
                assert mlflow.active_run().info.run_id == run.run_id
                mlflow.log_param("fluent", 1)
            assert mlflow.active_run().info.run_id == outer      # the caller's run goes on
            assert client.get_run(outer).info.status == "RUNNING"
    finally:
        mlflow.set_tracking_uri(previous)
    child = client.get_run(run.run_id)
    assert child.data.tags["mlflow.parentRunId"] == outer
    assert child.data.params["fluent"] == "1" and child.info.status == "FINISHED"
    assert "fluent" not in client.get_run(outer).data.params


@pytest.mark.slow
def test_non_finite_metrics_of_every_call_stay_listed(tmp_path, monkeypatch):
    # the tag was overwritten by each call: a pipeline logging its metrics in a loop kept
    # only the last call's skipped names ("b"), and "a" was lost without a trace
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    with tracked_run("terrain-test", announce=False) as run:
        run.log_metrics({"a": float("nan"), "ok": 1.0})
        run.log_metrics({"b": float("inf")})
        run.log_metrics({"ok2": 2.0})
    logged = mlflow.MlflowClient(tracking_uri=tracking_uri()).get_run(run.run_id)
    assert logged.data.tags["non_finite_metrics"] == "a,b"
    assert logged.data.metrics == {"ok": 1.0, "ok2": 2.0}


@pytest.mark.slow
def test_metric_values_that_are_not_numbers_are_refused_by_name(tmp_path, monkeypatch):
    # text was logged through float ('0.5' -> 0.5, a column read as text unnoticed) and None
    # was Python's bare TypeError from float()
    import numpy as np

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    with tracked_run("terrain-test", announce=False) as run:
        with pytest.raises(ConfigError, match=r"log_metrics takes real numbers, got "
                                              r"acc='0\.5' \(str\), t=None \(NoneType\)"):
            run.log_metrics({"ok": 1.0, "acc": "0.5", "t": None})
        run.log_metrics({"f32": np.float32(0.25), "flag": np.bool_(True), "n": np.int64(3)})
    logged = mlflow.MlflowClient(tracking_uri=tracking_uri()).get_run(run.run_id)
    assert logged.data.metrics == {"f32": 0.25, "flag": 1.0, "n": 3.0}


@pytest.mark.slow
def test_a_table_is_logged_as_csv_under_a_csv_name_only(tmp_path, monkeypatch):
    # log_table writes CSV whatever the name: `terrain control-grid` logged its tuning and
    # comparison tables as CSV text in files named tuning_husky.json and comparison.json
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    table = pd.DataFrame({"kp": [2.0, 5.0], "cost": [0.1, 0.09]})
    with tracked_run("terrain-test", announce=False) as run:
        with pytest.raises(ConfigError, match=r"log_table writes CSV: name 'tuning.json' "
                                              r"must end in \.csv"):
            run.log_table(table, "tuning.json")
        run.log_table(table, "tuning.csv")
    root = tmp_path / "mlartifacts" / "terrain-test" / run.run_id / "artifacts"
    assert sorted(p.name for p in root.iterdir()) == ["tuning.csv"]
    assert pd.read_csv(root / "tuning.csv").equals(table)


@pytest.mark.slow
def test_a_logged_dict_is_strict_json_with_undefined_figures_null(tmp_path, monkeypatch):
    # MLflow writes a dict with json.dumps' defaults: a NaN figure (the recall of a class
    # without a window in cv_report.json) became the bare token NaN that jq and JSON.parse
    # refuse; numpy scalars and tuples are written as JSON numbers and lists, floats in full
    import json

    import numpy as np

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    data = {"recall": {"SNOW": float("nan"), "ICE": np.float64(0.123456789)},
            "delays_s": (1.5, np.inf), "n": np.int64(3)}
    with tracked_run("terrain-test", announce=False) as run:
        run.log_dict(data, "report.json")
    text = (tmp_path / "mlartifacts" / "terrain-test" / run.run_id / "artifacts"
            / "report.json").read_text()
    assert json.loads(text, parse_constant=lambda c: pytest.fail(f"bare {c} in {text}")) == {
        "recall": {"SNOW": None, "ICE": 0.123456789}, "delays_s": [1.5, None], "n": 3}


@pytest.mark.slow
def test_environment_variable_selects_another_store(tmp_path, monkeypatch):
    other = tmp_path / "elsewhere.db"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{other}")
    monkeypatch.chdir(tmp_path)
    assert tracking_uri() == f"sqlite:///{other}"
    with tracked_run("terrain-test", announce=False):
        pass
    assert other.exists() and not (tmp_path / "mlflow.db").exists()


@pytest.mark.slow
@pytest.mark.parametrize("caller_run", [False, True])
def test_a_model_is_never_logged_to_a_run_other_than_its_own(tmp_path, monkeypatch,
                                                             caller_run):
    # log_sklearn_model uses MLflow's fluent model logging, which writes to the active run;
    # when MLflow's process-wide store was another one, tracked_run opened its run on its
    # own store without making it active, and the model went to a new run of the other store
    # (or, with the caller's own run active there, into the caller's run)
    from contextlib import nullcontext

    from sklearn.dummy import DummyRegressor

    monkeypatch.chdir(tmp_path)
    # monkeypatch owns the variable first, so that it leaves with the test (MLflow's
    # set_tracking_uri exports it)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    previous = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(f"sqlite:///{tmp_path / 'other.db'}")
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{tmp_path / 'mine.db'}")
    X = pd.DataFrame({"a": [0.0, 1.0, 2.0]})
    model = DummyRegressor().fit(X, [0.0, 1.0, 2.0])
    try:
        with mlflow.start_run() if caller_run else nullcontext():
            with pytest.raises(ConfigError, match="not MLflow's active run"):
                with tracked_run("terrain-test", announce=False) as run:
                    run.log_sklearn_model(model, "m", X)
        assert mlflow.active_run() is None
    finally:
        mlflow.set_tracking_uri(previous)
    other = mlflow.MlflowClient(tracking_uri=f"sqlite:///{tmp_path / 'other.db'}")
    assert other.search_experiments(filter_string="name = 'terrain-test'") == []


@pytest.mark.slow
def test_a_sqlite_store_named_by_the_environment_keeps_its_artifacts_beside_it(
        tmp_path, monkeypatch):
    # the README's recipe (train in one folder, then from another folder
    # MLFLOW_TRACKING_URI=sqlite:////where/train/ran/mlflow.db terrain predict ...) created
    # terrain-predict with MLflow's default artifact root, ./mlruns of the folder the command
    # ran in: a stray mlruns/ there, and the store's artifacts scattered over every folder
    # an experiment was first created from
    store = tmp_path / "store"
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{store / 'mlflow.db'}")
    monkeypatch.chdir(elsewhere)
    with tracked_run("terrain-test", announce=False) as run:
        run.log_dict({"x": 1}, "report.json")
    exp = mlflow.MlflowClient(tracking_uri=tracking_uri()).get_experiment_by_name(
        "terrain-test")
    assert exp.artifact_location == (store / "mlartifacts" / "terrain-test").as_uri()
    assert (store / "mlartifacts" / "terrain-test" / run.run_id / "artifacts" /
            "report.json").exists()
    assert not any(elsewhere.iterdir())          # no mlruns/ in the working folder
    # a relative sqlite:/// path is the working folder's database: artifacts beside it too
    monkeypatch.setenv("MLFLOW_TRACKING_URI", "sqlite:///rel.db")
    with tracked_run("terrain-test", announce=False):
        pass
    exp = mlflow.MlflowClient(tracking_uri="sqlite:///rel.db").get_experiment_by_name(
        "terrain-test")
    assert exp.artifact_location == (elsewhere / "mlartifacts" / "terrain-test").as_uri()
    assert [p.name for p in elsewhere.iterdir()] == ["rel.db"]     # and no mlruns/


def test_a_store_that_cannot_be_used_is_one_line_at_once(tmp_path, monkeypatch, capsys,
                                                         closed_port):
    # MLflow retried an unopenable SQLite file for ~100 s and then raised a database error
    # that the CLI called a defect of terrain; an unreachable server for minutes
    monkeypatch.chdir(tmp_path)
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    for uri, match in ((f"sqlite:///{blocker}/mlflow.db", "cannot be opened"),
                       (f"http://127.0.0.1:{closed_port}", "does not answer")):
        with pytest.raises(ConfigError, match=match):
            check_store(uri)
        monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
        start = time.monotonic()
        assert main(["cv", "--dataset", "vulpi", "--seeds", "0", "--no-progress"]) == 2
        assert time.monotonic() - start < 60
        err = capsys.readouterr().err
        assert "terrain cv: error: MLflow tracking s" in err and uri in err
        assert "internal error" not in err and "Traceback" not in err
    check_store(f"sqlite:///{tmp_path}/new/folder/mlflow.db")   # created, as MLflow does
    assert (tmp_path / "new" / "folder" / "mlflow.db").exists()


def test_a_file_that_is_not_a_sqlite_database_is_refused_at_once(
        tmp_path, monkeypatch, capsys):
    # sqlite3.connect opens lazily, so such a file passed the check; MLflow then raised
    # SQLAlchemy's DatabaseError, which the CLI called a defect of terrain (exit 1)
    monkeypatch.chdir(tmp_path)
    not_a_db = tmp_path / "notadb.db"
    not_a_db.write_text("not a database\n")
    uri = f"sqlite:///{not_a_db}"
    with pytest.raises(ConfigError, match="cannot be opened: file is not a database"):
        check_store(uri)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    assert main(["cv", "--dataset", "vulpi", "--seeds", "0", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "terrain cv: error: MLflow tracking store" in err and uri in err
    assert "internal error" not in err and "Traceback" not in err
    assert not_a_db.read_text() == "not a database\n"          # left as it was
    empty = tmp_path / "empty.db"
    empty.touch()
    check_store(f"sqlite:///{empty}")                             # an empty file is a database


@pytest.mark.parametrize("uri", ["sqlite:///", "sqlite:///:memory:", "sqlite://",
                                 "sqlite:///?timeout=5"])
def test_a_store_that_keeps_nothing_is_refused_before_any_run(tmp_path, monkeypatch, uri):
    # MLFLOW_TRACKING_URI=sqlite:///$DB with DB unset: the runs went to a database in memory,
    # lost when the command ended, after 'MLflow run ... (browse: mlflow ui
    # --backend-store-uri sqlite:///)'
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    with pytest.raises(ConfigError, match="names no database file"):
        with tracked_run("terrain-test", announce=False):
            pytest.fail("a run was opened")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_server_that_answers_any_status_passes_the_check():
    # a proxy or an MLflow server without /health: answering is enough, MLflow says the rest
    class NotFound(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            self.send_error(404)

        def log_message(self, *args):
            pass

    server = http.server.HTTPServer(("127.0.0.1", 0), NotFound)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        check_store(f"http://127.0.0.1:{server.server_address[1]}")
    finally:
        server.shutdown()


def test_the_slip_model_lookup_falls_back_at_once_when_the_server_does_not_answer(
        monkeypatch, closed_port):
    # terrain estimate's default lookup of the registered slip model waited minutes on
    # MLflow's retries before falling back to physics
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"http://127.0.0.1:{closed_port}")
    start = time.monotonic()
    model, where = resolve_slip_model(None)
    assert model is None and time.monotonic() - start < 30
    assert where.startswith("tracking store not usable: MLflow tracking server") and \
        "does not answer" in where


def test_a_registry_model_on_a_server_that_does_not_answer_is_one_line_at_once(
        tmp_path, monkeypatch, capsys, closed_port):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"http://127.0.0.1:{closed_port}")
    start = time.monotonic()
    assert main(["predict", "--model", "models:/terrain-borealtc/latest", str(tmp_path),
                 "--out", "p.csv", "--no-progress"]) == 2
    assert time.monotonic() - start < 30
    err = capsys.readouterr().err
    assert "cannot load model 'models:/terrain-borealtc/latest'" in err
    assert "does not answer" in err and "Traceback" not in err


@pytest.mark.slow
def test_the_slip_model_lookup_loads_the_latest_version_and_leaves_mlflow_as_it_was(
        tmp_path, monkeypatch):
    # the lookup used to set MLflow's process-wide tracking and registry URIs (the latter
    # also as MLFLOW_REGISTRY_URI in the environment), pinning every later registry lookup
    # of the process to this store
    import mlflow.sklearn
    from sklearn.dummy import DummyRegressor

    from pipelines.slip_model import REGISTERED_SLIP_MODEL

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_REGISTRY_URI", raising=False)
    store = f"sqlite:///{tmp_path / 'slip.db'}"
    before = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(store)
    try:
        for constant in (0.1, 0.2):
            with mlflow.start_run():
                mlflow.sklearn.log_model(
                    DummyRegressor(strategy="constant", constant=constant).fit([[0.0]], [0.0]),
                    name="m", registered_model_name=REGISTERED_SLIP_MODEL)
    finally:
        mlflow.set_tracking_uri(before)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", store)
    model, where = resolve_slip_model(None)
    assert where == f"models:/{REGISTERED_SLIP_MODEL}/latest"
    assert model.predict([[0.0]])[0] == pytest.approx(0.2)            # version 2
    assert "MLFLOW_REGISTRY_URI" not in os.environ
    assert mlflow.get_tracking_uri() == before


@pytest.mark.slow
def test_processes_that_open_a_new_store_together_all_log_their_run(tmp_path):
    """MLflow creates and migrates a new SQLite store without guarding against another
    process doing the same: two `terrain train` started together in a fresh folder failed
    (3 of 3 tries: 'table _alembic_tmp_tags already exists'). terrain.tracking.store_lock
    serialises the store's first opening."""
    import subprocess
    import sys

    script = ("import sys\nfrom terrain.tracking import tracked_run\n"
              "with tracked_run('race', run_name=sys.argv[1], announce=False) as run:\n"
              "    run.log_metrics({'x': 1.0})\n")
    env = {k: v for k, v in os.environ.items() if k != "MLFLOW_TRACKING_URI"}
    procs = [subprocess.Popen([sys.executable, "-c", script, f"run{k}"], cwd=tmp_path, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for k in range(3)]
    results = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], [err[-400:] for _, err in results]
    client = mlflow.MlflowClient(tracking_uri=f"sqlite:///{tmp_path / 'mlflow.db'}")
    runs = client.search_runs([client.get_experiment_by_name("race").experiment_id])
    assert sorted(r.info.run_name for r in runs) == ["run0", "run1", "run2"]


def test_a_store_lock_held_too_long_is_a_one_line_config_error(tmp_path, monkeypatch):
    """filelock's Timeout escaped as a traceback; a query string (``?timeout=``) gave the same
    database another lock."""
    import threading

    from terrain import tracking
    from terrain.errors import ConfigError

    monkeypatch.setattr(tracking, "STORE_LOCK_TIMEOUT_S", 0.2)
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    held, release = threading.Event(), threading.Event()

    def hold():
        with tracking.store_lock(uri):
            held.set()
            release.wait(10)

    holder = threading.Thread(target=hold)
    holder.start()
    try:
        assert held.wait(10)
        with pytest.raises(ConfigError, match="opened by another process for over 0.2 s"):
            with tracking.store_lock(uri + "?timeout=30"):
                pass
    finally:
        release.set()
        holder.join(10)
    with tracking.store_lock(uri):   # released: taken at once
        pass


@pytest.mark.slow
def test_a_store_lock_held_briefly_is_waited_for(tmp_path):
    """Another process opening the store holds its lock for a moment: the second opening
    waits for it (up to STORE_LOCK_TIMEOUT_S, 300 s), it does not fail."""
    import threading

    from terrain import tracking

    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    held = threading.Event()

    def hold():
        with tracking.store_lock(uri):
            held.set()
            time.sleep(0.5)

    holder = threading.Thread(target=hold)
    holder.start()
    try:
        assert held.wait(10)
        start = time.monotonic()
        with tracking.store_lock(uri):
            waited = time.monotonic() - start
    finally:
        holder.join(10)
    assert 0.2 < waited < 10


@pytest.mark.slow
def test_a_server_that_takes_the_connection_but_never_answers_is_refused_after_5_s():
    """README: a server that does not answer within 5 s is a one-line error (a closed port
    is refused at once, so only a silent server exercises the wait)."""
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)          # the connection is taken, no answer ever comes
        uri = f"http://127.0.0.1:{server.getsockname()[1]}"
        start = time.monotonic()
        with pytest.raises(ConfigError, match=r"does not answer: .*\(waited up to 5 s\)"):
            check_store(uri)
        assert 4.0 < time.monotonic() - start < 30.0


@pytest.mark.parametrize("uri, database", [
    ("sqlite:///mlflow.db", "mlflow.db"),
    ("sqlite:////abs/dir/mlflow.db", "/abs/dir/mlflow.db"),
    ("sqlite:////abs/mlflow.db?timeout=30", "/abs/mlflow.db"),
    ("sqlite:///:memory:", None),
    ("http://127.0.0.1:5000", None),
    ("file:///tmp/mlruns", None),
])
def test_the_database_file_of_a_tracking_uri(uri, database):
    from terrain.tracking import sqlite_database

    got = sqlite_database(uri)
    assert (None if got is None else str(got)) == database


def test_the_store_check_opens_the_database_a_query_names(tmp_path):
    """check_store took ``?timeout=30`` for part of the file's name and created a second,
    empty database beside the user's."""
    from terrain.tracking import check_store

    check_store(f"sqlite:///{tmp_path / 'mlflow.db'}?timeout=30")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mlflow.db"]


@pytest.mark.slow
def test_a_table_name_with_a_folder_is_logged_in_that_folder(tmp_path, monkeypatch):
    # log_table wrote the CSV to <tmp>/<name> without the folder existing: 'tables/x.csv'
    # raised a bare FileNotFoundError, where log_figure takes 'figures/x.png'
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    table = pd.DataFrame({"kp": [2.0, 5.0]})
    with tracked_run("terrain-test", announce=False) as run:
        run.log_table(table, "tables/tuning.csv")
    root = tmp_path / "mlartifacts" / "terrain-test" / run.run_id / "artifacts"
    assert pd.read_csv(root / "tables" / "tuning.csv").equals(table)


@pytest.mark.slow
@pytest.mark.parametrize("fluent", [True, False])
def test_a_run_whose_block_raises_ends_failed_and_not_active(tmp_path, monkeypatch, fluent):
    """A pipeline that fails inside its run leaves it ``FAILED`` (not ``FINISHED`` or
    ``RUNNING``), whether the run was MLflow's active run or only the client's, and the
    error reaches the caller."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    previous = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(f"sqlite:///{tmp_path / 'other.db'}")   # exports the variable
    if not fluent:   # the run's store is not MLflow's process-wide one
        monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{tmp_path / 'mine.db'}")
    try:
        with pytest.raises(ZeroDivisionError):
            with tracked_run("terrain-test", announce=False) as run:
                assert (mlflow.active_run() is not None) == fluent
                1 / 0
        assert mlflow.active_run() is None
    finally:
        mlflow.set_tracking_uri(previous)
    mine = f"sqlite:///{tmp_path / ('other.db' if fluent else 'mine.db')}"
    assert run.uri == mine
    assert mlflow.MlflowClient(tracking_uri=mine).get_run(run.run_id).info.status == "FAILED"


@pytest.mark.slow
def test_a_run_on_a_store_other_than_mlflows_ends_finished(tmp_path, monkeypatch):
    """The client-only path (the run's store is not MLflow's process-wide one, so the run
    is not MLflow's active run) ends a block that returns ``FINISHED``, as the fluent path
    does; only the raising block of the test above ends ``FAILED``."""
    monkeypatch.chdir(tmp_path)
    previous = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(f"sqlite:///{tmp_path / 'other.db'}")   # exports the variable
    mine = f"sqlite:///{tmp_path / 'mine.db'}"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", mine)
    try:
        with tracked_run("terrain-test", announce=False) as run:
            assert mlflow.active_run() is None
            run.log_metrics({"accuracy": 0.75})
    finally:
        mlflow.set_tracking_uri(previous)
    logged = mlflow.MlflowClient(tracking_uri=mine).get_run(run.run_id)
    assert logged.info.status == "FINISHED" and logged.data.metrics == {"accuracy": 0.75}


def test_code_version_is_the_commit_marked_dirty_by_modified_tracked_files(
        tmp_path, monkeypatch):
    """``code_version`` tags a run with the source tree's commit, ``-dirty`` when a tracked
    file differs from it (an untracked file does not), and the package version outside a
    git checkout."""
    import subprocess

    import terrain
    import terrain.tracking as tracking

    def git(*args):
        return subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args],
                              cwd=tmp_path / "repo", check=True, capture_output=True,
                              text=True).stdout.strip()

    (tmp_path / "repo").mkdir()
    module = tmp_path / "repo" / "tracking.py"
    module.write_text("x = 1\n")
    git("init", "-q")
    git("add", "tracking.py")
    git("commit", "-q", "-m", "c")
    sha = git("rev-parse", "HEAD")
    monkeypatch.setattr(tracking, "__file__", str(module))
    assert code_version() == sha and len(sha) == 40
    (tmp_path / "repo" / "new.txt").write_text("untracked\n")
    assert code_version() == sha
    module.write_text("x = 2\n")
    assert code_version() == sha + "-dirty"
    (tmp_path / "plain").mkdir()
    monkeypatch.setattr(tracking, "__file__", str(tmp_path / "plain" / "tracking.py"))
    assert code_version() == f"terrain-{terrain.__version__}"


@pytest.mark.slow
def test_a_run_that_cannot_become_active_is_not_left_running(tmp_path, monkeypatch):
    """The caller chose another experiment (``mlflow.set_experiment``): MLflow refuses to make
    a run of ``terrain-test`` active. The run created for it ends ``FAILED``; it was left
    ``RUNNING`` for good, and the error reaches the caller."""
    from mlflow.exceptions import MlflowException
    from mlflow.tracking import fluent

    uri = f"sqlite:///{tmp_path / 'mine.db'}"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    previous = mlflow.get_tracking_uri()
    mlflow.set_tracking_uri(uri)                       # fluent: the run would be active
    client = mlflow.MlflowClient(tracking_uri=uri)
    monkeypatch.setattr(fluent, "_active_experiment_id", client.create_experiment("theirs"))
    try:
        with pytest.raises(MlflowException, match="active experiment"):
            with tracked_run("terrain-test", announce=False):
                pass
        assert mlflow.active_run() is None
    finally:
        mlflow.set_tracking_uri(previous)
    (run,) = client.search_runs([client.get_experiment_by_name("terrain-test").experiment_id])
    assert run.info.status == "FAILED"


@pytest.mark.slow
def test_metrics_logged_at_steps_keep_their_steps(tmp_path, monkeypatch):
    """A curve logged step by step (``terrain control-grid``'s tuning costs) keeps each
    value at its step; without a step the value is at step 0."""
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{tmp_path / 'mine.db'}")
    with tracked_run("terrain-test", announce=False) as run:
        for step, cost in enumerate((3.0, 2.0, 1.5)):
            run.log_metrics({"cost": cost}, step=step)
        run.log_metrics({"final": 1.5})
    client = mlflow.MlflowClient(tracking_uri=tracking_uri())
    history = sorted((m.step, m.value) for m in client.get_metric_history(run.run_id, "cost"))
    assert history == [(0, 3.0), (1, 2.0), (2, 1.5)]
    assert [m.step for m in client.get_metric_history(run.run_id, "final")] == [0]


def test_code_version_of_a_package_inside_another_projects_checkout_is_its_version(
        tmp_path, monkeypatch):
    """An install inside another project's git checkout (a virtual environment in it, its
    site-packages untracked or ignored) is not that project's source tree: its commit is
    not the code's version, so the run gets the package version."""
    import subprocess

    import terrain
    import terrain.tracking as tracking

    def git(*args):
        return subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args],
                              cwd=tmp_path, check=True, capture_output=True, text=True)

    git("init", "-q")
    (tmp_path / ".gitignore").write_text(".venv/\n")
    git("add", ".gitignore")
    git("commit", "-q", "-m", "their project")
    package = tmp_path / ".venv" / "site-packages" / "terrain"
    package.mkdir(parents=True)
    (package / "tracking.py").write_text("x = 1\n")
    monkeypatch.setattr(tracking, "__file__", str(package / "tracking.py"))
    assert code_version() == f"terrain-{terrain.__version__}"


def test_a_deleted_experiment_is_refused_by_name_with_its_remedy():
    """An experiment deleted in the store (``mlflow experiments delete``) was reused as it
    was: MLflow then refused the run with "The experiment 1 must be in the 'active' state",
    naming neither the experiment nor the remedy."""
    from types import SimpleNamespace

    from terrain.tracking import _experiment_id

    class Client:
        def get_experiment_by_name(self, name):
            return SimpleNamespace(experiment_id="7", lifecycle_stage="deleted", name=name)

        def create_experiment(self, *args, **kwargs):     # pragma: no cover - the bug
            raise AssertionError("a deleted experiment's name cannot be created again")

    uri = "sqlite:////tmp/x/mlflow.db"
    with pytest.raises(ConfigError, match=r"experiment 'terrain-cv' \(id 7\) .* deleted.*"
                                          r"mlflow experiments restore --experiment-id 7"):
        _experiment_id(Client(), "terrain-cv", uri)
    live = SimpleNamespace(experiment_id="3", lifecycle_stage="active")
    Client.get_experiment_by_name = lambda self, name: live
    assert _experiment_id(Client(), "terrain-cv", uri) == "3"


@pytest.mark.slow
def test_an_integer_metric_beyond_the_float_range_is_skipped_as_non_finite(tmp_path,
                                                                           monkeypatch):
    # float(10**400) raised Python's bare OverflowError out of log_metrics, and nothing of
    # the call was logged: it is a real number MLflow cannot hold, as inf
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    with tracked_run("terrain-test", announce=False) as run:
        run.log_metrics({"count": 10**400, "neg": -10**400, "ok": 1.0})
    logged = mlflow.MlflowClient(tracking_uri=tracking_uri()).get_run(run.run_id)
    assert logged.data.metrics == {"ok": 1.0}
    assert logged.data.tags["non_finite_metrics"] == "count,neg"


_SLOW_COMMAND = '''
import sys, time, types
import terrain.cli as cli
from terrain.tracking import tracked_run

module = types.ModuleType("slow_pipeline")
module.__doc__ = "A command that opens a run and works for a while."
module.add_arguments = lambda parser: None


def main(args):
    with tracked_run("terrain-test", run_name="slow"):
        time.sleep(120)
    return 0


module.main = main
sys.modules["slow_pipeline"] = module
cli.SUBCOMMANDS = {"slow": "slow_pipeline"}
sys.exit(cli.main(["slow"]))
'''


@pytest.mark.slow
def test_a_command_stopped_by_sigterm_ends_its_run_failed_in_one_line(tmp_path):
    # SIGTERM (kill, timeout, a job scheduler) ended the process where it stood: the run
    # stayed RUNNING in the store for ever and the command said nothing
    import signal
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "MLFLOW_TRACKING_URI"}
    proc = subprocess.Popen([sys.executable, "-c", _SLOW_COMMAND], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()         # the run is announced once it is open
        assert "MLflow run" in line
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 143
    assert "terrain slow: terminated" in err and "Traceback" not in err
    run_id = line.split()[2]
    client = mlflow.MlflowClient(tracking_uri=f"sqlite:///{tmp_path / 'mlflow.db'}")
    assert client.get_run(run_id).info.status == "FAILED"
