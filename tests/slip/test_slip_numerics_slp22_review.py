"""Review slp22: numerical robustness (valid inputs near the edges of a formula's domain,
long runs, epoch clocks, tiny residuals) and determinism of the slip area."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

FAST = settings(max_examples=60, deadline=None)


def _fused_std_reference(vp: float, vl: float, rho: float) -> float:
    """The std of the inverse-variance weighted mean, in exact rational arithmetic."""
    vp, vl, rho = Fraction(vp), Fraction(vl), Fraction(rho)
    wp, wl = 1 / vp ** 2, 1 / vl ** 2
    a, b = wp / (wp + wl) * vp, wl / (wp + wl) * vl
    return float(a * a + b * b + 2 * rho * a * b) ** 0.5


@FAST
@given(st.floats(1e-4, 0.5), st.floats(-1e-6, 1e-6), st.floats(-1.0, -0.999))
def test_fused_std_with_a_negative_correlation_is_never_nan(vp, rel, rho):
    """rho = -1 (allowed) with two nearly equal stds: the variance a^2 + b^2 - 2 a b of the
    weighted mean is ~0 and rounding made it negative, the std NaN (the pseudo-measurement
    then silently skipped); it is the exact std, floored."""
    from terrain.slip.estimate import FusionSettings, pseudo_measurement

    vl = vp * (1.0 + rel)
    t = np.arange(1.0)
    out = {"physics": (t, np.zeros((1, 2)), np.full((1, 2), vp)),
           "learned": (t, np.zeros((1, 2)), np.full((1, 2), vl))}
    floor = 1e-9
    fs = FusionSettings(min_std=floor, error_correlation=rho)
    _, _, std = pseudo_measurement(out, "fused", fs)
    assert np.all(np.isfinite(std))
    ref = max(_fused_std_reference(vp, vl, rho), floor)
    np.testing.assert_allclose(std, ref, rtol=1e-6)


def test_fused_std_at_minus_one_correlation_in_bulk():
    """Many window-sides: none NaN (10 % were, with stds within 1e-9 of each other)."""
    from terrain.slip.estimate import FusionSettings, pseudo_measurement

    rng = np.random.default_rng(0)
    vp = rng.uniform(1e-3, 0.1, (5000, 2))
    vl = vp * (1 + rng.uniform(-1e-9, 1e-9, vp.shape))
    t = np.arange(5000.0)
    out = {"physics": (t, np.zeros_like(vp), vp), "learned": (t, np.zeros_like(vl), vl)}
    fs = FusionSettings(min_std=1e-5, error_correlation=-1.0)
    _, _, std = pseudo_measurement(out, "fused", fs)
    assert not np.isnan(std).any()
    np.testing.assert_array_equal(std, 1e-5)
