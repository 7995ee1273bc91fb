"""Review trk22: `terrain validate --out` writes the same file for the same tables."""

from __future__ import annotations

import argparse
import itertools
import sys
import types

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

import pipelines.validate as validate


def _fake_report(monkeypatch, tables):
    report = types.ModuleType("fake_trk22_report")
    report.sections = lambda quick: [(f"T{i}", (lambda t=t: t)) for i, t in enumerate(tables)]
    monkeypatch.setitem(sys.modules, "fake_trk22_report", report)
    monkeypatch.setattr(validate, "REPORTS", {"fake": "fake_trk22_report"})


def test_regenerating_a_report_gives_an_identical_file(tmp_path, monkeypatch, capsys):
    # each section's computing time, "(1.0 s)", was written into the --out file: the same
    # tables regenerated gave a different file every time
    _fake_report(monkeypatch, [pd.DataFrame({"case": ["a"], "x": [0.5]}),
                               pd.DataFrame({"n": [3]})])
    clock = itertools.count(0.0, 0.7)
    monkeypatch.setattr(validate, "time", types.SimpleNamespace(
        perf_counter=lambda: next(clock) ** 2))   # every delta differs
    first, second = tmp_path / "a.md", tmp_path / "b.md"
    for out in (first, second):
        assert validate.main(argparse.Namespace(report="fake", quick=True, out=out)) == 0
    printed = capsys.readouterr().out
    assert first.read_text() == second.read_text()
    assert " s)" in printed                      # the time is still printed
    assert all(line in printed for line in first.read_text().splitlines())


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(st.floats(-1e300, 1e300), st.sampled_from([np.nan, np.inf, -np.inf])),
                min_size=1, max_size=6))
def test_markdown_numbers_read_back_as_the_tables_to_4_digits(values):
    # the Markdown table states the numbers of the table it comes from
    table = pd.DataFrame({"name": [f"r{i}" for i in range(len(values))], "v": values})
    lines = validate.to_markdown(table).splitlines()[2:]
    assert len(lines) == len(values)
    for line, v in zip(lines, values):
        cell = line.split("|")[2].strip()
        back = float(cell)
        if np.isnan(v):
            assert np.isnan(back)
        elif np.isinf(v):
            assert back == v
        else:
            assert back == float(f"{v:.4g}")
            assert abs(back - v) <= 5e-4 * abs(v)
