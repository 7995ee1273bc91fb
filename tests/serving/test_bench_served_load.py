"""benchmarks/bench_served_load.py: the request bodies it sends (no server started)."""

from __future__ import annotations

import json
import runpy
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from terrain.run import TIME

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "bench_served_load.py"


@pytest.fixture(scope="module")
def script():
    return runpy.run_path(str(SCRIPT))


def _run(run_id: str, seconds: float, rate_hz: float = 10.0):
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    frame = pd.DataFrame({TIME: t, "vel_l": np.ones_like(t), "vel_r": np.ones_like(t)})
    return SimpleNamespace(run_id=run_id, duration_s=seconds, streams={"wheels": frame})


def _rows(body: bytes) -> pd.DataFrame:
    split = json.loads(body)["dataframe_split"]
    return pd.DataFrame(split["data"], columns=split["columns"])


def test_long_bodies_repeat_a_run_up_to_the_byte_limit(script):
    runs = [_run("long", 100.0), _run("short", 20.0)]
    one = len(script["long_bodies"](runs, ("wheels",), 1, 10 ** 9, max_span_s=101.0)[0])
    (body,) = script["long_bodies"](runs, ("wheels",), 1, int(3.5 * one))
    assert len(body) <= 3.5 * one
    rows = _rows(body)
    assert len(rows) == 3 * 1000                  # the longest run, three times
    # on one clock: each copy shifted by the run's span plus 1 s
    assert rows[TIME].is_monotonic_increasing
    assert rows[TIME].iloc[-1] == pytest.approx(2 * 100.9 + 99.9)


def test_a_run_longer_than_the_limit_is_sent_once(script):
    (body,) = script["long_bodies"]([_run("long", 100.0)], ("wheels",), 1, 10)
    assert len(_rows(body)) == 1000


def test_request_bodies_slice_the_stream_they_say(script):
    bodies = script["request_bodies"]([_run("r", 60.0)], ("wheels",), 4.0, 5)
    assert len(bodies) == 5
    for body in bodies:
        rows = _rows(body)
        assert len(rows) in (40, 41)              # 4 s at 10 Hz
        assert set(rows["stream"]) == {"wheels"}


def test_a_request_longer_than_every_run_is_a_usage_error(script, monkeypatch, capsys):
    # `--request-s 600`: no run was long enough to slice, and rng.integers(0) ended in
    # "ValueError: high <= 0"
    env = script["main"].__globals__
    monkeypatch.setitem(env, "load_dataset", lambda name: [_run("r", 60.0)])
    monkeypatch.setitem(env, "load_stream_model",
                        lambda path: SimpleNamespace(window=SimpleNamespace(window_s=2.0)))
    monkeypatch.setitem(env, "model_stream_names", lambda model: ("wheels",))
    monkeypatch.setattr(sys, "argv", ["bench_served_load.py", "--model", "m", "--request-s",
                                      "600", "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    assert "--request-s" in capsys.readouterr().err


def test_the_in_process_reference_decides_each_body_once_on_its_frame(script, monkeypatch):
    import mlflow.pyfunc

    seen = []

    class Model:
        def predict(self, frame):
            seen.append(frame)

    monkeypatch.setattr(mlflow.pyfunc, "load_model", lambda path: Model())
    bodies = script["request_bodies"]([_run("r", 60.0)], ("wheels",), 4.0, 3)
    latencies = script["in_process_latencies"](Path("m"), bodies)
    assert latencies.shape == (3,) and np.all(latencies >= 0)
    assert len(seen) == 4                         # one warm-up, then each body once
    for frame, body in zip(seen[1:], bodies):
        pd.testing.assert_frame_equal(frame, _rows(body))
    assert script["in_process_latencies"](Path("m"), []).shape == (0,)


def test_a_run_too_short_for_a_request_is_never_sliced(script):
    short = _run("short", 3.0)
    short.streams["wheels"]["vel_l"] = 2.0
    bodies = script["request_bodies"]([short, _run("long", 60.0)], ("wheels",), 4.0, 20)
    for body in bodies:
        rows = _rows(body)
        assert len(rows) in (40, 41) and set(rows["vel_l"]) == {1.0}


def test_served_and_in_process_figures_in_ms_and_requests_per_second(script, monkeypatch,
                                                                     capsys, logged_metrics):
    # the served requests answered in 10, 20, ..., 80 ms (after a warm-up of 1 s), every
    # in-process decision 2 ms (500 req/s)
    import threading

    env = script["main"].__globals__
    logged = logged_metrics(env)
    lock, answered = threading.Lock(), []

    def post(url, body):
        with lock:
            answered.append(url)
            return True, (0.010 * (len(answered) - 1) if len(answered) > 1 else 1.0)
    monkeypatch.setitem(env, "load_dataset", lambda name: [_run("r", 60.0)])
    monkeypatch.setitem(env, "load_stream_model",
                        lambda path: SimpleNamespace(window=SimpleNamespace(window_s=2.0)))
    monkeypatch.setitem(env, "model_stream_names", lambda model: ("wheels",))
    monkeypatch.setitem(env, "is_served_model", lambda path: True)
    proc = SimpleNamespace(terminate=lambda: None, wait=lambda timeout: 0)
    monkeypatch.setitem(env, "_serve", lambda model_dir, served_out=None: (proc, "http://x"))
    monkeypatch.setitem(env, "_post", post)
    monkeypatch.setitem(env, "in_process_latencies",
                        lambda model_dir, bodies: np.full(len(bodies), 0.002))
    monkeypatch.setattr(sys, "argv", ["bench_served_load.py", "--kind", "wheels", "--model",
                                      "m", "--requests", "8", "--reference", "4"])
    assert script["main"]() == 0
    assert logged["served_requests"] == 8 and logged["served_errors"] == 0
    assert logged["served_p50_ms"] == pytest.approx(45.0)
    assert logged["served_p99_ms"] == pytest.approx(79.3)
    assert logged["served_throughput_rps"] == pytest.approx(8 / logged["served_wall_s"])
    assert logged["inprocess_p50_ms"] == pytest.approx(2.0)
    assert logged["inprocess_throughput_rps"] == pytest.approx(500.0)
    assert logged["served_over_inprocess_p50"] == pytest.approx(22.5)
    assert logged["served_over_inprocess_throughput"] == pytest.approx(
        logged["served_throughput_rps"] / 500.0)
    assert "served / in-process" in capsys.readouterr().out


def test_a_model_directory_that_is_no_model_is_a_usage_error(script, monkeypatch, capsys,
                                                             tmp_path):
    # `--model /nonexistent` was load_stream_model's ConfigError traceback
    env = script["main"].__globals__
    monkeypatch.setitem(env, "load_dataset", lambda name: [_run("r", 60.0)])
    monkeypatch.setattr(sys, "argv", ["bench_served_load.py", "--kind", "wheels", "--model",
                                      str(tmp_path / "none"), "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "argument --model" in err and "does not exist" in err


def test_a_model_given_by_folder_chooses_the_streams_sent(script, monkeypatch, capsys,
                                                          logged_metrics):
    # `--model DIR` of an all-signal model sent only the wheels stream of `--kind`'s default
    # recipe: every request lacked the IMU channels and counted as an error
    env = script["main"].__globals__
    logged = logged_metrics(env)
    sent = []
    run = _run("r", 60.0)
    run.streams["imu"] = run.streams["wheels"]
    monkeypatch.setitem(env, "load_dataset", lambda name: [run])
    model = SimpleNamespace(window=SimpleNamespace(window_s=2.0))
    monkeypatch.setitem(env, "load_stream_model", lambda path: model)
    monkeypatch.setitem(env, "model_stream_names",
                        lambda m: ("imu", "wheels") if m is model else ())
    monkeypatch.setitem(env, "request_bodies",
                        lambda runs, streams, request_s, n: sent.append(streams) or ["b"] * n)
    monkeypatch.setitem(env, "is_served_model", lambda path: True)
    proc = SimpleNamespace(terminate=lambda: None, wait=lambda timeout: 0)
    monkeypatch.setitem(env, "_serve", lambda model_dir, served_out=None: (proc, "http://x"))
    monkeypatch.setitem(env, "_post", lambda url, body: (True, 0.01))
    monkeypatch.setitem(env, "in_process_latencies", lambda model_dir, bodies: np.array([]))
    monkeypatch.setattr(sys, "argv", ["bench_served_load.py", "--model", "m", "--requests",
                                      "3", "--reference", "0"])
    assert script["main"]() == 0
    assert sent == [("imu", "wheels")]
    assert "served model m (2 s windows): 3 requests" in capsys.readouterr().out
    assert logged["served_requests"] == 3


def test_model_stream_names_are_the_streams_of_the_model_channels(wheel_model, all_model):
    from terrain.serving.evaluation import model_stream_names

    assert model_stream_names(wheel_model) == ("wheels",)
    assert model_stream_names(all_model) == ("imu", "wheels")
