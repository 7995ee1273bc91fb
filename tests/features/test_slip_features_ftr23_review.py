"""Slip features review (ftr23): boundaries and off-by-one (thresholds, window edges)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from features.slip_features import MIN_TURN_RATE_RAD_S, SLIP_CHANNELS, slip_targets
from features.windows import HUSKY_TRACK_M, WindowSet
from terrain.run import TIME, Run


def _turning(yaw_rate, duration_s=600.0, t0=None):
    """A simulated run turning at ``yaw_rate`` on a 100 Hz truth clock (the simulator's),
    and 2 s windows starting at ``t0`` whose wheel speeds turn at that rate with chi 1."""
    tt = np.arange(int(duration_s * 100) + 1) / 100.0
    truth = pd.DataFrame({TIME: tt, "slip_1": 0.0, "slip_2": 0.0, "yaw_rate": yaw_rate,
                          "v_by": 0.0, "terrain": "SNOW"})
    run = Run("sim1", "sim", "SNOW", {"truth": truth})
    t0 = np.arange(0.0, duration_s - 2.0, 1.0) if t0 is None else np.asarray(t0, float)
    X = np.zeros((len(t0), len(SLIP_CHANNELS), 100))
    X[:, list(SLIP_CHANNELS).index("vel_r")] = yaw_rate * HUSKY_TRACK_M
    ids = np.array(["sim1"] * len(t0), dtype=object)
    return run, WindowSet(X, SLIP_CHANNELS, ids, ids, ids, t0, t0 + 2.0, 50.0)


@settings(max_examples=10, deadline=None)
@given(st.booleans())
def test_chi_is_defined_for_a_turn_at_exactly_the_minimum_rate(left):
    """chi is NaN only where the robot turns slower than MIN_TURN_RATE_RAD_S (module
    docstring; ``|yaw| >= MIN_TURN_RATE_RAD_S`` in the code): a steady turn at exactly
    0.1 rad/s has chi 1 in every window. The window means of the truth's running sum carry
    rounding (0.09999999999999995 rad/s late in a 10 min run), and chi was NaN in 328 of
    598 windows."""
    rate = -MIN_TURN_RATE_RAD_S if left else MIN_TURN_RATE_RAD_S
    run, ws = _turning(rate)
    Y = slip_targets([run], ws)
    assert not Y["chi"].isna().any()
    np.testing.assert_allclose(Y["chi"], 1.0, rtol=1e-9)


def test_chi_is_undefined_just_below_the_minimum_rate():
    """The allowance for rounding is no margin: a turn 1e-9 rad/s slower than the minimum
    rate has no chi target."""
    run, ws = _turning(MIN_TURN_RATE_RAD_S - 1e-9, duration_s=60.0)
    assert slip_targets([run], ws)["chi"].isna().all()


@settings(max_examples=12, deadline=None)
@given(st.sampled_from([(1.7, 50.0), (2.0, 50.0), (1.0, 25.0), (5.0, 100.0), (1.7, 20.0)]),
       st.integers(0, 200))
def test_a_truth_sample_on_a_window_edge_goes_to_the_window_it_starts(window, first):
    """A window's targets are means of the truth samples in ``[t_start_s, t_end_s)``: the
    one stamped on ``t_start_s`` in, the one on ``t_end_s`` (the next window's first) out.
    The simulator stamps its 100 Hz truth ``k * 0.01`` and the aligned grid ``i / rate``;
    raw float comparison put the sample on the end inside in 6 % of 1.7 s windows at
    50 Hz (171 samples), so the mean of a ramp was off by half a sample."""
    window_s, rate_hz = window
    n = round(window_s * rate_hz)
    per = round(100 / rate_hz) if rate_hz <= 100 else 1
    tt = np.arange(0.0, 60.0 + 1e-9, 0.01)                  # the simulator's truth clock
    truth = pd.DataFrame({TIME: tt, "slip_1": np.arange(len(tt), dtype=float),
                          "slip_2": 0.0, "yaw_rate": 0.5, "v_by": 0.0, "terrain": "SNOW"})
    run = Run("sim1", "sim", "SNOW", {"truth": truth})
    grid = np.arange(int(55 * rate_hz)) / rate_hz           # the aligned clock
    starts = np.arange(first, len(grid) - n, 3)
    t0 = grid[starts]
    X = np.zeros((len(t0), len(SLIP_CHANNELS), n))
    ids = np.array(["sim1"] * len(t0), dtype=object)
    ws = WindowSet(X, SLIP_CHANNELS, ids, ids, ids, t0, t0 + n / rate_hz, rate_hz)
    got = slip_targets([run], ws)["slip_1"].to_numpy()
    held = n * per                                           # truth samples in a window
    np.testing.assert_allclose(got, starts * per + 0.5 * (held - 1), rtol=0, atol=1e-9)
