"""Review tm9 of the integrator and force model (terrain/sim/dynamics.py, forces.py):
boolean arrays refused where numbers are meant, and physical invariants of short runs
(a standing vehicle stays still, a mirrored command gives a mirrored run, a braked vehicle
holds on a grade below its friction limit, the step converges as dt shrinks)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim.dynamics import integrate
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

HUSKY = get_vehicle("husky")
AGRIMARO = get_vehicle("agrimaro")
ASPHALT = (get_terrain("ASPHALT"),)
T = np.arange(21) * 0.01


def _run(t_s=T, twist=None, vehicle=HUSKY, terrains=ASPHALT, slope=0.0, **kw):
    twist = np.zeros((len(t_s), 3)) if twist is None else twist
    return integrate(vehicle, vehicle.contact_geometry(), terrains, np.inf, t_s, twist,
                     slope, 1.0, **kw)


def test_a_boolean_command_is_refused():
    # np.ones((n, 3), bool) drove the Husky at v_x = 1 m/s, v_y = 1 m/s, 1 rad/s
    with pytest.raises(ConfigError, match="twist_cmd.*booleans"):
        _run(twist=np.ones((len(T), 3), dtype=bool))


def test_a_boolean_time_grid_is_refused():
    # [False, True] was a bare numpy TypeError (boolean subtract)
    with pytest.raises(ConfigError, match="t_s.*booleans"):
        _run(t_s=np.array([False, True]))


def test_a_boolean_steering_offset_is_refused():
    # [True, False, True] steered units 1 and 3 by 1 rad (57 deg)
    with pytest.raises(ConfigError, match="steer_offset_rad.*booleans"):
        _run(vehicle=AGRIMARO, steer_offset_rad=np.array([True, False, True]))


def test_a_boolean_hook_correction_is_refused():
    # the hook's [True, True] added 1 rad/s to both motors' commands
    with pytest.raises(ConfigError, match="hook.*booleans"):
        _run(hook=lambda snap: np.array([True, True]))


def _turn(t_s, v_x=0.8, v_y=0.0, yaw_rate=0.5):
    return np.column_stack([np.full(len(t_s), v_x), np.full(len(t_s), v_y),
                            np.full(len(t_s), yaw_rate)])


T2 = np.arange(0.0, 2.0, 0.01)


@pytest.mark.parametrize("vehicle, terrain, physics, slope", [
    ("husky", "ASPHALT", "v1", 0.0), ("husky", "ASPHALT", "v2", 0.1),
    ("husky", "SANDY_LOAM", "v2", 0.1), ("tracked", "SNOW", "v2", -0.1)])
def test_a_mirrored_turn_gives_the_mirrored_run(vehicle, terrain, physics, slope):
    # mirrored about the body x axis (a left-right symmetric vehicle on a plane rising along
    # world +x): (v_x, v_y, r) -> (v_x, -v_y, -r) must give (x, -y, -yaw), the left and right
    # motors swapped; a sign slip in a lateral force, the Coriolis terms, the gravity's side
    # component or the lateral load transfer breaks it
    veh = get_vehicle(vehicle)
    ter = (get_terrain(terrain),)
    v_x = 0.8 if vehicle == "husky" else 0.3       # (the tracked sprockets stop at 10 rad/s)
    left = _run(T2, _turn(T2, v_x), veh, ter, slope, physics=physics)
    right = _run(T2, _turn(T2, v_x, yaw_rate=-0.5), veh, ter, slope, physics=physics)
    assert abs(left.pose[-1, 2]) > 0.3                     # it did turn
    assert not left.speed_clipped_steps.any()
    np.testing.assert_allclose(right.pose, left.pose * [1.0, -1.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(right.twist, left.twist * [1.0, -1.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(right.torque, left.torque[:, ::-1], atol=1e-7)
    np.testing.assert_allclose(right.slip_motor, left.slip_motor[:, ::-1], atol=1e-9)


def test_agrimaro_mirrored_front_to_back_gives_the_mirrored_run():
    # AgriMaRo's units sit at x = -+0.5075 m on its axis and one at (0, -0.756 m): symmetric
    # front to back, so (v_x, v_y, r) -> (-v_x, v_y, -r) must give (-x, y, -yaw)
    fwd = _run(T2, _turn(T2, 0.4, 0.2, 0.3), AGRIMARO)
    back = _run(T2, _turn(T2, -0.4, 0.2, -0.3), AGRIMARO)
    assert abs(fwd.pose[-1, 2]) > 0.2
    np.testing.assert_allclose(back.pose, fwd.pose * [-1.0, 1.0, -1.0], atol=1e-9)


@pytest.mark.parametrize("vehicle, terrain, physics, v_x", [
    ("husky", "ASPHALT", "v2", 0.8), ("husky", "ICE", "v2", 0.8),
    ("husky", "SANDY_LOAM", "v2", 0.8), ("tracked", "SNOW", "v2", 0.3),
    ("husky", "GRAVEL", "v1", 0.8), ("agrimaro", "GRASS", "v1", 0.8)])
def test_a_vehicle_stopping_on_level_ground_never_gains_kinetic_energy(vehicle, terrain,
                                                                       physics, v_x):
    # a turn at v_x, 0.3 rad/s, then zero commands: with no grade to feed it and the rims
    # behind the body, every step of the stop must lose kinetic energy (not on ICE in v1:
    # its body lags the rims by the end of the turn, which push on for 2 steps after it)
    veh = get_vehicle(vehicle)
    t = np.arange(0.0, 2.5, 0.01)
    cmd = _turn(t, v_x, 0.0, 0.3)
    cmd[t >= 1.0] = 0.0
    p = _run(t, cmd, veh, (get_terrain(terrain),), physics=physics)
    ke = 0.5 * veh.mass_kg * (p.twist[:, 0] ** 2 + p.twist[:, 1] ** 2) \
        + 0.5 * veh.yaw_inertia_kg_m2 * p.twist[:, 2] ** 2
    stop = ke[t >= 1.0]
    assert stop[0] > 0.5                                   # it was moving
    assert np.all(np.diff(stop) <= 1e-9 * stop[0])
    assert stop[-1] < 1e-3 * stop[0]                       # and it stopped


@pytest.mark.slow
@pytest.mark.parametrize("vehicle, terrain, physics", [
    ("husky", "ASPHALT", "v2"), ("husky", "SANDY_LOAM", "v2"), ("tracked", "SNOW", "v1")])
def test_the_run_converges_as_the_step_shrinks(vehicle, terrain, physics):
    # linearly implicit Euler is first order: the end pose of a 1.5 s turn at dt = 10, 5,
    # 2.5 ms moves by less each halving (about half), and 10 ms is within 2 cm of 1.25 ms
    veh = get_vehicle(vehicle)
    ends = []
    for dt in (0.01, 0.005, 0.0025, 0.00125):
        t = np.arange(0.0, 1.5 + 1e-9, dt)
        ends.append(_run(t, _turn(t, 0.3, 0.0, 0.3), veh, (get_terrain(terrain),),
                         physics=physics).pose[-1])
    gaps = [np.abs(a - b).max() for a, b in zip(ends, ends[1:])]
    assert gaps[1] < 0.75 * gaps[0] and gaps[2] < 0.75 * gaps[1]
    assert np.abs(ends[0] - ends[-1]).max() < 0.02


@pytest.mark.parametrize("terrains, shown", [
    (get_terrain("ASPHALT"), "TerrainParams"), (("ASPHALT",), "'ASPHALT'"),
    ((get_terrain("ASPHALT"), None), "None")])
def test_terrains_that_are_not_a_sequence_of_terrain_params_are_refused(terrains, shown):
    # one TerrainParams was a bare "object of type 'TerrainParams' has no len()", a name a
    # bare "'str' object has no attribute 'name'"
    with pytest.raises(ConfigError, match=f"terrains.*{shown}"):
        _run(terrains=terrains)


def test_a_lifting_wheel_keeps_five_percent_of_its_static_load():
    # the floor is 0.05 of the static load (MIN_LOAD_FRACTION; a test that reads the
    # constant cannot see it change): in a 50 m/s^2 left turn the Husky's inner wheels ask
    # for -348 N each, sit at 0.05 x 122.6 N and are rescaled with the outer ones to the
    # static total 490.3 N: 0.05 W 4 W / (2 (0.05 W) + 2 (W + 471 N)), 2.50 N
    from terrain.sim.forces import LOAD_TRANSFER, contact_layout, transferred_normal_loads
    w = 50.0 * 9.80665 / 4.0
    layout = contact_layout(HUSKY.contact_geometry(), HUSKY.mass_kg, 0.0, 1.0)
    n = transferred_normal_loads(layout.normal_load_n, layout.x_m, layout.y_m, HUSKY.mass_kg,
                                 LOAD_TRANSFER["husky"].cog_height_m, 0.0, 50.0)
    shift = HUSKY.mass_kg * LOAD_TRANSFER["husky"].cog_height_m * 50.0 / (4 * abs(layout.y_m[0]))
    inner = 0.05 * w * 4 * w / (2 * 0.05 * w + 2 * (w + shift))
    assert inner == pytest.approx(2.50, abs=0.01)
    np.testing.assert_allclose(n[layout.y_m > 0], inner, rtol=1e-9)


def test_a_step_longer_than_the_motor_lag_reaches_the_command_without_overshoot():
    # the speed loop is a first-order lag of 0.1 s (Husky) stepped with
    # alpha = min(1, dt / tau): a 0.2 s step lands on the command, it must not overshoot
    # to twice it (alpha = 2) and ring
    t = np.arange(6) * 0.2
    p = _run(t, _turn(t, 0.5, 0.0, 0.0))
    # row k + 1 is the wheel after the step that applied the command of row k (row 0 is
    # the vehicle at rest, 2026-11-30)
    np.testing.assert_array_equal(p.omega[0], 0.0)
    np.testing.assert_allclose(p.omega[1:], p.omega_cmd[:-1], rtol=1e-12)


def test_traction_from_rest_does_not_carry_the_body_past_its_rims():
    # from rest the SAE slip is exactly 1; its slope d slip / d v_long was taken as 0 there
    # (saturated), so the first step was explicit: at 100 Hz on ASPHALT the body reached
    # 0.0745 m/s behind rims at 0.05 m/s (7.45 m/s^2). The slope of the unsaturated side
    # keeps it implicit (0.030 m/s)
    t = np.arange(10) * 0.01
    p = _run(t, _turn(t, 0.5, 0.0, 0.0))
    rim = p.omega[:, 0] * HUSKY.contact_geometry().wheel_radius_m
    assert np.all(p.twist[:, 0] <= rim + 1e-9)
