"""Review tests of the traction loop (terrain.control.closed_loop.TractionLoop)."""

from __future__ import annotations

import numpy as np
import pytest
from control_helpers import observation

from terrain.control import build_slip_table, config_for_vehicle
from terrain.control.closed_loop import TractionLoop
from terrain.control.estimators import VelocityEstimate


class _Standing:
    """Estimate of a robot at rest: wheels, ground speed and acceleration 0, fresh."""

    name, limits = "standing", "constant stub"

    def update(self, obs):
        """The constant estimate.

        Parameters
        ----------
        obs : Observation
            Ignored.
        """
        n = len(obs.omega_low_level)
        return VelocityEstimate(np.zeros(n), np.zeros(n), np.zeros(n), 0.0, 0.0)


def _loop(decision, table):
    cfg, n = config_for_vehicle("husky", kp=2.0)
    return TractionLoop(cfg, n, _Standing(), table, decision), n


@pytest.mark.parametrize("stamp", [None, float("nan")])
def test_a_decision_of_unknown_time_gets_the_fallback(stamp):
    """``(label, confidence, None)``: a decision whose time is not known. select_target
    gives the fallback for an age of None or NaN (its docstring); the loop raised Python's
    TypeError from float(None) instead (a NaN stamp already gave the fallback)."""
    table = build_slip_table(["GRASS", "ICE"])
    loop, n = _loop(lambda t: ("GRASS", 0.9, stamp), table)
    loop(observation(1.0, np.full(n, 1.0)))
    assert loop.log[-1]["target_traction"] == table.fallback.traction
    assert loop.log[-1]["target_traction"] != table.entries["GRASS"].traction
