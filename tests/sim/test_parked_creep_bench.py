"""benchmarks/parked_creep.py: the terrains it reads (no simulation run)."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "parked_creep.py"


def test_terrains_are_read_as_terrain_simulate_reads_them(monkeypatch, capsys):
    # "ASPHALT, ice" failed on ' ice' (get_terrain's ConfigError traceback) after ASPHALT
    # had been simulated and printed
    script = runpy.run_path(str(SCRIPT))
    env = script["main"].__globals__
    seen = []

    def parked(terrain, physics, seconds, slope_deg):
        seen.append(terrain)
        return np.zeros(3), np.zeros(3)

    monkeypatch.setitem(env, "parked_speed", parked)
    monkeypatch.setattr(sys, "argv", ["parked_creep.py", "--terrains", "ASPHALT, ice",
                                      "--no-mlflow"])
    assert script["main"]() == 0
    assert seen == ["ASPHALT", "ICE"] * 2                  # both physics versions
    assert "v1 | ICE |" in capsys.readouterr().out
