"""benchmarks/bench_ekf.py: its figures from the times it measures (nothing filtered)."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "bench_ekf.py"


def test_ratios_are_filterpy_time_over_ours_and_best_of_the_repeats(
        monkeypatch, capsys, logged_metrics):
    script = runpy.run_path(str(SCRIPT))
    env = script["main"].__globals__
    # seconds per 100 steps: numba 0.4 then 0.5 (the best counts, not the last), numpy 2.0,
    # pure 4.0, filterpy 2.0
    numba = iter([0.4, 0.5])
    monkeypatch.setitem(env, "bench_ours", lambda model, t, z, engine="numba":
                        next(numba) if engine == "numba" else 2.0)
    monkeypatch.setitem(env, "first_compiled_call", lambda *a: (0.1, "compiled"))
    monkeypatch.setitem(env, "bench_pure", lambda *a: 4.0)
    monkeypatch.setitem(env, "bench_filterpy", lambda *a: 2.0)
    monkeypatch.setitem(env, "simulate_agrimaro", lambda *a, **k: SimpleNamespace(run=None))
    monkeypatch.setitem(env, "data_driven_settings", lambda run: None)
    monkeypatch.setitem(env, "estimate_agrimaro",
                        lambda run, settings, engine: SimpleNamespace(t_s=np.zeros(1000)))
    logged = logged_metrics(env)
    monkeypatch.setattr(sys, "argv", ["bench_ekf.py", "--steps", "100", "--repeats", "2",
                                      "--minutes", "1"])
    assert script["main"]() == 0
    assert logged["ours_steps_per_s"] == pytest.approx(250.0)
    assert logged["filterpy_steps_per_s"] == pytest.approx(50.0)
    assert logged["ratio_ours_vs_filterpy"] == pytest.approx(5.0)      # 5x faster
    assert logged["ratio_reference_vs_filterpy"] == pytest.approx(1.0)
    assert logged["ratio_pure_vs_filterpy"] == pytest.approx(0.5)
    assert logged["ours_reference_steps_per_s"] == pytest.approx(50.0)
    assert logged["ours_pure_steps_per_s"] == pytest.approx(25.0)
    assert logged["long_run_steps"] == 1000.0
    assert "ratio ours / filterpy      5.00x" in capsys.readouterr().out


@pytest.mark.parametrize("minutes, named", [("1000", "7200"), ("0.0001", "agrimaro")])
def test_a_long_run_the_simulator_refuses_is_a_usage_error_before_any_timing(
        monkeypatch, capsys, minutes, named):
    # --minutes 1000 (60,000 s, past the simulator's 7200 s) was SimConfig's ConfigError
    # traceback once every timing of the steps had been run (minutes of them by default)
    script = runpy.run_path(str(SCRIPT))
    env = script["main"].__globals__
    timed = []
    for name in ("bench_ours", "bench_pure", "bench_filterpy", "first_compiled_call",
                 "_measurements"):
        monkeypatch.setitem(env, name, lambda *a, name=name, **k: timed.append(name))
    monkeypatch.setattr(sys, "argv", ["bench_ekf.py", "--steps", "100", "--minutes", minutes,
                                      "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--minutes" in err and named in err
    assert timed == []
