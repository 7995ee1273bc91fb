"""Review of the clock rules and the intake at the bounds their docstrings draw (hand
mutants of clocks.py and intake.py that the other tests let live)."""

from __future__ import annotations

import numpy as np

from terrain.serving.clocks import UNITS_STEPS, StreamClock, steps_ahead
from terrain.serving.intake import OVERFLOW
from test_intake import _intake


def test_a_step_of_exactly_a_clocks_step_is_no_step_ahead():
    # "more than step_s past prev_t_s": 6 s after the stream's newest is a lag the config
    # tolerates, even when it is 7 s past the other stream (binary-exact stamps)
    assert not steps_ahead(16.0, 10.0, [9.0], 6.0, 60.0)
    assert steps_ahead(16.5, 10.0, [9.0], 6.0, 60.0)


def test_a_rejection_inside_a_noted_span_never_shortens_it():
    # a span of rejections [2, 10] s (an overflow run, noted with until_s); a rejection of
    # the same reason at 5 s falls inside it: every window holding 6-10 s keeps its flag
    intake, _ = _intake()
    intake.note("wheels", 2.0, OVERFLOW, until_s=10.0)
    intake.note("wheels", 5.0, OVERFLOW)
    assert list(intake.events["wheels"]) == [(2.0, 10.0, OVERFLOW)]
    intake.note("wheels", 11.0, OVERFLOW)       # within one window (2 s) after: extends
    assert list(intake.events["wheels"]) == [(2.0, 11.0, OVERFLOW)]
    intake.note("wheels", 13.5, OVERFLOW)       # more than a window after: a new span
    assert list(intake.events["wheels"])[-1] == (13.5, 13.5, OVERFLOW)


def test_a_clock_found_in_ms_stays_in_ms_while_too_few_steps_say_otherwise():
    # "as before when too little to judge": a clock judged in ms, then moved with only
    # three stamps remembered, is still in ms (its samples stay refused)
    clock = StreamClock(10, "imu")
    clock.remember(np.arange(UNITS_STEPS + 1) * 10.0)   # 100 Hz stamped in ms
    assert clock.judge_ms() == (True, True)
    clock.restamp(np.array([500.0, 510.0, 520.0]))
    assert clock.judge_ms() == (True, False) and clock.on_ms_clock
