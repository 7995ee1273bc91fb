"""The service's intake on its own: the decision clock it shares with the service, and what
it keeps, counts and holds of a stream (without a model)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.run import WHEEL_CHANNELS
from terrain.serving.clocks import AHEAD, DUPLICATE, TIME_RULE, UNITS
from terrain.serving.config import StreamConfig
from terrain.serving.intake import OVERFLOW, DecisionClock, StreamIntake
from terrain.serving.rules import DEFAULT_RULES


def test_decision_clock_look_back_rewind_and_reset():
    clock = DecisionClock(window_s=2.0, rate_hz=50.0)
    assert clock.needed_since() == -np.inf           # before the first decision: every sample
    clock.next_t = 10.0
    # the window [8, 10) plus two periods of the 50 Hz clock to interpolate from
    assert clock.needed_since() == pytest.approx(10.0 - 2.0 - 0.04, abs=1e-12)
    clock.rewind(newest_s=9.0, max_backlog_s=60.0)   # 1 s ahead: a hop, not a stray stamp
    assert clock.next_t == 10.0
    clock.rewind(newest_s=-51.0, max_backlog_s=60.0)  # 61 s ahead of every stream: again
    assert clock.next_t is None
    clock.next_t = 3.0
    clock.reset()
    assert clock.next_t is None and clock.needed_since() == -np.inf


def test_decision_clock_hops_do_not_drift():
    # a running sum of 0.3 s hops was 2.2e-9 s late after 20 000 decisions (68 min), past
    # the 1e-9 s by which a window's end is told from a grid point; the clock is now its
    # origin plus whole hops, and placing it again starts a new origin
    clock = DecisionClock(window_s=2.0, rate_hz=50.0)
    clock.next_t = 12.0
    for _ in range(20_000):
        clock.advance(1, 0.3)
    assert clock.next_t == 12.0 + 20_000 * 0.3
    clock.advance(5, 0.3)                            # a skip over silent hops
    assert clock.next_t == 12.0 + 20_005 * 0.3
    clock.next_t = 100.0
    clock.advance(1, 0.3)
    assert clock.next_t == 100.3


def _intake(buffer_samples=64, **config):
    cfg = StreamConfig(streams={"wheels": WHEEL_CHANNELS}, buffer_samples=buffer_samples,
                       **config)
    clock = DecisionClock(window_s=2.0, rate_hz=10.0)
    return StreamIntake({"wheels": WHEEL_CHANNELS}, cfg, DEFAULT_RULES, clock), clock


def _chunk(t0, n, step=0.1):
    t = t0 + step * np.arange(n)
    v = np.column_stack([np.full(n, 0.5), np.full(n, 0.5), np.full(n, 2.0), np.full(n, 2.0)])
    return t, v


def test_increasing_samples_are_buffered_and_a_resend_counted_as_duplicate():
    intake, _ = _intake()
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v)
    assert len(intake.buffers["wheels"]) == 20 and intake.newest() == pytest.approx(1.9)
    intake.ingest("wheels", t[10:], v[10:])           # the publisher sends its last 10 again
    assert intake.refused == {("wheels", DUPLICATE): 10}
    assert len(intake.buffers["wheels"]) == 20


def test_a_late_sample_is_refused_and_flagged_at_its_stamp():
    intake, _ = _intake()
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v)
    late_t = np.array([1.05])                          # before the newest, no sample of it
    intake.ingest("wheels", late_t, v[:1] + 0.1)
    assert intake.refused == {("wheels", TIME_RULE): 1}
    assert (1.05, 1.05, TIME_RULE) in intake.events["wheels"]   # a span of one refusal


def test_samples_pushed_out_before_the_decision_clock_read_them_are_counted():
    """A chunk longer than the buffer while the decision clock still needs the old samples:
    what it pushes out is counted as buffer_overflow (the intake asks the shared clock)."""
    intake, clock = _intake(buffer_samples=32)
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v)
    clock.next_t = 2.0                                  # the next window reads from -0.2 s on
    t2, v2 = _chunk(2.0, 30)
    intake.ingest("wheels", t2, v2)
    assert intake.refused.get(("wheels", OVERFLOW), 0) == 20 + 30 - 32
    # flagged where they were lost (0.0 to 1.7 s: the windows of the decisions at 2.0 to
    # 3.5 s that would have read them), not at the chunk's first stamp (2.0 s: the windows
    # at 2.5 to 4.0 s, the first one missed and the last one whole)
    (first_s, last_s, reason), = intake.events["wheels"]
    assert reason == OVERFLOW and (first_s, last_s) == pytest.approx((0.0, 1.7))
    # a decision clock already past them (its next window reads from 7.8 s on): they were
    # read, nothing is lost
    fresh, fresh_clock = _intake(buffer_samples=32)
    fresh.ingest("wheels", t, v)
    fresh_clock.next_t = 10.0
    fresh.ingest("wheels", t2, v2)
    assert ("wheels", OVERFLOW) not in fresh.refused
    # before the first decision every sample may still be read: all 18 count
    first, _ = _intake(buffer_samples=32)
    first.ingest("wheels", t, v)
    first.ingest("wheels", t2, v2)
    assert first.refused[("wheels", OVERFLOW)] == 18
    # no window will read them: the first one placed says so
    assert first.unplaced == {("wheels", OVERFLOW)} and not first.events["wheels"]


def test_a_clock_offset_of_the_config_is_the_clocks_start():
    intake, _ = _intake(clock_offsets_s={"wheels": -100.0})
    assert intake.clocks["wheels"].offset_s == -100.0 and intake.restarts == 0


def test_a_lone_stream_stepping_ahead_is_taken_there_is_no_other_clock():
    """With one stream there is no other clock to be ahead of: a forward step is a gap of
    that stream, nothing is held or refused as time_ahead."""
    intake, _ = _intake()
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v)
    t2, v2 = _chunk(30.0, 20)
    intake.ingest("wheels", t2, v2)
    assert ("wheels", AHEAD) not in intake.refused
    assert intake.clocks["wheels"].held() == {}
    assert intake.newest() == pytest.approx(31.9)


def test_a_held_run_refused_as_a_stray_stamp_counts_all_its_samples_under_time_ahead():
    """A run held ahead of the other stream's clock is bounded (``buffer_samples``): the
    oldest held samples it drops were counted as buffer_overflow, and when the stream then
    went on on its old clock the run was refused as time_ahead with only the samples still
    held (40 held into a 32-sample hold: 8 buffer_overflow + 32 time_ahead). Every sample
    of the run is now counted once, under the reason that finally dropped it."""
    streams = {"wheels": ("vel_l", "vel_r"), "currents": ("cur_l", "cur_r")}
    cfg = StreamConfig(streams=streams, buffer_samples=32)
    intake = StreamIntake(streams, cfg, DEFAULT_RULES, DecisionClock(2.0, 10.0))
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v[:, :2])
    intake.ingest("currents", t, v[:, 2:])
    t2, v2 = _chunk(12.0, 40)                  # the wheel clock steps 10 s ahead, alone
    intake.ingest("wheels", t2, v2[:, :2])
    assert intake.clocks["wheels"].held() == {AHEAD: 32}
    assert intake.refused == {("wheels", OVERFLOW): 8}     # counted nowhere else yet
    t3, v3 = _chunk(2.0, 1)                    # the wheels go on on their old clock
    intake.ingest("wheels", t3, v3[:, :2])
    assert intake.clocks["wheels"].held() == {}
    assert intake.refused == {("wheels", AHEAD): 40}


def test_late_samples_held_for_a_restart_and_purged_with_a_clock_in_ms_count_once():
    """Samples refused as time_not_increasing are held as a possible restarted clock (and
    stay counted there); a purge of the stream found on a clock in ms counted them again as
    timestamp_units: 3 late samples and 9 on the ms clock gave 15 refusals for 12 samples.
    They are now counted once, under the purge's reason."""
    intake, _ = _intake()
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v)
    t2, v2 = _chunk(1.05, 3)                  # late: before the newest (1.9 s)
    intake.ingest("wheels", t2, v2)
    assert intake.refused == {("wheels", TIME_RULE): 3} and len(intake.clocks["wheels"].late)
    pushed = 0
    while ("wheels", UNITS) not in intake.refused:   # the wheels go on in ms
        t3, v3 = _chunk(2000.0 + 100.0 * pushed, 1)
        intake.ingest("wheels", t3, v3)
        pushed += 1
    assert pushed == 9 and intake.refused == {("wheels", UNITS): 3 + pushed}
