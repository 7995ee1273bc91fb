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
    ("v1", "SANDY_LOAM"): (4.72213343281, 1.02798425459, -0.103291252411, 0.102640550521,
                           0.275031321893, 5.36193877551, 5.01275510204),
    ("v1", "SNOW"): (4.33678430973, 0.131113017953, -0.0352115242936, 0.016220237359,
                     0.441176078718, 6.16979591837, 5.69234693878),
    ("v1", "ICE"): (5.8405097191, 0.754715226006, -0.323396754937, 0.104885054955,
                    0.177334085684, 2.69806122449, 2.53602040816),
    ("v2", "SANDY_LOAM"): (4.68310986516, 1.81544912253, -0.218626408164, 0.174968251764,
                           0.149229722906, 6.30142857143, 5.93948979592),
    ("v2", "SNOW"): (5.07329944813, 0.450391928188, -0.035766352349, 0.041619732629,
                     0.341939258444, 6.76673469388, 6.41826530612),
    ("v2", "ICE"): (4.78002709962, 2.09737967261, -0.108919054949, 0.183193927279,
                    0.089915828744, 3.12775510204, 2.89928571429),
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
