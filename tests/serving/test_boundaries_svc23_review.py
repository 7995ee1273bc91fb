"""Review tests (svc23) of the streaming service at its boundaries: a window's edges on
clocks far from 0, counts at the limits of the buffers and thresholds."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
import pytest

from features.windows import WindowConfig
from terrain.serving import StreamConfig, StreamModel, StreamService, TableTargets
from terrain.serving.buffers import RingBuffer

CLASSES = ("ASPHALT", "SNOW", "ICE")
ONE = {"wheels": ("vel_l", "vel_r")}
FAST = settings(max_examples=25, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


class _Recorder:
    """Three-class stand-in that keeps every window it is asked about (uniform answer)."""

    classes_ = np.array(CLASSES)

    def __init__(self) -> None:
        self.windows: list[np.ndarray] = []

    def predict_proba(self, X):
        self.windows.append(np.array(X[0]))
        return np.full((len(X), 3), 1.0 / 3.0)


def _recording_service(rate_hz, window_s, hop_s, **config):
    rec = _Recorder()
    model = StreamModel(rec, ("vel_l", "vel_r"),
                        WindowConfig(window_s=window_s, rate_hz=rate_hz), CLASSES)
    svc = StreamService(model, TableTargets(CLASSES),
                        StreamConfig(hop_s=hop_s, streams=ONE, **config))
    return svc, rec


# (model rate Hz, window s, hop s): the samples come at the model's rate, so every grid
# point of a window is a sample and a decision time is a sample's time
_CLOCKS = [(10.0, 1.0, 0.1), (100.0, 1.0, 0.3), (50.0, 2.0, 0.5), (20.0, 2.0, 0.5)]


@pytest.mark.slow
@FAST
@given(clock=st.sampled_from(_CLOCKS),
       t0=st.sampled_from([0.0, 3.7, 1.7e9, 1.7e9 + 0.123, 2.0 ** 31, 1e10]))
def test_a_window_ends_before_the_sample_at_its_decision_time_on_an_epoch_clock(clock, t0):
    """The window of the decision at ``t`` is ``[t - window_s, t)`` (module docstring):
    its last aligned sample is the one a period before ``t`` and its age 0, on a clock
    from 0 as on an epoch clock. At 1.7e9 s the 1 ns by which a grid point was told from
    ``t`` is below the clock's resolution (2.4e-7 s): a decision time rounded 1 ulp above
    the sample at it read that sample, one grid point late, and the next decision read the
    same window (10 Hz, hop 0.1 s: 186 of 190 decisions differed from a clock from 0)."""
    rate, window_s, hop = clock
    svc, rec = _recording_service(rate, window_s, hop)
    n_win = int(round(window_s * rate))
    n = int(round(6.0 * rate))
    idx = np.arange(n)
    t = t0 + idx / rate
    out = []
    for i in range(n):   # the value of sample i is 0.001 i (m/s): the window says which
        out += svc.push("wheels", t[i:i + 1], np.array([[1e-3 * i, -1e-3 * i]]))
    assert len(out) == len(rec.windows) >= 3
    for d, x in zip(out, rec.windows):
        k = int(round((d.t_s - t0) * rate))     # the sample at the decision time
        read = np.round(x[0] * 1e3).astype(int)
        assert read.tolist() == list(range(k - n_win, k)), (d.t_s - t0, read[[0, -1]])
        assert d.window_age_s == 0.0
        assert d.flags in ("", "low_confidence")


@pytest.mark.slow
@FAST
@given(clock=st.sampled_from(_CLOCKS + [(20.0, 1.0, 0.05)]), data=st.data(),
       t0=st.sampled_from([0.0, 100.0, 1.7e9, 2.0 ** 31]))
def test_a_refused_sample_flags_exactly_the_windows_that_hold_its_time(clock, data, t0):
    """A sample refused (non-finite) at ``s`` flags the decisions at ``t`` whose window
    ``[t - window_s, t)`` holds ``s`` (``StreamIntake.events``): the window starting at it,
    not the one ending at it. Compared as floats, the decision at 1.7 s (1.0 + 7 x 0.1 =
    1.7000000000000002) was flagged for the sample at 1.7 s, which its aligned window does
    not read, and the one at 2.7 s (window from 1.7000000000000002) was not, which reads
    it (interpolated across), on a clock from 0; on an epoch clock the other way round."""
    rate, window_s, hop = clock
    svc, rec = _recording_service(rate, window_s, hop)
    n = int(round(5.0 * rate))
    bad = data.draw(st.integers(int(round(window_s * rate)), n - 1), label="bad")
    t = t0 + np.arange(n) / rate
    out = []
    for i in range(n):
        v = np.array([[np.nan if i == bad else 0.01, 0.02]])
        out += svc.push("wheels", t[i:i + 1], v)
    assert svc.refused_samples == {("wheels", "non_finite"): 1}
    k_bad = Fraction(bad) / Fraction(rate)          # the refused stamp - t0, exactly
    w, h = Fraction(window_s), Fraction(hop).limit_denominator(1000)
    for j, d in enumerate(out):                      # the first decision at window_s
        end = w + j * h
        assert abs(float(end) - (d.t_s - t0)) < 1e-5
        holds = end - w <= k_bad < end
        assert ("non_finite" in d.flags.split("|")) == holds, (float(end), float(k_bad))


TWO = {"left": ("vel_l",), "right": ("vel_r",)}


@pytest.mark.slow
@FAST
@given(clock=st.sampled_from([(10.0, 1.0, 0.1, 0.3), (20.0, 1.0, 0.05, 0.3),
                              (10.0, 2.0, 0.3, 0.7), (100.0, 1.0, 0.3, 0.9),
                              (10.0, 1.0, 0.1, 1.0)]),
       data=st.data(), t0=st.sampled_from([0.0, 100.0, 1.7e9]))
def test_a_stream_silent_for_exactly_stale_s_is_not_stale(clock, data, t0):
    """``stale``: a stream whose newest sample is older than the decision time by *more
    than* ``stale_s`` (``StreamConfig``); one exactly ``stale_s`` old is not, whatever the
    rounding of the two times (20 Hz, hop 0.05 s, stale_s 0.3 s: the right wheel's last
    sample at 1.5 s made the decision at 1.8 s stale, 1.8 - 1.5 = 0.30000000000000004;
    stale decisions get the fallback targets)."""
    rate, window_s, hop, stale_s = clock
    rec = _Recorder()
    model = StreamModel(rec, ("vel_l", "vel_r"),
                        WindowConfig(window_s=window_s, rate_hz=rate), CLASSES)
    svc = StreamService(model, TableTargets(CLASSES),
                        StreamConfig(hop_s=hop, streams=TWO, stale_s=stale_s))
    n = int(round(4.0 * rate))
    stop = data.draw(st.integers(int(round(window_s * rate)), n - 1), label="stop")
    t = t0 + np.arange(n) / rate
    out = []
    for i in range(n):
        out += svc.push("left", t[i:i + 1], {"vel_l": [0.1]})
        if i <= stop:
            out += svc.push("right", t[i:i + 1], {"vel_r": [0.1]})
    last = Fraction(stop) / Fraction(rate)
    w, h = Fraction(window_s), Fraction(hop).limit_denominator(1000)
    stale = Fraction(stale_s).limit_denominator(1000)
    assert out
    for j, d in enumerate(out):
        end = w + j * h
        assert abs(float(end) - (d.t_s - t0)) < 1e-5
        assert ("stale" in d.flags.split("|")) == (end - last > stale), float(end)


@pytest.mark.slow
@FAST
@given(clock=st.sampled_from([(10.0, 1.0, 0.2, 4.2), (10.0, 1.0, 0.1, 3.0),
                              (10.0, 1.0, 0.3, 6.0), (8.0, 1.0, 0.5, 5.0)]),
       pause=st.integers(60, 130), t0=st.sampled_from([0.0, 100.0, 1.7e9]))
def test_a_silent_hop_exactly_max_backlog_s_before_the_newest_sample_is_decided(
        clock, pause, t0):
    """Decisions due *more than* ``max_backlog_s`` before the newest sample whose window
    holds no sample are skipped (module docstring); one exactly ``max_backlog_s`` before it
    is decided, whatever the rounding (10 Hz, hop 0.2 s, max_backlog_s 4.2 s, newest
    sample at 14.8 s: the decision at 10.6 s was skipped on a clock from 0, decided on one
    from 100 s)."""
    rate, window_s, hop, backlog = clock
    svc, rec = _recording_service(rate, window_s, hop, max_backlog_s=backlog,
                                  clock_restart_s=1000.0)
    n = int(3 * rate)
    idx = list(range(n)) + list(range(n + pause, n + pause + 12))
    out, newest = [], []
    for i in idx:
        got = svc.push("wheels", [t0 + i / rate], np.array([[0.1, 0.2]]))
        out += got
        newest += [Fraction(i) / Fraction(rate)] * len(got)
    r, w, h = Fraction(rate), Fraction(window_s), Fraction(hop).limit_denominator(1000)
    last_before, first_after = Fraction(n - 1) / r, Fraction(n + pause) / r
    decided = {int(round((d.t_s - t0 - window_s) / hop)): N for d, N in zip(out, newest)}
    for k in range(max(decided) + 1):
        t = w + k * h
        silent = t - w - 2 / r > last_before and t < first_after
        if k in decided:
            assert not (silent and decided[k] - t > Fraction(backlog)), float(t)
        else:   # skipped: silent, more than max_backlog_s before the newest sample
            N = min(v for j, v in decided.items() if j > k)
            assert silent and N - t > Fraction(backlog), (float(t), float(N))
    assert svc.skipped_decisions == max(decided) + 1 - len(decided)


def test_a_buffers_usual_step_reads_the_steps_between_its_newest_last_samples():
    """``last`` counts samples, not steps (``RingBuffer.median_step``, ``usual_step``): the
    newest 4 samples of 0, 1, 3, 6, 10 s hold the steps 2, 3, 4 s (median 3 s, smallest
    2 s), not the newest 4 steps 1 to 4 s (median 2.5 s); ``few`` counts those steps."""
    buf = RingBuffer(1, 16)
    buf.append(np.array([0.0, 1.0, 3.0, 6.0, 10.0]), np.zeros((5, 1)))
    assert buf.median_step(last=4) == 3.0
    assert buf.usual_step(last=4, few=3) == 3.0     # 3 steps known: not fewer than 3
    assert buf.usual_step(last=4, few=4) == 2.0     # fewer than 4: the smallest
    assert np.isnan(buf.usual_step(last=1))         # one sample: no step
