"""State of the ``terrain`` entry point (aud24): a command run in-process, failing or not,
leaves the process as it found it (environment, working folder, warnings, SIGTERM)."""

from __future__ import annotations

import os
import signal
import warnings

import pytest

from terrain import cli
from terrain.errors import ConfigError, DataWarning


def _process_state():
    return (dict(os.environ), os.getcwd(), warnings.showwarning, list(warnings.filters),
            signal.getsignal(signal.SIGTERM))


@pytest.mark.parametrize("fails", [False, True])
def test_a_command_run_in_process_leaves_the_process_as_it_was(monkeypatch, tmp_path,
                                                               capsys, fails):
    from pipelines import slip_table

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    # MLflow as in a fresh process (an earlier test of the suite may have set its
    # process-wide URI, which the entry point then sets, and MLflow exports, by design:
    # terrain.tracking.activate_store)
    from mlflow.tracking._tracking_service import utils as mlflow_tracking
    monkeypatch.setattr(mlflow_tracking, "_tracking_uri", None)
    seen = []

    def command(args):
        warnings.warn("assumed 100 Hz", DataWarning)
        seen.append(signal.getsignal(signal.SIGTERM))
        if fails:
            raise ConfigError("refused")
        return 0

    monkeypatch.setattr(slip_table, "main", command)
    cli.build_parser()   # (the first import of MLflow adds its own warnings filters)
    before = _process_state()
    for _ in range(2):   # the same command twice: the same answer
        assert cli.main(["slip-table"]) == (2 if fails else 0)
        assert _process_state() == before
    err = capsys.readouterr().err
    assert err.count("terrain: warning: assumed 100 Hz") == 2
    # the command itself ran under the entry point's SIGTERM handler
    assert seen and all(h is not before[-1] for h in seen)
