"""Review sim11 of the simulator (terrain.sim) and the vehicles: physical invariants,
docstring claims and survivors of hand mutation."""

import numpy as np

from terrain.sim.scenarios import make_commands


def test_random_omnidirectional_speed_is_capped_per_component_not_as_a_resultant():
    """make_commands' docstring said every scenario's speeds stay within 0.95 of the limit;
    the random scenario caps v_x and v_y each, so an omnidirectional run's body speed passes
    the limit itself (seed 2, 120 s: 1.008 of it), within 0.95 sqrt(1.25)."""
    cmd = make_commands("random", 120.0, 0.01, np.random.default_rng(2), 1.0,
                        omnidirectional=True)
    assert np.abs(cmd.twist[:, 0]).max() <= 0.95 + 1e-12
    assert np.abs(cmd.twist[:, 1]).max() <= 0.5 * 0.95 + 1e-12
    speed = np.hypot(cmd.twist[:, 0], cmd.twist[:, 1])
    assert speed.max() > 1.0
    assert speed.max() <= 0.95 * np.sqrt(1.25) + 1e-12
