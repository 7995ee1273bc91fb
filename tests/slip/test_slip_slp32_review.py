"""Review slp32: held-out evaluation of slip models and slip-compensated odometry
(target shapes, std signs, measured checks' inputs, physical invariants of dead reckoning)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.linear_model import LinearRegression

from terrain.slip.evaluation import fit_predict, leave_one_out

FAST = settings(max_examples=30, deadline=None)


@FAST
@given(n_groups=st.integers(2, 4), per_group=st.integers(2, 4), seed=st.integers(0, 999))
def test_leave_one_out_of_one_target_per_window_is_one_prediction_per_window(
        n_groups, per_group, seed):
    """A single target per window (shape (n,), which fit_predict takes) gives one
    prediction per window as with the target as a column, not an (n, n) table."""
    rng = np.random.default_rng(seed)
    n = n_groups * per_group
    X = pd.DataFrame({"a": rng.normal(size=n), "b": rng.normal(size=n)})
    y = rng.normal(size=n)
    groups = np.repeat(np.arange(n_groups), per_group)
    train = np.arange(n) % per_group != 0
    test = ~train
    flat = leave_one_out(LinearRegression, X, y, groups, train, test)
    column = leave_one_out(LinearRegression, X, y[:, None], groups, train, test)
    assert flat.shape == (n,)
    np.testing.assert_array_equal(flat, column[:, 0])
    for g in range(n_groups):   # each group's prediction is the model of the others
        m = groups == g
        np.testing.assert_allclose(flat[test & m], fit_predict(
            LinearRegression, X, y, train & ~m, test & m)[test & m])
