"""Review est5: inputs and settings of the estimators that were silently accepted."""

import numpy as np
import pytest

from terrain.errors import ConfigError, TimeStepError
from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer
from terrain.estimation.skid_steer import SkidSteerModel


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_observer_refuses_a_non_finite_sample_time_naming_it(bad):
    # a NaN time passed the "strictly increasing" test (NaN compares False) and made every
    # estimate from that sample on NaN
    t = np.array([0.0, 0.01, bad, 0.03, 0.04])
    pose = np.zeros((5, 3))
    pose[:, 0] = np.arange(5) * 0.01
    v = np.ones(5)
    with pytest.raises(TimeStepError, match="sample 2"):
        run_adaptive_observer(t, pose, v, v)


def test_observer_still_runs_on_finite_increasing_times():
    t = np.arange(5) * 0.01
    pose = np.zeros((5, 3))
    pose[:, 0] = t
    v = np.ones(5)
    res = run_adaptive_observer(t, pose, v, v)
    assert np.isfinite(res.eta).all()


@pytest.mark.parametrize("value", ["no", 1, None])
def test_observer_use_position_must_be_a_boolean(value):
    # read by truthiness: the text "no" (or 1) ran the position rows
    with pytest.raises(ConfigError, match="use_position"):
        AdaptiveObserverSettings(use_position=value)


def test_observer_use_position_takes_a_numpy_boolean():
    assert AdaptiveObserverSettings(use_position=np.bool_(False)).use_position == np.False_


@pytest.mark.parametrize("value", ["2", True, 0.0, -1.0, np.nan, np.inf, None])
def test_skid_steer_wheel_variance_scale_must_be_a_finite_number_gt_0(value):
    # "2" gave a variance 2 x, True 1 x, a negative or NaN one failed later without naming it
    with pytest.raises(ConfigError, match="wheel_r_scale"):
        SkidSteerModel(wheel_r_scale=value)


def test_skid_steer_wheel_variance_scale_multiplies_the_wheel_rows_only():
    base = SkidSteerModel().R_diag
    np.testing.assert_allclose(SkidSteerModel(wheel_r_scale=np.float64(4.0)).R_diag,
                               base * [4.0, 4.0, 1.0])
