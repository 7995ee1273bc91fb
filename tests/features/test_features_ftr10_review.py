"""Feature transformers and windowing review (ftr10): settings and inputs refused where they
are given, and the lines a hand mutation left untested."""

from __future__ import annotations

import numpy as np
import pytest

from features.transformers import WindowFeatures
from features.wheel_physics import WheelPhysicsFeatures
from features.windows import as_windows
from terrain.errors import ConfigError


@pytest.mark.parametrize("field, value, words", [
    ("track_m", -1.0, "a finite value > 0"), ("track_m", 0.0, "a finite value > 0"),
    ("track_m", float("nan"), "a finite value > 0"), ("ridge", 0.0, "a finite value > 0"),
    ("ridge", float("inf"), "a finite value > 0"), ("track_m", "0.57", "a real number"),
    ("ridge", True, "a real number")])
def test_wheel_physics_fit_refuses_a_track_or_ridge_that_transform_refuses(
        field, value, words):
    # fit took them and fixed its 50 names; only transform refused them, from inside
    # physics_features ("physics_features.track_m must be ..."), as rate_hz was before
    X = np.ones((2, 4, 40))
    with pytest.raises(ConfigError, match=f"WheelPhysicsFeatures.{field} must be {words}"):
        WheelPhysicsFeatures(**{field: value}).fit(X)


@pytest.mark.parametrize("values", [
    np.ones((2, 4, 40), dtype=bool),                       # a mask passed for the windows
    [[[True, False] * 20] * 4] * 2,                        # the same, as nested lists
    np.full((2, 4, 40), "1.5"),                            # text: was parsed to 1.5
    np.full((2, 4, 40), 1.5 + 2.0j),                       # complex: the imaginary part lost
])
@pytest.mark.parametrize("make", [
    lambda: WheelPhysicsFeatures(),
    lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l"))])
def test_windows_that_are_not_real_numbers_are_refused_naming_the_dtype(values, make):
    # as_windows converted them with np.asarray(X, dtype=float): booleans became samples of
    # 0 and 1 (50 and 36 features of a mask), text was parsed, complex values lost their
    # imaginary part with a ComplexWarning only
    with pytest.raises(ValueError, match="X must hold real numbers"):
        make().fit(values)
    fitted = make().fit(np.ones((2, 4, 40)))
    with pytest.raises(ValueError, match="X must hold real numbers"):
        fitted.transform(values)


def test_windows_of_integers_and_float32_are_read_as_float64():
    ints = np.arange(2 * 4 * 40).reshape(2, 4, 40) % 7
    fx = WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")).fit(ints)
    np.testing.assert_array_equal(fx.transform(ints), fx.transform(ints.astype(float)))
    np.testing.assert_array_equal(as_windows(ints.astype(np.float32), "abcd"),
                                  ints.astype(np.float32).astype(float))
