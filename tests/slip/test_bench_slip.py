"""benchmarks/bench_slip.py: the ratio to the same run's scikit-learn reference."""

from __future__ import annotations

import runpy
from pathlib import Path

import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "bench_slip.py"


def test_the_compiled_path_is_logged_over_the_same_runs_reference():
    # the reference was timed, printed and logged, the comparable ratio was not
    ratios = runpy.run_path(str(SCRIPT))["reference_ratios"]
    got = ratios({"batch_ms_per_window": 0.002, "single_ms_per_window": 0.05,
                  "reference_batch_ms_per_window": 0.008,
                  "reference_single_ms_per_window": 0.5})
    assert got == {"batch_over_reference": pytest.approx(0.25),
                   "single_over_reference": pytest.approx(0.1)}
