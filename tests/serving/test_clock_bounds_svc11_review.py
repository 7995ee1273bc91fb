"""Review svc11: clock rules and replay flags exactly at their bounds (hand mutants that
survived every test: ``<=`` turned ``<`` in ``in_a_gap``, ``>`` turned ``>=`` in
``first_long_step``, a window end moved in ``stuck_decision_flags``)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from terrain.serving.clocks import first_long_step, in_a_gap
from terrain.serving.decisions import stuck_decision_flags


def test_a_hole_of_exactly_max_backlog_s_is_a_dropout_and_one_just_longer_is_not():
    """``in_a_gap``: a hole "no longer than ``max_backlog_s``" (docstring) takes its
    bound (binary-exact stamps: 10 s to 70 s is 60 s)."""
    assert in_a_gap(np.array([10.0, 70.0, 70.5]), 12.0, 18.0, 60.0, [], 5.0)
    assert not in_a_gap(np.array([10.0, 70.5, 71.0]), 12.0, 18.0, 60.0, [], 5.0)


def test_a_step_of_exactly_the_longest_ordinary_step_is_not_long():
    """``first_long_step``: a step "more than ``max_step_s``" (docstring) opens the hold;
    one of exactly 1 s (an IMU's ten periods at its slowest nominal rate) does not."""
    t = np.array([0.0, 1.0, 2.0, 3.5])
    assert first_long_step(t, -1.0, 1.0) == 3      # steps 1, 1, 1, then 1.5
    assert first_long_step(t[:3], -1.0, 1.0) == 0  # steps of exactly 1 s: none long
    assert first_long_step(np.array([0.0, 0.25, 1.25]), None, 1.0) == 0


def test_a_replay_flags_a_stuck_stretch_inside_each_decisions_half_open_window():
    """``stuck_decision_flags``: the window of a decision is ``[t_s - age - window_s,
    t_s - age)``: a stretch ending exactly at its start is in it, one starting exactly at
    its end is not (the next window has it), as ``terrain predict`` flags its windows."""
    frame = pd.DataFrame({"t_s": [10.0, 10.0, 10.0, 10.0],
                          "window_age_s": [0.0, 0.0, 0.5, 0.5]})
    key = "wheels.vel_l"
    # windows [8, 10), [8, 10), [7.5, 9.5), [7.5, 9.5)
    for spans, want in (([[10.0, 11.0]], ["", "", "", ""]),
                        ([[7.0, 8.0]], [f"stuck:{key}"] * 2 + [f"stuck:{key}"] * 2),
                        ([[6.0, 7.9995]], ["", ""] + [f"stuck:{key}"] * 2),
                        ([[9.5, 9.75]], [f"stuck:{key}"] * 2 + ["", ""]),
                        ([[6.0, 7.5]], ["", ""] + [f"stuck:{key}"] * 2)):
        assert stuck_decision_flags(frame, {key: spans}, 2.0).tolist() == want, spans
    # a decision with no window (infinite age) is never flagged
    none = pd.DataFrame({"t_s": [10.0], "window_age_s": [np.inf]})
    assert stuck_decision_flags(none, {key: [[0.0, 100.0]]}, 2.0).tolist() == [""]
