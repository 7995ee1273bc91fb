"""Review io20 of terrain.io.align: metamorphic relations of :func:`align_streams`.

The aligned values must not depend on the order the streams are named in, nor on where the
run's clock starts: shifting every timestamp by one constant shifts the grid by it and
leaves every value (gaps, anti-alias filtering, interpolation) as it was. Timestamps and the
shift are multiples of 1/256 s, so both frames are computed on exact times and compared
bit for bit.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.io.align import align_streams
from terrain.run import TIME, Run

SETTINGS = settings(max_examples=40, deadline=None)


def _stream(rng, n: int, step_ticks: int, start_ticks: int, columns, gap: bool,
            nan: bool) -> pd.DataFrame:
    """``n`` samples every ``step_ticks`` / 256 s (a few jittered by a tick), optionally one
    gap (eight steps missing) and a NaN cell."""
    ticks = start_ticks + step_ticks * np.arange(n) + rng.integers(0, 2, n) * (step_ticks > 2)
    if gap and n > 12:
        ticks[n // 2:] += 8 * step_ticks
    frame = pd.DataFrame({TIME: ticks / 256.0,
                          **{c: rng.normal(0.0, 1.0, n) for c in columns}})
    if nan and n > 4:
        frame.loc[n // 3, columns[0]] = np.nan
    return frame


@st.composite
def runs(draw) -> Run:
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    imu = _stream(rng, draw(st.integers(2, 400)), 2, draw(st.integers(0, 300)),
                  ("wx", "ax"), draw(st.booleans()), draw(st.booleans()))
    wheels = _stream(rng, draw(st.integers(2, 40)), 40, draw(st.integers(0, 300)),
                     ("vel_l", "cur_l"), draw(st.booleans()), draw(st.booleans()))
    return Run("x/SNOW/00", "x", "SNOW", {"imu": imu, "wheels": wheels})


def _aligned(run: Run, streams=("imu", "wheels"), rate_hz: float = 32.0):
    try:
        return align_streams(run, streams, rate_hz=rate_hz)
    except Exception as exc:  # (no overlap): the same error for the other call
        return type(exc)


@SETTINGS
@given(run=runs(), rate_hz=st.sampled_from([8.0, 32.0, 64.0]))
def test_the_order_the_streams_are_named_in_changes_only_the_column_order(run, rate_hz):
    a = _aligned(run, ("imu", "wheels"), rate_hz)
    b = _aligned(run, ("wheels", "imu"), rate_hz)
    if isinstance(a, type):
        assert a is b
        return
    assert list(b.columns) == [TIME, "vel_l", "cur_l", "wx", "ax"]
    np.testing.assert_array_equal(b[a.columns].to_numpy(), a.to_numpy())


@SETTINGS
@given(run=runs(), shift_ticks=st.integers(-2000, 200_000),
       rate_hz=st.sampled_from([8.0, 32.0, 64.0]))
def test_shifting_every_clock_by_one_constant_shifts_the_grid_only(run, shift_ticks, rate_hz):
    shift = shift_ticks / 256.0
    moved = Run(run.run_id, run.dataset, run.terrain,
                {k: f.assign(**{TIME: f[TIME] + shift}) for k, f in run.streams.items()})
    a, b = _aligned(run, rate_hz=rate_hz), _aligned(moved, rate_hz=rate_hz)
    if isinstance(a, type):
        assert a is b
        return
    np.testing.assert_array_equal(b[TIME].to_numpy(), a[TIME].to_numpy() + shift)
    np.testing.assert_array_equal(b.drop(columns=TIME).to_numpy(),
                                  a.drop(columns=TIME).to_numpy())
