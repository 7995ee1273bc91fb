"""Combined-slip (friction ellipse) tyre law and what it does to a simulated skid-steer."""

from __future__ import annotations

from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pytest

import terrain.sim.dynamics as dynamics
from terrain.errors import ConfigError
from terrain.sim import SimConfig
from terrain.sim.forces import COMBINED_SLIP
from terrain.sim.simulate import simulate_with_physics
from terrain.terramechanics import get_terrain, is_deformable, traction_coefficient
from terrain.terramechanics.traction import traction_peak
from terrain.terramechanics.combined_slip import combined_slip_coefficients
from terrain.vehicles import HUSKY
from terrain.vehicles.icr import icr_expansion_factor

ASPHALT = get_terrain("ASPHALT").curve


def test_without_side_slip_it_is_the_longitudinal_curve():
    s = np.linspace(-1.0, 1.0, 41)
    c = combined_slip_coefficients(ASPHALT, s, np.zeros_like(s), 0.7)
    np.testing.assert_allclose(c.mu_long, traction_coefficient(ASPHALT, s), atol=1e-12)
    np.testing.assert_array_equal(c.mu_side, 0.0)


def test_pure_side_slip_gives_the_side_force_factor_times_the_curve_against_the_slip():
    s_y = np.array([-0.8, -0.1, 0.05, 0.3, 1.0])
    c = combined_slip_coefficients(ASPHALT, np.zeros_like(s_y), s_y, 0.6)
    np.testing.assert_allclose(c.mu_side, -0.6 * traction_coefficient(ASPHALT, s_y),
                               atol=1e-12)
    np.testing.assert_array_equal(c.mu_long, 0.0)


def test_force_lies_on_the_ellipse_of_the_resultant_slip_and_along_the_slip():
    rng = np.random.default_rng(3)
    s_x, s_y = rng.uniform(-0.7, 0.7, 200), rng.uniform(-0.7, 0.7, 200)
    k = 0.7
    c = combined_slip_coefficients(ASPHALT, s_x, s_y, k)
    mu_res = traction_coefficient(ASPHALT, np.hypot(s_x, s_y))
    np.testing.assert_allclose(np.hypot(c.mu_long, c.mu_side / k), mu_res, rtol=1e-12)
    # same secant in both directions: the force points along (s_x, -k s_y)
    np.testing.assert_allclose(c.mu_long * (-k * s_y), c.mu_side * s_x, atol=1e-12)
    # past s_res = 1 the curve is held at its value at 1
    far = combined_slip_coefficients(ASPHALT, np.array([1.0]), np.array([3.0]), 1.0)
    assert np.hypot(far.mu_long, far.mu_side)[0] == pytest.approx(
        float(traction_coefficient(ASPHALT, 1.0)))
    assert far.tangent[0] == 0.0


def test_side_force_factor_outside_0_1_is_refused():
    for k in (0.0, -0.5, 1.2):
        with pytest.raises(ConfigError, match="side_force_factor"):
            combined_slip_coefficients(ASPHALT, np.zeros(1), np.zeros(1), k)


def test_rigid_surfaces_are_the_non_deformable_entries():
    assert not any(is_deformable(get_terrain(t)) for t in ("ASPHALT", "FLOORING", "ICE",
                                                           "CONCRETE"))
    assert all(is_deformable(get_terrain(t)) for t in ("SANDY_LOAM", "SNOW", "GRASS"))


def _v2_spin(terrain: str, **tyre):
    """Physics of a simulated 16 s v2 Husky spin with the tyre entry's fields ``tyre``."""
    original = dynamics.COMBINED_SLIP
    dynamics.COMBINED_SLIP = MappingProxyType(
        {**original, "husky": replace(original["husky"], **tyre)})
    try:
        return simulate_with_physics(SimConfig(vehicle="husky", terrains=(terrain,),
                                               scenario="spin", duration_s=16.0, seed=1,
                                               physics="v2")).physics
    finally:
        dynamics.COMBINED_SLIP = original


def _chi(p) -> float:
    """chi of a simulated run's physics (yaw rate on the wheel yaw rate, turning samples)."""
    x = (p.omega[:, 1] - p.omega[:, 0]) * HUSKY.wheel_radius_m / HUSKY.track_m
    m = np.abs(x) > 0.1
    return icr_expansion_factor(p.twist[m, 2], x[m])


def _spin_chi(terrain: str, k_s: float) -> float:
    """chi of a simulated v2 Husky spin with side-force factor ``k_s``."""
    return _chi(_v2_spin(terrain, side_force_factor=k_s))


@pytest.mark.parametrize("terrain, k_s", [("ASPHALT", 1.0), ("ASPHALT", 0.7),
                                          ("FLOORING", 0.7)])
def test_simulated_spin_chi_is_the_moment_balance_of_sliding_contacts(terrain, k_s):
    # every contact sliding at (+-a, +-b): b mu_L = a |mu_S|  =>  chi = 1 + k_S (a / b)^2,
    # whatever the friction level of the surface (module docstring)
    a, b = HUSKY.wheelbase_m / 2.0, HUSKY.track_m / 2.0
    assert _spin_chi(terrain, k_s) == pytest.approx(1.0 + k_s * (a / b) ** 2, rel=0.01)


def test_the_husky_tyre_entry_is_in_range_and_sourced():
    tyre = COMBINED_SLIP["husky"]
    assert 0.0 < tyre.side_force_factor <= 1.0 and "training" in tyre.source


def test_held_at_the_peak_there_is_no_falling_branch():
    peak = traction_peak(ASPHALT)
    s_x = np.array([0.05, 0.1, 0.5, 1.0])
    s_y = np.array([0.02, 0.05, 2.0, 3.0])
    held = combined_slip_coefficients(ASPHALT, s_x, s_y, 0.7, hold_slip=peak.slip)
    full = combined_slip_coefficients(ASPHALT, s_x, s_y, 0.7)
    below = np.hypot(s_x, s_y) < peak.slip
    # below the peak slip nothing changes; past it the resultant friction is the peak's
    np.testing.assert_allclose(held.mu_long[below], full.mu_long[below], rtol=1e-12)
    np.testing.assert_allclose(np.hypot(held.mu_long, held.mu_side / 0.7)[~below], peak.mu,
                               rtol=1e-9)
    assert np.all(held.tangent[~below] == 0.0)
    assert np.all(np.hypot(full.mu_long, full.mu_side)[~below]
                  < np.hypot(held.mu_long, held.mu_side)[~below])
    for bad in (0.0, 1.5):
        with pytest.raises(ConfigError, match="hold_slip"):
            combined_slip_coefficients(ASPHALT, s_x, s_y, 0.7, hold_slip=bad)


def test_tyre_hold_slip_is_the_peak_of_a_falling_curve_only():
    tyre = replace(COMBINED_SLIP["husky"], hold_at_peak=True)
    flooring = get_terrain("FLOORING").curve
    assert tyre.hold_slip(flooring) == pytest.approx(traction_peak(flooring).slip)
    assert 0.05 < tyre.hold_slip(flooring) < 0.3
    assert tyre.hold_slip(get_terrain("ICE").curve) == 1.0        # rises to full slip
    assert replace(tyre, hold_at_peak=False).hold_slip(flooring) == 1.0


def _turning_torque(p) -> float:
    """Mean drive torque magnitude of a simulated run's turning samples, N m."""
    return float(np.mean(np.abs(p.torque[np.abs(p.twist[:, 2]) > 0.3])))


def _spin_torque(hold_at_peak: bool) -> float:
    """Mean drive torque magnitude of a simulated v2 Husky spin on FLOORING, N m."""
    return _turning_torque(_v2_spin("FLOORING", hold_at_peak=hold_at_peak))


@pytest.mark.slow
def test_spin_torque_follows_the_held_friction():
    # sliding contacts: the drive torque of a spin is proportional to the friction at the
    # contacts' resultant slip (s_L = (chi - 1) / chi, s_S = (a / b) / chi, past the peak),
    # so holding the FLOORING curve at its peak raises it by mu_peak / mu(s_res)
    flooring = get_terrain("FLOORING").curve
    k_s = COMBINED_SLIP["husky"].side_force_factor
    a, b = HUSKY.wheelbase_m / 2.0, HUSKY.track_m / 2.0
    chi = 1.0 + k_s * (a / b) ** 2
    s_res = np.hypot((chi - 1.0) / chi, (a / b) / chi)
    assert s_res > traction_peak(flooring).slip
    ratio = traction_peak(flooring).mu / float(traction_coefficient(flooring, s_res))
    measured = _spin_torque(True) / _spin_torque(False)
    assert measured == pytest.approx(ratio, rel=0.1)
    assert measured > 1.15


def test_tyre_friction_scale_scales_the_burckhardt_friction_and_keeps_its_peak_slip():
    ice = get_terrain("ICE").curve
    asphalt = get_terrain("ASPHALT").curve
    tyre = replace(COMBINED_SLIP["husky"], friction_scale=MappingProxyType({"ICE": 3.0,
                                                                            "ASPHALT": 0.5}))
    s = np.linspace(0.0, 1.0, 21)
    np.testing.assert_allclose(traction_coefficient(tyre.surface_curve("ICE", ice), s),
                               3.0 * traction_coefficient(ice, s), rtol=1e-12)
    half = tyre.surface_curve("ASPHALT", asphalt)
    assert traction_peak(half).slip == pytest.approx(traction_peak(asphalt).slip, rel=1e-6)
    assert traction_peak(half).mu == pytest.approx(0.5 * traction_peak(asphalt).mu)
    flooring = get_terrain("FLOORING").curve
    assert tyre.surface_curve("FLOORING", flooring) is flooring        # no entry: catalogue
    with pytest.raises(ConfigError, match="friction_scale"):
        replace(tyre, friction_scale=MappingProxyType({"ICE": 0.0})).surface_curve("ICE", ice)
    with pytest.raises(ConfigError, match="Burckhardt"):
        tyre.surface_curve("ICE", get_terrain("SANDY_LOAM").curve)


@pytest.mark.slow
def test_simulated_ice_spin_current_rises_with_the_tyre_friction_and_chi_does_not():
    def spin(scale):
        p = _v2_spin("ICE", friction_scale=MappingProxyType({"ICE": scale}))
        return _chi(p), _turning_torque(p)
    (chi1, torque1), (chi2, torque2), (chi3, torque3) = spin(1.0), spin(2.0), spin(3.0)
    assert chi3 == pytest.approx(chi1, rel=0.03)       # chi = 1 + k_S (a/b)^2 at any friction
    assert chi2 == pytest.approx(chi1, rel=0.03)
    # the sliding contacts' friction torque is linear in the friction level (the rolling
    # resistance torque, most of it on ICE, is not): equal steps of the factor, equal steps
    assert torque3 - torque1 == pytest.approx(2.0 * (torque2 - torque1), rel=0.1)
    assert torque3 - torque1 > 0.1 * torque1
