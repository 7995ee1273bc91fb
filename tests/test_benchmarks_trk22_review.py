"""Review trk22: a benchmark that logs to MLflow refuses a store it cannot use before its
work, and --no-mlflow neither checks nor touches a store."""

from __future__ import annotations

import importlib.util
import signal
import sys
from pathlib import Path

import pytest

from terrain.errors import ConfigError

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"
LOGGING = sorted(p for p in BENCHMARKS.glob("*.py") if "tracked_run" in p.read_text())
#: required options of a script (a folder under the test's tmp_path)
REQUIRED = {"ensemble_weights": ["--out", "{tmp}/out"], "unseen_runs": ["--out", "{tmp}/out"]}


class _Worked(Exception):
    """The script was still computing after the alarm: it did not check its store first."""


def _load(path):
    spec = importlib.util.spec_from_file_location(f"benchmark_trk22_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_logging_benchmark_is_listed():
    assert len(LOGGING) >= 20


@pytest.mark.parametrize("path", LOGGING, ids=[p.stem for p in LOGGING])
def test_a_store_that_keeps_nothing_stops_a_benchmark_before_its_work(path, tmp_path,
                                                                      monkeypatch):
    # MLFLOW_TRACKING_URI=sqlite:///:memory: (or a server that does not answer) was refused
    # by tracked_run only at the end: after the whole benchmark (minutes to hours)
    module = _load(path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", "sqlite:///:memory:")
    extra = [a.format(tmp=tmp_path) for a in REQUIRED.get(path.stem, [])]
    monkeypatch.setattr(sys, "argv", [path.name, *extra])

    def stop(signum, frame):
        raise _Worked(path.stem)

    previous = signal.signal(signal.SIGALRM, stop)
    signal.alarm(5)
    try:
        with pytest.raises(ConfigError, match="names no database file"):
            module.main()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert not list(tmp_path.iterdir())            # nothing written (no mlflow.db, no out)


def test_no_mlflow_neither_checks_nor_creates_a_store(tmp_path, monkeypatch, capsys):
    # --no-mlflow: an unusable store is not looked at, and no mlflow.db appears
    module = _load(BENCHMARKS / "parked_creep.py")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", "sqlite:///:memory:")
    monkeypatch.setattr(sys, "argv", ["parked_creep.py", "--no-mlflow", "--seconds", "0.5",
                                      "--terrains", "ASPHALT"])
    assert module.main() == 0
    monkeypatch.delenv("MLFLOW_TRACKING_URI")
    assert module.main() == 0
    assert not list(tmp_path.iterdir())
