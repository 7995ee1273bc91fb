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


@pytest.mark.parametrize("argv, named", [
    (["--terrain", "SNOW", "--variants", "[{"], "not JSON"),
    (["--terrain", "SNOW", "--variants", '{"k": 1}'], "a non-empty JSON list of objects"),
    (["--terrain", "SNOW", "--variants", '[{"nope": 1}]'], "nope"),
    # ICE has no SOILS entry: the override was never applied, every variant printed the
    # same v2 row under its own name
    (["--terrain", "ICE", "--variants", '[{"lateral_shear_modulus_m": 0.01}]'], "--base-soil"),
    (["--terrain", "ICE", "--base-soil", "ICE", "--variants",
      '[{"lateral_shear_modulus_m": 0.01}]'], "--base-soil"),
])
def test_bad_variants_are_usage_errors_before_any_replay(monkeypatch, capsys, argv, named):
    # '[{' and an unknown field were JSONDecodeError / TypeError tracebacks, the field's
    # only after every run had been replayed
    main = runpy.run_path(str(SCRIPT))["main"]
    monkeypatch.setitem(main.__globals__, "load_dataset", lambda dataset: pytest.fail("read"))
    monkeypatch.setattr(sys, "argv", ["sweep_soil_params.py", *argv, "--no-chi"])
    with pytest.raises(SystemExit) as stop:
        main()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "argument --variants" in err and named in err
