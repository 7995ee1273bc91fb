"""Property-based tests (hypothesis) of the streaming service, second pass: two streams on
their own rates, a time shift of every clock, the slip targets of the table, the ``stale``
and ``low_confidence`` rules as documented, typed errors of bad pushes, bounded memory.

A three-class stand-in model (softmax of the windows' mean ``vel_l``, mean ``vel_r`` and 0)
on an 8 Hz clock (a period of 1/8 s, so stamps on multiples of 1/64 s and shifts by whole
seconds are exact in float64) keeps every example fast; no fitted model is needed.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from features.windows import WindowConfig
from terrain.errors import ConfigError, DataFormatError, MissingColumnError
from terrain.serving import (CataloguePeakTargets, SmoothingConfig, StreamConfig,
                             StreamModel, StreamService, TableTargets)
from terrain.serving.buffers import RingBuffer
from terrain.serving.intake import MAX_EVENTS
from terrain.serving.smoothing import PROBA_FLOOR, ForwardFilter

FAST = settings(max_examples=40, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
CLASSES = ("ASPHALT", "SNOW", "ICE")
TWO = {"left": ("vel_l",), "right": ("vel_r",)}
ONE = {"wheels": ("vel_l", "vel_r")}


class _Softmax:
    """Three-class stand-in: softmax of 3 x (mean vel_l, mean vel_r, 0) over the window."""

    classes_ = np.array(CLASSES)

    def predict_proba(self, X):
        z = 3.0 * np.column_stack([X[:, 0].mean(axis=1), X[:, 1].mean(axis=1),
                                   np.zeros(len(X))])
        e = np.exp(z - z.max(axis=1, keepdims=True))
        return e / e.sum(axis=1, keepdims=True)


MODEL = StreamModel(_Softmax(), ("vel_l", "vel_r"), WindowConfig(window_s=1.0, rate_hz=8.0),
                    CLASSES)


def _service(streams=TWO, smoothing=SmoothingConfig(), offsets=None, min_confidence=0.5,
             buffer_samples=4096):
    return StreamService(MODEL, TableTargets(CLASSES),
                         StreamConfig(hop_s=0.5, streams=streams, smoothing=smoothing,
                                      clock_offsets_s=offsets or {},
                                      min_confidence=min_confidence,
                                      buffer_samples=buffer_samples))


# stamps on multiples of 1/64 s (exact sums); steps of ~10 Hz and ~7 Hz with a rare dropout
_STEP_L = st.sampled_from([6, 6, 7, 7, 7, 8]).map(lambda k: k / 64)
_STEP_R = st.sampled_from([8, 9, 9, 10, 10, 11, 40]).map(lambda k: k / 64)
_V = st.floats(-1.5, 1.5, allow_nan=False)


@st.composite
def _two_streams(draw, min_size=20, max_size=90):
    """``[(stream, t_s, value), ...]`` in arrival (time) order, left before right at a tie,
    plus the two streams' own arrays."""
    out = {}
    for name, step in (("left", _STEP_L), ("right", _STEP_R)):
        n = draw(st.integers(min_size, max_size))
        t = 100.0 + np.cumsum(draw(st.lists(step, min_size=n, max_size=n)))
        v = np.array(draw(st.lists(_V, min_size=n, max_size=n)))
        out[name] = (t, v)
    events = sorted([(t, 0 if s == "left" else 1, s, i) for s, (ts, _) in out.items()
                     for i, t in enumerate(ts.tolist())])
    return [(s, i) for _, _, s, i in events], out


def _runs(order):
    """Consecutive samples of one stream in arrival order: ``[(stream, [i, ...]), ...]``."""
    runs = []
    for s, i in order:
        if runs and runs[-1][0] == s:
            runs[-1][1].append(i)
        else:
            runs.append((s, [i]))
    return runs


def _push_chunks(svc, streams, chunks, shift=0.0):
    """Push ``[(stream, [i, ...]), ...]``; returns the decisions and, per decision, the
    newest stamp pushed of each stream when it came (service clock)."""
    out, newest, at = [], {s: -np.inf for s in streams}, []
    for s, idx in chunks:
        t, v = streams[s]
        got = svc.push(s, t[idx] + shift, {MODEL.channels[s == "right"]: v[idx]})
        newest[s] = float(t[idx][-1]) + shift
        out += got
        at += [dict(newest)] * len(got)
    return out, at


def _key(decisions, shift=0.0):
    return [(d.t_s - shift, d.terrain, d.flags, round(d.confidence, 9),
             tuple(np.round(d.proba, 9)), d.target_slip_traction, d.target_slip_braking,
             d.target_slip_steady, d.window_age_s) for d in decisions]


@st.composite
def _chunked(draw, order):
    """The runs of ``order`` cut into chunks of random sizes, the last sample of each run
    alone (as :func:`terrain.serving.replay.interleave` gives them: a lagging stream is
    judged stale from the first sample of the newest push)."""
    chunks = []
    for s, idx in _runs(order):
        body, i = idx[:-1], 0
        while i < len(body):
            k = draw(st.integers(1, 12))
            chunks.append((s, body[i:i + k]))
            i += k
        chunks.append((s, idx[-1:]))
    return chunks


# ---------------------------------------------------------------- chunking, two streams

@pytest.mark.slow
@FAST
@given(data=st.data(), streams=_two_streams(),
       smoothing=st.sampled_from([SmoothingConfig(), SmoothingConfig(dwell_s=None),
                                  SmoothingConfig(hysteresis=0.2)]))
def test_two_streams_decide_the_same_one_by_one_and_in_chunks(data, streams, smoothing):
    """Two streams at their own rates, interleaved in time order: pushed sample by sample
    or each run of one stream in chunks of any size (its last sample alone), the service
    gives the same decisions, counts and holds."""
    order, arrays = streams
    one, chunked = _service(smoothing=smoothing), _service(smoothing=smoothing)
    a, _ = _push_chunks(one, arrays, [(s, [i]) for s, i in order])
    b, _ = _push_chunks(chunked, arrays, data.draw(_chunked(order)))
    assert _key(a) == _key(b)
    assert one.refused_samples == chunked.refused_samples
    assert one.held_samples == chunked.held_samples


# ---------------------------------------------------------------- time shift

@pytest.mark.slow
@FAST
@given(streams=_two_streams(), shift=st.sampled_from([-64.0, 1.0, 37.0, 4096.0]))
def test_a_shift_of_every_clock_shifts_the_decision_times_and_nothing_else(streams, shift):
    """Every stamp of every stream moved by the same whole number of seconds: the decisions
    are those of the unshifted streams with ``t_s`` moved by it (terrain, probabilities,
    flags, targets and window ages unchanged); the same shift given as the streams'
    ``clock_offsets_s`` gives them too."""
    order, arrays = streams
    per_sample = [(s, [i]) for s, i in order]
    base, _ = _push_chunks(_service(), arrays, per_sample)
    moved, _ = _push_chunks(_service(), arrays, per_sample, shift)
    offset, _ = _push_chunks(_service(offsets={"left": shift, "right": shift}), arrays,
                             per_sample)
    assert _key(moved, shift) == _key(base)
    assert _key(offset, shift) == _key(base)


# ---------------------------------------------------------------- flags and targets

@pytest.mark.slow
@FAST
@given(streams=_two_streams(), data=st.data(),
       min_conf=st.sampled_from([0.5, 0.6, 0.9]),
       smoothing=st.sampled_from([SmoothingConfig(), SmoothingConfig(dwell_s=None),
                                  SmoothingConfig(hysteresis=0.3)]))
def test_stale_low_confidence_and_targets_follow_the_documented_rules(
        streams, data, min_conf, smoothing):
    """For clean samples (no rule refuses any), per decision:

    * ``stale`` iff a stream's newest sample, when the decision came, is more than
      ``stale_s`` before ``t_s``;
    * ``low_confidence`` iff a terrain is decided below ``min_confidence``;
    * the targets are the desired-slip table's entry for the decided terrain when it is
      trusted (decided, at or above ``min_confidence``, not stale), else its conservative
      fallback (the smallest traction and steady targets, the braking one nearest 0);
    * the confidence is the decided class's probability, the probabilities a distribution.
    """
    order, arrays = streams
    svc = _service(smoothing=smoothing, min_confidence=min_conf)
    got, newest = _push_chunks(svc, arrays, data.draw(_chunked(order)))
    table = svc.targets.table
    fb = table.fallback
    entries = list(table.entries.values())
    assert fb.traction == min(e.traction for e in entries)
    assert fb.steady == min(e.steady for e in entries)
    assert abs(fb.braking) == min(abs(e.braking) for e in entries)
    for d, last in zip(got, newest):
        flags = set(d.flags.split("|")) - {""}
        stale = any(d.t_s - t > svc.config.stale_s for t in last.values())
        assert ("stale" in flags) == stale
        low = d.terrain is not None and d.confidence < min_conf
        assert ("low_confidence" in flags) == low
        assert np.all((d.proba >= 0) & (d.proba <= 1)) and d.proba.sum() == pytest.approx(1)
        if d.terrain is None:
            assert d.confidence == 0.0
        else:
            assert d.confidence == d.proba[CLASSES.index(d.terrain)]
        want = table.entries[d.terrain] if (d.terrain is not None and not low
                                            and not stale) else fb
        assert (d.target_slip_traction, d.target_slip_braking, d.target_slip_steady) == \
            (want.traction, want.braking, want.steady)


@pytest.mark.slow
@FAST
@given(streams=_two_streams(), hyst=st.floats(0.05, 0.6))
def test_the_decided_terrain_changes_only_past_the_hysteresis_margin(streams, hyst):
    """With a hysteresis margin the decided terrain changes from one decision to the next
    only when the new one's probability exceeds the old one's by more than the margin (an
    unclassified window, a gap, changes nothing: the filter only predicts)."""
    order, arrays = streams
    for dwell in (None, 10.0):
        svc = _service(smoothing=SmoothingConfig(dwell_s=dwell, hysteresis=hyst))
        got, _ = _push_chunks(svc, arrays, [(s, [i]) for s, i in order])
        for before, d in zip(got, got[1:]):
            if before.terrain is not None and d.terrain != before.terrain:
                new, old = CLASSES.index(d.terrain), CLASSES.index(before.terrain)
                assert d.proba[new] > d.proba[old] + hyst


@pytest.mark.slow
@settings(FAST, max_examples=10)
@given(streams=_two_streams(max_size=50), data=st.data())
def test_the_value_container_of_a_push_changes_no_decision(streams, data):
    """The same chunks pushed as ``{channel: array}``, an ``(n, 1)`` array, a 1-D column
    or a DataFrame give the same decisions."""
    order, arrays = streams
    chunks = data.draw(_chunked(order))
    got = []
    for form in ("dict", "matrix", "column", "frame"):
        svc = _service()
        out = []
        for s, idx in chunks:
            t, v = arrays[s]
            ch = MODEL.channels[s == "right"]
            values = {"dict": {ch: v[idx]}, "matrix": v[idx][:, None], "column": v[idx],
                      "frame": pd.DataFrame({ch: v[idx]})}[form]
            out += svc.push(s, t[idx], values)
        got.append(_key(out))
    assert got[1] == got[0] and got[2] == got[0] and got[3] == got[0]


# ---------------------------------------------------------------- memory

@pytest.mark.slow
@settings(FAST, max_examples=8)
@given(seed=st.integers(0, 2**31 - 1), capacity=st.sampled_from([24, 64]))
def test_memory_stays_bounded_on_a_long_faulty_stream(seed, capacity):
    """A long stream with non-finite and out-of-range samples, late and re-sent ones:
    every buffer holds at most ``buffer_samples`` (its arrays never grow), the rejection
    log at most ``MAX_EVENTS`` spans per stream, and every sample pushed is accounted for
    (buffered, refused, held or pushed out)."""
    rng = np.random.default_rng(seed)
    svc = _service(streams=ONE, buffer_samples=capacity)
    buf = svc._intake.buffers["wheels"]
    nbytes = buf._t.nbytes + buf._v.nbytes
    t, pushed = 100.0, 0
    for k in range(2000):
        t += rng.choice([0.1, 0.1, 0.1, 0.125])
        v = rng.uniform(-1, 1, 2)
        if k % 7 == 0:
            v[0] = np.nan
        elif k % 11 == 0:
            v[1] = 9.0
        stamp = t - 0.35 if k % 13 == 0 else t   # a late sample now and then
        svc.push("wheels", stamp, v)
        pushed += 1
    buf = svc._intake.buffers["wheels"]
    assert len(buf) <= capacity and buf._t.nbytes + buf._v.nbytes == nbytes
    assert all(len(ev) <= MAX_EVENTS for ev in svc._intake.events.values())
    assert len(buf) + sum(svc.refused_samples.values()) + sum(svc.held_samples.values()) \
        <= pushed
    assert {r for _, r in svc.refused_samples} <= {"non_finite", "implausible_value",
                                                   "time_not_increasing", "duplicate"}


# ---------------------------------------------------------------- typed errors of a push

_GOOD_T = np.array([1.0, 1.1])
_GOOD_V = np.zeros((2, 2))


@pytest.mark.parametrize("stream, t_s, values, error, column", [
    ("imu", _GOOD_T, _GOOD_V, ConfigError, None),            # not configured
    (3, _GOOD_T, _GOOD_V, ConfigError, None),                # not a name
    ("wheels", np.array([True, False]), _GOOD_V, DataFormatError, "t_s"),
    ("wheels", _GOOD_T, np.zeros((2, 2), dtype=bool), DataFormatError, "values"),
    ("wheels", _GOOD_T, np.zeros((2, 3)), DataFormatError, "values"),
    ("wheels", _GOOD_T, np.zeros((2, 2)).T[:1], DataFormatError, "values"),
    ("wheels", _GOOD_T, {"vel_l": [0.0, 0.0]}, MissingColumnError, "vel_r"),
    ("wheels", _GOOD_T, {"vel_l": [0.0, 0.0], "vel_r": [0.0]}, DataFormatError, "vel_r"),
    ("wheels", _GOOD_T, {"vel_l": [0.0, 0.0], "vel_r": [True, False]}, DataFormatError,
     "vel_r"),
    ("wheels", ["1.0", "1.1"], _GOOD_V, DataFormatError, "t_s"),
    ("wheels", np.array([1, 2], dtype="timedelta64[ms]"), _GOOD_V, DataFormatError, "t_s"),
    ("wheels", np.ones((2, 1)), _GOOD_V, DataFormatError, "t_s"),
])
def test_a_bad_push_raises_a_typed_error_naming_the_stream_and_field(stream, t_s, values,
                                                                     error, column):
    svc = _service(streams=ONE)
    with pytest.raises(error) as info:
        svc.push(stream, t_s, values)
    assert repr(stream)[:20] in str(info.value)
    if column is not None:
        assert info.value.column == column and info.value.path == f"stream {stream}"
    assert not svc.refused_samples and not len(svc._intake.buffers["wheels"])


def test_nan_and_backward_stamps_are_refused_and_counted_not_raised():
    """A NaN stamp and a stamp going back are samples the rules refuse (counted by stream
    and reason), not errors: the robot's loop goes on."""
    svc = _service(streams=ONE)
    svc.push("wheels", np.array([1.0, 1.1, math.nan, 1.05, 1.2]), np.zeros((5, 2)))
    assert svc.refused_samples == {("wheels", "non_finite"): 1,
                                   ("wheels", "time_not_increasing"): 1}
    np.testing.assert_array_equal(svc._intake.buffers["wheels"].times(), [1.0, 1.1, 1.2])


# ---------------------------------------------------------------- boundaries (hand mutants)

class _Const:
    """Stand-in answering the same probabilities ``q`` for every window."""

    classes_ = np.array(CLASSES)

    def __init__(self, q):
        self.q = np.asarray(q, dtype=float)

    def predict_proba(self, X):
        return np.tile(self.q, (len(X), 1))


def _const_service(q, streams=ONE, **kw):
    model = StreamModel(_Const(q), ("vel_l", "vel_r"), WindowConfig(window_s=1.0, rate_hz=8.0),
                        CLASSES)
    return StreamService(model, TableTargets(CLASSES),
                         StreamConfig(hop_s=0.5, streams=streams, **kw))


def test_a_confidence_equal_to_min_confidence_is_trusted():
    """A decision at exactly ``min_confidence`` is trusted (the table's rule,
    ``confidence_is_trusted``): no ``low_confidence``, the terrain's own targets. (Mutant
    ``conf > min_confidence`` survived every test of the area.)"""
    svc = _const_service([0.5, 0.3, 0.2], smoothing=SmoothingConfig(dwell_s=None))
    t = 100.0 + np.arange(40) / 8
    got = svc.push("wheels", t, np.zeros((40, 2)))
    assert got and all(d.terrain == "ASPHALT" and d.confidence == 0.5 for d in got)
    asphalt = svc.targets.table.entries["ASPHALT"]
    assert all(d.flags == "" and d.target_slip_traction == asphalt.traction for d in got)


def test_a_rejection_flags_the_windows_holding_it_from_its_first_edge_on():
    """A refused sample flags exactly the windows ``[t - window_s, t)`` holding it: one at
    a window's start does, one at its end does not, and two rejections 1.5 windows apart
    are two spans (a window between them is clean). (Mutants ``last > t_lo`` in
    ``_decide`` and a merge of spans up to two windows apart in ``StreamIntake.note``.)"""
    t = 100.0 + np.arange(80) / 8
    v = np.zeros((80, 2))
    v[t == 102.0, 0] = np.nan
    v[t == 103.5, 0] = np.nan
    svc = _const_service([0.9, 0.05, 0.05])
    got = {d.t_s: d.flags for d in svc.push("wheels", t, v)}
    assert got[102.0] == ""                      # [101, 102): the rejection at its end
    assert got[102.5] == got[103.0] == "non_finite"    # [102, 103) holds it at its start
    assert got[103.5] == ""                      # [102.5, 103.5): between the two
    assert got[104.0] == got[104.5] == "non_finite"


def test_a_lagging_stream_is_waited_for_until_another_began_stale_s_past_the_decision():
    """A decision waits for a silent stream until another stream's newest push begins
    exactly ``stale_s`` past it, not one sample later. (Mutant ``arrived > next_t +
    stale_s``.)"""
    svc = _service()
    emitted = {}
    for k in range(60):
        s = 100.0 + k / 8
        for stream, ch in (("left", "vel_l"), ("right", "vel_r")):
            if stream == "right" and s > 103.0:
                continue     # the right stream falls silent after 103 s
            for d in svc.push(stream, s, {ch: 0.0}):
                emitted[d.t_s] = s
    late = {t: s for t, s in emitted.items() if t > 103.0}
    assert late and all(s == t + svc.config.stale_s for t, s in late.items())


def test_a_silent_stretch_skips_every_decision_due_over_max_backlog_before_the_newest():
    """After a 90 s silence, the decisions whose window holds no sample and that are due
    more than ``max_backlog_s`` before the newest sample are skipped and counted, every
    one of them (the first emitted after the silence is the first within the backlog).
    (Mutants: ``floor`` for ``ceil`` in ``_silent_hops``, ``skipped += 1`` per skip.)"""
    svc = _service(streams=ONE)
    t = np.r_[100.0 + np.arange(81) / 8, 200.25 + np.arange(20) / 8]
    got = []
    for s in t:
        got += svc.push("wheels", s, np.zeros(2))
    times = np.array([d.t_s for d in got])
    # the samples after the 90 s step wait for 8 steps (rule timestamp_units): the
    # silence's decisions are due once the one at 201.25 s is taken
    silent = times[(times > 111.0) & (times < 200.0)]
    assert silent.min() == 141.5 >= 201.25 - svc.config.max_backlog_s
    assert svc.skipped_decisions == len(np.arange(111.5, 141.25, 0.5)) == 60


def test_a_reset_restarts_the_filter_at_exactly_reset_windows_confident_windows():
    """The switch reset restarts the filter from the floored last window at the
    ``reset_windows``-th confident window naming another class, not one later, and not by
    the hysteresis margin (0.99 here). (Mutants ``streak > reset_windows``, hysteresis
    halved.)"""
    f = ForwardFilter(3, 0.5, SmoothingConfig(hysteresis=0.99, reset_confidence=0.9,
                                              reset_windows=2))
    for _ in range(5):
        f.update(np.array([1.0, 0.0, 0.0]))
    q = np.array([0.0, 0.95, 0.05])
    assert f.update(q)[0] == 0
    decided, p = f.update(q)
    assert decided == 1
    floored = np.maximum(q, PROBA_FLOOR)
    np.testing.assert_allclose(p, floored / floored.sum())


def test_evicted_counts_a_held_sample_at_exactly_since():
    """A sample at exactly ``since_s`` is still needed: pushed out, it counts. (Mutant
    ``first_t > since_s``.)"""
    buf = RingBuffer(1, 2)
    buf.append(np.array([1.0]), np.zeros((1, 1)))
    buf.append(np.array([2.0]), np.zeros((1, 1)))
    assert buf.evicted(np.array([3.0]), 1.0) == 1
    assert buf.evicted(np.array([3.0]), 1.5) == 0


def test_a_provider_threshold_just_above_the_services_is_refused():
    """A provider threshold of 0.505 beside the service's 0.5 would give fallback targets
    to unflagged decisions: refused; an equal one is taken. (Mutant: a 0.01 tolerance.)"""
    model = MODEL
    with pytest.raises(ConfigError, match="min_confidence"):
        StreamService(model, CataloguePeakTargets(CLASSES, min_confidence=0.505),
                      StreamConfig(streams=ONE, min_confidence=0.5))
    StreamService(model, CataloguePeakTargets(CLASSES, min_confidence=0.5),
                  StreamConfig(streams=ONE, min_confidence=0.5))


def test_the_first_decision_is_one_window_after_the_latest_stream_starts():
    """Two clean streams starting 0.5 s apart: the first decision is due one window after
    the later one starts (the first window both cover), and no decision is ``short``.
    (Mutant: placed after the earlier one's start, a first decision ``short``.)"""
    svc = _const_service([0.9, 0.05, 0.05], streams=TWO)
    got = []
    for k in range(40):
        got += svc.push("left", 100.0 + k / 8, {"vel_l": 0.0})
        got += svc.push("right", 100.5 + k / 8, {"vel_r": 0.0})
    assert got[0].t_s == 100.5 + MODEL.window.window_s
    assert all(d.flags == "" for d in got)


def test_a_stream_slower_than_the_look_back_margin_fills_every_window():
    """A stream at 2.7 Hz (0.375 s steps, longer than the window's 2-period look-back of
    0.25 s on the model's 8 Hz clock) still fills every window: every decision clean and
    fresh, from one window after its first sample."""
    svc = _const_service([0.9, 0.05, 0.05])
    t = 100 + np.arange(40) * 0.375
    got = svc.push("wheels", t, np.zeros((40, 2)))
    assert len(got) == 28 and got[0].t_s == 101.0
    assert all(d.flags == "" and d.window_age_s == 0.0 for d in got)


def test_chunks_longer_than_stale_s_make_no_early_decision():
    """Two streams pushed in turn in 5 s chunks (``stale_s`` 1 s) give the decisions of
    the sample-by-sample replay, none stale or short: a stream's staleness is judged from
    the first sample of its newest push. (Mutant: judged from its last sample.)"""
    one, chunked = (_const_service([0.9, 0.05, 0.05], streams=TWO) for _ in range(2))
    t = 100 + np.arange(120) / 8
    a, b = [], []
    for k in range(120):
        a += one.push("left", t[k], {"vel_l": 0.0}) + one.push("right", t[k], {"vel_r": 0.0})
    for k in range(0, 120, 40):
        b += chunked.push("left", t[k:k + 40], {"vel_l": np.zeros(40)})
        b += chunked.push("right", t[k:k + 40], {"vel_r": np.zeros(40)})
    assert _key(b) == _key(a) and len(a) == 28
    assert all(d.flags == "" for d in b)


def test_a_stamp_equal_to_the_one_before_is_not_increasing():
    """A stamp equal to the stream's newest, or to the one before it in the chunk, is
    refused (strictly increasing, the readers' ``TimestampError``); with other values it
    is no re-send: ``time_not_increasing``, and the buffer stays strictly increasing.
    (Mutant ``>=`` in ``time_increasing``.)"""
    from terrain.serving.rules import time_increasing
    keep, _ = time_increasing(("x",), np.array([1.0, 1.0, 2.0]), np.zeros((3, 1)), -np.inf)
    np.testing.assert_array_equal(keep, [True, False, True])
    assert not time_increasing(("x",), np.array([2.0]), np.zeros((1, 1)), 2.0)[0].any()
    svc = _service(streams=ONE)
    svc.push("wheels", np.array([1.0, 1.125]), np.zeros((2, 2)))
    svc.push("wheels", 1.125, np.ones(2))
    assert svc.refused_samples == {("wheels", "time_not_increasing"): 1}
    np.testing.assert_array_equal(svc._intake.buffers["wheels"].times(), [1.0, 1.125])


def test_rejections_of_alternating_reasons_each_flag_the_windows_holding_them():
    """Rejections of two reasons in turn (a NaN at 102.0 s, a 9 m/s speed at 102.25 s, a
    NaN at 102.5 s) are three spans of the bounded log: the window [101.5, 102.5) holds
    the first two and carries both flags, though the third came before it was decided.
    (Mutant: a log of 2 spans, ``MAX_EVENTS = 2``.)"""
    t = 100.0 + np.arange(40) / 8
    v = np.zeros((40, 2))
    v[t == 102.0, 0] = np.nan
    v[t == 102.25, 1] = 9.0
    v[t == 102.5, 0] = np.nan
    svc = _const_service([0.9, 0.05, 0.05])
    got = {}
    for k in range(40):
        got.update({d.t_s: d.flags for d in svc.push("wheels", t[k], v[k])})
    assert got[102.5] == "implausible_value|non_finite"
    assert got[102.0] == ""


# ---------------------------------------------------------------- defects found

@pytest.mark.parametrize("channels", [5, None, 2.5, True])
def test_stream_channels_that_are_not_a_sequence_are_a_config_error_naming_the_stream(
        channels):
    """``StreamConfig(streams={"wheels": 5})`` raised Python's own ``TypeError: 'int'
    object is not iterable`` (and ``None`` likewise), where the docstring promises a
    ``ConfigError`` for streams that do not map names to channel names."""
    with pytest.raises(ConfigError, match="wheels"):
        StreamConfig(streams={"wheels": channels})


def test_rules_without_time_increasing_still_keep_the_buffers_in_time_order():
    """A robot's own rules in place of the defaults (``rules=(finite_values,)``) let a
    chunk going back in time into the buffer: after samples to 103.625 s, a push of 100.5
    and 100.6 s left the buffer ``[..., 103.5, 103.625, 100.5, 100.6, 103.9]``, unsorted,
    with nothing refused (every later window read by binary search on it). The buffers
    need increasing time, so the service applies ``time_increasing`` whatever the rules:
    the two samples are refused and counted as ``time_not_increasing`` (a NaN stamp after
    them as ``non_finite`` by the robot's rule)."""
    from terrain.serving.rules import finite_values
    svc = StreamService(MODEL, TableTargets(CLASSES), StreamConfig(streams=ONE),
                        rules=(finite_values,))
    t = 100 + np.arange(30) / 8
    svc.push("wheels", t, np.zeros((30, 2)))
    svc.push("wheels", np.array([100.5, 100.6]), np.ones((2, 2)))
    svc.push("wheels", np.array([103.9, math.nan]), np.zeros((2, 2)))
    times = svc._intake.buffers["wheels"].times()
    assert np.all(np.diff(times) > 0) and times[-1] == 103.9
    assert svc.refused_samples == {("wheels", "time_not_increasing"): 2,
                                   ("wheels", "non_finite"): 1}


def test_a_refused_last_sample_pushed_alone_leaves_no_decision_undecided():
    """Found by the chunking property with refused samples: the right stream outlasts the
    left one by 7 s and is pushed as :func:`terrain.serving.replay.interleave` gives it
    (one chunk, then its last sample alone, so that the decisions due sample by sample
    come); when that last sample is refused (a NaN value), the stream's newest push is
    still the chunk, whose first sample (103.125 s) says how far it had reached: 5
    decisions (to 103.0 s) where the same samples one by one give 16 (to 108.5 s). The
    served model replays a request in chunks of 32 (``replay_run(max_chunk=32)``). A
    strict xfail from svc17 to stop 91; a push refused whole for its values now marks the
    stream's kept samples as arrived (``RingBuffer.mark_arrived``)."""
    t_left, t_right = 100 + np.arange(25) / 8, 100 + np.arange(81) / 8
    v_right = np.zeros(81)
    v_right[-1] = np.nan
    arrays = {"left": (t_left, np.zeros(25)), "right": (t_right, v_right)}
    order = [(s, i) for _, _, s, i in sorted(
        (t, s == "right", s, i) for s, (ts, _) in arrays.items()
        for i, t in enumerate(ts.tolist()))]
    one, chunked = (_const_service([0.9, 0.05, 0.05], streams=TWO) for _ in range(2))
    a, _ = _push_chunks(one, arrays, [(s, [i]) for s, i in order])
    b, _ = _push_chunks(chunked, arrays,
                        [(s, [i]) for s, i in order if s == "left" or i < 25]
                        + [("right", list(range(25, 80))), ("right", [80])])
    assert len(a) == 16 and a[-1].t_s == 108.5
    assert _key(b) == _key(a)


def test_a_push_refused_whole_marks_the_kept_samples_as_arrived():
    """A chunk then a push refused whole: for a NaN value stamped past the chunk, a stamp
    going back (here a sample sent again), a NaN stamp, or both, the buffer's kept samples
    count as arrived (``batch_first_t`` is its newest sample, as one by one: svc21 found
    one by one giving 2 more decisions than a chunk followed by a NaN-stamped sample)."""
    t = 100 + np.arange(20) / 8
    for stamp, value in [(102.6, math.nan), (101.0, 0.0), (math.nan, 0.0),
                         (101.0, math.nan)]:
        svc = _const_service([0.9, 0.05, 0.05])
        svc.push("wheels", t, np.zeros((20, 2)))
        assert svc._intake.buffers["wheels"].batch_first_t == t[0]
        svc.push("wheels", np.array([stamp]), np.full((1, 2), value))
        buf = svc._intake.buffers["wheels"]
        assert buf.batch_first_t == t[-1], (stamp, value)
        assert buf.last_t == t[-1] and len(buf) == 20
    buf.append(np.array([103.0]), np.zeros((1, 2)))     # the next push sets it again
    assert buf.batch_first_t == 103.0


def test_a_stream_refused_whole_after_its_chunk_ends_its_lag_as_one_by_one():
    """Two streams: the right one's chunk (to 109.875 s) then a NaN sample at 110 s
    alone. The left stream stopped at 103 s; the decisions then run to 108.5 s, where
    the right stream's samples pushed one by one (the last one refused) take them."""
    t_left, t_right = 100 + np.arange(25) / 8, 100 + np.arange(81) / 8
    pushes = [("left", t_left, np.zeros((25, 1))), ("right", t_right[:80], np.zeros((80, 1))),
              ("right", t_right[80:], np.full((1, 1), math.nan))]
    decided = []
    svc = _const_service([0.9, 0.05, 0.05], streams=TWO)
    for stream, t, v in pushes:
        decided += svc.push(stream, t, v)
    assert decided[-1].t_s == 108.5
    without = _const_service([0.9, 0.05, 0.05], streams=TWO)
    assert [d.t_s for d in sum((without.push(*p) for p in pushes[:2]), [])][-1] < 104.0
