"""Every benchmark script imports and parses its arguments.

The benchmarks are run by hand (their figures are in docs/), so a renamed library function
would break one unseen until somebody needed it. Each script is imported as a module (its
``main`` is not run) and asked for ``--help``, which builds its argument parser.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

SCRIPTS = sorted((Path(__file__).resolve().parents[1] / "benchmarks").glob("*.py"))


def test_there_are_benchmarks():
    assert len(SCRIPTS) > 20


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_benchmark_imports_and_answers_help(path, monkeypatch, capsys):
    spec = importlib.util.spec_from_file_location(f"benchmark_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.__doc__ and callable(module.main)
    monkeypatch.setattr(sys, "argv", [path.name, "--help"])
    with pytest.raises(SystemExit) as stop:
        module.main()
    assert stop.value.code == 0
    assert "usage:" in capsys.readouterr().out


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_benchmark_refuses_a_prefix_of_an_option(path, capsys):
    # as `terrain` does (allow_abbrev=False): `--seed 1` must not run a benchmark as
    # `--seeds 1`, a prefix is a usage error (exit 2), not the option it abbreviates
    import copy

    from test_docs_truth_doc4 import _benchmark_parser

    parser = copy.deepcopy(_benchmark_parser(path))     # the cached one stays untouched
    options = [s for a in parser._actions for s in a.option_strings
               if s.startswith("--") and s != "--help" and len(s) > 4]
    if not options:
        pytest.skip("no long option to abbreviate")
    prefix = options[0][:-1]
    if any(s != options[0] and s.startswith(prefix) for s in options):
        pytest.skip(f"{options[0]} has no unique prefix")
    for action in parser._actions:            # a missing required option would end the
        if action.option_strings:             # parse before the prefix is looked at
            action.required = False
    with pytest.raises(SystemExit) as stop:
        parser.parse_args([prefix, "1"])
    assert stop.value.code == 2
    assert "unrecognized arguments" in capsys.readouterr().err
