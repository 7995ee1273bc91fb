"""Third review pass of the closed loop's controller callback
(terrain.control.closed_loop.TractionLoop): what a terrain decision callable may return."""

from __future__ import annotations

import numpy as np
import pytest
from control_helpers import observation

from terrain.control import build_slip_table, config_for_vehicle
from terrain.control.closed_loop import TractionLoop
from terrain.control.estimators import VelocityEstimate
from terrain.errors import ConfigError


class _Cruise:
    """Constant estimate: ground 1 m/s, wheels at 1.1 m/s rim, accelerating (traction)."""

    name, limits = "fixed", "constant stub"

    def __init__(self, radius):
        self.radius = radius

    def update(self, obs):
        n = len(obs.omega_low_level)
        return VelocityEstimate(np.full(n, 1.1 / self.radius), np.full(n, 1.0), np.ones(n),
                                1.0, 0.0)


def _loop(decision):
    cfg, n = config_for_vehicle("husky", kp=2.0)
    loop = TractionLoop(cfg, n, _Cruise(cfg.wheel_radius_m), build_slip_table(["GRASS", "ICE"]),
                        decision, feed_forward=False)
    return loop, np.full(n, 1.1 / cfg.wheel_radius_m)


@pytest.mark.parametrize("decision", [("GRASS",), "GRASS", None, 0.9,
                                      ("GRASS", 0.9, 0.0, "extra"),
                                      ("GRASS", 0.9, "yesterday"), ("GRASS", 0.9, True)])
def test_a_malformed_terrain_decision_is_a_typed_error(decision):
    """The callable must return ``(label or None, confidence)`` or ``(label, confidence,
    t_decided_s)``. Before: a 1-tuple was Python's bare IndexError, None or a number a bare
    TypeError, the bare label "GRASS" was read as label "G" with confidence "R", a text time
    a bare ValueError, a fourth element was dropped unsaid and a boolean time True a decision
    made at 1 s."""
    loop, omega = _loop(lambda t: decision)
    with pytest.raises(ConfigError, match="terrain_decision"):
        loop(observation(0.02, omega))


@pytest.mark.parametrize("decision, fallback", [
    (("GRASS", 0.9), False), (["GRASS", 0.9, 0.01], False), (("GRASS", 0.9, None), True),
    ((None, 0.0), True), (("GRASS", 0.9, np.float64(-5.0)), True)])
def test_well_formed_decisions_still_pick_the_table_row(decision, fallback):
    """Pairs, triples (lists too) and a time of None (unknown: the fallback) as before."""
    loop, omega = _loop(lambda t: decision)
    loop(observation(0.02, omega))
    assert loop.log[-1]["fallback"] is fallback
    assert loop.log[-1]["target_traction"] == pytest.approx(0.0098, abs=1e-4) if fallback \
        else loop.log[-1]["target_traction"] == pytest.approx(0.3)
