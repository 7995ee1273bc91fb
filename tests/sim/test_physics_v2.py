"""Physics v2: lateral wheel-soil model, load transfer, the v1/v2 switch."""

from __future__ import annotations

from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pytest
from scipy.integrate import trapezoid

import terrain.sim.dynamics as dynamics
from terrain.errors import ConfigError
from terrain.sim import Effects, SimConfig
from terrain.sim.dynamics import integrate, soil_contacts
from terrain.sim.forces import (LOAD_TRANSFER, contact_forces, contact_layout, gravity_force,
                                reach_chord_contact, specific_force_m_s2,
                                transferred_normal_loads, velocity_maps)
from terrain.sim.simulate import motor_currents, simulate_with_physics
from terrain.terramechanics.catalogue import MEASURED_HUSKY_STRAIGHT, get_terrain
from terrain.terramechanics.lateral import (SOILS, bearing_capacity_factors,
                                            bulldozing_force_n, combined_shear_shares,
                                            lateral_strength_n, longitudinal_curve,
                                            rate_weakening_factor, shear_mobilisation,
                                            soil_contact,
                                            slip_sunk_strength_n, soil_lateral_force_and_slope,
                                            wheel_sinkage_m)
from terrain.terramechanics.resistance import (bekker_sinkage_m, is_deformable,
                                               soil_resistance_coefficient)
from terrain.terramechanics.traction import patch_mobilisation, traction_curve_and_slope
from terrain.vehicles import HUSKY, get_vehicle

W = 50.0 * 9.80665 / 4.0          # static Husky wheel load, N


def test_bearing_capacity_factors_match_the_tables():
    # Vesic's values at phi = 30 deg: N_c 30.14, N_q 18.40, N_gamma 22.40 (Das, Principles
    # of Foundation Engineering, Table 3.3)
    n_c, n_q, n_g = bearing_capacity_factors(30.0)
    assert (n_c, n_q, n_g) == pytest.approx((30.14, 18.40, 22.40), abs=0.02)


def test_shear_mobilisation_limits_and_monotone():
    a = np.array([0.0, 1e-8, 0.1, 1.0, 10.0, 1e4])
    g = shear_mobilisation(a)
    assert g[0] == pytest.approx(0.0, abs=1e-9) and g[-1] == pytest.approx(1.0, abs=1e-3)
    assert g[2] == pytest.approx(0.05, rel=0.05)          # a / 2 for small a
    assert g[3] == pytest.approx(np.exp(-1.0), rel=1e-9)   # 1 - (1 - e^-1) = e^-1
    assert np.all(np.diff(g) > 0)


def _wong_hump(u, k_r):
    """Wong's hump-type shear curve tau / tau_max at u = j / K_w (Theory of Ground
    Vehicles, ch. 2.4), written out independently of the library."""
    b = 1.0 / (k_r * (1.0 - np.exp(-1.0))) - 1.0
    return k_r * (1.0 + b * np.exp(1.0 - u)) * (1.0 - np.exp(-u))


@pytest.mark.parametrize("k_r", [0.8, 0.4, 0.2])
def test_hump_patch_mobilisation_is_wongs_curve_averaged_over_the_patch(k_r):
    b = 1.0 / (k_r * (1.0 - np.exp(-1.0))) - 1.0
    k_w = k_r * (1.0 + b * np.e)          # K_w / K: the exponential curve's initial stiffness
    a = np.array([1e-6, 3e-5, 2e-4, 0.05, 0.7, 2.0, 6.0, 25.0])
    g, dg = patch_mobilisation(a, k_r)
    for a_i, g_i in zip(a, g):
        j = np.linspace(0.0, a_i, 400_001)           # shear displacement over K
        assert g_i == pytest.approx(trapezoid(_wong_hump(j / k_w, k_r), j) / a_i,
                                    rel=1e-7, abs=1e-13)
    h = 1e-6 * a
    num = (patch_mobilisation(a + h, k_r)[0] - patch_mobilisation(a - h, k_r)[0]) / (2 * h)
    np.testing.assert_allclose(dg, num, rtol=1e-5, atol=1e-9)
    # the same initial shear stiffness as the exponential curve (g ~ a / 2) ...
    assert g[0] == pytest.approx(a[0] / 2, rel=1e-5)
    # ... a peak of the point curve near tau_max (exact at K_r ~ 0.66), the residual K_r
    # far past it
    u = np.linspace(0.0, 20.0, 20_001)
    assert _wong_hump(u, k_r).max() == pytest.approx(1.0, abs=0.05)   # 1.04 at K_r 0.2
    assert patch_mobilisation(np.array([1e5]), k_r)[0][0] == pytest.approx(k_r, rel=1e-3)
    assert dg[-1] < 0                                  # softening: past the hump's peak


def test_exponential_patch_mobilisation_and_invalid_residual_ratio():
    a = np.array([1e-5, 1.0, 10.0])
    g, _ = patch_mobilisation(a)
    np.testing.assert_allclose(g, 1.0 + np.expm1(-a) / a, rtol=1e-9)
    np.testing.assert_allclose(shear_mobilisation(a), g, rtol=0)
    # the compiled kernel keeps the input's shape: a number, a strided view, a grid
    g0, dg0 = patch_mobilisation(1.0, 0.4)
    assert g0.shape == () and dg0.shape == ()
    grid = np.linspace(0.0, 8.0, 24).reshape(4, 6)
    g2, dg2 = patch_mobilisation(grid[:, ::2], 0.4)
    assert g2.shape == (4, 3)
    np.testing.assert_array_equal(g2, patch_mobilisation(grid, 0.4)[0][:, ::2])
    np.testing.assert_array_equal(dg2[0, 0], patch_mobilisation(0.0, 0.4)[1])
    for bad in (0.0, 1.0, 1.5, float("nan")):
        # the typed error (a ValueError too): was a plain ValueError
        with pytest.raises(ConfigError, match="residual_ratio"):
            patch_mobilisation(a, bad)
        with pytest.raises(ConfigError, match="residual_ratio"):
            replace(SOILS["SNOW"], residual_ratio=bad)


def test_snow_traction_softens_past_its_peak_and_the_ploughed_field_does_not():
    snow, loam, field = SOILS["SNOW"], SOILS["SANDY_LOAM"], SOILS["PLOUGHED"]
    # snow softens most, the firm sandy loam a little, the Vulpi field keeps the
    # exponential law its K was chosen with
    assert snow.residual_ratio < loam.residual_ratio < 1.0 and field.residual_ratio is None
    curves = {}
    for name, soil in (("snow", snow), ("snow-exp", replace(snow, residual_ratio=None)),
                       ("field", field)):
        contact = soil_contact(soil, 0.11, 0.08, 0.1651, 4 * W)
        curves[name] = longitudinal_curve(contact, W)
    s = np.linspace(0.0, 1.0, 201)
    mu_hump, dmu_hump = traction_curve_and_slope(curves["snow"], s)
    mu_exp, _ = traction_curve_and_slope(curves["snow-exp"], s)
    _, dmu_field = traction_curve_and_slope(curves["field"], s)
    assert curves["snow"].mu_max == curves["snow-exp"].mu_max     # same peak strength
    assert np.all(dmu_field >= 0)                                  # exponential: monotone
    assert dmu_hump[-1] < 0 and mu_hump[-1] < 0.9 * mu_exp[-1]     # a spinning wheel: less
    assert mu_hump[1] == pytest.approx(mu_exp[1], rel=0.01)        # same initial stiffness


def test_sinkage_is_bekker_on_firm_soil_and_grows_on_snow():
    loam, snow = SOILS["SANDY_LOAM"], SOILS["SNOW"]
    z, length = wheel_sinkage_m(W, 0.11, 0.08, 0.1651, loam)
    # on sandy loam the chord stays inside the tyre footprint: the plate formula itself
    assert length == pytest.approx(0.08)
    assert z == pytest.approx(bekker_sinkage_m(W, 0.11, 0.08, loam.k_c, loam.k_phi, loam.n))
    z_s, l_s = wheel_sinkage_m(W, 0.11, 0.08, 0.1651, snow)
    assert 0.02 < z_s < 0.1651 and l_s > 0.08
    # fixed point: the sinkage is the Bekker sinkage of its own contact length
    assert z_s == pytest.approx(bekker_sinkage_m(W, 0.11, l_s, snow.k_c, snow.k_phi, snow.n),
                                rel=0.02)
    assert wheel_sinkage_m(2 * W, 0.11, 0.08, 0.1651, snow)[0] > z_s


def test_layer_depth_caps_the_sinkage_and_weakens_the_lateral_strength():
    snow = SOILS["SNOW"]
    assert snow.layer_depth_m is None             # shipped: a layer deeper than any sinkage
    deep, _ = wheel_sinkage_m(W, 0.11, 0.08, 0.1651, snow)
    shallow = replace(snow, layer_depth_m=0.03)
    z, length = wheel_sinkage_m(W, 0.11, 0.08, 0.1651, shallow)
    assert deep > 0.05 and z == pytest.approx(0.03)
    assert length == pytest.approx(2 * np.sqrt(2 * 0.1651 * 0.03 - 0.03 ** 2), rel=0.01)
    # a layer deeper than the sinkage changes nothing
    assert wheel_sinkage_m(W, 0.11, 0.08, 0.1651, replace(snow, layer_depth_m=0.5))[0] == deep
    strength = {}
    for name, soil in (("deep", snow), ("shallow", shallow)):
        c = soil_contact(soil, 0.11, 0.08, 0.1651, 4 * W)
        strength[name] = np.interp(W, c.load_grid_n, c.strength_grid_n)
    assert strength["shallow"] < 0.8 * strength["deep"]   # a lower, shorter bulldozing wall
    with pytest.raises(ConfigError, match="layer_depth_m"):
        replace(snow, layer_depth_m=0.0)


def test_bulldozing_grows_with_depth_and_vanishes_without_sinkage():
    snow = SOILS["SNOW"]
    assert bulldozing_force_n(0.0, 0.2, snow) == 0.0
    assert bulldozing_force_n(0.08, 0.2, snow) > bulldozing_force_n(0.04, 0.2, snow) > 0
    assert bulldozing_force_n(0.08, 0.4, snow) == pytest.approx(
        2 * bulldozing_force_n(0.08, 0.2, snow))


def test_soil_lateral_force_bounded_odd_and_grows_with_slip_angle():
    c = soil_contact(SOILS["SANDY_LOAM"], 0.11, 0.08, 0.1651, 4 * W)
    strength = np.interp(W, c.load_grid_n, c.strength_grid_n)
    # c A + W tan(phi) plus the bulldozing of a ~1 mm sinkage wall (n = 0.7, Wong T. 2.3)
    z, length = wheel_sinkage_m(W, 0.11, 0.08, 0.1651, SOILS["SANDY_LOAM"])
    assert 0.5e-3 < z < 2e-3 and length == pytest.approx(0.08)
    bull = bulldozing_force_n(z, length, SOILS["SANDY_LOAM"])
    assert 0 < bull < 0.05 * W
    assert strength == pytest.approx(1720.0 * 0.11 * 0.08 + W * np.tan(np.radians(29.0))
                                     + bull, rel=0.01)
    v = np.array([-0.3, -0.05, 0.0, 0.05, 0.3])
    f, k, _ = soil_lateral_force_and_slope(c, np.full(5, W), v, np.full(5, 0.3))
    assert np.all(np.abs(f) <= strength + 1e-9)
    assert f == pytest.approx(-f[::-1])
    assert np.all(k <= 0) and f[2] == 0.0
    # the same sideways speed shears more when the wheel rolls slower (larger slip angle)
    f_slow, _, _ = soil_lateral_force_and_slope(c, np.array([W]), np.array([0.05]),
                                                np.array([0.05]))
    assert abs(f_slow[0]) > abs(f[3])


def test_slip_sinkage_deepens_the_wall_with_the_slip_and_keeps_the_static_contact_at_rest():
    snow = replace(SOILS["SNOW"], slip_sinkage_ratio=1.0)
    c = soil_contact(snow, 0.11, 0.08, 0.1651, 4 * W)
    loads = np.array([0.0, W, W, W, W])
    slips = np.array([0.5, 0.0, 0.2, 0.5, -0.5])
    strength, length = slip_sunk_strength_n(c, loads, slips)
    z0, l0 = wheel_sinkage_m(W, 0.11, 0.08, 0.1651, snow)
    # at rest: the tabulated static contact (the table is the same formula at z_0)
    assert strength[1] == pytest.approx(np.interp(W, c.load_grid_n, c.strength_grid_n),
                                        rel=1e-3)
    assert length[1] == pytest.approx(l0, rel=1e-3)
    # deeper with the slip, whichever its sign, as the bulldozing of Wong eq. 2.61 says
    assert 0.05 < z0 < 0.1651 / 1.5        # the shipped snow: ~73 mm static sinkage
    z = z0 * (1 + 1.0 * 0.2)
    chord = 2 * np.sqrt(2 * 0.1651 * z - z * z)
    assert strength[2] == pytest.approx(
        620.0 * 0.11 * chord + W * np.tan(np.radians(23.2)) + bulldozing_force_n(z, chord, snow),
        rel=1e-3)   # z_0 interpolated from the load table
    assert strength[0] == 0.0 and strength[1] < strength[2] < strength[3] == strength[4]
    # nor below a firm base under a shallow layer
    layer = replace(c, soil=replace(snow, layer_depth_m=0.03))
    capped, _ = slip_sunk_strength_n(layer, np.array([W, W]), np.array([0.0, 0.9]))
    assert capped[0] == capped[1]
    # nor below the wheel's rim
    deep, _ = slip_sunk_strength_n(replace(c, soil=replace(snow, slip_sinkage_ratio=1e3)),
                                   np.array([W]), np.array([1.0]))
    z_r = 0.1651
    assert deep[0] == pytest.approx(620.0 * 0.11 * 2 * z_r + W * np.tan(np.radians(23.2))
                                    + bulldozing_force_n(z_r, 2 * z_r, snow))
    # the force law uses the deepened strength only on a soil with slip sinkage
    v = np.array([0.1])
    f_static, _, _ = soil_lateral_force_and_slope(c, np.array([W]), v, np.array([0.2]))
    f_slip, _, _ = soil_lateral_force_and_slope(c, np.array([W]), v, np.array([0.2]),
                                                slip_ratio=np.array([0.5]))
    plain = soil_contact(replace(snow, slip_sinkage_ratio=None), 0.11, 0.08, 0.1651, 4 * W)
    f_plain, _, _ = soil_lateral_force_and_slope(plain, np.array([W]), v, np.array([0.2]),
                                                 slip_ratio=np.array([0.5]))
    assert abs(f_slip[0]) > abs(f_static[0]) and f_plain[0] == pytest.approx(f_static[0])
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ConfigError, match="slip_sinkage_ratio"):
            replace(snow, slip_sinkage_ratio=bad)


def test_velocity_weakening_scales_both_directions_by_their_own_slip_speed():
    snow = SOILS["SNOW"]
    assert snow.rate_weakening_speed_m_s is None          # shipped: no weakening
    f, df = rate_weakening_factor(np.array([0.0, 0.2, -0.2, 0.6]), snow)
    np.testing.assert_array_equal(f, 1.0)
    np.testing.assert_array_equal(df, 0.0)
    weak = replace(snow, rate_weakening_speed_m_s=0.2)
    f, df = rate_weakening_factor(np.array([0.0, 0.2, -0.2, 0.6]), weak)
    np.testing.assert_allclose(f, [1.0, 0.5, 0.5, 0.25])
    np.testing.assert_allclose(df, [-5.0, -1.25, -1.25, -0.3125])
    for bad in (0.0, -0.1, float("nan"), float("inf")):
        with pytest.raises(ConfigError, match="rate_weakening_speed_m_s"):
            replace(snow, rate_weakening_speed_m_s=bad)
    # lateral: the strength at the lateral slip speed, the force and its secant alike
    plain = soil_contact(snow, 0.11, 0.08, 0.1651, 4 * W)
    weak_c = replace(plain, soil=weak)
    v = np.array([0.05, 0.2, -0.4])
    f_p, k_p, _ = soil_lateral_force_and_slope(plain, np.full(3, W), v, np.full(3, 0.3))
    f_w, k_w, _ = soil_lateral_force_and_slope(weak_c, np.full(3, W), v, np.full(3, 0.3))
    scale = 1.0 / (1.0 + np.abs(v) / 0.2)
    np.testing.assert_allclose(f_w, f_p * scale)
    np.testing.assert_allclose(k_w, k_p * scale)
    # longitudinal: a wheel spinning at 0.3 m/s on a body at rest, slip 1, slip speed 0.3 m/s
    geo = HUSKY.contact_geometry()
    layout = contact_layout(geo, HUSKY.mass_kg, 0.0, 1.0)
    maps = velocity_maps(layout, np.zeros_like(layout.x_m))
    ter = dynamics.v2_terrain(get_terrain("SNOW"), plain, W)
    omega = np.full(geo.n_motors, 0.3 / geo.wheel_radius_m)
    still = np.zeros(3)
    c_p = contact_forces(layout, maps, ter, still, omega, soil=plain)
    c_w = contact_forces(layout, maps, ter, still, omega, soil=weak_c)
    np.testing.assert_allclose(c_w.mu, c_p.mu / (1.0 + 0.3 / 0.2))
    assert c_w.force[0] < c_p.force[0]
    # the reach of the implicit step weakens its curve as the contact did (no slip change
    # here: the same contact back)
    r_w = reach_chord_contact(c_w, layout, maps, ter, np.zeros(3), soil=weak_c)
    np.testing.assert_allclose(r_w.mu, c_w.mu)


@pytest.mark.parametrize("k_r", [None, 0.9, 0.4])
def test_combined_shear_shares_put_the_resultant_on_the_strength_curve(k_r):
    a_x = np.array([0.0, 0.5, 2.0, 1e-13, 3.0, 40.0])
    a_y = np.array([1.0, 0.0, 2.0, 0.7, 1e-3, 5.0])
    s_x, s_y = combined_shear_shares(a_x, a_y, k_r)
    a = np.hypot(a_x, a_y)
    g, g_x, g_y = (shear_mobilisation(v, k_r) for v in (a, a_x, a_y))
    # each direction's force is the resultant's shear along its own displacement ...
    np.testing.assert_allclose(s_x * g_x, g * a_x / a, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(s_y * g_y, g * a_y / a, rtol=1e-9, atol=1e-15)
    # ... so both together mobilise the strength once, g(a), never each its own g(a_i)
    np.testing.assert_allclose(np.hypot(s_x * g_x, s_y * g_y), g, rtol=1e-9)
    # a direction the other does not share with keeps its whole force; a direction that
    # slides far leaves little stiffness to the other (the friction-ellipse effect)
    assert s_x[1] == 1.0 and s_y[0] == 1.0
    assert s_x[4] == pytest.approx(1.0, abs=1e-6)
    assert s_y[4] < 0.5


def test_combined_shear_keeps_a_spinning_wheel_within_the_soil_strength():
    # the defect the flag answers (docs/physics_v2.md, "The shear strength shared between
    # directions"): a wheel slipping 0.4 along and sliding 0.2 m/s sideways at a 0.3 m/s rim
    # speed takes the patch's whole Mohr-Coulomb strength in each direction
    loam = SOILS["SANDY_LOAM"]
    assert not loam.combined_shear                      # shipped: each direction whole
    strength = float(lateral_strength_n(loam, 0.11, np.array([W]),
                                        *wheel_sinkage_m(W, 0.11, 0.08, 0.1651, loam))[0])
    results = {}
    for flag in (False, True):
        c = soil_contact(replace(loam, combined_shear=flag), 0.11, 0.08, 0.1651, 4 * W)
        curve = longitudinal_curve(c, W)
        a_x = np.array([0.4 / curve.shear_slip]) if flag else None
        f_y, _, share = soil_lateral_force_and_slope(c, np.array([W]), np.array([0.2]),
                                                     np.array([0.3]), shear_long=a_x)
        share = 1.0 if share is None else share
        f_x = W * curve.coefficients(np.array([0.4]), 0.0).mu * share
        results[flag] = float(np.hypot(f_x, f_y)[0])
    assert results[False] > 1.1 * strength              # 99 N against 85 N
    assert results[True] <= strength
    with pytest.raises(ConfigError, match="combined_shear"):
        replace(loam, combined_shear=1)
    with pytest.raises(ConfigError, match="slip_compaction"):
        replace(loam, slip_compaction="no")
    # a NumPy boolean (a flag read from an array or a parquet table) is a boolean
    assert replace(loam, combined_shear=np.bool_(True)).combined_shear


@pytest.mark.slow
def test_combined_shear_lets_the_husky_spin_more_freely_on_sandy_loam(monkeypatch):
    # sharing the strength leaves less lateral shear to a wheel that spins: 1/chi larger
    # (sweep on the training runs: simulated spin chi 1.74 -> 1.61, docs/physics_v2.md)
    a2 = _spin_yaw("v2")
    monkeypatch.setattr(dynamics, "SOILS", MappingProxyType({
        **SOILS, "SANDY_LOAM": replace(SOILS["SANDY_LOAM"], combined_shear=True)}))
    assert a2 < _spin_yaw("v2") < 1


def test_slip_compaction_adds_the_deeper_ruts_bekker_compaction_to_the_resistance():
    loam = replace(SOILS["SANDY_LOAM"], slip_sinkage_ratio=5.0, slip_compaction=True)
    contact = soil_contact(loam, 0.11, 0.08, 0.1651, 4 * W)
    base = get_terrain("SANDY_LOAM")
    ter = dynamics.v2_terrain(base, contact, W)
    s = np.array([0.0, 0.1, 0.4, 1.0])
    c = ter.curve.coefficients(s, base.soil_resistance)
    plain = dynamics.v2_terrain(base, replace(contact, soil=replace(loam, slip_compaction=False)),
                                W).curve.coefficients(s, base.soil_resistance)
    np.testing.assert_array_equal(c.mu, plain.mu)          # traction unchanged
    np.testing.assert_array_equal(plain.resistance, base.soil_resistance)
    z0 = wheel_sinkage_m(W, 0.11, 0.08, 0.1651, loam)[0]
    # Wong eq. 2.54 at z = z0 (1 + 5 s) less its value at rest, over the load (z0 from the
    # contact's load table, within 1e-3 of the direct fixed point at W)
    k = loam.k_c / 0.11 + loam.k_phi
    r_c = 0.11 * k * (z0 * (1 + 5 * s)) ** 1.7 / 1.7
    np.testing.assert_allclose(c.resistance - base.soil_resistance, (r_c - r_c[0]) / W,
                               rtol=1e-3, atol=1e-12)
    assert c.resistance[0] == base.soil_resistance and np.all(np.diff(c.resistance) > 0)
    h = 1e-6
    up = ter.curve.coefficients(s[1:] + h, base.soil_resistance).resistance
    down = ter.curve.coefficients(s[1:] - h, base.soil_resistance).resistance
    np.testing.assert_allclose(c.dresistance_ds[1:], (up - down) / (2 * h), rtol=1e-5)
    # a rut as deep as the wheel radius stops deepening: no slope there
    deep = replace(contact, soil=replace(loam, slip_sinkage_ratio=1e6))
    capped = dynamics.v2_terrain(base, deep, W).curve.coefficients(np.array([0.5]), 0.08)
    assert capped.dresistance_ds[0] == 0.0
    with pytest.raises(ConfigError, match="slip_compaction"):
        replace(loam, slip_compaction="yes")


def test_longitudinal_curve_is_the_catalogue_strength_with_the_soils_k_x():
    loam = SOILS["SANDY_LOAM"]
    c = soil_contact(loam, 0.11, 0.08, 0.1651, 4 * W)
    curve = longitudinal_curve(c, W)
    cat = get_terrain("SANDY_LOAM").curve
    # same Mohr-Coulomb strength on the same 0.11 x 0.08 m patch as the catalogue (v1) curve
    assert curve.mu_max == pytest.approx(cat.mu_max, rel=1e-6)
    # Janosi shear slip K / L with the v2 soil's longitudinal K_x (the lateral K_y differs)
    assert curve.shear_slip == pytest.approx(loam.shear_modulus_m / 0.08, rel=1e-6)
    assert loam.shear_modulus_y_m != loam.shear_modulus_m


def test_load_transfer_balances_forces_and_moments():
    geo = HUSKY.contact_geometry()
    static = np.full(4, W)
    x, y = geo.positions_m[:, 0], geo.positions_m[:, 1]
    h = LOAD_TRANSFER["husky"].cog_height_m
    n = transferred_normal_loads(static, x, y, 50.0, h, 1.0, 2.0)
    assert n.sum() == pytest.approx(static.sum())
    assert np.sum((n - static) * x) == pytest.approx(-50.0 * h * 1.0)
    assert np.sum((n - static) * y) == pytest.approx(-50.0 * h * 2.0)
    # left turn (a_y > 0): the right (outer, y < 0) wheels carry more
    assert n[y < 0].sum() > n[y > 0].sum()
    assert np.all(transferred_normal_loads(static, x, y, 50.0, h, 0.0, 50.0) > 0)


def _curve_currents(physics):
    veh = get_vehicle("husky")
    geo = veh.contact_geometry()
    t = np.arange(0.0, 6.0, 0.01)
    twist = np.column_stack([np.full_like(t, 1.0), np.zeros_like(t), np.full_like(t, 0.6)])
    p = integrate(veh, geo, (get_terrain("ASPHALT"),), 1e9, t, twist, 0.0, 1.0,
                  physics=physics)
    cur = np.abs(veh.motor.current_from_torque(p.torque, p.omega))
    return cur[t > 3.0].mean(axis=0)      # steady left turn: left inner, right outer


def test_steady_curve_current_split_is_set_by_equilibrium_not_load_transfer(monkeypatch):
    # finding of docs/physics_v2.md: in a steady turn the side forces are fixed by the force
    # and moment balance of the body, so shifting normal load to the outer wheels (5 % of the
    # wheel load at 0.6 m/s^2) changes only the load-proportional rolling loss: the outer
    # motor draws more in both versions, and the load transfer of v2 moves the split by a few
    # hundredths of an A (v2's rigid-surface tyre law switched off to isolate it; that law
    # changes the turn itself, tests/terramechanics/test_combined_slip.py)
    monkeypatch.setattr(dynamics, "COMBINED_SLIP", MappingProxyType({}))
    left1, right1 = _curve_currents("v1")
    left2, right2 = _curve_currents("v2")
    assert right1 > left1 + 1.0 and right2 > left2 + 1.0
    assert abs((right2 - left2) - (right1 - left1)) < 0.05
    assert (left2 + right2) == pytest.approx(left1 + right1, rel=0.02)


def _spin_yaw(physics):
    sim = simulate_with_physics(SimConfig(terrains=("SANDY_LOAM",), scenario="spin",
                                          duration_s=8.0, seed=1, physics=physics))
    p = sim.physics
    x = (p.omega[:, 1] - p.omega[:, 0]) * HUSKY.wheel_radius_m / HUSKY.track_m
    m = np.abs(x) > 0.1
    return float(np.sum(x[m] * p.twist[m, 2]) / np.sum(x[m] ** 2))


def test_v2_spins_more_freely_than_v1_on_sandy_loam():
    # v1 scrubs with Coulomb friction 0.35 whatever the slip angle; the v2 lateral shear
    # needs displacement to build up, so the robot follows the wheels better (1/chi larger)
    a1, a2 = _spin_yaw("v1"), _spin_yaw("v2")
    assert 0 < a1 < a2 < 1


def test_v1_is_the_default_and_unchanged_on_rigid_ground_without_acceleration():
    assert SimConfig().physics == "v1"
    veh = get_vehicle("husky")
    t = np.arange(0.0, 3.0, 0.01)
    twist = np.column_stack([np.full_like(t, 0.5), np.zeros_like(t), np.zeros_like(t)])
    p1 = integrate(veh, veh.contact_geometry(), (get_terrain("ASPHALT"),), 1e9, t, twist,
                   0.0, 1.0, physics="v1")
    p2 = integrate(veh, veh.contact_geometry(), (get_terrain("ASPHALT"),), 1e9, t, twist,
                   0.0, 1.0, physics="v2")
    # once the speed is steady, no acceleration, no load transfer: the same torques
    np.testing.assert_allclose(p1.torque[-50:], p2.torque[-50:], rtol=1e-3)


def test_unknown_physics_is_a_config_error():
    with pytest.raises(ConfigError, match="v1, v2"):
        SimConfig(physics="v3")


def test_velocity_maps_are_the_rim_speed_kinematics_of_eq_4_20():
    """velocity_maps calls vehicles.swerve.wheel_rim_speed (the one home of eq. 4.20); its
    maps equal the closed-form rows ``(cos d, sin d, -y cos d + x sin d)`` and, across the
    wheel, ``(-sin d, cos d, y sin d + x cos d)``, and map a twist onto the rim speeds."""
    from terrain.sim.forces import contact_layout, velocity_maps
    from terrain.vehicles.swerve import wheel_rim_speed
    for name, chi in (("husky", 1.4), ("agrimaro", 1.0)):
        veh = get_vehicle(name)
        layout = contact_layout(veh.contact_geometry(), veh.mass_kg, 0.0, chi)
        rng = np.random.default_rng(3)
        d = rng.uniform(-np.pi, np.pi, len(layout.x_m)) if layout.steered else np.zeros(
            len(layout.x_m))
        maps = velocity_maps(layout, d)
        x, y, yk = layout.x_m, layout.y_m, layout.y_kinematic_m
        c, s = np.cos(d), np.sin(d)
        np.testing.assert_allclose(maps.long_kinematic, np.column_stack([c, s, -yk * c + x * s]),
                                   atol=1e-15)
        np.testing.assert_allclose(maps.long_force, np.column_stack([c, s, -y * c + x * s]),
                                   atol=1e-15)
        np.testing.assert_allclose(maps.lateral, np.column_stack([-s, c, y * s + x * c]),
                                   atol=1e-15)
        twist = np.array([0.4, -0.1, 0.7])
        np.testing.assert_allclose(maps.long_force @ twist,
                                   wheel_rim_speed(*twist, x, y, d), atol=1e-15)
        if not layout.steered:      # skid-steer: kinematic lines at chi y (Mandow 2007)
            np.testing.assert_allclose(maps.long_kinematic[:, 2], -chi * y)


@pytest.fixture(scope="module")
def ploughed_held_out_turns():
    """Chi and mean current of the curves of vulpi PLOUGHED/5, measured and replayed."""
    # vulpi PLOUGHED/5 is held out of the choice of the PLOUGHED soil's K (training runs 1,
    # 4, 6): its curves turn with chi 2.3 (gyro on (v_R - v_L) / B); v1's Coulomb friction
    # 1.0 digs the replayed robot in (chi about 9), the v2 soil contact follows the turn
    from terrain.audit.frames import MANOEUVRES, prepare_frame
    from terrain.audit.replay import ReplaySettings, replay_run
    from terrain.io.shipped import load_dataset
    from terrain.vehicles.icr import icr_expansion_factor

    run = next(r for r in load_dataset("vulpi") if r.run_id == "vulpi/PLOUGHED/5")
    chi, current = {}, {}
    for physics in ("v1", "v2"):
        f = prepare_frame(run, replay_run(run, ReplaySettings(physics=physics)))
        m = (f.score_imu & np.isfinite(f.wz) & (f.manoeuvre == MANOEUVRES.index("curve"))
             & (np.abs(f.commanded_yaw_rate) > 0.1))
        assert m.sum() > 50
        chi["measured"] = icr_expansion_factor(f.wz[m], f.commanded_yaw_rate[m])
        chi[physics] = icr_expansion_factor(f.sim_wz[m], f.commanded_yaw_rate[m])
        current["measured"], current[physics] = f.cur[m].mean(), f.sim_cur[m].mean()
    return chi, current


@pytest.mark.slow
def test_v2_ploughed_soil_follows_the_measured_turns_of_a_held_out_vulpi_run(
        ploughed_held_out_turns):
    chi, current = ploughed_held_out_turns
    assert 2.0 < chi["measured"] < 2.6
    assert chi["v1"] > 3.0 * chi["measured"]
    assert chi["v2"] < 1.2 * chi["measured"]             # v1 digs in; v2 turns
    # and the turning current: v1 about 3 A too high, v2 within 1 A
    assert current["v1"] - current["measured"] > 2.0
    assert abs(current["v2"] - current["measured"]) < 1.0


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
    "issue 14's 10 % chi target, missed since v2 keeps PLOUGHED's Brixius motion "
    "resistance and the soil's K was chosen again on the training runs (2026-11-25): 2.68 "
    "against 2.30 measured (+17 %; 2.66, +16 %, once the implicit step iterates, "
    "2026-11-30); it was 2.38 (+4 %) while v2 dropped that resistance "
    "(docs/physics_v2.md, 'PLOUGHED re-measured')"))
def test_v2_ploughed_held_out_turn_chi_within_10_percent(ploughed_held_out_turns):
    chi, _ = ploughed_held_out_turns
    assert chi["v2"] == pytest.approx(chi["measured"], rel=0.10)


@pytest.mark.slow   # two v2 replays of every held-out SNOW run: ~30 s quiet, over 60 s loaded
def test_snow_hump_lowers_the_replayed_spin_current_of_held_out_runs(monkeypatch):
    # the held-out SNOW runs (alternate_split: the residual ratio was chosen on the other
    # half) spin at 8 A on average where the exponential snow contact of v2 replays 11 A
    # (docs/physics_v2.md): a wheel that shears the snow past its peak strength drives with
    # the residual strength, so the hump-type curve must bring the spin current down
    from terrain.audit.frames import MANOEUVRES, prepare_frame
    from terrain.audit.physics import alternate_split
    from terrain.audit.replay import ReplaySettings, replay_run
    from terrain.io.shipped import load_dataset

    held = alternate_split([r for r in load_dataset("borealtc") if r.terrain == "SNOW"])[1]
    frames = {}  # the manoeuvres and measured currents: from the commands, not the physics
    sq = {}
    for name, soil in (("hump", SOILS["SNOW"]),
                       ("exponential", replace(SOILS["SNOW"], residual_ratio=None))):
        monkeypatch.setattr(dynamics, "SOILS", MappingProxyType({**SOILS, "SNOW": soil}))
        errs, sim_mean, meas_mean = [], [], []
        for r in held:
            replay = replay_run(r, ReplaySettings(physics="v2"))
            if r.run_id not in frames:
                frames[r.run_id] = prepare_frame(r, replay)
            f = frames[r.run_id]
            cur = replay.cur[-f.n:]
            m = (f.manoeuvre == MANOEUVRES.index("spin")) & np.isfinite(f.cur).all(axis=1)
            errs.append((cur[m] - f.cur[m]).ravel())
            sim_mean.append(cur[m].ravel())
            meas_mean.append(f.cur[m].ravel())
        sq[name] = float(np.sqrt(np.mean(np.concatenate(errs) ** 2)))
        sq[name + "_sim"] = float(np.mean(np.concatenate(sim_mean)))
    measured = float(np.mean(np.concatenate(meas_mean)))
    assert len(np.concatenate(errs)) > 2000
    assert sq["exponential_sim"] > measured + 2.0        # the exponential contact: too high
    assert sq["hump_sim"] < sq["exponential_sim"] - 1.0  # the hump: lower spin current ...
    assert sq["hump"] < 0.9 * sq["exponential"]          # ... and closer to the measurement


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in MEASURED_HUSKY_STRAIGHT if n in SOILS])
def test_v2_soil_keeps_the_catalogue_motion_resistance_and_the_calibrated_current(name):
    # v2 swaps the soil's Janosi traction in but keeps the terrain's motion resistance, also
    # where it lives inside the catalogue curve (Brixius PLOUGHED, soil_resistance 0): the
    # steady straight current is r N (f_soil + h) whatever the curve, the calibrated target
    # within the tolerance of tests/sim/test_sim.py::test_husky_straight_current_matches_measured
    target, speed = MEASURED_HUSKY_STRAIGHT[name]
    geo = HUSKY.contact_geometry()
    t = np.arange(0.0, 12.0, 0.01)
    twist = np.zeros((len(t), 3))
    twist[:, 0] = np.minimum(t * 0.5, speed)
    current = {}
    for physics in ("v1", "v2"):
        p = integrate(HUSKY, geo, (get_terrain(name),), 25.0, t, twist, 0.0, 1.55,
                      physics=physics)
        cur = motor_currents(p, HUSKY, Effects(icr_expansion=1.55), physics)
        current[physics] = cur[t > 6.0].mean()
        assert p.slip_motor[t > 6.0].mean() > 1e-3          # the soil's resistance costs slip
    assert current["v2"] == pytest.approx(target, rel=0.05)
    # equal on the Janosi soils; on PLOUGHED the Brixius resistance grows with slip
    # (0.5 s / sqrt(Bn)) and the soil curve needs more slip than v1's: 4.76 against 4.70 A
    assert current["v2"] == pytest.approx(current["v1"], rel=0.02)
    assert current["v2"] >= current["v1"] - 1e-3
    layout = contact_layout(geo, HUSKY.mass_kg, 0.0, 1.55)
    soil = soil_contacts(HUSKY, geo, (get_terrain(name),))[name]
    entry = dynamics.v2_terrain(get_terrain(name), soil, float(np.mean(layout.normal_load_n)))
    assert is_deformable(entry) == is_deformable(get_terrain(name))
    s = np.linspace(0.0, 1.0, 11)
    np.testing.assert_array_equal(soil_resistance_coefficient(entry, s),
                                  soil_resistance_coefficient(get_terrain(name), s))


def test_specific_force_at_rest_is_gravity_up_the_slope():
    theta = np.radians(15.0)
    g_up = 9.80665 * np.sin(theta)
    for yaw, expected in ((0.0, (g_up, 0.0)), (np.pi, (-g_up, 0.0)),
                          (0.5 * np.pi, (0.0, -g_up))):     # facing +y: uphill on its right
        f = specific_force_m_s2(np.zeros(2), gravity_force(50.0, theta, yaw), 50.0)
        np.testing.assert_allclose(f, expected, atol=1e-12)


def test_v2_husky_at_rest_facing_uphill_has_wongs_axle_loads(monkeypatch):
    # Wong, Theory of Ground Vehicles, ch. 3.1: at rest on a grade theta the axle loads are
    # W cos(theta) l_other / L -+ h W sin(theta) / L, the rear (downhill) axle the heavier
    loads = []

    def spy(*args):
        loads.append(transferred_normal_loads(*args))
        return loads[-1]

    monkeypatch.setattr(dynamics, "transferred_normal_loads", spy)
    theta = np.radians(15.0)
    geo = HUSKY.contact_geometry()
    t = np.arange(0.0, 2.0, 0.01)
    integrate(HUSKY, geo, (get_terrain("ASPHALT"),), 1e9, t, np.zeros((len(t), 3)), theta,
              1.0, physics="v2")
    weight = HUSKY.mass_kg * 9.80665
    shift = weight * np.sin(theta) * LOAD_TRANSFER["husky"].cog_height_m / HUSKY.wheelbase_m
    assert shift == pytest.approx(53.3, abs=0.05)
    x = geo.positions_m[:, 0]
    for n in (loads[0], loads[-1]):               # from the first step on, and held at rest
        assert n[x < 0].sum() == pytest.approx(weight * np.cos(theta) / 2 + shift, abs=0.05)
        assert n[x > 0].sum() == pytest.approx(weight * np.cos(theta) / 2 - shift, abs=0.05)


def test_current_report_refuses_an_unknown_physics_version():
    """reported_current_a took any name but "v1" as v2: "V1" or "v3" reported 1.00 A for a
    braking wheel (-5 N m at 2 rad/s) where v1 reports 0.80 A, without a word (the online
    sensors of the closed loop pass their physics through unchecked). Now a ConfigError
    lists the versions."""
    from terrain.sim.forces import reported_current_a
    torque, omega = np.array([-5.0]), np.array([2.0])
    v1 = reported_current_a(HUSKY.motor, torque, omega, "v1")[0]
    assert v1 == pytest.approx(0.8047, abs=1e-4)
    assert reported_current_a(HUSKY.motor, torque, omega, "v2")[0] == pytest.approx(1.0)
    for bad in ("V1", "v3"):
        with pytest.raises(ConfigError, match="v1, v2"):
            reported_current_a(HUSKY.motor, torque, omega, bad)
    from terrain.sim.closed_loop import OnlineSensors
    from terrain.sim.simulate import DEFAULT_SENSORS
    with pytest.raises(ConfigError, match="v1, v2"):
        OnlineSensors("husky", DEFAULT_SENSORS["husky"], 0, 1.0, physics="V1")


def test_load_transfer_floor_is_counted(monkeypatch):
    """The v2 load transfer floors a contact's load at MIN_LOAD_FRACTION of its static load
    (a wheel about to lift) and rescales the others, but no count said when it did: a Husky
    with its CoG raised to 1.5 m starting to 1 m/s and stopping (specific force up to
    5.5 m/s^2, loads down to -278 N asked for) held its wheels at the floor on 24, 22, 24, 22
    steps of 300 without a word. PhysicsResult.load_floor_steps now counts them per contact
    (None without load transfer), and a simulated run's metadata carries them."""
    from terrain.sim.forces import MIN_LOAD_FRACTION
    geo = HUSKY.contact_geometry()
    t = np.arange(0.0, 3.0, 0.01)
    cmd = np.zeros((len(t), 3))
    cmd[t < 1.5, 0] = 1.0
    p1 = integrate(HUSKY, geo, (get_terrain("ASPHALT"),), 1e9, t, cmd, 0.0, 1.0, physics="v1")
    assert p1.load_floor_steps is None
    p2 = integrate(HUSKY, geo, (get_terrain("ASPHALT"),), 1e9, t, cmd, 0.0, 1.0, physics="v2")
    np.testing.assert_array_equal(p2.load_floor_steps, np.zeros(4, dtype=np.int64))
    loads = []

    def spy(*args):
        loads.append(transferred_normal_loads(*args))
        return loads[-1]

    monkeypatch.setattr(dynamics, "transferred_normal_loads", spy)
    monkeypatch.setattr(dynamics, "LOAD_TRANSFER", MappingProxyType(
        {"husky": replace(LOAD_TRANSFER["husky"], cog_height_m=1.5)}))
    p = integrate(HUSKY, geo, (get_terrain("ASPHALT"),), 1e9, t, cmd, 0.0, 1.0, physics="v2")
    at_floor = np.array(loads) <= MIN_LOAD_FRACTION * W * (1 + 1e-12)
    assert at_floor.any()
    np.testing.assert_array_equal(p.load_floor_steps, at_floor.sum(axis=0))
    sim = simulate_with_physics(SimConfig(terrains=("ASPHALT",), scenario="straight_accel",
                                          duration_s=1.0, seed=0, physics="v2"))
    assert sim.run.meta["load_floor_steps"] == [0, 0, 0, 0]
    assert "load_floor_steps" not in simulate_with_physics(SimConfig(
        terrains=("ASPHALT",), scenario="straight_accel", duration_s=1.0, seed=0)).run.meta


def test_the_tracked_vehicles_own_cog_height_sets_its_load_transfer(monkeypatch):
    # TrackedParams.cog_height_m (seed 003 Table 2) was validated and never read: v2 took a
    # second copy of Table 2's 0.150 m from terrain.sim.forces, so a tracked vehicle built
    # with another CoG height drove with the catalogue's load transfer
    heights, loads = [], []

    def spy(static, x, y, mass, cog_height_m, ax, ay):
        heights.append(cog_height_m)
        loads.append(transferred_normal_loads(static, x, y, mass, cog_height_m, ax, ay))
        return loads[-1]

    monkeypatch.setattr(dynamics, "transferred_normal_loads", spy)
    t = np.arange(0.0, 1.0, 0.01)
    cmd = np.zeros((len(t), 3))
    cmd[:, 0] = 0.5
    default = get_vehicle("tracked")
    assert default.cog_height_m == 0.150
    rear_minus_front = {}
    for h in (default.cog_height_m, 0.40):
        veh = replace(default, cog_height_m=h)
        heights.clear()
        loads.clear()
        integrate(veh, veh.contact_geometry(), (get_terrain("ASPHALT"),), 1e9, t, cmd, 0.1,
                  1.0, physics="v2")
        assert heights and set(heights) == {h}
        x = veh.contact_geometry().positions_m[:, 0]
        rear_minus_front[h] = loads[-1][x < 0].sum() - loads[-1][x > 0].sum()
    # climbing a 0.1 rad grade the rear contacts carry more; the transfer is proportional to
    # the height (transferred_normal_loads): 0.40 m moves 2.7 times what 0.150 m moves
    assert rear_minus_front[0.40] > 2.0 * rear_minus_front[0.150] > 0.0


def test_v2_current_report_blends_the_holding_current_in_near_rest():
    """The docstring said a braking wheel reports the no-load current only, I_0 m; near rest
    the holding torque's current is blended in with weight 1 - m (m = |tanh(omega/0.05)|), as
    the code does and the docstring now says: braking at 0.01 rad/s reports more than I_0 m,
    at 2 rad/s I_0 m to 1e-9, and at rest |T| / k."""
    from terrain.sim.forces import reported_current_a
    motor = HUSKY.motor
    k = motor.gear_ratio * motor.torque_constant_nm_per_a * motor.efficiency
    torque = np.array([-5.0, -5.0, -5.0])
    omega = np.array([2.0, 0.01, 0.0])
    got = reported_current_a(motor, torque, omega, "v2")
    m = np.abs(np.tanh(omega / 0.05))
    want = motor.no_load_current_a * m + (1 - m) * 5.0 / k
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert got[0] == pytest.approx(motor.no_load_current_a * m[0], abs=1e-9)
    assert got[1] > motor.no_load_current_a * m[1] + 0.5
    assert got[2] == pytest.approx(5.0 / k)
