"""The clock rules of the streaming service as pure functions (terrain.serving.clocks).

Values are worked out by hand from the rules' definitions (module docstring of
terrain.serving.clocks); the service-level scenarios (a restarted driver, an NTP step, a
re-sending publisher) are in test_service.py.
"""

import numpy as np
import pytest

from terrain.serving.clocks import (AHEAD, UNITS, UNITS_STEPS, HeldChunks, HeldRun,
                                    StreamClock, ahead_shift, clock_in_ms, continues_run,
                                    first_long_step, in_a_gap, newest_on_ms_clock, resent_mask,
                                    resolve_hold,
                                    restart_shift, steps_ahead, went_on_live)


def _values(n, start=0.0):
    """(n, 2) distinct sample values."""
    return np.column_stack([start + np.arange(n, dtype=float), -np.arange(n, dtype=float)])


# --- HeldRun -----------------------------------------------------------------------------

def test_held_run_is_bounded_and_keeps_its_start():
    held = HeldRun(3)
    held.begin(10.0, 0.4, {"wheels": 9.9})
    for i in range(5):
        held.append(10.0 + 0.1 * i, _values(1, i)[0])
    t, v = held.arrays()
    assert len(held) == 3 and held.full
    np.testing.assert_allclose(t, [10.2, 10.3, 10.4])
    assert v.shape == (3, 2) and v[0, 0] == 2.0
    assert held.t0_s == 10.0 and held.lead_s == 0.4          # the start outlives the bound
    assert held.others_newest_s == {"wheels": 9.9}
    # what the bound dropped: the oldest two, 10.0 to 10.1 s (their windows are flagged
    # when the run is released)
    assert held.n_dropped == 2 and held.dropped_last_s == pytest.approx(10.1)
    held.clear()
    assert len(held) == 0 and held.last_t == -np.inf and held.arrays()[1].shape[0] == 0
    assert held.n_dropped == 0 and np.isnan(held.dropped_last_s)


def test_extend_clock_begins_a_new_run_at_a_break():
    held = HeldRun(100)
    t = np.array([1.0, 1.1, 1.2, 5.0, 5.1])     # a step of 3.8 s breaks a 0.3 s max step
    held.extend_clock(t, _values(5), 0.3, {"imu": 7.0})
    run_t, run_v = held.arrays()
    np.testing.assert_allclose(run_t, [5.0, 5.1])
    np.testing.assert_allclose(run_v[:, 0], [3.0, 4.0])
    assert held.t0_s == 5.0
    assert held.lead_s == pytest.approx(0.1)     # the chunk's newest (5.1) past the start
    assert held.others_newest_s == {"imu": 7.0}
    # a later chunk that continues the run keeps its start and lead
    held.extend_clock(np.array([5.2, 5.3]), _values(2), 0.3, {"imu": 8.0})
    assert len(held) == 4 and held.t0_s == 5.0 and held.others_newest_s == {"imu": 7.0}


def test_extend_clock_with_no_usual_step_holds_one_sample():
    held = HeldRun(10)      # a NaN max step (the stream has no usual step) continues nothing
    held.extend_clock(np.array([1.0, 1.1, 1.2]), _values(3), np.nan, {})
    assert len(held) == 1 and held.t0_s == 1.2 and held.lead_s == 0.0


def test_continues_run():
    assert continues_run(1.1, 1.0, 0.2)
    assert not continues_run(1.0, 1.0, 0.2)      # the same stamp is no step forward
    assert not continues_run(0.9, 1.0, 0.2)
    assert not continues_run(1.3, 1.0, 0.2)
    assert not continues_run(1.1, 1.0, np.nan)


# --- a forward step of one clock ----------------------------------------------------------

def test_steps_ahead():
    # the IMU steps 100 s ahead of wheels that were with it just before
    assert steps_ahead(200.0, 100.0, [100.0], 5.0, 60.0)
    # a step of 3 s is within the 5 s a lag may take
    assert not steps_ahead(103.0, 100.0, [100.0], 5.0, 60.0)
    # ahead of its own newest but not of the other stream
    assert not steps_ahead(200.0, 100.0, [198.0], 5.0, 60.0)
    # the wheels were 50 s behind already (dead or lagging): no clock to judge by
    assert not steps_ahead(200.0, 100.0, [50.0], 5.0, 60.0)
    # one stream alone steps nowhere
    assert not steps_ahead(200.0, 100.0, [], 5.0, 60.0)


def test_steps_ahead_of_a_first_sample():
    # more than max_backlog_s from every other stream, ahead or behind: another clock
    assert steps_ahead(1000.0, -np.inf, [100.0], 5.0, 60.0)
    assert steps_ahead(100.0, -np.inf, [1000.0], 5.0, 60.0)
    # 30 s behind is a late delivery, not another clock
    assert not steps_ahead(70.0, -np.inf, [100.0], 5.0, 60.0)


def test_resolve_hold():
    args = (1.0, 5.0, 60.0)   # lag_s, clock_restart_s, max_backlog_s
    # the wheels caught up with the held run (they lagged): take it as it is
    assert resolve_hold(200.0, 210.0, {"wheels": 100.0}, {"wheels": 199.0}, *args) == []
    # a step of 6.5 s: the wheels, 6.5 s behind when it began, went on for 5 s; 1.5 s
    # short of the run, they have not met it (a tolerance of clock_restart_s took it as
    # it was)
    assert resolve_hold(200.0, 205.0, {"wheels": 193.5}, {"wheels": 198.5}, *args) \
        == ["wheels"]
    # the wheels went on live for the run's span: its clock stepped alone
    assert resolve_hold(200.0, 210.0, {"wheels": 100.0}, {"wheels": 110.0}, *args) \
        == ["wheels"]
    # they went on by less than half the span (a backlog sent at once): keep holding
    assert resolve_hold(200.0, 210.0, {"wheels": 100.0}, {"wheels": 101.0}, *args) is None
    # ... until the run has lasted max_backlog_s: take it as it is
    assert resolve_hold(200.0, 261.0, {"wheels": 100.0}, {"wheels": 101.0}, *args) == []
    # a run shorter than clock_restart_s is no clock yet
    assert resolve_hold(200.0, 202.0, {"wheels": 100.0}, {"wheels": 102.0}, *args) is None


def test_ahead_shift_after_the_streams_last_sample():
    # the IMU's last sample before the step at 99.95 s, its step 0.05 s; the wheels were at
    # 100.0 s (step 0.1 s) when the first held sample (500 s) came: one step after 99.95,
    # i.e. 100.0, which lies inside the wheels' step [100.0, 100.1]
    assert ahead_shift(500.0, 0.0, [100.0], [0.1], 99.95, 0.05) == pytest.approx(-400.0)
    # the chunk arrived 0.5 s after its first sample: the window moves 0.5 s earlier,
    # [99.5, 99.6], but never before half a step after the stream's own last sample
    assert ahead_shift(500.0, 0.5, [100.0], [0.1], 99.95, 0.05) == pytest.approx(-400.025)


def test_ahead_shift_of_a_first_sample_is_the_middle_of_the_step():
    assert ahead_shift(500.0, 0.0, [100.0], [0.1], -np.inf, np.nan) \
        == pytest.approx(100.05 - 500.0)
    # no usual step of the others (one sample): the step is taken as 0
    assert ahead_shift(500.0, 0.0, [100.0], [np.nan], -np.inf, np.nan) \
        == pytest.approx(-400.0)


# --- a restart of one stream alone --------------------------------------------------------

def test_restart_shift_is_half_a_step_after_the_running_streams():
    # an IMU driver restarts its clock at 0 while the wheels (step 0.01 s) are at 73.4 s
    assert restart_shift(0.0, 0.0, [73.4], [0.01], 3.0) == pytest.approx(73.405)
    # its chunk's newest arrived 0.2 s after its first sample
    assert restart_shift(0.0, 0.2, [73.4], [0.01], 3.0) == pytest.approx(73.205)
    # the newest running stream sets the reference
    assert restart_shift(0.0, 0.0, [73.4, 73.0], [0.01, 0.1], 3.0) == pytest.approx(73.405)


def test_restart_shift_within_a_gap_is_none():
    # the new clock agrees with the running one within 3 of its steps: not moved
    assert restart_shift(73.41, 0.0, [73.4], [0.01], 3.0) == 0.0
    assert restart_shift(73.45, 0.0, [73.4], [0.01], 3.0) == pytest.approx(-0.045)


# --- a late backlog of a dropout ----------------------------------------------------------

def test_in_a_gap():
    # a dropout 10..20 s; its backlog 12..18 s comes after the live samples
    assert in_a_gap(np.array([10.0, 20.0, 20.1]), 12.0, 18.0, 60.0, [], 5.0)
    # the sample after the hole is the stream's newest: on another stream's clock it is
    # live, a dropout; far ahead of every other stream it is one stray stamp
    assert in_a_gap(np.array([10.0, 20.0]), 12.0, 18.0, 60.0, [19.9], 5.0)
    assert not in_a_gap(np.array([10.0, 20.0]), 12.0, 18.0, 60.0, [11.0], 5.0)
    # a hole longer than max_backlog_s, a run past the hole or before the buffer: no gap
    assert not in_a_gap(np.array([10.0, 100.0, 100.1]), 12.0, 18.0, 60.0, [], 5.0)
    assert not in_a_gap(np.array([10.0, 20.0, 20.1]), 12.0, 20.05, 60.0, [], 5.0)
    assert not in_a_gap(np.array([10.0, 20.0, 20.1]), 5.0, 8.0, 60.0, [], 5.0)


# --- re-sent samples -----------------------------------------------------------------------

def test_resent_mask_tells_a_resend_from_a_loop():
    bt, bv = np.array([1.0, 1.1, 1.2, 1.3]), _values(4)
    kw = dict(oldest_t_s=1.0, newest_t_s=1.3, last_held_t_s=None, max_step_s=0.3)
    # the publisher re-sends 1.1 and 1.2 with the same values: duplicates
    assert resent_mask(bt[1:3], bv[1:3], bt, bv, **kw).tolist() == [True, True]
    # the same stamps with other values are a new clock's samples: held, not refused
    assert resent_mask(bt[1:3], bv[1:3] + 5.0, bt, bv, **kw).tolist() == [False, False]
    # played again from the oldest buffered sample: a loop (held for a restart)
    assert resent_mask(bt, bv, bt, bv, **kw).tolist() == [False] * 4
    # samples past the newest are the rules' to judge
    assert resent_mask(np.array([1.4, 1.5]), _values(2, 9), bt, bv, **kw).tolist() \
        == [False, False]


def test_resent_mask_within_one_chunk():
    empty = (np.empty(0), np.empty((0, 2)))
    kw = dict(oldest_t_s=np.inf, newest_t_s=-np.inf, last_held_t_s=None, max_step_s=0.3)
    t, v = np.array([1.0, 1.1, 1.1]), _values(3)
    v[2] = v[1]                      # the chunk repeats its second sample
    assert resent_mask(t, v, *empty, **kw).tolist() == [False, False, True]
    t, v = np.array([1.0, 1.1, 1.0]), _values(3)
    v[2] = v[0]                      # ... or starts again from its first: a loop
    assert resent_mask(t, v, *empty, **kw).tolist() == [False, False, False]


def test_resent_mask_continuing_a_held_run_is_no_resend():
    bt, bv = np.array([1.0, 1.1, 1.2, 1.3]), _values(4)
    # a held late run ends at 1.05; 1.2 (a buffered sample) continues it
    mask = resent_mask(bt[2:3], bv[2:3], bt, bv, 1.0, 1.3, 1.05, 0.3)
    assert mask.tolist() == [False]


def test_a_held_run_knows_the_samples_it_holds():
    held = HeldRun(8)
    held.begin(100.0, 0.0, {})
    for i, (ti, vi) in enumerate(zip(100.0 + 0.01 * np.arange(5), _values(5))):
        held.append(ti, vi)
    t, v = held.arrays()
    assert held.repeats(t[2], v[2]) and held.repeats(t[4] + 1e-7, v[4])
    assert not held.repeats(t[2], v[2] + 1.0)       # the stamp again, other values
    assert not held.repeats(t[2] + 0.005, v[2])     # other stamp
    assert not held.repeats(99.0, v[0]) and not HeldRun(4).repeats(t[0], v[0])

# --- a clock in ms ---------------------------------------------------------------------------


def test_clock_in_ms():
    ms = np.arange(UNITS_STEPS + 1) * 10.0     # a 100 Hz IMU stamped in ms: 0.1 "Hz"
    assert clock_in_ms(ms, "imu") is True
    assert clock_in_ms(ms / 1000.0, "imu") is False
    assert clock_in_ms(ms * 1000.0, "imu") is True          # in us: 1e-4 "Hz"
    assert clock_in_ms(ms * 1e6, "imu") is True             # in ns
    assert clock_in_ms(ms * 1e9, "imu") is False            # no unit makes it 100 Hz
    # a 2000 Hz IMU in us: 0.002 "Hz", 2 Hz in ms (below the range), 2000 Hz in us; the
    # scaled ms rule missed it (the ms test at x1000 needs a rate under 1 Hz), the readers'
    # rule itself (timestamp_unit) does not
    assert clock_in_ms(np.arange(UNITS_STEPS + 1) * 500.0, "imu") is True
    assert clock_in_ms(ms[:UNITS_STEPS], "imu") is None      # too few steps to judge
    assert clock_in_ms(np.full(UNITS_STEPS + 1, 5.0), "imu") is None   # no step forward


def test_newest_on_ms_clock():
    # samples 0.01 s apart, then the clock switches to ms: 20, 30, 40 "s"
    times = np.array([0.0, 0.01, 0.02, 20.0, 30.0, 40.0])
    assert newest_on_ms_clock(times, 1.0) == 3
    assert newest_on_ms_clock(np.array([0.0, 10.0, 20.0]), 1.0) == 3   # none known good
    assert newest_on_ms_clock(np.array([0.0, 0.01, 0.02]), 1.0) == 0


def test_first_long_step():
    # an IMU chunk switching to ms after its third sample
    t = np.array([40.97, 40.98, 40.99, 41000.0, 41010.0])
    assert first_long_step(t, 40.96, 1.0) == 3
    # the step into the chunk's first sample is long: 0, as when none is
    assert first_long_step(t[3:], 40.99, 1.0) == 0
    assert first_long_step(t[:3], 40.96, 1.0) == 0
    # a NaN stamp is skipped: the step runs from the finite stamp before it
    assert first_long_step(np.array([1.0, np.nan, 5.0]), 0.9, 1.0) == 2
    # a first chunk: its first sample has no step
    assert first_long_step(np.array([0.0, 10.0]), None, 1.0) == 1


def test_held_chunks_keep_copies_in_order_and_count_finite_stamps():
    held = HeldChunks()
    t, v = np.array([np.nan, 50.0, 60.0]), _values(3)
    held.append(t, v)
    held.append(np.array([70.0]), _values(1, 9))
    t[1], v[:] = -1.0, -1.0               # the robot reuses its arrays
    assert held.t0_s == 50.0 and len(held) == 4 and held.n_finite == 3
    chunks = held.take()
    assert [c[0][1] for c in chunks[:1]] == [50.0] and chunks[0][1][0, 0] == 0.0
    assert chunks[1][0].tolist() == [70.0]
    assert len(held) == 0 and held.n_finite == 0 and held.take() == []


def test_went_on_live():
    # a run spanning 10 s: a stream that advanced 5 s or more went on at its pace
    assert went_on_live(10.0, 5.0) and went_on_live(10.0, 12.0)
    # one that advanced 1 s fell behind a run sent at once (a backlog or a re-send)
    assert not went_on_live(10.0, 1.0)
    assert not went_on_live(0.0, 0.0)          # a stream that did not advance at all


# --- StreamClock -------------------------------------------------------------------------

def test_stream_clock_threshold_is_ten_periods_of_the_slowest_nominal_rate():
    # the readers' nominal ranges (terrain.io.plausibility.NOMINAL_RATE_HZ): IMU from
    # 10 Hz (1 s), wheels from 1 Hz (10 s); a stream of unknown channels has no rule
    assert StreamClock(10, "imu").ms_step_s == pytest.approx(1.0)
    assert StreamClock(10, "wheels").ms_step_s == pytest.approx(10.0)
    unknown = StreamClock(10, None, offset_s=-2.5)
    assert unknown.ms_step_s is None and unknown.offset_s == -2.5
    assert unknown.judge_ms() == (False, False)
    assert len(unknown.late) == 0 and unknown.ahead is None and not unknown.held()


def test_stream_clock_remembers_the_newest_finite_stamps():
    clock = StreamClock(10, "imu")
    assert clock.newest_stamp_s is None
    clock.remember(np.array([0.5]))
    clock.remember(np.array([np.nan]))             # a NaN stamp is no step
    assert clock.newest_stamp_s == 0.5
    clock.remember(np.arange(1.0, 30.0))           # a long chunk: its newest ones only
    assert clock.newest_stamp_s == 29.0
    # a 100 Hz IMU in s after the ms stamps above: judged on the newest steps only
    clock.remember(30.0 + 0.01 * np.arange(1, UNITS_STEPS + 2))
    assert clock.judge_ms() == (False, False)


def test_stream_clock_judges_a_switch_to_ms_once():
    clock = StreamClock(10, "imu")
    clock.remember(np.arange(UNITS_STEPS) * 10.0)  # too few steps: as before (in s)
    assert clock.judge_ms() == (False, False) and not clock.on_ms_clock
    clock.remember(np.array([UNITS_STEPS * 10.0]))  # 100 Hz stamped in ms: 0.1 "Hz"
    assert clock.judge_ms() == (True, True) and clock.on_ms_clock
    assert clock.judge_ms() == (True, False)        # still in ms: no new switch
    # moved onto a clock in s (a restart placed it): the stamps before no longer count
    clock.restamp(40.0 + 0.01 * np.arange(UNITS_STEPS + 1))
    assert clock.judge_ms() == (False, False) and not clock.on_ms_clock


def test_stream_clock_reports_what_it_holds():
    clock = StreamClock(10, "wheels")
    clock.ahead = HeldRun(10)
    clock.ahead.begin(100.0, 0.0, {})
    clock.ahead.append(100.0, _values(1)[0])
    clock.unjudged.append(np.array([200.0, 210.0]), _values(2))
    clock.late.append(5.0, _values(1)[0])           # refused and counted already
    assert clock.held() == {AHEAD: 1, UNITS: 2}


def test_clock_rules_at_their_bounds():
    """Each rule at the exact bound its docstring draws (stamps exact in binary)."""
    # a step of exactly max_step_s continues a run (a gap is a step longer than that)
    assert continues_run(1.25, 1.0, 0.25)
    # exactly step_s ahead of the other stream is no step of its own clock ("more than")
    assert not steps_ahead(200.0, 100.0, [195.0], 5.0, 60.0)
    assert steps_ahead(200.0, 100.0, [194.875], 5.0, 60.0)
    # another stream exactly step_s behind the stream just before is still a clock to judge
    # by ("behind by more than step_s" is a dead or lagging one)
    assert steps_ahead(200.0, 100.0, [95.0], 5.0, 60.0)
    assert not steps_ahead(200.0, 100.0, [94.875], 5.0, 60.0)
    # a run that has lasted exactly max_backlog_s with the others silent is taken as it is
    args = (1.0, 5.0, 60.0)   # lag_s, clock_restart_s, max_backlog_s
    assert resolve_hold(200.0, 260.0, {"wheels": 100.0}, {"wheels": 101.0}, *args) == []
    assert resolve_hold(200.0, 259.875, {"wheels": 100.0}, {"wheels": 101.0}, *args) is None
    # the clocks meet while the other stream's newest stamp lies within lag_s of the held
    # run, either side: 1 s before its first stamp or 1 s after its newest, not 1.125 s
    assert resolve_hold(200.0, 210.0, {"wheels": 100.0}, {"wheels": 199.0}, *args) == []
    assert resolve_hold(200.0, 210.0, {"wheels": 100.0}, {"wheels": 198.875}, *args) \
        == ["wheels"]
    assert resolve_hold(200.0, 210.0, {"wheels": 100.0}, {"wheels": 211.0}, *args) == []
    assert resolve_hold(200.0, 210.0, {"wheels": 100.0}, {"wheels": 211.125}, *args) \
        == ["wheels"]


def test_a_held_run_knows_a_resent_sample_within_the_stamp_tolerance_either_side():
    """A re-sent stamp rounded (a float32 clock) may land just before or just after the
    held one: within DUPLICATE_TOL_S either way it is the same sample; the same stamp
    with other values is not."""
    from terrain.serving.clocks import DUPLICATE_TOL_S

    held = HeldRun(8)
    v = np.array([0.25, 8.0])
    held.begin(100.0, 0.0, {})
    held.append(99.5, v + 1.0)
    held.append(100.0, v)
    held.append(100.5, v + 2.0)
    for dt in (0.0, 0.5 * DUPLICATE_TOL_S, -0.5 * DUPLICATE_TOL_S):
        assert held.repeats(100.0 + dt, v), dt
    assert not held.repeats(100.0 + 3 * DUPLICATE_TOL_S, v)
    assert not held.repeats(100.0, v + 0.5)
