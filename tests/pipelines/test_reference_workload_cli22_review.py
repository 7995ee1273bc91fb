"""Boundaries of the benchmarks' reference workload (cli22 review)."""

from __future__ import annotations

import math

import pytest

from pipelines.reference_workload import sort_reference_ms
from terrain.errors import ConfigError


def test_one_repeat_is_the_fewest_and_times_the_workload():
    """``repeats`` >= 1 (its docstring): one run is the median of itself, a real time."""
    ms = sort_reference_ms(1)
    assert math.isfinite(ms) and ms > 0


@pytest.mark.parametrize("repeats", [0, -1, True, 2.0])
def test_no_repeat_is_refused_rather_than_a_nan_time(repeats):
    """0 repeats was the median of nothing: NaN ms (with NumPy's "Mean of empty slice"),
    which a benchmark divided its figures by."""
    with pytest.raises(ConfigError, match="repeats must be an integer >= 1"):
        sort_reference_ms(repeats)
