"""The simulator's outputs pinned, so a change of the physics cannot pass unnoticed.

The figures of docs/physics_v2.md, docs/sim_validation.md and the audit reports were
measured with the physics as it is. A change that moves a simulated run (an equation, a
parameter, the integrator, the default of a setting) must come with those figures
re-measured. These pins fail on any such change; refresh them only together with the
documents, and say so in the commit.

Pinned: three 15 s runs of the ``random`` scenario (seed 7) per physics version, on a
deformable soil, snow and a rigid surface: the true end pose (x, y in m, yaw in rad), the
RMS true yaw rate (rad/s), the mean absolute true slip ratio of wheel 1 and the mean
reported motor currents (A). The tolerance (1e-6 relative) leaves room for the last bits
of another processor's floating point, not for a change of the model.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain.sim import SimConfig, simulate

#: (physics, terrain): x, y, yaw, RMS yaw rate, mean |slip_1|, mean cur_l, mean cur_r
PINS = {
    ("v1", "SANDY_LOAM"): (4.72102044607, 1.02892840581, -0.102803620955, 0.102751126269,
                           0.274907405478, 5.35948979592, 5.01112244898),
    ("v1", "SNOW"): (4.33803616355, 0.131034872452, -0.0351860083484, 0.0162031524627,
                     0.440329701141, 6.16836734694, 5.69163265306),
    ("v1", "ICE"): (5.84004934782, 0.753713900969, -0.323733550649, 0.104876336389,
                    0.176667120001, 2.69775510204, 2.5362244898),
    ("v2", "SANDY_LOAM"): (4.68417825106, 1.81140835526, -0.218208306527, 0.174686462045,
                           0.148673498252, 6.30489795918, 5.94224489796),
    ("v2", "SNOW"): (5.07142751736, 0.449754576739, -0.0354683924208, 0.0414941758617,
                     0.341326898996, 6.76469387755, 6.41683673469),
    ("v2", "ICE"): (4.7758866761, 2.10138282461, -0.111130677323, 0.1835833989,
                    0.0882948355502, 3.11071428571, 2.92204081633),
}


@pytest.mark.slow
@pytest.mark.parametrize("physics, terrain", list(PINS))
def test_simulated_run_matches_its_pin(physics, terrain):
    run = simulate(SimConfig(vehicle="husky", terrains=(terrain,), scenario="random",
                             duration_s=15.0, seed=7, physics=physics))
    truth, wheels = run.streams["truth"], run.streams["wheels"]
    got = (truth.x.iloc[-1], truth.y.iloc[-1], truth.yaw.iloc[-1],
           np.sqrt(np.mean(truth.yaw_rate ** 2)), np.mean(np.abs(truth.slip_1)),
           wheels.cur_l.mean(), wheels.cur_r.mean())
    np.testing.assert_allclose(got, PINS[physics, terrain], rtol=1e-6, atol=1e-9,
                               err_msg=f"physics {physics} on {terrain} moved: re-measure "
                                       "the documented figures before refreshing the pin")


def test_pins_tell_the_physics_versions_and_terrains_apart():
    # a pin that two versions or two terrains share would not catch a switch between them
    values = np.array(list(PINS.values()))
    gaps = np.abs(values[:, None, :] - values[None, :, :]).max(axis=2)
    assert gaps[~np.eye(len(values), dtype=bool)].min() > 0.1
