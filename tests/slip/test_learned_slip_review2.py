"""Second review of the learned slip model: its settings are checked before a fit."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.slip.learned import SlipRegressor


def _windows(n_runs=6, per_run=20):
    """Windows of ``n_runs`` runs whose slip is predicted exactly (constant 0)."""
    rng = np.random.default_rng(1)
    groups = np.repeat(np.arange(n_runs), per_run)
    X = rng.normal(size=(groups.size, 3))
    y = np.column_stack([np.zeros(groups.size), np.zeros(groups.size),
                         np.full(groups.size, 2.0), np.zeros(groups.size)])
    return X, y, groups


@pytest.mark.parametrize("floor", [float("nan"), 0.0, -0.001, float("inf"), "0.001"])
def test_a_std_floor_that_is_not_a_finite_positive_number_is_refused_by_name(floor):
    # NaN made the variance target NaN (scikit-learn's bare "Input y contains NaN", about a y
    # that is fine); 0 made it log(0) = -inf where a residual is exactly 0 ("Input y contains
    # infinity"); a negative floor was squared into the variance target but floored nothing
    X, y, groups = _windows()
    with pytest.raises(ConfigError, match="SlipRegressor.std_floor"):
        SlipRegressor(max_iter=3, min_samples_leaf=5, std_floor=floor).fit(X, y, groups=groups)


@pytest.mark.parametrize("folds", [2.5, 3.0, True, None])
def test_calibration_folds_that_are_not_an_integer_are_refused_by_name(folds):
    # 2.5 reached GroupKFold (scikit-learn's InvalidParameterError after fitting the four
    # outputs); True was taken as 1 fold and silently disabled the calibration
    X, y, groups = _windows()
    with pytest.raises(ConfigError, match="SlipRegressor.calibration_folds"):
        SlipRegressor(max_iter=3, min_samples_leaf=5,
                      calibration_folds=folds).fit(X, y, groups=groups)


def test_valid_settings_still_fit_and_fewer_than_two_folds_still_disable_the_std():
    X, y, groups = _windows()
    model = SlipRegressor(max_iter=3, min_samples_leaf=5, calibration_folds=1)
    assert np.isnan(model.fit(X, y, groups=groups).predict_std(X[:2])).all()
    model = SlipRegressor(max_iter=3, min_samples_leaf=5, std_floor=0.002)
    np.testing.assert_allclose(model.fit(X, y, groups=groups).predict_std(X[:2]), 0.002)
