"""pipelines/reference_workload.py: the one reference workload the benchmarks time."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

import pipelines.reference_workload as workload

BENCHMARKS = Path(__file__).parents[2] / "benchmarks"


def test_the_median_of_the_runs_in_milliseconds(monkeypatch):
    times = iter([0.004, 0.001, 0.003, 0.002, 0.010])
    monkeypatch.setattr(workload, "sort_reference_s", lambda: next(times))
    assert workload.sort_reference_ms(5) == pytest.approx(3.0)


def test_one_run_sorts_the_fixed_input(monkeypatch):
    sorted_ = []
    monkeypatch.setattr(workload.np, "sort", lambda x: sorted_.append(x))
    assert workload.sort_reference_s() >= 0.0
    assert sorted_ == [workload.REFERENCE_INPUT]
    np.testing.assert_array_equal(workload.REFERENCE_INPUT,
                                  np.random.default_rng(0).standard_normal(4096))
    with pytest.raises(ValueError):             # nothing can change it between runs
        workload.REFERENCE_INPUT[0] = 0.0


def test_bench_sim_and_bench_serving_time_this_workload():
    # the same sort of 4096 floats was written out in both scripts
    sim = runpy.run_path(str(BENCHMARKS / "bench_sim.py"))
    serving = runpy.run_path(str(BENCHMARKS / "bench_serving.py"))
    assert sim["reference_ms"] is workload.sort_reference_ms
    assert serving["latency"].__globals__["sort_reference_s"] is workload.sort_reference_s
