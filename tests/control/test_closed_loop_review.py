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


class _Accelerating(_Standing):
    """At rest, but the estimated acceleration of call k is ``accels[k]`` m/s^2."""

    def __init__(self, accels):
        self.accels = iter(accels)

    def update(self, obs):
        """The estimate with the next acceleration.

        Parameters
        ----------
        obs : Observation
            Ignored but for the number of units.
        """
        est = super().update(obs)
        return est._replace(a_local_m_s2=np.full(len(obs.omega_low_level), next(self.accels)))


def test_an_acceleration_time_constant_of_zero_is_accepted_and_turns_the_filter_off():
    """``accel_tau_s = 0`` is documented as "no filter": the mode sees each call's
    acceleration as estimated (2 then -3 m/s^2), where tau 0.3 s keeps most of the 2."""
    cfg, n = config_for_vehicle("husky", kp=2.0)
    table = build_slip_table(["ICE"])
    seen = {}
    for tau in (0.0, 0.3):
        loop = TractionLoop(cfg, n, _Accelerating([2.0, -3.0]), table,
                            lambda t: ("ICE", 1.0), accel_tau_s=tau)
        loop(observation(0.02, np.full(n, 1.0)))
        loop(observation(0.04, np.full(n, 1.0)))
        seen[tau] = loop.a_filtered.copy()
    np.testing.assert_array_equal(seen[0.0], -3.0)
    expected = 2.0 + (1.0 - np.exp(-0.02 / 0.3)) * (-3.0 - 2.0)
    np.testing.assert_allclose(seen[0.3], expected, rtol=1e-12)


class _RecordingLive:
    """A live terrain decision that records the observation times it is fed."""

    def __init__(self):
        self.fed = []

    def update(self, obs):
        """Record the call's time.

        Parameters
        ----------
        obs : Observation
            Samples since the previous call.
        """
        self.fed.append(obs.t_s)

    def __call__(self, t_s):
        """No decision.

        Parameters
        ----------
        t_s : float
            Time, s.
        """
        return None, 0.0


def test_a_live_classifier_is_fed_every_observation_of_the_run():
    """run_closed_loop wires the live classifier's ``update`` as the loop's observer: it sees
    each control call's samples once, in order, before its decision is read."""
    from terrain.control.closed_loop import run_closed_loop

    live = _RecordingLive()
    _, loop, _ = run_closed_loop("husky", "ICE", "straight_accel", True, 0, 1.0,
                                 live_terrain=live)
    assert len(loop.log) > 10
    assert live.fed == [r["t_s"] for r in loop.log]


def test_a_live_classifier_and_a_decision_function_exclude_each_other():
    """Both given: a ConfigError, not one silently ignored (before any simulation)."""
    from terrain.control.closed_loop import run_closed_loop
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match="not both"):
        run_closed_loop("husky", "ICE", "straight_accel", True, 0, 1.0,
                        terrain_decision=lambda t: ("ICE", 1.0), live_terrain=_RecordingLive())


def test_the_metrics_count_the_control_steps_that_ran_on_the_fallback_target():
    """A decision made 10 s before each call (older than the table's limit) is never
    trusted: every step runs on the fallback, yet the decisions and the accuracy count it as
    ICE (right); ``fallback_steps`` says how many steps assumed the fallback. Fresh until
    0.5 s, stale after: the steps after 0.5 s."""
    from terrain.control.closed_loop import run_closed_loop

    _, loop, m = run_closed_loop("husky", "ICE", "straight_accel", True, 0, 1.0,
                                 terrain_decision=lambda t: ("ICE", 1.0, t - 10.0))
    n = len(loop.log)
    assert m["terrain_decisions"] == {"ICE": n} and m["terrain_accuracy"] == 1.0
    assert m["fallback_steps"] == n
    max_age = loop.table.config.max_decision_age_s
    _, loop, m = run_closed_loop(
        "husky", "ICE", "straight_accel", True, 0, 1.0,
        terrain_decision=lambda t: ("ICE", 1.0, t if t <= 0.5 else t - max_age - 1.0))
    t = np.array([r["t_s"] for r in loop.log])
    assert m["fallback_steps"] == int(np.sum(t > 0.5)) > 0
    _, _, m = run_closed_loop("husky", "ICE", "straight_accel", True, 0, 1.0)
    assert m["fallback_steps"] == 0


def test_a_decision_without_a_time_is_current_however_late_in_the_run():
    """``(label, confidence)``: taken as made now (age 0), at 0.02 s and at 100 s alike; had
    it been aged from the run's start, the table's 4 s limit would put every later step on
    the fallback."""
    table = build_slip_table(["GRASS", "ICE"])
    loop, n = _loop(lambda t: ("GRASS", 0.9), table)
    for t in (0.02, 100.0):
        loop(observation(t, np.full(n, 1.0)))
        assert loop.log[-1]["decision_age_s"] == 0.0
        assert loop.log[-1]["target_traction"] == table.entries["GRASS"].traction
        assert not loop.log[-1]["fallback"]


def test_a_low_confidence_decision_gets_the_fallback_and_a_confident_one_its_entry():
    """GRASS decided at confidence below the table's ``min_confidence``: the fallback's
    targets (ICE's traction), logged as fallback; at 0.99 GRASS's own."""
    table = build_slip_table(["GRASS", "ICE"])
    low = table.config.min_confidence / 2
    for conf, expect in ((low, table.fallback), (0.99, table.entries["GRASS"])):
        loop, n = _loop(lambda t: ("GRASS", conf), table)
        loop(observation(0.02, np.full(n, 1.0)))
        assert loop.log[-1]["target_traction"] == expect.traction
        assert loop.log[-1]["fallback"] == (expect is table.fallback)
    assert table.fallback.traction != table.entries["GRASS"].traction


def test_a_run_that_never_reaches_cruise_has_no_steady_slip_scores():
    """Steady steps count only after the cruise speed is reached: timed against an
    unreachable speed (cruise_fraction 10) the same run has no steady samples (None),
    though its controller is in steady mode on many enabled steps."""
    from terrain.control.closed_loop import loop_metrics, run_closed_loop
    from terrain.control.traction import STEADY

    sim, loop, m = run_closed_loop("husky", "TILES", "straight_accel", True, 0, 4.0)
    steady = np.array([r["enabled"] & (r["mode"] == STEADY) for r in loop.log])
    assert steady.sum() > 10
    never = loop_metrics(sim, loop, 24.0, cruise_fraction=10.0)
    assert never["time_to_speed_s"] is None
    assert never["steady_slip_within_0_02"] is None
    assert never["steady_slip_error_max"] is None


def test_the_peak_slip_is_the_largest_magnitude_braking_slip_included():
    """A locking wheel (slip -0.9, braking) is the run's peak slip 0.9: magnitudes, not the
    largest signed value."""
    from terrain.control.closed_loop import loop_metrics, run_closed_loop

    sim, loop, m = run_closed_loop("husky", "ICE", "straight_accel", False, 0, 1.0)
    assert m["peak_slip"] < 0.9
    sim.physics.slip_motor[len(sim.physics.t_s) // 2, 0] = -0.9
    assert loop_metrics(sim, loop, 24.0)["peak_slip"] == pytest.approx(0.9)


def test_the_feed_forward_limits_on_the_decided_terrain_not_the_fallbacks():
    """GRASS decided with a GRASS and ICE table: the first ramp step grows the reference by
    GRASS's acceleration at GRASS's target, not ICE's (the fallback's terrain, lower)."""
    from terrain.control.closed_loop import FIRST_FEEDFORWARD_STEP_S
    from terrain.control.feedforward import traction_acceleration_limit
    from terrain.terramechanics import get_terrain

    table = build_slip_table(["GRASS", "ICE"])
    loop, n = _loop(lambda t: ("GRASS", 1.0), table)
    loop(observation(0.02, np.full(n, 10.0)))
    grass = traction_acceleration_limit(get_terrain("GRASS"), table.entries["GRASS"].traction)
    ice = traction_acceleration_limit(get_terrain("ICE"), table.fallback.traction)
    assert grass > 1.5 * ice > 0                     # 0.85 against 0.47 m/s^2
    np.testing.assert_allclose(loop.v_ref, grass * FIRST_FEEDFORWARD_STEP_S, rtol=1e-12)
