"""What the ``terrain`` entry point leaves in the process (cli25): a command run in-process
from a folder whose name MLflow writes quoted (a space: ``My Robots``) left
``MLFLOW_TRACKING_URI`` set, so the next command, from another folder, logged to the
first folder's store."""

from __future__ import annotations

import os

import pytest

from terrain import cli
from terrain.errors import ConfigError
from terrain.tracking import tracking_uri


@pytest.mark.parametrize("fails", [False, True])
@pytest.mark.parametrize("name", ["My Robots", "runs#1", "été"])
def test_the_next_command_from_another_folder_uses_that_folders_store(monkeypatch, tmp_path,
                                                                      capsys, name, fails):
    from mlflow.tracking._tracking_service import utils as mlflow_tracking

    from pipelines import slip_table

    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    monkeypatch.setattr(mlflow_tracking, "_tracking_uri", None)   # as in a fresh process
    seen = []

    def command(args):
        seen.append(tracking_uri())
        if fails:
            raise ConfigError("refused")
        return 0

    monkeypatch.setattr(slip_table, "main", command)
    first, second = tmp_path / name, tmp_path / "other"
    for folder in (first, second):
        folder.mkdir()
        monkeypatch.chdir(folder)
        assert cli.main(["slip-table"]) == (2 if fails else 0)
        assert "MLFLOW_TRACKING_URI" not in os.environ
    capsys.readouterr()
    assert seen == [f"sqlite:///{first / 'mlflow.db'}", f"sqlite:///{second / 'mlflow.db'}"]


# terrain.tracking.activate_store set MLflow's process-wide tracking URI and nothing put it
# back: the caller's mlflow.get_tracking_uri() named the first folder's store from any folder
def test_mlflows_process_wide_store_is_as_the_caller_left_it(monkeypatch, tmp_path, capsys):
    import mlflow
    from mlflow.tracking._tracking_service import utils as mlflow_tracking

    from pipelines import slip_table

    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    monkeypatch.setattr(mlflow_tracking, "_tracking_uri", None)   # as in a fresh process
    monkeypatch.setattr(slip_table, "main", lambda args: 0)
    first, second = tmp_path / "My Robots", tmp_path / "other"
    first.mkdir()
    second.mkdir()
    monkeypatch.chdir(first)
    assert cli.main(["slip-table"]) == 0
    monkeypatch.chdir(second)
    try:
        assert mlflow.get_tracking_uri() == f"sqlite:///{second / 'mlflow.db'}"
    finally:
        mlflow_tracking._tracking_uri = None


def test_two_commands_run_at_once_in_threads_leave_pythons_warning_printer(monkeypatch,
                                                                           capsys):
    # each call saved and put back the warnings' state on its own: the later call put back
    # what it had found (the earlier's one-line printer), installed for good
    import threading
    import time
    import warnings

    from pipelines import slip_table
    from terrain.errors import DataWarning

    def command(args):
        time.sleep(0.05)
        warnings.warn("assumed 100 Hz", DataWarning)
        return 0

    monkeypatch.setattr(slip_table, "main", command)
    cli.build_parser()   # (the first import of MLflow adds its own warnings filters)
    before = (warnings.showwarning, list(warnings.filters))
    for delay in (0.0, 0.02, 0.04):
        threads = [threading.Thread(target=cli.main, args=(["slip-table"],))
                   for _ in range(2)]
        threads[0].start()
        time.sleep(delay)
        threads[1].start()
        for t in threads:
            t.join()
        assert (warnings.showwarning, list(warnings.filters)) == before
    # (Python prints a warning once per line of code while one warnings state lasts: the
    # two calls of a round, at once, share one)
    assert capsys.readouterr().err.count("terrain: warning: assumed 100 Hz") >= 3


def test_two_commands_at_once_from_a_quoted_folder_leave_the_variable_unset(monkeypatch,
                                                                            tmp_path):
    # each call put back the variable as it had found it: the later one found the
    # earlier's export and put it back, for good
    import threading
    import time

    from mlflow.tracking._tracking_service import utils as mlflow_tracking

    from pipelines import slip_table

    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    monkeypatch.setattr(mlflow_tracking, "_tracking_uri", None)
    monkeypatch.setattr(slip_table, "main", lambda args: time.sleep(0.05) or 0)
    cli.build_parser()
    folder = tmp_path / "My Robots"
    folder.mkdir()
    monkeypatch.chdir(folder)
    threads = [threading.Thread(target=cli.main, args=(["slip-table"],)) for _ in range(2)]
    threads[0].start()
    time.sleep(0.02)
    threads[1].start()
    for t in threads:
        t.join()
    assert "MLFLOW_TRACKING_URI" not in os.environ


def test_a_command_still_running_when_another_ends_keeps_the_one_line_warnings(
        monkeypatch, capsys):
    import threading
    import time
    import warnings

    from pipelines import slip_table
    from terrain.errors import DataWarning

    def command(args):
        if threading.current_thread().name == "long":
            time.sleep(0.15)    # the short call ends meanwhile
            warnings.warn("long call's note", DataWarning)
        return 0

    monkeypatch.setattr(slip_table, "main", command)
    cli.build_parser()
    threads = [threading.Thread(target=cli.main, args=(["slip-table"],), name=name)
               for name in ("long", "short")]
    threads[0].start()
    time.sleep(0.05)
    threads[1].start()
    for t in threads:
        t.join()
    assert "terrain: warning: long call's note" in capsys.readouterr().err
