"""benchmarks/bench_sim.py: what it times and what it logs (simulations stubbed or short)."""

from __future__ import annotations

import runpy
import sys
import time
from pathlib import Path

import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "bench_sim.py"


@pytest.fixture
def script():
    return runpy.run_path(str(SCRIPT))


def _main(script, monkeypatch, logged_metrics, argv: list[str], simulate=None) -> dict:
    env = script["main"].__globals__
    logged = logged_metrics(env)
    if simulate is not None:
        monkeypatch.setitem(env, "simulate", simulate)
    monkeypatch.setattr(sys, "argv", ["bench_sim.py", *argv])
    assert script["main"]() == 0
    return logged


def test_the_first_vehicle_does_not_pay_the_process_warm_up(script, monkeypatch, logged_metrics):
    # the process's first simulation carries one-off costs (lazy imports, numba caches):
    # 0.2-0.25 s here, 10 % of a 2-minute Husky run, charged to the Husky alone
    calls = []

    def simulate(cfg):
        time.sleep((0.3 if not calls else 0.0) + cfg.duration_s / 600.0)
        calls.append(cfg.vehicle)

    logged = _main(script, monkeypatch, logged_metrics, ["--minutes", "0.5"], simulate)
    per_min = [logged[f"{v}_s_per_sim_min"] for v in ("husky", "agrimaro", "tracked")]
    assert max(per_min) < 1.5 * min(per_min), per_min


def test_a_short_run_logs_cpu_time_and_the_reference_ratio(script, monkeypatch, capsys,
                                                           logged_metrics):
    logged = _main(script, monkeypatch, logged_metrics, ["--minutes", "0.02"])
    assert "reference" in capsys.readouterr().out
    assert logged["reference_ms"] > 0
    for vehicle in ("husky", "agrimaro", "tracked"):
        assert logged[f"{vehicle}_cpu_s_per_sim_min"] > 0
        assert logged[f"{vehicle}_over_reference"] == pytest.approx(
            1e3 * logged[f"{vehicle}_s_per_sim_min"] / logged["reference_ms"])


@pytest.mark.parametrize("minutes", ["0", "-1", "nan", "inf"])
def test_minutes_must_be_positive_and_finite(script, monkeypatch, capsys, minutes):
    # 0 and -1 were the simulator's ConfigError traceback, nan and inf another
    monkeypatch.setattr(sys, "argv", ["bench_sim.py", "--minutes", minutes, "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    assert "--minutes" in capsys.readouterr().err


def test_reference_and_cpu_time_are_per_call_and_per_simulated_minute(script, monkeypatch,
                                                                      logged_metrics):
    def busy(cfg):
        end = time.process_time() + cfg.duration_s / 6000.0
        while time.process_time() < end:
            pass

    monkeypatch.setitem(script["main"].__globals__, "reference_ms", lambda: 0.01)
    logged = _main(script, monkeypatch, logged_metrics, ["--minutes", "4"], busy)
    assert logged["reference_ms"] == pytest.approx(0.01)
    for vehicle in ("husky", "agrimaro", "tracked"):
        # one thread: its CPU time per simulated minute is at most the wall time's
        assert 0 < logged[f"{vehicle}_cpu_s_per_sim_min"] \
            <= 1.05 * logged[f"{vehicle}_s_per_sim_min"]
        assert logged[f"{vehicle}_over_reference"] == pytest.approx(
            1e5 * logged[f"{vehicle}_s_per_sim_min"])
        # simulated seconds per wall second
        assert logged[f"{vehicle}_realtime_factor"] == pytest.approx(
            60.0 / logged[f"{vehicle}_s_per_sim_min"])


def test_the_reference_is_the_mean_of_its_times_before_and_after(script, monkeypatch,
                                                                 logged_metrics):
    # a machine whose load changes during the run: before 0.01 ms, after 0.03 ms
    times = iter([0.01, 0.03])
    monkeypatch.setitem(script["main"].__globals__, "reference_ms", lambda: next(times))
    logged = _main(script, monkeypatch, logged_metrics, ["--minutes", "1"], lambda cfg: None)
    assert logged["reference_ms"] == pytest.approx(0.02)


@pytest.mark.parametrize("argv, named", [
    (["--terrains", "FOO"], "unknown terrain 'FOO'"),
    (["--terrains", "ASPHALT,"], "empty terrain name"),
    (["--minutes", "1000"], "7200"),             # 60,000 s: past the simulator's longest run
    (["--minutes", "0.001"], "husky"),           # 0.06 s: under two Husky wheel reports
])
def test_a_simulation_the_simulator_refuses_is_a_usage_error_before_any_timing(
        script, monkeypatch, capsys, argv, named):
    # each was the simulator's ConfigError traceback, raised after the reference workload
    # had been timed (--minutes 1000: the cap is only checked by SimConfig)
    calls = []
    env = script["main"].__globals__
    monkeypatch.setitem(env, "simulate", lambda cfg: calls.append(cfg))
    monkeypatch.setitem(env, "reference_ms", lambda: calls.append("reference") or 0.01)
    monkeypatch.setattr(sys, "argv", ["bench_sim.py", *argv, "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert named in err and argv[0] in err
    assert calls == []


def test_terrain_names_are_read_as_the_simulate_command_reads_them(script, monkeypatch,
                                                                   logged_metrics):
    # "sandy_loam, snow" (any case, spaces after the comma) is SANDY_LOAM then SNOW
    seen = []
    _main(script, monkeypatch, logged_metrics, ["--minutes", "1", "--terrains",
                                                "sandy_loam, snow"], seen.append)
    assert {cfg.terrains for cfg in seen} == {("SANDY_LOAM", "SNOW")}
