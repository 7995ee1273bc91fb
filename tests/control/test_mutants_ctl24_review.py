"""Review ctl24: tests for the mutants of the control layer that the suite let survive (hand
mutants of terrain/control, one at a time): each pins a documented behaviour that no test
held."""

import numpy as np
import pytest

from terrain.control.closed_loop import fallback_basis
from terrain.control.desired_slip import build_slip_table
from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionState,
                                      traction_control_step)

TARGETS = SlipTargets(0.1, -0.15, 0.05)


def _table():
    return build_slip_table(["ICE", "TILES"])


def test_a_nan_previous_slip_not_marked_valid_is_no_input():
    """Mutant (the finiteness check read ``slip_prev`` whatever ``slip_valid``) survived: a
    state restored from a log that writes NaN for the previous slip where it was not
    measured is not a non-finite memory; the step is the one of a fresh state, not the safe
    output."""
    one = np.array([1.0])
    args = (TARGETS, 2.0 * one, 2.0 * one, np.array([1.6]), np.array([0.0]), 1.6, 0.02)
    cfg = TractionControlConfig(kp=1.0, ki=2.0, kd=0.1)
    logged = TractionState.zeros(1)._replace(slip_prev=np.array([np.nan]))
    out, state = traction_control_step(cfg, logged, *args)
    fresh_out, fresh_state = traction_control_step(cfg, TractionState.zeros(1), *args)
    assert not out.safe[0] and out.correction_rad_s[0] < 0.0   # slip 0.2 above 0.1: slowed
    for got, want in zip((*out, *state), (*fresh_out, *fresh_state)):
        assert np.array_equal(got, want)


class _Standing:
    """Estimate of a robot at rest, fresh."""

    name, limits = "standing", "constant stub"

    def update(self, obs):
        """The constant estimate.

        Parameters
        ----------
        obs : Observation

        Returns
        -------
        VelocityEstimate
        """
        from terrain.control.estimators import VelocityEstimate
        z = np.zeros(2)
        return VelocityEstimate(z, z, z, 0.0, 0.0)


@pytest.mark.parametrize("beyond, fallback", [(0.0, False), (1.0, True)])
def test_decision_ages_beyond_zero_or_the_limit_by_exactly_the_clock_slack_are_snapped(
        beyond, fallback):
    """Mutants (``-slack <= age`` to ``<``, ``age <= cap + slack`` to ``<``) survived. On an
    epoch clock (1.7e9 s, slack 2**-16 s) a decision stamped exactly one slack after the
    call has the age 0, one exactly ``max_decision_age_s`` plus one slack old the age
    ``max_decision_age_s``: both trusted; one ulp of the clock further, the fallback."""
    from control_helpers import observation

    from terrain.control import config_for_vehicle
    from terrain.control.closed_loop import TractionLoop
    from terrain.run import clock_slack

    t = 1.7e9
    slack = float(clock_slack(t))
    assert slack == 2.0 ** -16
    ulp = float(np.spacing(t)) * beyond
    table = _table()
    cap = table.config.max_decision_age_s
    cfg, n = config_for_vehicle("husky", kp=2.0)
    for stamp, age in ((t + slack + ulp, 0.0), (t - cap - slack - ulp, cap)):
        loop = TractionLoop(cfg, n, _Standing(), table, lambda _: ("TILES", 1.0, stamp))
        loop(observation(t, np.full(n, 1.0)))
        assert loop.log[-1]["fallback"] is fallback
        if not fallback:
            assert loop.log[-1]["decision_age_s"] == age


@pytest.mark.parametrize("classes, basis", [(["GRASS", "SNOW"], "SNOW"),
                                            (["GRASS", "GRAVEL"], "GRAVEL"),
                                            (["SNOW", "SANDY_LOAM", "GRASS", "GRAVEL"],
                                             "GRAVEL")])
def test_fallback_basis_among_tied_targets_is_the_one_that_accelerates_least(classes, basis):
    """Mutant (the tie broken by name alone) survived: the docstring's SANDY_LOAM / GRAVEL
    example is also the alphabetical order. GRASS and SNOW share the 0.30 cap; SNOW lets
    the robot accelerate less at it (0.59 against 0.85 m/s^2), so it is the basis, in
    either order of the classes."""
    from terrain.control.feedforward import traction_acceleration_limit
    from terrain.terramechanics.catalogue import get_terrain

    for order in (classes, classes[::-1]):
        table = build_slip_table(order)
        assert fallback_basis(table) == basis
        limits = {c: traction_acceleration_limit(get_terrain(c), table.entries[c].traction)
                  for c in classes}
        assert limits[basis] == min(limits.values())
