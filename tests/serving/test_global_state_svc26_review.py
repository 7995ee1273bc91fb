"""Global state and concurrency of the serving code (review svc26): what a call leaves
behind in the process, and two threads using one context or model at once."""

from __future__ import annotations

import os
import threading

import pytest

from terrain.serving import pyfunc

KEY = "MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR"


@pytest.fixture
def no_key(monkeypatch):
    monkeypatch.delenv(KEY, raising=False)


def test_artifact_progress_restores_after_overlapping_threads(no_key):
    # two loads hiding the bars in two threads, the first leaving before the second: the
    # second set the variable it found ("false", the first's) back on exit, for ever
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def first():
        with pyfunc.artifact_progress(False):
            a_in.set()
            b_in.wait(5)
        a_out.set()

    def second():
        a_in.wait(5)
        with pyfunc.artifact_progress(False):
            b_in.set()
            a_out.wait(5)
            seen["inside"] = os.environ.get(KEY)   # the first left: still hidden here

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert seen["inside"] == "false"
    assert KEY not in os.environ


def test_artifact_progress_restores_a_set_value_on_failure(monkeypatch):
    monkeypatch.setenv(KEY, "true")
    with pytest.raises(RuntimeError):
        with pyfunc.artifact_progress(False):
            assert os.environ[KEY] == "false"
            raise RuntimeError("download failed")
    assert os.environ[KEY] == "true"


def test_artifact_progress_many_threads(no_key):
    barrier = threading.Barrier(8)
    errors = []

    def work():
        try:
            barrier.wait(5)
            for _ in range(200):
                with pyfunc.artifact_progress(False):
                    if os.environ.get(KEY) != "false":
                        errors.append(os.environ.get(KEY))
        except Exception as exc:   # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert errors == []
    assert KEY not in os.environ
