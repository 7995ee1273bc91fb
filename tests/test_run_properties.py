"""Properties of terrain.run (Hypothesis): the time-contract rules against slow references,
and their invariance under a time shift and under taking a subset of samples or streams."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import DataFormatError, NonFiniteError
from terrain.run import Run, step_index, times_out_of_order

#: any float a time column may hold, NaN and infinities included
ANY_TIME = st.floats(allow_nan=True, allow_infinity=True, width=64)
#: times on a 1/8 s grid: sums and differences of them are exact, so a shift changes nothing
EIGHTHS = st.integers(-4000, 4000).map(lambda k: k / 8.0)
#: shifts (whole seconds) that keep the eighths exact
SHIFTS = st.integers(-10_000, 10_000).map(float)


def _slow_out_of_order(t, strict):
    """Row by row: not finite, or not after a finite previous time."""
    bad = []
    for i, ti in enumerate(t):
        if not math.isfinite(ti):
            bad.append(i)
        elif i and math.isfinite(t[i - 1]) and (ti <= t[i - 1] if strict else ti < t[i - 1]):
            bad.append(i)
    return bad


def _slow_step_index(grid, t, clip):
    """First step at or after each time (1e-9 s tolerance), ``len(grid)`` past the last."""
    out = []
    for ti in t:
        j = next((j for j, g in enumerate(grid) if g >= ti - 1e-9), len(grid))
        out.append(min(j, len(grid) - 1) if clip else j)
    return out


@settings(max_examples=300, deadline=None)
@given(st.lists(ANY_TIME, max_size=12), st.booleans())
def test_times_out_of_order_matches_the_row_by_row_rule(t, strict):
    assert times_out_of_order(t, strict).tolist() == _slow_out_of_order(t, strict)


@settings(max_examples=200, deadline=None)
@given(st.lists(EIGHTHS, max_size=12), SHIFTS, st.booleans())
def test_times_out_of_order_does_not_depend_on_the_clock_origin(t, shift, strict):
    shifted = [x + shift for x in t]
    assert times_out_of_order(shifted, strict).tolist() == times_out_of_order(t, strict).tolist()


@pytest.mark.slow
@settings(max_examples=200, deadline=None)
@given(st.sets(EIGHTHS, min_size=1, max_size=15), st.data())
def test_a_subset_of_increasing_times_is_in_order(times, data):
    t = sorted(times)
    keep = data.draw(st.lists(st.booleans(), min_size=len(t), max_size=len(t)))
    sub = [x for x, k in zip(t, keep) if k]
    assert times_out_of_order(t).size == 0
    assert times_out_of_order(sub).size == 0
    # a repeated time breaks the strict contract only
    doubled = sorted(t + t[:1])
    assert times_out_of_order(doubled).tolist() == [1]
    assert times_out_of_order(doubled, strict=False).size == 0


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(st.sets(EIGHTHS, min_size=1, max_size=10), st.lists(EIGHTHS, max_size=10),
       st.booleans())
def test_step_index_matches_the_first_step_at_or_after_each_time(grid, t, clip):
    grid = np.array(sorted(grid))
    assert step_index(grid, t, clip).tolist() == _slow_step_index(grid, t, clip)


@settings(max_examples=200, deadline=None)
@given(st.sets(EIGHTHS, min_size=1, max_size=10), st.lists(EIGHTHS, max_size=10), SHIFTS,
       st.booleans())
def test_step_index_does_not_depend_on_the_clock_origin(grid, t, shift, clip):
    grid = np.array(sorted(grid))
    shifted = step_index(grid + shift, np.array(t) + shift, clip)
    assert shifted.tolist() == step_index(grid, t, clip).tolist()


@settings(max_examples=100, deadline=None)
@given(st.sets(EIGHTHS, min_size=1, max_size=10))
def test_a_sample_on_a_step_or_a_rounding_before_it_belongs_to_that_step(grid):
    grid = np.array(sorted(grid))
    idx = np.arange(len(grid))
    assert step_index(grid, grid).tolist() == idx.tolist()
    assert step_index(grid, grid - 5e-10).tolist() == idx.tolist()
    # past the last step: n, or the last step when clipped
    assert step_index(grid, [grid[-1] + 1.0]).tolist() == [len(grid)]
    assert step_index(grid, [grid[-1] + 1.0], clip=True).tolist() == [len(grid) - 1]


def _uniform(n, step, start=0.0):
    return pd.DataFrame({"t_s": start + step * np.arange(n)})


@settings(max_examples=100, deadline=None)
@given(st.integers(2, 200), st.sampled_from([1 / 128, 1 / 64, 0.125, 0.5, 1.0, 4.0]), SHIFTS,
       st.integers(1, 5))
def test_rate_and_duration_of_a_uniform_stream(n, step, shift, every):
    run = Run("r/X/00", "r", None, {"wheels": _uniform(n, step)})
    moved = Run("r/X/00", "r", None, {"wheels": _uniform(n, step, shift)})
    assert run.rate_hz("wheels") == 1.0 / step
    assert run.duration_s == (n - 1) * step
    # the clock origin changes neither
    assert moved.rate_hz("wheels") == run.rate_hz("wheels")
    assert moved.duration_s == run.duration_s
    # every k-th sample: the rate divided by k, the duration of the samples kept
    sub = _uniform(n, step).iloc[::every].reset_index(drop=True)
    if len(sub) >= 2:
        thinned = Run("r/X/00", "r", None, {"wheels": sub})
        assert thinned.rate_hz("wheels") == pytest.approx(1.0 / (step * every), rel=1e-12)
        assert thinned.duration_s == sub["t_s"].iloc[-1]


@settings(max_examples=100, deadline=None)
@given(st.lists(st.sampled_from(["imu", "cam", "steer", "truth"]), unique=True, max_size=4),
       st.integers(2, 50), st.integers(2, 50))
def test_the_wheel_stream_sets_the_duration_whatever_other_streams_a_run_holds(others, n, m):
    streams = {name: _uniform(m + i, 0.25) for i, name in enumerate(others)}
    alone = Run("r/X/00", "r", None, {"wheels": _uniform(n, 0.5)})
    together = Run("r/X/00", "r", None, {**streams, "wheels": _uniform(n, 0.5)})
    assert together.duration_s == alone.duration_s == (n - 1) * 0.5
    if others:   # without wheels: the longest stream
        without = Run("r/X/00", "r", None, streams)
        assert without.duration_s == max((len(f) - 1) * 0.25 for f in streams.values())


@settings(max_examples=150, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), min_size=1,
                max_size=10))
def test_require_finite_names_the_first_non_finite_value_or_passes(values):
    frame = pd.DataFrame({"t_s": np.arange(len(values), dtype=float), "vel_l": values})
    run = Run("r/X/00", "r", None, {"wheels": frame}, source="w.csv")
    bad = [i for i, v in enumerate(values) if not math.isfinite(v)]
    if not bad:
        run.require_finite("wheels", ["vel_l"])
        return
    with pytest.raises(NonFiniteError) as info:
        run.require_finite("wheels", ["vel_l"])
    assert f"{len(bad)} non-finite value(s)" in str(info.value)
    assert f"first at row {bad[0]}" in str(info.value)
    assert isinstance(info.value, DataFormatError)
