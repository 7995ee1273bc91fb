"""Review tests of :func:`terrain.serving.replay.interleave`: every sample once, in
timestamp order, ties between streams in the order the streams are named, chunks never
crossing a stream change."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.run import TIME, Run
from terrain.serving.replay import _overlap_s, interleave


def _run(times: dict[str, np.ndarray]) -> Run:
    streams = {name: pd.DataFrame({TIME: t, "x": np.arange(len(t)) + 1000.0 * k})
               for k, (name, t) in enumerate(times.items())}
    return Run("test/ICE/00", "test", "ICE", streams)


def _events(run, streams, max_chunk):
    return [(s, t.tolist(), v[:, 0].tolist()) for s, t, v in
            interleave(run, streams, max_chunk)]


@pytest.mark.parametrize("max_chunk", [1, 2, 3, 7, 1000])
def test_interleave_yields_every_sample_once_in_time_order_with_ties_in_stream_order(
        max_chunk):
    # 200 samples per stream on a 0.01 s grid and 0.02 s grid: every second stamp of "a"
    # ties one of "b" (large enough for numpy's unstable sort to reorder ties)
    t_a = np.round(np.arange(200) * 0.01, 6)
    t_b = np.round(np.arange(200) * 0.02, 6)
    run = _run({"a": t_a, "b": t_b})
    events = _events(run, ("a", "b"), max_chunk)
    flat = [(s, t, v) for s, ts, vs in events for t, v in zip(ts, vs)]
    # every sample exactly once, with its own value
    for name, t, off in (("a", t_a, 0.0), ("b", t_b, 1000.0)):
        got = [(t_, v) for s, t_, v in flat if s == name]
        assert [g[0] for g in got] == t.tolist()
        assert [g[1] for g in got] == (np.arange(len(t)) + off).tolist()
    stamps = [t for _, t, _ in flat]
    assert stamps == sorted(stamps)
    # a tie: the stream named first comes first
    for i in range(len(flat) - 1):
        if flat[i][1] == flat[i + 1][1]:
            assert (flat[i][0], flat[i + 1][0]) == ("a", "b")
    # chunks hold at most max_chunk samples of one stream, and consecutive chunks of one
    # stream only when the previous one was full or the later one is the run's last sample
    # alone (which ends every run: the service judges staleness from a push's first sample)
    assert all(1 <= len(ts) <= max_chunk for _, ts, _ in events)
    for (s0, ts0, _), (s1, ts1, _) in zip(events, events[1:]):
        assert s0 != s1 or len(ts0) == max_chunk or len(ts1) == 1
    for (s0, ts0, _), (s1, _, _) in zip(events, events[1:] + [(None, [], [])]):
        assert s0 == s1 or len(ts0) == 1


def test_interleave_keeps_the_tail_of_each_run_of_one_stream():
    # three samples of "a", then two of "b", then one of "a": chunks of 2 must give
    # a[0:2], a[2:3], b[0:1], b[1:2] (a run's last sample alone), a[3:4]
    run = _run({"a": np.array([0.0, 0.1, 0.2, 0.5]), "b": np.array([0.3, 0.4])})
    assert _events(run, ("b", "a"), 2) == [
        ("a", [0.0, 0.1], [0.0, 1.0]), ("a", [0.2], [2.0]),
        ("b", [0.3], [1000.0]), ("b", [0.4], [1001.0]), ("a", [0.5], [3.0])]


def test_overlap_is_the_span_every_stream_covers():
    a = pd.DataFrame({TIME: [0.0, 5.0]})
    b = pd.DataFrame({TIME: [1.0, 7.0]})
    assert _overlap_s([a, b]) == 4.0
    assert _overlap_s([a, pd.DataFrame({TIME: [6.0, 9.0]})]) == 0.0
    assert _overlap_s([a, pd.DataFrame({TIME: []})]) == 0.0


@pytest.mark.parametrize("times", [{"a": np.array([])}, {"a": np.array([]), "b": np.array([])},
                                   {"c": np.array([0.0, 1.0])}])
def test_interleave_of_no_sample_of_the_named_streams_yields_nothing(times):
    # streams absent from the run are skipped (docstring): none present, or none holding a
    # sample, is nothing to replay (was numpy's ValueError / an IndexError)
    assert _events(_run(times), ("a", "b"), 4) == []


def test_streams_overlapping_exactly_one_window_are_not_too_short():
    # one window fits in an overlap of exactly window_s (planned_decisions: 1 decision)
    from terrain.serving.replay import RunReplay

    run = _run({"a": np.arange(0.0, 2.001, 0.01)})
    frame = pd.DataFrame({"flags": []})

    def replay(end_s):
        return RunReplay(run, frame, 0, end_s, 2.0, 0.5, 3.0, ("a",), {}, {}, 0, 2.0, end_s)

    assert not replay(2.0).too_short and replay(np.nextafter(2.0, 0)).too_short


def test_a_run_the_service_decides_on_is_not_too_short_where_its_span_rounds_below_a_window(
        wheel_model):
    # srv21's left-alone: 41 wheel samples 0.05 s apart from 0.3 s span 2.3 - 0.3 =
    # 1.9999999999999998 s; the service decides once (t 0.3 + 2.0 <= 2.3), the replay
    # refused the run as overlapping for less than one window; from 0 s it took it
    from terrain.serving import CataloguePeakTargets, StreamConfig, StreamService
    from terrain.serving.replay import replay_recorded

    def wheel_service():
        return StreamService(wheel_model, CataloguePeakTargets(wheel_model.classes),
                             StreamConfig(hop_s=0.5))

    for t0 in (0.0, 0.3):
        t = t0 + np.arange(41) * 0.05
        wheels = pd.DataFrame({TIME: t, "vel_l": 0.3, "vel_r": 0.3, "cur_l": 2.0,
                               "cur_r": 2.0})
        run = Run("probe/SNOW/0", "probe", "SNOW", {"wheels": wheels})
        replay = replay_recorded(wheel_service(), run)
        assert len(replay.frame) == 1 and not replay.too_short, t0
        replay.check("probe")
        # one sample fewer: no decision, and refused as too short
        shorter = Run("probe/SNOW/0", "probe", "SNOW", {"wheels": wheels.iloc[:-1]})
        short = replay_recorded(wheel_service(), shorter)
        assert len(short.frame) == 0 and short.too_short
