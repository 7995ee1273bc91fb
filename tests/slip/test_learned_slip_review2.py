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


def test_calibration_folds_are_grouped_by_run_whatever_the_order_of_the_windows():
    # each run's windows share features and a slip unrelated to them: only a model that saw
    # the run predicts it. With the windows of the runs interleaved, folds that are not
    # grouped by run (plain KFold) put every run on both sides and calibrate on residuals
    # near 0; grouped folds see the run-to-run spread of the slip (std 0.1)
    rng = np.random.default_rng(0)
    n_runs, per_run = 9, 30
    run_x, run_s = rng.normal(size=(n_runs, 3)), rng.normal(0.0, 0.1, size=n_runs)
    groups = np.tile(np.arange(n_runs), per_run)
    X = run_x[groups] + 1e-3 * rng.normal(size=(groups.size, 3))
    y = np.column_stack([run_s[groups], run_s[groups], np.full(groups.size, 2.0),
                         np.zeros(groups.size)])
    model = SlipRegressor(max_iter=20, min_samples_leaf=5).fit(X, y, groups=groups)
    assert model.calibration_["median_abs_residual"] > 0.03
