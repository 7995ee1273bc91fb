"""benchmarks/slip_nees.py: its --seeds and --settings (no run simulated)."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "slip_nees.py"


@pytest.mark.parametrize("argv, named", [
    (["--seeds", "abc"], "'abc' is not a seed"),         # was int()'s ValueError traceback
    (["--seeds", "5-3"], "runs backwards"),              # was no seed at all
    (["--seeds", "1-3,2"], "[2] given twice"),           # seed 2 was pooled twice
    (["--settings", "[{"], "not JSON"),                  # after every run was simulated
    (["--settings", "{}"], "non-empty JSON list"),
    (["--settings", '[{"no_such_field": 1}]'], "no_such_field"),
])
def test_bad_seeds_and_settings_are_usage_errors_before_any_run(monkeypatch, capsys, argv,
                                                                named):
    script = runpy.run_path(str(SCRIPT))
    env = script["main"].__globals__
    monkeypatch.setitem(env, "resolve_slip_model", lambda *a: pytest.fail("ran"))
    monkeypatch.setattr(sys, "argv", ["slip_nees.py", *argv])
    with pytest.raises(SystemExit) as stop:
        script["main"]()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {argv[0]}" in err and named in err


def test_seed_ranges_and_settings_as_documented():
    script = runpy.run_path(str(SCRIPT))
    assert script["_seeds"]("200-203") == (200, 201, 202, 203)
    assert script["_seeds"]("100-101, 300") == (100, 101, 300)
    (cfg, rho, fusion), = script["_settings"]('[{"rho": 0.5}]')
    assert cfg == {} and rho == 0.5 and fusion.error_correlation == 0.5
    (cfg, rho, fusion), = script["_settings"]("[{}]")
    assert fusion == script["BATCH_FUSION"]
