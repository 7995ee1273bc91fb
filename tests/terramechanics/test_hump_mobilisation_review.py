"""Patch mean of Wong's hump-type shear curve against a direct quadrature (review tests)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from terrain.terramechanics.traction import patch_mobilisation


def _hump(u: float, kr: float) -> float:
    """Wong's hump-type shear curve over its peak strength, ``u = j / K_w`` (ch. 2.4)."""
    b = 1.0 / (kr * (1.0 - np.exp(-1.0))) - 1.0
    return kr * (1.0 + b * np.exp(1.0 - u)) * (1.0 - np.exp(-u))


def _k_w_over_k(kr: float) -> float:
    """``K_w / K = f'(0) = K_r (1 + B e)``: the initial stiffness of the exponential curve."""
    b = 1.0 / (kr * (1.0 - np.exp(-1.0))) - 1.0
    return kr * (1.0 + b * np.e)


@pytest.mark.parametrize("kr", [0.4, 0.9])
@pytest.mark.parametrize("a", [1e-4, 0.05, 1.0, 4.0, 12.0])
def test_hump_patch_mean_and_slope_are_the_quadrature_of_wongs_curve(kr, a):
    # a = 1e-4 lies on the series branch (U < 1e-4), the others on the closed form
    s0 = _k_w_over_k(kr)
    u_end = a / s0
    mean = quad(_hump, 0.0, u_end, args=(kr,), epsabs=0.0, epsrel=1e-13)[0] / u_end
    slope = (_hump(u_end, kr) - mean) / u_end / s0      # d/da of (1/U) int_0^U f, U = a / s0
    g, dg = patch_mobilisation(np.array([a]), kr)
    assert g[0] == pytest.approx(mean, rel=1e-8)
    assert dg[0] == pytest.approx(slope, rel=1e-6, abs=1e-12)


@pytest.mark.parametrize("kr", [0.2, 0.4, 0.9])
def test_hump_series_meets_the_closed_form_where_the_kernel_switches(kr):
    # the kernel switches from its second-order series to the closed form at U = 1e-4
    a = _k_w_over_k(kr) * 1e-4 * np.array([1.0 - 1e-9, 1.0 + 1e-9])
    g, dg = patch_mobilisation(a, kr)
    assert g[1] == pytest.approx(g[0], rel=1e-7)
    assert dg[1] == pytest.approx(dg[0], rel=1e-6)
