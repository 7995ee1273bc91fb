"""Review fixslip of the learned slip model: infinite features are refused, naming the
feature column and the row (fit: scikit-learn's bare "Input X contains infinity"; predict:
the compiled trees and scikit-learn's own predict took inf as the largest value, without a
word)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import NonFiniteInputError
from terrain.slip.learned import SlipRegressor

NAMES = ["cur_l__mean", "vel_l__mean", "pitch"]


def _windows(n_runs=6, per_run=20):
    rng = np.random.default_rng(3)
    groups = np.repeat(np.arange(n_runs), per_run)
    X = rng.normal(size=(groups.size, len(NAMES)))
    y = np.column_stack([0.1 * X[:, 0], 0.05 * X[:, 1], np.full(groups.size, 2.0),
                         np.zeros(groups.size)])
    return pd.DataFrame(X, columns=NAMES), y, groups


def _model():
    return SlipRegressor(max_iter=5, min_samples_leaf=5)


@pytest.mark.parametrize("value", [np.inf, -np.inf])
@pytest.mark.parametrize("named", [True, False])
def test_fit_refuses_an_infinite_feature_naming_its_column_and_row(value, named):
    X, y, groups = _windows()
    X.iloc[7, 1] = value
    X.iloc[9, 1] = value
    with pytest.raises(NonFiniteInputError,
                       match=r"SlipRegressor.fit: X holds 2 infinite value\(s\), the first in "
                             + (r"column 'vel_l__mean'" if named else r"column 1")
                             + r", row 7"):
        _model().fit(X if named else X.to_numpy(), y, groups=groups)


def test_a_refused_fit_leaves_the_fitted_model_as_it_was():
    X, y, groups = _windows()
    model = _model().fit(X, y, groups=groups)
    before = model.predict(X)
    bad = X.copy()
    bad.iloc[0, 0] = np.inf
    with pytest.raises(NonFiniteInputError):
        model.fit(bad, y, groups=groups)
    np.testing.assert_array_equal(model.predict(X), before)


@pytest.mark.parametrize("method", ["predict", "predict_reference", "predict_std"])
@pytest.mark.parametrize("kind", ["frame", "array"])
def test_predict_refuses_an_infinite_feature_naming_its_column_and_row(method, kind):
    X, y, groups = _windows()
    model = _model().fit(X, y, groups=groups)
    bad = X.iloc[:6].copy()
    bad.iloc[4, 2] = -np.inf
    # a bare array is read in the order of feature_names_in_: named by them as well
    with pytest.raises(NonFiniteInputError,
                       match=rf"SlipRegressor.{method}: X holds 1 infinite value\(s\), the "
                             r"first in column 'pitch', row 4"):
        getattr(model, method)(bad if kind == "frame" else bad.to_numpy())


def test_a_model_fitted_on_a_bare_array_names_the_column_by_position():
    X, y, groups = _windows()
    model = _model().fit(X.to_numpy(), y, groups=groups)
    bad = X.to_numpy()[:3].copy()
    bad[2, 0] = np.inf
    with pytest.raises(NonFiniteInputError, match=r"the first in column 0, row 2"):
        model.predict(bad)


def test_nan_features_stay_missing_values_and_finite_ones_predict_as_before():
    """NaN is HistGradientBoosting's missing value (learned, not refused); a table of finite
    features fits and predicts exactly as scikit-learn's own path."""
    X, y, groups = _windows()
    model = _model().fit(X, y, groups=groups)
    gap = X.iloc[:4].copy()
    gap.iloc[1, 0] = np.nan
    np.testing.assert_array_equal(model.predict(gap), model.predict_reference(gap))
    np.testing.assert_array_equal(model.predict(X), model.predict_reference(X))
    withnan = X.copy()
    withnan.iloc[3, 2] = np.nan
    _model().fit(withnan, y, groups=groups)       # (no error)
