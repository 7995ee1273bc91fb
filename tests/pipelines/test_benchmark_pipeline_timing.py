"""pipelines/benchmark.py (``terrain benchmark``): what its figures time (data and CV stubbed)."""

from __future__ import annotations

import argparse
import time
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

import pipelines.benchmark as benchmark


class _Windows(SimpleNamespace):
    def __len__(self):
        return len(self.X)


class _Clock:
    """The benchmark's ``time`` module with a clock that only the stubs' sleeps advance: the
    figures are then the seconds the stubs stand for, exactly, however loaded the machine
    (real sleeps of 8 ms took 20 ms on a busy 2-core machine and failed a 50 % tolerance)."""

    def __init__(self):
        self.now_s = 0.0

    def perf_counter(self) -> float:
        return self.now_s

    def sleep(self, seconds: float) -> None:
        self.now_s += seconds

    def __getattr__(self, name):
        return getattr(time, name)


def _stub(monkeypatch, logged_metrics, reference_s: list[float], ours_s: float = 0.001,
          load_s: float = 0.0, reference_offset: float = 0.0) -> dict:
    """Shipped data, windows, features and CV stubbed; ``reference_features`` takes the
    seconds of ``reference_s`` in turn (the last one from then on) and returns ours plus
    ``reference_offset``; reading the data takes ``load_s``."""
    logged = logged_metrics(vars(benchmark))
    clock = _Clock()
    monkeypatch.setattr(benchmark, "time", clock)
    ws = _Windows(X=np.zeros((8, 2, 4)), channels=("a", "b"), rate_hz=10.0)
    calls = iter(reference_s)
    last = [reference_s[-1]]

    def reference(X, channels, rate_hz):
        last[0] = next(calls, last[0])
        clock.sleep(last[0])
        return np.full((len(X), 3), reference_offset)

    def transform(X):
        clock.sleep(ours_s)
        return np.zeros((len(X), 3))

    report = SimpleNamespace(pooled=pd.DataFrame({"accuracy": [0.9]}))
    monkeypatch.setattr(benchmark, "load_dataset", lambda name: clock.sleep(load_s) or [])
    monkeypatch.setattr(benchmark, "make_windows", lambda runs, signals, config: ws)
    monkeypatch.setattr(benchmark, "feature_extractor",
                        lambda w: SimpleNamespace(transform=transform))
    monkeypatch.setattr(benchmark, "reference_features", reference)
    monkeypatch.setattr(benchmark, "run_cv",
                        lambda config, runs: SimpleNamespace(report=report))
    return logged


def test_the_reference_is_timed_by_the_same_best_of_repeats_rule_as_ours(monkeypatch, capsys,
                                                                         logged_metrics):
    # ours was the best of --repeats, the reference one call, the process's first (scipy's
    # lazy imports and cold caches included): a first call 10x the best one inflated the
    # speed-up 10x; the best call counts, not the last
    logged = _stub(monkeypatch, logged_metrics, [0.5, 0.05, 0.2], ours_s=0.005)
    assert benchmark.main(argparse.Namespace(reference_windows=4, repeats=3)) == 0
    assert logged["reference_s_per_window"] == pytest.approx(0.05 / 4, rel=0.5)
    assert logged["speedup_vs_reference"] < 20
    assert logged["speedup_vs_reference"] == pytest.approx(
        logged["reference_s_per_window"] / logged["ours_s_per_window"])
    assert "speedup_vs_reference" in capsys.readouterr().out


def test_per_window_figures_divide_by_the_windows_timed(monkeypatch, capsys, logged_metrics):
    # --reference-windows above the windows held: both are timed on all 8, per window
    logged = _stub(monkeypatch, logged_metrics, [0.08], ours_s=0.008)
    assert benchmark.main(argparse.Namespace(reference_windows=300, repeats=1)) == 0
    assert "hold 8 windows" in capsys.readouterr().out
    assert logged["reference_s_per_window"] == pytest.approx(0.01, rel=0.5)
    assert logged["ours_s_per_window"] == pytest.approx(0.001, rel=0.5)
    assert logged["n_windows"] == 8 and logged["n_features"] == 3
    assert logged["max_abs_diff_vs_reference"] == 0.0
    assert logged["combined_accuracy"] == pytest.approx(0.9)


def test_the_data_pass_with_and_without_the_readers(monkeypatch, capsys, logged_metrics):
    # windows_and_features_s leaves the readers out, readers_windows_features_s (the < 10 s
    # target) counts them; load_s is the first, cold read
    logged = _stub(monkeypatch, logged_metrics, [0.001], ours_s=0.001, load_s=0.05)
    assert benchmark.main(argparse.Namespace(reference_windows=4, repeats=2)) == 0
    assert logged["load_s"] >= 0.05
    assert logged["windows_and_features_s"] < 0.04
    assert logged["readers_windows_features_s"] >= 0.05 + logged["windows_and_features_s"]


@pytest.mark.parametrize("offset", [0.25, -0.25])
def test_the_largest_difference_to_the_reference_is_absolute(monkeypatch, capsys, offset,
                                                             logged_metrics):
    logged = _stub(monkeypatch, logged_metrics, [0.001], reference_offset=offset)
    assert benchmark.main(argparse.Namespace(reference_windows=4, repeats=1)) == 0
    assert logged["max_abs_diff_vs_reference"] == pytest.approx(0.25)
