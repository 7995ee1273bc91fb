"""Force model of the simulator (terrain/sim/forces.py) and the load transfer it is fed:
invariants the docstrings state, checked at the contact level (loads that sum to the weight,
the outer wheels loaded in a turn, Jacobians that are the derivatives or secants they claim,
a step that stays damped past a traction peak)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import terrain.sim.dynamics as dynamics
from terrain.sim.dynamics import integrate
from terrain.sim.forces import (LOAD_TRANSFER, MIN_LOAD_FRACTION, contact_forces,
                                contact_layout, reach_chord_contact, transferred_normal_loads,
                                velocity_maps)
from terrain.terramechanics.catalogue import get_terrain
from terrain.terramechanics.lateral import SOILS, combined_shear_shares, soil_contact
from terrain.terramechanics.traction import JanosiCurve, TractionAndResistance
from terrain.vehicles import HUSKY

W = 50.0 * 9.80665 / 4.0          # static Husky wheel load, N


def _husky():
    geo = HUSKY.contact_geometry()
    layout = contact_layout(geo, HUSKY.mass_kg, 0.0, 1.0)
    return geo, layout, velocity_maps(layout, np.zeros_like(layout.x_m))


def test_floored_loads_still_sum_to_the_weight():
    # a hard left turn (f_y = 50 m/s^2) asks dN = -+ m h f_y / (4 |y|) = -+ 471 N of each
    # wheel: the left (inner) wheels would go negative and sit at the floor 0.05 N_static,
    # the right carry N_static + 471 N, and all are rescaled to the static total
    geo, layout, _ = _husky()
    x, y = layout.x_m, layout.y_m
    h = LOAD_TRANSFER["husky"].cog_height_m
    n = transferred_normal_loads(layout.normal_load_n, x, y, HUSKY.mass_kg, h, 0.0, 50.0)
    shift = HUSKY.mass_kg * h * 50.0 / (4 * abs(y[0]))
    assert shift == pytest.approx(471.0, abs=0.5)
    inner, outer = MIN_LOAD_FRACTION * W, W + shift
    scale = 4 * W / (2 * inner + 2 * outer)
    np.testing.assert_allclose(n[y > 0], inner * scale, rtol=1e-9)
    np.testing.assert_allclose(n[y < 0], outer * scale, rtol=1e-9)
    assert n.sum() == pytest.approx(4 * W, rel=1e-12)


def _steady_left_turn_loads(monkeypatch):
    loads = []

    def spy(*args):
        loads.append(transferred_normal_loads(*args))
        return loads[-1]

    monkeypatch.setattr(dynamics, "transferred_normal_loads", spy)
    geo = HUSKY.contact_geometry()
    t = np.arange(0.0, 6.0, 0.01)
    cmd = np.column_stack([np.full_like(t, 1.0), np.zeros_like(t), np.full_like(t, 0.6)])
    p = integrate(HUSKY, geo, (get_terrain("ASPHALT"),), 1e9, t, cmd, 0.0, 1.0,
                  physics="v2")
    return p, np.array(loads), geo


def test_accel_body_is_the_kinematic_acceleration_of_the_twist(monkeypatch):
    # PhysicsResult.accel_body is dV/dt + r x V = (dv_x/dt - r v_y, dv_y/dt + r v_x): in a
    # turn the centripetal r v_x, and the r v_y of the skid's side velocity, are in it
    p, _, _ = _steady_left_turn_loads(monkeypatch)
    dt = 0.01
    v = p.twist[:-1]
    acc = (p.twist[1:, :2] - v[:, :2]) / dt
    expected = np.column_stack([acc[:, 0] - v[:, 2] * v[:, 1],
                                acc[:, 1] + v[:, 2] * v[:, 0]])
    np.testing.assert_allclose(p.accel_body[1:], expected, rtol=1e-9, atol=1e-12)
    steady = slice(-100, None)
    assert np.all(np.abs(p.twist[steady, 1] * p.twist[steady, 2]) > 1e-4)


def test_a_steady_left_turn_loads_the_outer_right_wheels(monkeypatch):
    # Wong ch. 6.1: the centripetal acceleration r v_x > 0 of a left turn shifts
    # m h r v_x / B of load from the inner (left) side onto the outer (right, y < 0) one,
    # so the right side carries 2 m h r v_x / B more than the left (B the track)
    p, loads, geo = _steady_left_turn_loads(monkeypatch)
    y = geo.positions_m[:, 1]
    track = y.max() - y.min()
    h = LOAD_TRANSFER["husky"].cog_height_m
    v_x, r = p.twist[-1, 0], p.twist[-1, 2]
    assert r > 0.1 and v_x > 0.5                          # a left turn under way
    n = loads[-1]
    assert n[y < 0].sum() - n[y > 0].sum() == pytest.approx(
        2 * HUSKY.mass_kg * h * r * v_x / track, rel=0.02)


def test_the_motion_resistance_jacobian_is_its_derivative():
    # with no traction (mu = 0) the longitudinal force is -N f_soil(|s|) tanh(v / 0.01): its
    # Jacobian has no secant in it and must be the derivative of the force, including the
    # slip-dependent Brixius term 0.5 |s| / sqrt(Bn) (PLOUGHED)
    _, layout, maps = _husky()
    plough = get_terrain("PLOUGHED")
    ter = replace(plough, curve=TractionAndResistance(JanosiCurve(0.0, 0.1), plough.curve))
    omega = np.array([0.4, 0.2]) / HUSKY.wheel_radius_m
    twist = np.array([0.3, 0.0, 0.0])     # no side slip: the lateral secant is its tangent
    c = contact_forces(layout, maps, ter, twist, omega)
    h = 1e-7
    for j in (0, 2):
        dv = np.zeros(3)
        dv[j] = h
        fd = (contact_forces(layout, maps, ter, twist + dv, omega).force
              - contact_forces(layout, maps, ter, twist - dv, omega).force) / (2 * h)
        np.testing.assert_allclose(c.jacobian[[0, 2], j], fd[[0, 2]], rtol=1e-5, atol=1e-6)
    # the slip-dependent term is in it: the resistance alone has no slope at v = 0.3 m/s
    assert abs(c.jacobian[0, 0]) > 1.0


def test_combined_slip_side_slope_is_the_secant_of_the_side_force():
    # physics v2 on rigid ground (the tyre's friction ellipse): under pure side slip the
    # lateral slope is the secant F_y / v_y of each contact, with the side-force factor in it
    _, layout, maps = _husky()
    omega = np.full(2, 0.5 / HUSKY.wheel_radius_m)
    for k_s in (0.6, 1.0):
        c = contact_forces(layout, maps, get_terrain("ASPHALT"), np.array([0.5, 0.02, 0.0]),
                           omega, side_force_factor=k_s)
        assert c.force[1] < 0
        assert c.jacobian[1, 1] == pytest.approx(c.force[1] / 0.02, rel=1e-9)


def test_the_reach_chord_is_not_anti_damped_past_a_traction_peak():
    # SNOW's hump-type curve falls past slip 0.42: a wheel spinning at slip 0.8 whose body
    # the step speeds up falls back along the falling branch, where the chord is negative;
    # it is floored at 0 (docstring) so the longitudinal step stays damped
    _, layout, maps = _husky()
    contact = soil_contact(SOILS["SNOW"], 0.11, 0.08, 0.1651, 4 * W)
    ter = dynamics.v2_terrain(get_terrain("SNOW"), contact, W)
    omega = np.full(2, 0.5 / HUSKY.wheel_radius_m)
    c = contact_forces(layout, maps, ter, np.array([0.1, 0.0, 0.0]), omega, soil=contact)
    assert np.all(c.slip == pytest.approx(0.8)) and np.all(c.dmu_ds_tangent < 0)
    r = reach_chord_contact(c, layout, maps, ter, np.array([0.1, 0.0, 0.0]), soil=contact)
    np.testing.assert_array_equal(r.dmu_ds, 0.0)
    assert r.jacobian[0, 0] <= 0


def test_velocity_weakening_of_a_braking_wheel_uses_its_slip_speed():
    # a wheel braking at omega r = 0.3 m/s under a body at 0.5 m/s: slip -0.4, slip speed
    # |omega r - v| = 0.2 m/s, so mu = mu(0.4) / (1 + 0.2 / u_c); the SAE denominator is
    # the body speed, u = 0.5 |s|, and the slope in |s| is that of mu(|s|) / (1 + 0.5 |s| /
    # u_c)
    _, layout, maps = _husky()
    weak = replace(SOILS["SNOW"], rate_weakening_speed_m_s=0.2)
    plain = soil_contact(SOILS["SNOW"], 0.11, 0.08, 0.1651, 4 * W)
    contact = replace(plain, soil=weak)
    ter = dynamics.v2_terrain(get_terrain("SNOW"), plain, W)

    def weakened(s):
        return ter.curve.coefficients(np.array([s]), 0.0).mu[0] / (1 + 0.5 * s / 0.2)

    omega = np.full(2, 0.3 / HUSKY.wheel_radius_m)
    c = contact_forces(layout, maps, ter, np.array([0.5, 0.0, 0.0]), omega, soil=contact)
    np.testing.assert_allclose(c.slip, -0.4)
    np.testing.assert_allclose(c.mu, -weakened(0.4), rtol=1e-9)
    fd = (weakened(0.4 + 1e-6) - weakened(0.4 - 1e-6)) / 2e-6
    np.testing.assert_allclose(c.dmu_ds_tangent, fd, rtol=1e-5)


def test_combined_shear_scales_the_traction_by_its_share():
    # a soil with combined_shear: each wheel's traction is its one-direction curve times
    # the longitudinal share of combined_shear_shares (a_x = |s| / k, a_y = l |v_y| /
    # (K_y omega r)), so a wheel sliding sideways drives with less
    _, layout, maps = _husky()
    soil = replace(SOILS["SANDY_LOAM"], combined_shear=True)
    contact = soil_contact(soil, 0.11, 0.08, 0.1651, 4 * W)
    ter = dynamics.v2_terrain(get_terrain("SANDY_LOAM"), contact, W)
    omega = np.full(2, 0.5 / HUSKY.wheel_radius_m)
    c = contact_forces(layout, maps, ter, np.array([0.4, 0.2, 0.0]), omega, soil=contact)
    np.testing.assert_allclose(c.slip, 0.2)
    k = ter.curve.traction.shear_slip
    length = np.interp(W, contact.load_grid_n, contact.length_grid_m)
    a_y = length * 0.2 / (soil.shear_modulus_y_m * 0.5)
    share = combined_shear_shares(np.array([0.2 / k]), np.array([a_y]), soil.residual_ratio)[0]
    assert share[0] < 0.9
    mu_alone = ter.curve.coefficients(np.array([0.2]), 0.0).mu[0]
    np.testing.assert_allclose(c.mu, mu_alone * share[0], rtol=1e-9)
