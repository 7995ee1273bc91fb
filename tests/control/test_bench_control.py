"""benchmarks/bench_control.py: the fastest-chunk timing and the inputs it times."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "bench_control.py"


@pytest.fixture
def script():
    return runpy.run_path(str(SCRIPT))


def test_best_per_step_is_the_fastest_whole_chunk_per_step(script, monkeypatch):
    clock = [0.0]
    env = script["_best_per_step"].__globals__
    monkeypatch.setitem(env, "_clock", lambda: clock[0])

    def step(cost):
        clock[0] += cost

    # chunks of 2: (3, 5) 4 per step, (1, 9) 5, (2, 2) 2; the odd last row is no chunk
    rows = [3.0, 5.0, 1.0, 9.0, 2.0, 2.0, 0.0]
    assert script["_best_per_step"](rows, step, 2) == pytest.approx(2.0)
    # one chunk of everything but the last row: 22 / 6
    assert script["_best_per_step"](rows, step, 6) == pytest.approx(22.0 / 6.0)
    # the last whole chunk counts: (2, 0.5) is the fastest
    assert script["_best_per_step"]([3.0, 5.0, 2.0, 0.5], step, 2) == pytest.approx(1.25)


def test_inputs_hold_the_slip_they_are_built_from(script):
    x = script["make_inputs"](500, 3, np.random.default_rng(0))
    assert x["omega"].shape == (500, 3) and x["a"].shape == (500, 3)
    r = script["WHEEL_RADIUS_M"]
    slip = np.clip(x["slip"], -0.5, 0.5)
    # SAE slip, both branches: (omega r - v) / (omega r) driving, (omega r - v) / v braking
    # (this test pinned omega r = v / (1 - slip) for every slip, the driving branch alone)
    assert (slip < 0).any() and (slip > 0).any()
    rim = x["omega"] * r
    sae = (rim - x["v_long"]) / np.maximum(np.abs(rim), np.abs(x["v_long"]))
    np.testing.assert_allclose(sae, slip, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(x["omega_ll"][:, 0] * r, x["chassis"])
    assert x["chassis"].min() > 0.1      # never standing: accelerate, cruise, brake


def test_a_short_run_logs_the_ratio_to_its_same_run_reference(script, monkeypatch, capsys,
                                                              logged_metrics):
    import sys

    logged = logged_metrics(script["main"].__globals__)
    monkeypatch.setattr(sys, "argv", ["bench_control.py", "--steps", "100", "--repeats", "1",
                                      "--chunk", "50"])
    assert script["main"]() == 0
    for name in ("agrimaro", "husky", "four_wheels"):
        for sfx in ("", "_wall"):
            assert logged[f"{name}_over_simple_pid{sfx}"] == pytest.approx(
                logged[f"{name}_us_per_wheel{sfx}"]
                / logged[f"{name}_simple_pid_us_per_wheel{sfx}"])
    assert "x simple-pid" in capsys.readouterr().out
    # per wheel (per side for the Husky): the step's time over its units
    for name, units in (("agrimaro", 3), ("husky", 2), ("four_wheels", 4)):
        for sfx in ("", "_wall"):
            assert logged[f"{name}_us_per_wheel{sfx}"] == pytest.approx(
                logged[f"{name}_us_per_step{sfx}"] / units)


def test_per_wheel_and_per_step_figures_from_the_seconds_per_step(script, monkeypatch,
                                                                  logged_metrics):
    # seconds per step: ours 30 us, simple-pid (every wheel's PID) 6 us, sae_slip 5 us
    import sys

    env = script["main"].__globals__
    logged = logged_metrics(env)
    monkeypatch.setitem(env, "time_ours", lambda *a: 30e-6)
    monkeypatch.setitem(env, "time_simple_pid", lambda *a: 6e-6)
    monkeypatch.setitem(env, "time_sae_slip", lambda *a: 5e-6)
    monkeypatch.setattr(sys, "argv", ["bench_control.py", "--steps", "50", "--repeats", "1"])
    assert script["main"]() == 0
    for name, units in (("agrimaro", 3), ("husky", 2), ("four_wheels", 4)):
        assert logged[f"{name}_us_per_step"] == pytest.approx(30.0)
        assert logged[f"{name}_us_per_wheel"] == pytest.approx(30.0 / units)
        assert logged[f"{name}_simple_pid_us_per_wheel"] == pytest.approx(6.0 / units)
        assert logged[f"{name}_over_simple_pid"] == pytest.approx(5.0)
        assert logged[f"{name}_sae_slip_us_per_step"] == pytest.approx(5.0)


@pytest.mark.parametrize("steps, code", [(49, 2), (50, 0)])
def test_one_whole_chunk_is_enough(script, monkeypatch, capsys, logged_metrics, steps, code):
    import sys

    logged_metrics(script["main"].__globals__)
    monkeypatch.setattr(sys, "argv", ["bench_control.py", "--steps", str(steps), "--repeats",
                                      "1", "--chunk", "50"])
    if code:
        with pytest.raises(SystemExit) as stop:
            script["main"]()
        assert stop.value.code == code
        assert "--chunk" in capsys.readouterr().err
    else:
        assert script["main"]() == 0
