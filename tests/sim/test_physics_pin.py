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
    ("v1", "SANDY_LOAM"): (4.72370341399, 1.02782165219, -0.103597370507, 0.1026435917,
                           0.275264407548, 5.37030612245, 5.01755102041),
    ("v1", "SNOW"): (4.33803079543, 0.131069092511, -0.0352685849064, 0.0162209060047,
                     0.441513746944, 6.17816326531, 5.69806122449),
    ("v1", "ICE"): (5.84232045192, 0.75452139231, -0.325356464554, 0.105006955837,
                    0.177392528413, 2.70357142857, 2.53816326531),
    ("v2", "SANDY_LOAM"): (4.68497195248, 1.81501822904, -0.21970516838, 0.174990405777,
                           0.149318920485, 6.3056122449, 5.9437755102),
    ("v2", "SNOW"): (5.07507449714, 0.450319214146, -0.0363737762222, 0.0416492528597,
                     0.342098462859, 6.77551020408, 6.42163265306),
    ("v2", "ICE"): (4.78194272394, 2.09717895499, -0.110188158108, 0.18322321175,
                    0.0899870372377, 3.13224489796, 2.90214285714),
}


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
