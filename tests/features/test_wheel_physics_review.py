"""Wheel-physics transformer review: settings refused at fit, naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from features.wheel_physics import WheelPhysicsFeatures
from terrain.errors import ConfigError


@pytest.mark.parametrize("field, value", [
    ("short_s", float("nan")), ("short_s", float("inf")), ("rate_hz", float("nan")),
    ("rate_hz", float("inf")), ("rate_hz", 0.0), ("rate_hz", -10.0)])
def test_a_short_scale_or_rate_that_is_not_finite_is_refused_at_fit_naming_it(field, value):
    # NaN or inf short_s / rate_hz failed in int(round(...)) with a bare "cannot convert
    # float NaN to integer" (OverflowError for inf); a rate <= 0 passed fit and was first
    # refused by physics_features at transform
    X = np.ones((2, 4, 40))
    with pytest.raises(ConfigError, match=f"WheelPhysicsFeatures.{field} must be"):
        WheelPhysicsFeatures(**{field: value}).fit(X)


@pytest.mark.parametrize("short_s, names", [(None, 25), (0.0, 25), (-1.0, 25), (2.0, 50)])
def test_a_finite_short_scale_keeps_its_documented_meaning(short_s, names):
    # None, or a scale rounding to fewer than 3 samples: whole window only (documented);
    # 4 s windows at 10 Hz (the rate is given: the default is the 50 Hz aligned clock's)
    X = np.ones((2, 4, 40))
    assert len(WheelPhysicsFeatures(rate_hz=10.0, short_s=short_s).fit(X)
               .get_feature_names_out()) == names
