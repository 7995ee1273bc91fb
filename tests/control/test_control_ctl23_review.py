"""Review ctl23: contracts between the control layer and the modules it meets (the
simulator's truth and its physics version, the terramechanics curves the desired-slip table
and the feed-forward are built from, the estimators' slip and ground speed, the serving
module's targets).

Each test calls the real producer and the real consumer on the same input.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.closed_loop import BUS_VOLTAGE_V, TractionLoop, loop_metrics
from terrain.control.desired_slip import build_slip_table
from terrain.control.estimators import estimator_for
from terrain.control.traction import config_for_vehicle
from terrain.sim.closed_loop import simulate_closed_loop
from terrain.sim.simulate import SimConfig, motor_currents
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
