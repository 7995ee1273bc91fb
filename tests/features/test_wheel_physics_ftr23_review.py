"""Wheel physics features review (ftr23): boundaries of the second, recent time scale."""

from __future__ import annotations

import numpy as np
import pytest

from features.wheel_physics import PHYSICS_FEATURES, WheelPhysicsFeatures


def _windows(n):
    rng = np.random.default_rng(0)
    return 0.5 + 0.1 * rng.random((3, 4, n))


@pytest.mark.parametrize("short_s, n, scales", [
    (0.02, 10, 1), (0.03, 10, 2),                  # 2 samples: too few; 3: the fewest
    (0.09, 10, 2), (0.1, 10, 1), (0.11, 10, 1),   # 9 of 10 samples; the window; more
    (1e300, 10, 1), (1e308, 10, 1), (-1e308, 10, 1),   # counts past a float
])
def test_the_short_scale_holds_three_samples_to_one_less_than_the_window(short_s, n, scales):
    """The recent scale is kept where ``short_s`` rounds to 3 .. n - 1 samples (whole
    window only otherwise, documented); a length whose count overflows a float (1e308 s at
    100 Hz) is past the window, not Python's bare OverflowError of round()."""
    X = _windows(n)
    fx = WheelPhysicsFeatures(rate_hz=100.0, short_s=short_s).fit(X)
    assert len(fx.get_feature_names_out()) == scales * len(PHYSICS_FEATURES)
    out = fx.transform(X)
    assert out.shape == (3, scales * len(PHYSICS_FEATURES)) and np.isfinite(out).all()
