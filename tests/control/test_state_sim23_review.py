"""Review tests (sim23) of state and aliasing in the closed loop's controller callback:
the log of :class:`terrain.control.closed_loop.TractionLoop` keeps what each call saw, not
references to arrays the caller or an estimator may reuse or change afterwards."""

from __future__ import annotations

import numpy as np
from control_helpers import observation
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.control import build_slip_table, config_for_vehicle
from terrain.control.closed_loop import TractionLoop
from terrain.control.estimators import VelocityEstimate
from terrain.control.traction import TractionController


class _Buffered:
    """Estimator that hands out its own buffers (a robot-side estimator may reuse them)."""

    name, limits = "buffered", "stub reusing its arrays"

    def __init__(self):
        self.v = np.zeros(2)
        self.omega = np.zeros(2)

    def update(self, obs):
        """Write the new estimate into the same buffers and return them.

        Parameters
        ----------
        obs : Observation
            Its time sets the speed.
        """
        self.v[:] = 0.5 * obs.t_s
        self.omega[:] = 0.5 * obs.t_s / 0.165 * 1.5
        return VelocityEstimate(self.omega, self.v, np.zeros(2), float(self.v[0]), 0.0)


def _loop(estimator):
    cfg, n = config_for_vehicle("husky", kp=2.0)
    table = build_slip_table(["GRASS", "ICE"])
    return TractionLoop(cfg, n, estimator, table, lambda t: ("GRASS", 1.0))


def test_log_keeps_each_calls_command_when_the_caller_reuses_its_buffer():
    """A robot's driver fills one command buffer in place every cycle. The log held the
    buffer itself, so every record read the latest command (loop_metrics' cruise speed from
    it): each record must keep the command of its own call."""
    loop = _loop(_Buffered())
    command = np.zeros(2)
    for k, value in enumerate([1.0, 2.0, 3.0]):
        command[:] = value
        loop(observation(0.02 * (k + 1), command))
    logged = [r["omega_low_level"].tolist() for r in loop.log]
    assert logged == [[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]]


def test_log_keeps_each_calls_estimate_when_the_estimator_reuses_its_buffer():
    """An estimator returning the same array each call left every record with its last
    estimate."""
    loop = _loop(_Buffered())
    for k in range(3):
        loop(observation(0.2 * (k + 1), np.full(2, 4.0)))
    logged = [r["v_long"][0] for r in loop.log]
    np.testing.assert_allclose(logged, [0.1, 0.2, 0.3])


def test_changing_the_returned_correction_leaves_the_log_alone():
    """The correction returned was the log's own array: a caller scaling it in place (a
    rate limiter, a gain schedule) rewrote the logged correction."""
    loop = _loop(_Buffered())
    out = loop(observation(0.2, np.full(2, 4.0)))
    before = loop.log[-1]["correction"].copy()
    out += 100.0
    np.testing.assert_array_equal(loop.log[-1]["correction"], before)


@settings(max_examples=25, deadline=None)
@given(history=st.lists(st.tuples(st.floats(0.5, 10.0), st.floats(0.0, 3.0),
                                  st.floats(-2.0, 2.0)), min_size=1, max_size=6),
       probe=st.tuples(st.floats(0.5, 10.0), st.floats(0.0, 3.0), st.floats(-2.0, 2.0)))
def test_a_reset_controller_answers_as_a_fresh_one(history, probe):
    """After any history, reset() returns the controller to its freshly made state: the
    same output as a new controller on the same input (integral, derivative, held
    correction and active flags all forgotten)."""
    cfg, n = config_for_vehicle("husky", kp=2.0, ki=5.0, kd=0.1)
    targets = build_slip_table(["GRASS"]).entries["GRASS"]

    def step(ctl, omega, v, a):
        return ctl.step(targets, np.full(n, omega), np.full(n, omega * 0.9), np.full(n, v),
                        np.full(n, a), abs(v), 0.02)

    used = TractionController(cfg, n)
    for row in history:
        step(used, *row)
    used.reset()
    fresh = TractionController(cfg, n)
    for x, y in zip(step(used, *probe), step(fresh, *probe)):
        np.testing.assert_array_equal(x, y)
    for x, y in zip(used.state, fresh.state):
        np.testing.assert_array_equal(x, y)
