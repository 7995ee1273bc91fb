"""Features review (ftr22): metamorphic relations between windows, channels and entry points."""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from features.slip_features import SLIP_CHANNELS, slip_targets
from features.windows import WindowSet
from terrain.run import TIME, Run


def _truth_run(slip_1, dt=0.25):
    """A simulated run whose truth holds ``slip_1`` on a ``dt`` clock (dyadic: exact sums)."""
    tt = np.arange(len(slip_1)) * dt
    truth = pd.DataFrame({TIME: tt, "slip_1": slip_1, "slip_2": 0.5, "yaw_rate": 0.5,
                          "v_by": 0.0, "terrain": "SNOW"})
    return Run("sim1", "sim", "SNOW", {"truth": truth})


def _windows(t0, length_s=2.0):
    n, dv = 100, 0.25
    values = {c: np.zeros((len(t0), n)) for c in SLIP_CHANNELS}
    values.update(vel_l=np.full((len(t0), n), 0.5), vel_r=np.full((len(t0), n), 0.5 + dv),
                  vel_diff=np.full((len(t0), n), dv))
    X = np.stack([values[c] for c in SLIP_CHANNELS], axis=1)
    ids = np.array(["sim1"] * len(t0), dtype=object)
    t0 = np.asarray(t0, dtype=float)
    return WindowSet(X, SLIP_CHANNELS, ids, ids, ids, t0, t0 + length_s, 50.0)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 39), st.sampled_from([np.nan, np.inf, -np.inf]),
       st.permutations(range(5)))
def test_a_truth_nan_makes_only_the_windows_holding_it_nan(bad, value, order):
    """A window's target is the mean of the truth inside that window only: a NaN truth
    sample made every LATER window NaN too (the running sum carried it), so a window's
    target depended on the samples of the windows before it (an inf likewise, as inf - inf);
    and the targets follow the windows whatever their order."""
    slip = np.arange(40) * 0.25
    slip[bad] = value
    run = _truth_run(slip)
    starts = np.array([0.0, 2.0, 4.0, 6.0, 8.0])
    Y = slip_targets([run], _windows(starts), 0.5)
    t = np.arange(40) * 0.25
    for k, t0 in enumerate(starts):
        inside = (t >= t0) & (t < t0 + 2.0)
        want = np.nan if inside[bad] else slip[inside].mean()
        np.testing.assert_array_equal(Y["slip_1"].to_numpy()[k], want)
    order = list(order)
    Yp = slip_targets([run], _windows(starts[order]), 0.5)
    np.testing.assert_array_equal(Yp["slip_1"].to_numpy(), Y["slip_1"].to_numpy()[order])
