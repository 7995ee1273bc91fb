"""Global state and concurrency of the serving code (review svc26): what a call leaves
behind in the process, and two threads using one context or model at once."""

from __future__ import annotations

import copy
import os
import threading
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from terrain.serving import pyfunc, served
from terrain.serving.served import ServedInputError, is_long
from tests.threads import at_once

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


def test_concurrent_requests_in_both_lanes_answer_as_one_at_a_time(served_wheels,
                                                                   unseen_wheel_request,
                                                                   monkeypatch):
    # the scoring server runs each request in a thread of its own: short requests and a
    # long one (its own lane, so run at the same time) share one loaded model; every
    # answer must be what the request gets alone, and the model's settings unchanged
    # (the fixture's run is 10 s long: a request of more than 7 s takes the long lane)
    monkeypatch.setattr(served, "LONG_REQUEST_S", 7.0)
    short = [unseen_wheel_request(s) for s in (4.0, 5.0, 6.0)]
    bad = short[1].copy()
    bad.loc[4, "t_s"] = np.nan
    long = unseen_wheel_request(12.0)
    assert is_long(long) and not is_long(short[0])
    requests = [*short, long, bad]
    alone = [_answer(served_wheels, r) for r in requests]
    settings = copy.deepcopy(served_wheels.settings)
    for _ in range(3):
        _concurrently(served_wheels, requests, alone)
    assert served_wheels.settings == settings


def _concurrently(model, requests, alone):
    """Each request sent twice at once, in threads started together, answered as alone."""
    got = at_once(len(requests) * 2, lambda i: _answer(model, requests[i % len(requests)]),
                  timeout_s=60)
    for i, answer in enumerate(got):
        expected = alone[i % len(requests)]
        if isinstance(expected, str):
            assert answer == expected
        else:
            pd.testing.assert_frame_equal(answer, expected)


def _answer(model, frame):
    """The served answer to ``frame``, or the refusal's message."""
    try:
        return model.predict(None, frame.copy() if isinstance(frame, pd.DataFrame) else frame)
    except ServedInputError as exc:
        return exc.message


@pytest.mark.parametrize("empty_before", [False, True])
def test_a_model_directory_written_meanwhile_by_another_save_is_refused_and_kept(
        tmp_path, empty_before):
    # two saves of one path at once (two processes): both found it absent (or empty), the
    # other finished first; this one failed with a bare OSError (Directory not empty)
    from terrain.errors import ConfigError
    from terrain.serving.model import new_model_directory

    path = tmp_path / "model"
    if empty_before:
        path.mkdir()
    with pytest.raises(ConfigError, match="model directory .* exists and is not empty"):
        with new_model_directory(path) as stage:
            stage.mkdir()
            (stage / "MLmodel").write_text("mine")
            path.mkdir(exist_ok=True)                    # the other save, done first
            (path / "MLmodel").write_text("theirs")
    assert (path / "MLmodel").read_text() == "theirs"
    assert [p.name for p in tmp_path.iterdir()] == ["model"]   # no staging left


def _process_state(loggers=None):
    """What a request must leave as it found it in the process (of the loggers named in
    ``loggers``, all when None: a first request may create others, as imports do)."""
    import logging
    import sys
    import warnings

    return (np.geterr(), np.get_printoptions(), list(warnings.filters), dict(os.environ),
            os.getcwd(), list(sys.path), logging.getLogger().level,
            {n: (lg.level, list(lg.handlers), list(lg.filters))
             for n, lg in logging.Logger.manager.loggerDict.items()
             if isinstance(lg, logging.Logger) and (loggers is None or n in loggers)},
            np.random.get_state()[1].tobytes(), threading.active_count())


def test_requests_leave_the_process_as_they_found_it(served_wheels, unseen_wheel_request):
    good = unseen_wheel_request(6.0)
    bad = good.copy()
    bad.loc[4:9, "t_s"] = np.nan                    # refused half-way (a burst)
    odd = good.assign(vel_l=good["vel_l"] * 1e3)    # refused by a run-level rule
    before = _process_state()       # before the first request too: a change made once
    for frame in (good, bad, odd, good.iloc[:3], "not a frame", good):
        _answer(served_wheels, frame)
        assert _process_state(before[7]) == before


def test_the_terrain_pyfunc_predicts_from_threads_at_once_as_alone(
        wheel_model, train_runs, borealtc_runs, tmp_path):
    # the terrain predict pyfunc, served by MLflow, loads its pipeline on the first predict
    # when load_context has not run: threads started together on a fresh model (each may
    # load it) and on a loaded one answer as one at a time
    import joblib

    from terrain.serving.pyfunc import TerrainModel, runs_to_model_input

    path = tmp_path / "pipeline.joblib"
    joblib.dump(wheel_model.pipeline, path)
    w = wheel_model.window
    config = {"channels": list(wheel_model.channels), "classes": list(wheel_model.classes),
              "window": {"window_s": w.window_s, "hop_s": None, "rate_hz": w.rate_hz}}
    context = SimpleNamespace(model_config=config, artifacts={"pipeline": str(path)})
    seen = {r.run_id for r in train_runs}
    runs = [r for r in borealtc_runs if r.run_id not in seen][:3]
    inputs = [runs_to_model_input([r], wheel_model.channels, w.rate_hz)[0] for r in runs]
    alone = [_loaded(context).predict(context, x.copy()) for x in inputs]
    assert all(len(a) for a in alone)
    for model in (TerrainModel(), _loaded(context)):
        got = at_once(3 * len(inputs),
                      lambda i, model=model: model.predict(context,
                                                           inputs[i % len(inputs)].copy()),
                      timeout_s=60)
        for i, answer in enumerate(got):
            pd.testing.assert_frame_equal(answer, alone[i % len(inputs)])
            assert answer.attrs == alone[i % len(inputs)].attrs


def _loaded(context):
    """A terrain pyfunc loaded from ``context``."""
    from terrain.serving.pyfunc import TerrainModel

    model = TerrainModel()
    model.load_context(context)
    return model
