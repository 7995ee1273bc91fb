"""Review ctl23: contracts between the control layer and the modules it meets (the
simulator's truth and its physics version, the terramechanics curves the desired-slip table
and the feed-forward are built from, the estimators' slip and ground speed, the serving
module's targets).

Each test calls the real producer and the real consumer on the same input.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from terrain.control.closed_loop import BUS_VOLTAGE_V, TractionLoop, loop_metrics
from terrain.control.desired_slip import (DesiredSlipConfig, build_slip_table, desired_slip,
                                          select_target)
from terrain.control.estimators import (AgriMaRoVisualOdometryEKF, FusedSlipObserver,
                                        estimator_for)
from terrain.control.feedforward import traction_acceleration_limit
from terrain.control.grid import slip_limit_bound
from terrain.control.traction import (SlipTargets, TractionState, config_for_vehicle,
                                      traction_control_step)
from terrain.serving.targets import TableTargets
from terrain.sim.closed_loop import replay_observations, simulate_closed_loop
from terrain.sim.simulate import SimConfig, motor_currents, simulate_with_physics
from terrain.sim.sensors import physics_step_index
from terrain.slip import wheel_longitudinal_velocity, wheel_slip
from terrain.slip.core import skid_steer_contact_lines_m
from terrain.terramechanics import (get_terrain, is_deformable, steady_slip,
                                    traction_coefficient)
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.terramechanics.efficiency import tractive_efficiency
from terrain.terramechanics.slip import ground_speed_from_slip
from terrain.vehicles import get_vehicle


# --- loop_metrics' energy and the run's physics version ------------------------------------------

def _shadow_run(vehicle: str, terrain: str, scenario: str, physics: str, duration_s=6.0):
    """A shadow-mode closed-loop run (no correction) on the label, and its loop."""
    cfg, n = config_for_vehicle(vehicle, kp=2.0)

    def decision(t_s):
        return terrain, 1.0

    loop = TractionLoop(cfg, n, estimator_for(vehicle, decision), build_slip_table([terrain]),
                        decision, apply=False)
    sim = simulate_closed_loop(SimConfig(vehicle=vehicle, terrains=(terrain,),
                                         scenario=scenario, duration_s=duration_s, seed=0,
                                         physics=physics), loop)
    return sim, loop


@pytest.mark.parametrize("physics", ["v1", "v2"])
def test_loop_energy_integrates_the_currents_of_the_runs_own_physics(physics):
    # the simulator reports a motor's current by the run's physics version
    # (terrain.sim.simulate.motor_currents, terrain.sim.forces.reported_current_a: v2 reports
    # the no-load current while a motor brakes, the power drawn); loop_metrics computed the
    # energies from the v1 report whatever the run's physics: a v2 Husky 'random' run on
    # ASPHALT read 358.7 J/m where its own currents give 281.8 J/m
    sim, loop = _shadow_run("husky", "ASPHALT", "random", physics)
    m = loop_metrics(sim, loop, BUS_VOLTAGE_V["husky"])
    phys, vehicle = sim.physics, get_vehicle("husky")
    dt = float(phys.t_s[1] - phys.t_s[0])
    cur = motor_currents(phys, vehicle, sim.config.effects, sim.config.physics)
    distance = m["distance_m"]
    assert distance > 1.0
    assert m["energy_j_per_m"] == pytest.approx(
        BUS_VOLTAGE_V["husky"] * float(np.sum(cur) * dt) / distance, rel=1e-12)
    assert m["drive_energy_j_per_m"] == pytest.approx(
        float(np.sum(vehicle.motor.drive_power_w(cur, phys.omega)) * dt) / distance,
        rel=1e-12)
    if physics == "v2":   # the case that tells the two reports apart: a motor brakes
        v1 = motor_currents(phys, vehicle, sim.config.effects, "v1")
        assert np.sum(v1) > 1.05 * np.sum(cur)


# --- the desired-slip table against the physics curves it cites ----------------------------------

RIGID = [n for n in TERRAIN_NAMES if not is_deformable(get_terrain(n))]
DEFORMABLE = [n for n in TERRAIN_NAMES if is_deformable(get_terrain(n))]
_GRID = np.linspace(0.0, 1.0, 200001)


@pytest.mark.parametrize("name", RIGID)
def test_rigid_targets_sit_at_their_fraction_of_the_curves_own_maximum(name):
    # the maximum found here on a dense grid of the physics curve itself (not through
    # traction_peak or stable_side_end, which the table calls): traction at 95 % of it and
    # braking at 99 % of it, both on the rising side before it, in the SAE slip the curve
    # reads (odd: the braking target reads the negative branch)
    ter, cfg = get_terrain(name), DesiredSlipConfig()
    mu = traction_coefficient(ter.curve, _GRID)
    i = int(np.argmax(mu))
    s_star, mu_star = _GRID[i], mu[i]
    row = desired_slip(ter, cfg)
    assert float(traction_coefficient(ter.curve, row.traction)) == pytest.approx(
        cfg.traction_fraction * mu_star, rel=1e-6)
    assert float(traction_coefficient(ter.curve, row.braking)) == pytest.approx(
        -cfg.braking_fraction * mu_star, rel=1e-6)
    assert 0.0 < row.traction < -row.braking <= s_star + 1e-5
    rising = traction_coefficient(ter.curve, np.linspace(0.0, -row.braking, 2001))
    assert np.all(np.diff(rising) > 0.0)


@pytest.mark.parametrize("name", DEFORMABLE)
def test_deformable_traction_target_is_the_efficiency_maximum_or_the_cap(name):
    ter, cfg = get_terrain(name), DesiredSlipConfig()
    eta = tractive_efficiency(ter, _GRID)
    s_eff = _GRID[int(np.argmax(eta))]
    row = desired_slip(ter, cfg)
    assert row.traction == pytest.approx(min(s_eff, cfg.deformable_cap), abs=1e-4)
    # steady: the balance the simulator's force law settles at, gross traction = soil
    # resistance, read through the feed-forward's own acceleration limit (0 there)
    assert row.steady == pytest.approx(min(steady_slip(ter), row.traction), abs=0.0)
    if 0.0 < row.steady < row.traction:
        assert traction_acceleration_limit(ter, row.steady) == pytest.approx(0.0, abs=1e-8)


@pytest.mark.parametrize("name", TERRAIN_NAMES)
def test_slip_limit_bound_slip_for_command_gives_that_acceleration_back(name):
    # slip_for_command (terramechanics steady_slip at a / g) and the feed-forward's
    # acceleration limit are one traction balance: the slip the bound says a command needs
    # gives the command back, where the curve can give it at all
    ter = get_terrain(name)
    top = max(traction_acceleration_limit(ter, s) for s in np.linspace(0.0, 1.0, 401))
    for accel in (0.1, 0.5, 1.0):
        bound = slip_limit_bound(name, 0.2, accel_m_s2=accel)
        s = bound["slip_for_command"]
        if accel < 0.99 * top and s < 1.0:
            assert traction_acceleration_limit(ter, s) == pytest.approx(accel, abs=1e-7)


# --- the table as the serving module consumes it --------------------------------------------------

def test_serving_table_targets_are_the_tables_selected_targets():
    classes = ["ASPHALT", "ICE", "SNOW", "SANDY_LOAM", "TILES", "GRASS"]
    provider = TableTargets(classes)
    table = build_slip_table(classes)
    assert provider.min_confidence == table.config.min_confidence
    for name in classes + [None, "CONCRETE"]:
        for conf in (0.0, 0.49, 0.5, 0.9, 1.0):
            for stale in (False, True):
                got = provider.target_for(name, conf, stale)
                row = select_target(table, name, conf,
                                    2.0 * table.config.max_decision_age_s if stale else 0.0)
                assert tuple(got) == (row.traction, row.braking, row.steady)
                if stale or name not in table.entries or conf < 0.5:
                    assert tuple(got) == (table.fallback.traction, table.fallback.braking,
                                          table.fallback.steady)


# --- the estimators' slip as the traction step reads it ------------------------------------------

TARGETS = SlipTargets(0.1, -0.15, 0.0)


def _replayed(vehicle: str, terrain: str, duration_s: float = 4.0):
    return replay_observations(simulate_with_physics(SimConfig(
        vehicle=vehicle, terrains=(terrain,), scenario="straight_accel",
        duration_s=duration_s, seed=0)))


def test_the_husky_controller_regulates_the_fused_filters_own_slip_state():
    # the fused observer hands over a ground speed (ground_speed_from_slip of the measured
    # rim speed and its slip state); the traction step turns it back into a slip with
    # sae_slip: wherever the wheel is above the step's dead band that is the filter's state
    cfg, n = config_for_vehicle("husky")
    est = FusedSlipObserver("husky", lambda t: ("SNOW", 1.0))
    checked = 0
    for obs in _replayed("husky", "SNOW"):
        e = est.update(obs)
        out, _ = traction_control_step(cfg, TractionState.zeros(n), TARGETS,
                                       obs.omega_low_level, e.omega_meas_rad_s, e.v_long_m_s,
                                       e.a_local_m_s2, e.chassis_speed_m_s, 0.02)
        rim = np.abs(e.omega_meas_rad_s) * cfg.wheel_radius_m
        live = np.maximum(rim, np.abs(e.v_long_m_s)) >= cfg.wheel_speed_threshold_m_s
        state = np.clip(est.x[4:6], -0.95, 0.95)
        np.testing.assert_allclose(out.slip[live], state[live], atol=1e-12)
        checked += int(live.sum())
    assert checked > 100


def test_the_agrimaro_controller_slip_is_the_batch_slip_of_the_ekf_state():
    # the AgriMaRo EKF hands over each wheel's ground speed along its heading (eq. 4.20);
    # the step's slip of it and the raw encoder speed equals the batch per-wheel slip of
    # terrain.slip (eqs. 7.3-7.5 then sae_slip) on the same state, wheel by wheel
    cfg, n = config_for_vehicle("agrimaro")
    est = AgriMaRoVisualOdometryEKF()
    pos = np.asarray(get_vehicle("agrimaro").wheel_positions_m)
    checked = 0
    for obs in _replayed("agrimaro", "GRASS", 3.0):
        e = est.update(obs)
        out, _ = traction_control_step(cfg, TractionState.zeros(n), TARGETS,
                                       obs.omega_low_level, e.omega_meas_rad_s, e.v_long_m_s,
                                       e.a_local_m_s2, e.chassis_speed_m_s, 0.02)
        x = est.ekf.x
        batch = wheel_slip((e.omega_meas_rad_s * cfg.wheel_radius_m)[None], x[3:4], x[4:5],
                           x[5:6], pos, x[8:11][None],
                           dead_band_m_s=cfg.wheel_speed_threshold_m_s)[0]
        np.testing.assert_allclose(out.slip, batch, atol=1e-12)
        checked += int(np.count_nonzero(batch))
    assert checked > 50


@pytest.mark.parametrize("vehicle", ["husky", "agrimaro"])
def test_loop_speed_error_is_scored_against_the_slip_modules_wheel_velocity(vehicle):
    # the truth of speed_estimate_rmse_m_s is each unit's longitudinal velocity (eqs.
    # 7.3-7.5: terrain.slip.wheel_longitudinal_velocity, at the steering axes of a steered
    # vehicle, at the contact lines +-B/2 of a skid-steer one), in turns as well
    sim, loop = _shadow_run(vehicle, "TILES", "random", "v1", duration_s=3.0)
    m = loop_metrics(sim, loop, BUS_VOLTAGE_V[vehicle])
    phys, params = sim.physics, get_vehicle(vehicle)
    idx = physics_step_index(phys.t_s, np.array([r["t_s"] for r in loop.log]))
    tw = phys.twist[idx]
    assert np.max(np.abs(tw[:, 2])) > 0.1          # a turn: the yaw terms count
    geo = params.contact_geometry()
    if geo.steered:
        truth = wheel_longitudinal_velocity(tw[:, 0], tw[:, 1], tw[:, 2],
                                            np.asarray(params.wheel_positions_m),
                                            phys.delta[idx])
    else:
        truth = wheel_longitudinal_velocity(tw[:, 0], tw[:, 1], tw[:, 2],
                                            skid_steer_contact_lines_m(params.track_m))
    v_est = np.array([r["v_long"] for r in loop.log])
    assert m["speed_estimate_rmse_m_s"] == pytest.approx(
        float(np.sqrt(np.mean((v_est - truth) ** 2))), rel=1e-12)
    # the estimator's units are the simulator's motors in the same order (left, right; wheels
    # 1-3): any other order of the estimates fits the truth worse
    for order in itertools.permutations(range(truth.shape[1])):
        if list(order) != sorted(order):
            assert np.mean((v_est[:, order] - truth) ** 2) > np.mean((v_est - truth) ** 2)


@pytest.mark.parametrize("terrain", ["SNOW", "TILES"])
def test_loop_reference_speed_is_the_ground_speed_the_steady_slip_leaves(terrain):
    # reference_speed_m_s: the cruise rim speed less the true terrain's steady slip, through
    # the SAE slip's inverse (terramechanics ground_speed_from_slip), at the table's steady
    # target: the speed the command holds once the resistances balance
    sim, loop = _shadow_run("husky", terrain, "straight_accel", "v1", duration_s=3.0)
    m = loop_metrics(sim, loop, BUS_VOLTAGE_V["husky"])
    steady = build_slip_table([terrain]).entries[terrain].steady
    assert steady == steady_slip(get_terrain(terrain))
    expected = ground_speed_from_slip(m["cruise_speed_m_s"], steady)
    assert m["reference_speed_m_s"] == float(expected)


# --- the control-sim JSON fields the docs name ---------------------------------------------

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def _named(text: str, start: str, end: str) -> set[str]:
    """The backquoted names between ``start`` and ``end`` in ``text``."""
    import re

    i = text.index(start)
    return set(re.findall(r"`([a-z_0-9]+)`", text[i:text.index(end, i)]))


def test_the_metric_fields_the_docs_name_are_the_ones_a_closed_loop_run_gives():
    from terrain.control.closed_loop import run_closed_loop

    readme = (_ROOT / "README.md").read_text()
    doc = (_ROOT / "docs" / "control_validation.md").read_text()
    named = (_named(readme, "shadow mode. JSON:", "and more.")
             | _named(doc, "* **Metrics** (`loop_metrics`)", "**Stale figures")
             | _named(doc, "* **Energy**:", "* **Drive energy**")
             | {"estimator_limits", "estimator_pseudo_measurements",
                "estimator_speed_bound_samples"})
    named -= {"loop_metrics", "terramechanics", "steady_slip", "straight_accel"}
    assert {"slip_rmse", "peak_slip", "time_to_speed_s", "energy_j_per_m",
            "drive_energy_j_per_m", "distance_m", "mean_speed_m_s", "terrain_accuracy",
            "slip_excess_rmse", "reference_speed_m_s", "steady_slip_within_0_02",
            "mech_energy_j_per_m"} <= named
    metrics = run_closed_loop("husky", "TILES", "straight_accel", True, 0, 2.0)[2]
    assert named - set(metrics) == set()
