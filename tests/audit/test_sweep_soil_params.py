"""benchmarks/sweep_soil_params.py: the soil sweep refuses a terrain its dataset lacks."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "sweep_soil_params.py"


def test_a_terrain_without_runs_is_refused_not_swept(monkeypatch, capsys):
    # GRASS is no BorealTC terrain (and CONCRETE is a Vulpi one): the sweep printed a table
    # of NaN for empty training and held-out halves and exited 0
    main = runpy.run_path(str(SCRIPT))["main"]
    runs = [SimpleNamespace(terrain="ICE", run_id=f"borealtc/ICE/{i:02d}") for i in range(2)]
    monkeypatch.setitem(main.__globals__, "load_dataset", lambda dataset: runs)
    monkeypatch.setattr(sys, "argv", ["sweep_soil_params.py", "--terrain", "GRASS", "--no-chi"])
    with pytest.raises(SystemExit) as stop:
        main()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "GRASS" in err and "borealtc" in err
