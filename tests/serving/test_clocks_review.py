"""Review tests of the clock rules (:mod:`terrain.serving.clocks`): a forward step judged
against every other stream, and a restart shift at exactly a gap."""

from __future__ import annotations

import pytest

from terrain.serving.clocks import restart_shift, steps_ahead


def test_a_step_is_ahead_only_when_past_every_other_stream():
    # the wheels were with the IMU and stay behind, but a third stream is already at
    # 199 s: the IMU's 100 s step is no clock of its own (past one stream is not enough)
    assert steps_ahead(200.0, 100.0, [100.0, 100.0], 5.0, 60.0)
    assert not steps_ahead(200.0, 100.0, [100.0, 199.0], 5.0, 60.0)
    assert not steps_ahead(200.0, 100.0, [199.0, 100.0], 5.0, 60.0)


def test_a_restart_shift_of_exactly_a_gap_is_none_and_one_just_over_it_moves_the_run():
    # running stream at 64 s, step 0.25 s: the reference is 64.125 s; a shift of exactly
    # gap_factor (2) steps is within a gap (the readers' gap is a step longer than that)
    assert restart_shift(63.625, 0.0, [64.0], [0.25], 2.0) == 0.0
    assert restart_shift(63.5, 0.0, [64.0], [0.25], 2.0) == pytest.approx(0.625)
    assert restart_shift(64.625, 0.0, [64.0], [0.25], 2.0) == 0.0
    assert restart_shift(64.75, 0.0, [64.0], [0.25], 2.0) == pytest.approx(-0.625)


def test_a_stream_went_on_live_only_by_half_the_held_span():
    # a held run of 10 s: another stream that advanced 5 s meanwhile went on live (half
    # the span: a live clock beside a lagging delivery); 4.9 s or 2.5 s is a backlog or a
    # re-send sent faster than live, no clock to put the run on
    from terrain.serving.clocks import went_on_live

    assert went_on_live(10.0, 5.0)
    assert not went_on_live(10.0, 4.9)
    assert not went_on_live(10.0, 2.5)
