"""benchmarks/bench_serving.py: what its latency and soak figures count (no model trained)."""

from __future__ import annotations

import dataclasses
import runpy
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "bench_serving.py"


@pytest.fixture
def script():
    return runpy.run_path(str(SCRIPT))


@dataclasses.dataclass(frozen=True)
class _Model:
    pipeline: object
    classes: tuple = ("A", "B")
    channels: tuple = ("c",)
    window: object = dataclasses.field(
        default_factory=lambda: SimpleNamespace(window_s=2.0, rate_hz=10.0))


class _Pipeline:
    classes_ = np.array(["A", "B"])

    def predict_proba(self, X):
        return np.full((len(X), 2), 0.5)


class _Service:
    """One decision per push; each push calls the model's pipeline as the service does."""

    def __init__(self, model, targets, config):
        self.model = model

    def push(self, stream, t, v):
        self.model.pipeline.predict_proba(np.zeros((1, 1, 1)))
        return [object()]


def _fake(script, monkeypatch, n_pushes: int, rss=None):
    env = script["latency"].__globals__
    monkeypatch.setitem(env, "StreamService", _Service)
    monkeypatch.setitem(env, "CataloguePeakTargets", lambda classes: None)
    monkeypatch.setitem(env, "make_windows",
                        lambda *a, **k: SimpleNamespace(X=np.zeros((3, 1, 1))))
    monkeypatch.setitem(env, "_pushes", lambda svc, run: (
        ("wheels", np.array([10.0 * k]), {"c": np.zeros(1)}) for k in range(n_pushes)))
    if rss is not None:
        memory = iter(rss)
        process = SimpleNamespace(memory_info=lambda: SimpleNamespace(rss=next(memory)))
        monkeypatch.setitem(env, "psutil", SimpleNamespace(Process=lambda: process))


def test_the_warm_up_decisions_are_not_timed(script, monkeypatch):
    _fake(script, monkeypatch, 12)
    out = script["latency"](_Model(_Pipeline()), None, 5)
    assert {k: len(v) for k, v in out.items()} == {"decision": 7, "in_decision": 7, "hot": 7,
                                                   "reference": 7}
    assert (out["in_decision"] > 0).all()       # the pipeline call inside each decision


def test_memory_growth_counts_only_after_the_first_two_minutes(script, monkeypatch):
    # a sample every 10 s of stream (one push each, sample_every=1): RSS climbs 1 MiB a
    # sample for the first 2 min (warm-up: caches, buffers), then stays flat
    mib = 2 ** 20
    rss = [100 * mib + min(k, 12) * mib for k in range(31)]
    _fake(script, monkeypatch, 31, rss)
    result = script["soak"](_Model(_Pipeline()), None, sample_every=1)
    assert result["stream_s"] == pytest.approx(300.0)
    assert result["decisions"] == 31
    assert result["rss_peak_mb"] == pytest.approx(112.0)
    assert result["rss_after_2min_mb"] == pytest.approx(112.0)
    assert result["rss_growth_mb"] == pytest.approx(0.0)


def test_a_warm_up_longer_than_the_run_is_a_usage_error(script, monkeypatch, capsys):
    # every decision of the run was warm-up: np.percentile of nothing was an IndexError
    env = script["main"].__globals__
    monkeypatch.setitem(env, "fit_stream_model", lambda *a, **k: _Model(_Pipeline()))
    run = SimpleNamespace(run_id="r", duration_s=60.0, streams={"imu": 0, "wheels": 0})
    monkeypatch.setitem(env, "load_dataset", lambda name: [run])
    monkeypatch.setitem(env, "latency", lambda model, run, warmup: {
        k: np.array([]) for k in ("decision", "in_decision", "hot", "reference")})
    monkeypatch.setattr(sys, "argv", ["bench_serving.py", "--warmup", "5000", "--minutes", "0",
                                      "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    assert "--warmup" in capsys.readouterr().err


def test_latency_figures_are_percentiles_in_ms_of_the_paired_times(script, monkeypatch,
                                                                   capsys, logged_metrics):
    # decisions of 1, 2, ..., 101 ms; the pipeline inside each half of it, the same pipeline
    # right after 1 ms, the reference 0.1 ms
    env = script["main"].__globals__
    logged = logged_metrics(env)
    decision = np.arange(1, 102) / 1e3
    monkeypatch.setitem(env, "fit_stream_model", lambda *a, **k: _Model(_Pipeline()))
    run = SimpleNamespace(run_id="r", duration_s=60.0, streams={"imu": 0, "wheels": 0})
    monkeypatch.setitem(env, "load_dataset", lambda name: [run])
    monkeypatch.setitem(env, "latency", lambda model, run, warmup: {
        "decision": decision, "in_decision": decision / 2,
        "hot": np.full(101, 1e-3), "reference": np.full(101, 1e-4)})
    monkeypatch.setitem(env, "pipeline_parts", lambda model, run: {})
    monkeypatch.setattr(sys, "argv", ["bench_serving.py", "--minutes", "0"])
    assert script["main"]() == 0
    expected = {"decision_p50_ms": 51.0, "decision_p99_ms": 100.0, "decision_max_ms": 101.0,
                "decisions_timed": 101, "pipeline_p50_ms": 1.0, "pipeline_p99_ms": 1.0,
                "service_overhead_p50_ms": 50.0, "service_overhead_p99_ms": 99.0,
                "pipeline_in_decision_p50_ms": 25.5, "pipeline_in_decision_p99_ms": 50.0,
                "service_own_p50_ms": 25.5, "service_own_p99_ms": 50.0,
                "reference_p50_ms": 0.1, "reference_p99_ms": 0.1,
                "decision_p50_over_reference": 510.0, "decision_p99_over_reference": 1000.0}
    assert logged == pytest.approx(expected)
    assert "p99 100.000 ms" in capsys.readouterr().out


def test_a_push_that_completes_several_decisions_or_none_is_not_timed(script, monkeypatch):
    # a push completing two decisions (a catch-up after a gap) times two decisions' work
    # as one: neither it nor a push completing none is a decision's latency
    _fake(script, monkeypatch, 9)
    decisions = iter([1, 0, 2, 1, 1, 2, 0, 1, 1])

    class Service(_Service):
        def push(self, stream, t, v):
            self.model.pipeline.predict_proba(np.zeros((1, 1, 1)))
            return [object()] * next(decisions)

    monkeypatch.setitem(script["latency"].__globals__, "StreamService", Service)
    out = script["latency"](_Model(_Pipeline()), None, 1)
    assert len(out["decision"]) == 4            # 5 one-decision pushes, the first warm-up


def test_a_model_directory_that_is_no_model_is_a_usage_error(script, monkeypatch, capsys,
                                                             tmp_path):
    # `--model /nonexistent` was load_stream_model's ConfigError traceback
    env = script["main"].__globals__
    monkeypatch.setitem(env, "load_dataset", lambda name: [])
    monkeypatch.setattr(sys, "argv", ["bench_serving.py", "--model", str(tmp_path / "none"),
                                      "--minutes", "0", "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "argument --model" in err and "does not exist" in err


def test_a_model_given_by_folder_times_the_runs_holding_its_streams(
        script, monkeypatch, capsys, logged_metrics):
    # `--model DIR` of a wheel-only model kept the default all-signal recipe's streams: the
    # runs without an IMU were left out (here every run: max() of nothing, a ValueError)
    env = script["main"].__globals__
    logged = logged_metrics(env)
    timed = []
    model = _Model(_Pipeline())
    run = SimpleNamespace(run_id="r", duration_s=60.0, streams={"wheels": 0})
    monkeypatch.setitem(env, "load_dataset", lambda name: [run])
    monkeypatch.setitem(env, "load_stream_model", lambda path: model)
    monkeypatch.setitem(env, "model_stream_names", lambda m: ("wheels",))
    monkeypatch.setitem(env, "latency", lambda m, r, warmup: timed.append(r) or {
        k: np.full(3, 1e-3) for k in ("decision", "in_decision", "hot", "reference")})
    monkeypatch.setitem(env, "pipeline_parts", lambda m, r: {})
    monkeypatch.setattr(sys, "argv", ["bench_serving.py", "--model", "m", "--minutes", "0"])
    assert script["main"]() == 0
    assert timed == [run]
    assert capsys.readouterr().out.startswith("model m (1 channels")
    assert logged["decisions_timed"] == 3
