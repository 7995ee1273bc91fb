"""Feature transformers and windowing review (ftr10): settings and inputs refused where they
are given, and the lines a hand mutation left untested."""

from __future__ import annotations

import numpy as np
import pytest

from features.wheel_physics import WheelPhysicsFeatures
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
