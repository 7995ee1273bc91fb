"""Review srv10 of the streaming service's ring buffer and intake at their bounds (hand
mutants of buffers.py and intake.py that the other tests let live)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.buffers import RingBuffer
from terrain.serving.clocks import AHEAD, TIME_RULE
from terrain.serving.config import StreamConfig
from terrain.serving.intake import DecisionClock, StreamIntake
from terrain.serving.rules import DEFAULT_RULES
from test_intake import _chunk, _intake


def _stamps(*stamps: float) -> np.ndarray:
    return np.array(stamps, dtype=float)


def test_a_chunk_of_exactly_the_capacity_pushes_out_the_held_samples_only():
    # capacity 4 holding 0, 1; a chunk of 4 samples keeps all of its own: 0 and 1 go, none
    # of the chunk (mutant: its first sample counted lost too); one sample longer and its
    # first one goes as well
    buf = RingBuffer(1, 4)
    buf.append(_stamps(0, 1), np.zeros((2, 1)))
    assert buf.evicted_times(_stamps(5, 6, 7, 8), -np.inf).tolist() == [0.0, 1.0]
    assert buf.evicted(_stamps(5, 6, 7, 8), -np.inf) == 2
    assert buf.evicted_times(_stamps(5, 6, 7, 8, 9), -np.inf).tolist() == [0.0, 1.0, 5.0]
    # only those at or after the time still needed count
    assert buf.evicted(_stamps(5, 6, 7, 8, 9), 1.0) == 2
    buf.append(_stamps(5, 6, 7, 8), np.zeros((4, 1)))
    assert buf.times().tolist() == [5.0, 6.0, 7.0, 8.0]


def test_chunks_held_for_the_units_rule_stay_within_buffer_samples():
    # a long step (90 s: a switch to ms, or a dropout) opens the units hold; what follows
    # brings no finite stamp to judge it by (a driver sending NaN stamps): the hold is
    # bounded by buffer_samples, then released (the NaN stamps refused, counted), never
    # grown with every push (mutant: 300 held)
    intake, _ = _intake(buffer_samples=64)
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v)
    t, v = _chunk(100.0, 1)
    intake.ingest("wheels", t, v)
    held = intake.clocks["wheels"].unjudged
    assert len(held) == 1
    most = 0
    for _ in range(300):
        intake.ingest("wheels", _stamps(np.nan), v)
        most = max(most, len(held))
    assert most <= 64 and len(held) == 0
    # every sample accounted for: 20 + 1 taken, 300 refused
    assert intake.refused == {("wheels", "non_finite"): 300}
    assert len(intake.buffers["wheels"]) == 21 and intake.buffers["wheels"].last_t == 100.0


def test_a_sample_back_before_a_units_hold_drops_it_only_past_max_backlog_s():
    # wheels to 1.9 s, one sample after a long step, then samples back on the old clock:
    # after a step of 40 s (< max_backlog_s = 60 s: a dropout's backlog may be that late)
    # the held sample is taken as it came and those back are late; after 61 s it was a
    # stray stamp ahead, refused as time_ahead, and the old clock goes on (mutant of the
    # bound at half max_backlog_s: the 40 s step refused too)
    for jump, refused, newest in ((40.0, {("wheels", TIME_RULE): 3}, 41.9),
                                  (61.0, {("wheels", AHEAD): 1}, 2.2)):
        intake, _ = _intake(buffer_samples=64)
        t, v = _chunk(0.0, 20)
        intake.ingest("wheels", t, v)
        t, v = _chunk(1.9 + jump, 1)
        intake.ingest("wheels", t, v)
        assert intake.clocks["wheels"].held() == {"timestamp_units": 1}
        t, v = _chunk(2.0, 3)
        intake.ingest("wheels", t, v)
        assert intake.refused == refused, jump
        assert intake.buffers["wheels"].last_t == newest and not intake.clocks["wheels"].held()


def test_a_chunk_that_goes_on_past_a_stray_stamp_then_back_counts_every_sample_refused():
    # wheels to 1.9 s, one sample 98 s ahead (units hold), then one chunk of two more on
    # that clock and two back on the old one: the held sample and the chunk's two before
    # the step back are refused as time_ahead (3), the two after are taken (mutant: the
    # chunk's two dropped without a count)
    intake, _ = _intake(buffer_samples=64)
    t, v = _chunk(0.0, 20)
    intake.ingest("wheels", t, v)
    t, v = _chunk(100.0, 1)
    intake.ingest("wheels", t, v)
    t, v = _chunk(0.0, 4)
    intake.ingest("wheels", _stamps(100.1, 100.2, 2.0, 2.1), v + 0.01 * np.arange(4)[:, None])
    assert intake.refused == {("wheels", AHEAD): 3}
    np.testing.assert_allclose(intake.buffers["wheels"].times()[-3:], [1.9, 2.0, 2.1])
    assert len(intake.buffers["wheels"]) == 22 and not intake.clocks["wheels"].held()


def _imu(t_s: np.ndarray) -> np.ndarray:
    """Live IMU values (no sample repeats another: no re-send)."""
    return np.column_stack([np.zeros((len(t_s), 5)), 9.81 + 0.01 * np.sin(7.0 * t_s)])


def test_a_step_back_shorter_than_stale_s_is_a_lag_not_a_clock_moved():
    # wheels (10 Hz) and IMU (50 Hz) to 9.9 s; the wheel clock steps back 0.4 s (less than
    # stale_s = 1 s) and runs on past its old newest while the IMU goes on live: the 5
    # samples back are refused as late, the clock is not moved (mutant without the stale_s
    # bound: a restart of the wheel clock alone, its offset moved by 0.51 s)
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=1024),
                          DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))
    t, w = _chunk(0.0, 100)
    intake.ingest("wheels", t, w)
    t_imu = 0.02 * np.arange(496)
    intake.ingest("imu", t_imu, _imu(t_imu))
    k = 496
    for t_wheel in (9.5, 9.6, 9.7, 9.8, 9.9, 10.0, 10.1):
        for _ in range(5):
            t_imu = np.array([0.02 * k])
            intake.ingest("imu", t_imu, _imu(t_imu))
            k += 1
        t, w = _chunk(t_wheel, 1)
        intake.ingest("wheels", t, w + 1e-4 * k)
    assert intake.restarts == 0 and intake.clocks["wheels"].offset_s == 0.0
    assert intake.refused == {("wheels", TIME_RULE): 5}
    np.testing.assert_allclose(intake.buffers["wheels"].times()[-3:], [9.9, 10.0, 10.1])


def _wheels(t_s: np.ndarray) -> np.ndarray:
    """Live wheel values (no sample repeats another)."""
    return np.column_stack([0.5 + 0.01 * np.sin(t_s), 0.5 + 0.01 * np.cos(t_s),
                            2.0 + 0.1 * np.sin(5.0 * t_s), 2.0 + 0.1 * np.cos(5.0 * t_s)])


class _Taken:
    """Samples each stream's buffers took (appended less dropped as on a clock in ms) and
    pushed out (counted as buffer_overflow), by number of channels."""

    def __init__(self, monkeypatch) -> None:
        self.taken: dict[int, int] = {}
        self.pushed_out: dict[int, int] = {}
        append, drop, evicted = RingBuffer.append, RingBuffer.drop_newest, RingBuffer.evicted
        tally = self

        def counted_append(buf, t_s, values):
            key = buf._v.shape[1]
            tally.taken[key] = tally.taken.get(key, 0) + len(t_s)
            append(buf, t_s, values)

        def counted_drop(buf, n):
            key = buf._v.shape[1]
            tally.taken[key] = tally.taken.get(key, 0) - min(max(int(n), 0), len(buf))
            drop(buf, n)

        def counted_evicted(buf, t_s, since_s):
            lost = evicted(buf, t_s, since_s)
            key = buf._v.shape[1]
            tally.pushed_out[key] = tally.pushed_out.get(key, 0) + lost
            return lost

        monkeypatch.setattr(RingBuffer, "append", counted_append)
        monkeypatch.setattr(RingBuffer, "drop_newest", counted_drop)
        monkeypatch.setattr(RingBuffer, "evicted", counted_evicted)


@pytest.mark.slow
def test_random_clock_faults_lose_no_sample_uncounted_and_hold_within_bounds(monkeypatch):
    # two streams pushed in random chunks (1 to 300 samples) with random clock faults:
    # steps back and forward (0.3 s to 1000 s), switches to ms and back, NaN stamps and
    # re-sends. After every push, each sample pushed is taken, refused (counted by reason)
    # or held (held_samples); every hold stays within buffer_samples (the units hold: one
    # chunk more); and 70 s of both streams live afterwards leave nothing held
    tally = _Taken(monkeypatch)
    live = {"imu": (_imu, 0.02), "wheels": (_wheels, 0.1)}
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    for seed in range(8):
        tally.taken.clear()
        tally.pushed_out.clear()
        rng = np.random.default_rng(seed)
        bound = int(rng.choice([16, 64, 256]))
        intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=bound),
                              DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))
        decisions = intake._decisions
        own = {"imu": 0.0, "wheels": 0.0}
        scale = {"imu": 1.0, "wheels": 1.0}
        pushed = {"imu": 0, "wheels": 0}

        def push(stream, t_s, values):
            pushed[stream] += len(t_s)
            intake.ingest(stream, t_s + intake.clocks[stream].offset_s, values)
            newest = intake.newest()
            if decisions.next_t is None and newest > -np.inf:
                decisions.next_t = newest
            elif decisions.next_t is not None and newest > decisions.next_t:
                decisions.advance(int((newest - decisions.next_t) // 0.5) + 1, 0.5)
            for s in streams:
                clock, key = intake.clocks[s], len(streams[s])
                refused = sum(n for (r, _), n in intake.refused.items() if r == s)
                held = sum(clock.held().values())
                accounted = (tally.taken.get(key, 0) + refused
                             - tally.pushed_out.get(key, 0) + held)
                # (>: a restart of one clock takes again what its old buffer had taken)
                assert accounted >= pushed[s], (seed, s, pushed[s], accounted)
                assert len(clock.late) <= bound and len(clock.unjudged) <= bound + 300
                assert clock.ahead is None or len(clock.ahead) <= bound

        for _ in range(300):
            stream = "imu" if rng.random() < 0.6 else "wheels"
            values, step = live[stream]
            n = int(rng.choice([1, 1, 1, 3, 10, 50, 300]))
            fault = rng.random()
            if fault < 0.05:
                own[stream] -= rng.choice([0.3, 2.0, 8.0, 100.0])
            elif fault < 0.10:
                own[stream] += rng.choice([0.3, 3.0, 8.0, 70.0, 1000.0])
            elif fault < 0.12:
                scale[stream] = 1000.0 if scale[stream] == 1.0 else 1.0
            t = own[stream] + step * np.arange(n)
            own[stream] = t[-1] + step
            stamps, v = t * scale[stream], values(t)
            if rng.random() < 0.03:
                stamps[rng.integers(n)] = np.nan
            if rng.random() < 0.03 and len(intake.buffers[stream]):   # a re-send
                bt, v = intake.buffers[stream].since(intake.buffers[stream].last_t - 1.0)
                stamps = bt - intake.clocks[stream].offset_s
            push(stream, stamps, v)
        scale = {"imu": 1.0, "wheels": 1.0}
        for _ in range(700):   # both live, interleaved: 70 s
            for stream, n in (("imu", 5), ("wheels", 1)):
                values, step = live[stream]
                t = own[stream] + step * np.arange(n)
                own[stream] = t[-1] + step
                push(stream, t, values(t))
        assert not any(c.held() for c in intake.clocks.values()), seed


def test_samples_a_restart_of_one_clock_uses_are_no_longer_counted_refused():
    # wheels (10 Hz) and IMU (50 Hz) to 9.9 s; the wheel clock goes back to 0 s and runs
    # 7 s while the IMU goes on live: its samples are refused as late until they run 5 s
    # (clock_restart_s), then put on the IMU's clock (one restart, offset 10.01 s: half a
    # wheel step after the IMU's newest when the run began) and taken. None of the 70 stays
    # counted as refused (mutant: the 51 held ones still counted time_not_increasing)
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=1024),
                          DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))
    t = 0.1 * np.arange(100)
    intake.ingest("wheels", t, _wheels(t))
    t_imu = 0.02 * np.arange(496)
    intake.ingest("imu", t_imu, _imu(t_imu))
    k = 496
    for j in range(70):
        t_imu = 0.02 * (k + np.arange(5))
        k += 5
        intake.ingest("imu", t_imu, _imu(t_imu))
        t = np.array([0.1 * j])     # pushed as the service does: with the stream's offset
        intake.ingest("wheels", t + intake.clocks["wheels"].offset_s, _wheels(t + 100.0))
    assert intake.restarts == 1 and not intake.refused
    assert intake.clocks["wheels"].offset_s == pytest.approx(10.01)
    assert len(intake.buffers["wheels"]) == 70
    np.testing.assert_allclose(intake.buffers["wheels"].times()[[0, -1]], [10.01, 16.91])


def _two_streams() -> StreamIntake:
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    return StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=1024),
                        DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))


def test_a_stamp_refused_before_its_streams_first_sample_is_flagged_at_the_services_now():
    # the IMU to 5 s; the wheels' first push opens with a NaN stamp: refused, counted and
    # flagged at the service's newest time (5 s), the stream having none of its own
    # (mutant: noted at the empty buffer's -inf, a span no window ever holds)
    intake = _two_streams()
    t_imu = 0.02 * np.arange(251)
    intake.ingest("imu", t_imu, _imu(t_imu))
    intake.ingest("wheels", _stamps(np.nan, 5.1), _wheels(_stamps(0.0, 5.1)))
    assert intake.refused == {("wheels", "non_finite"): 1}
    assert list(intake.events["wheels"]) == [(5.0, 5.0, "non_finite")]
    assert intake.buffers["wheels"].last_t == 5.1 and not intake.unplaced


def test_streams_whose_clocks_restart_together_some_seconds_apart_are_taken_as_they_are():
    # both streams to 19.9 s; both clocks restart, the IMU from 0 s and the wheels from
    # 12 s (a lag under max_backlog_s): one restart of every clock, and the wheels, which
    # sent on the new clock, are no stream silent through it (its shorter first step):
    # taken as they are (mutant marking every stream with samples as rejoining: the 70
    # wheel samples held as on another clock)
    intake = _two_streams()
    for j in range(200):
        t_imu = 0.1 * j + 0.02 * np.arange(5)
        intake.ingest("imu", t_imu, _imu(t_imu))
        t = _stamps(0.1 * j)
        intake.ingest("wheels", t, _wheels(t))
    for j in range(70):
        t_imu = 0.1 * j + 0.02 * np.arange(5)
        intake.ingest("imu", t_imu, _imu(t_imu + 50.0))
        t = _stamps(12.0 + 0.1 * j)
        intake.ingest("wheels", t, _wheels(t + 50.0))
    assert intake.restarts == 1 and not intake.refused
    assert not any(c.held() or c.rejoining for c in intake.clocks.values())
    assert len(intake.buffers["wheels"]) == 70 and intake.buffers["wheels"].first_t == 12.0
    assert len(intake.buffers["imu"]) == 350
