"""Boundaries of a served request's length (srv21): a stream spanning exactly one window on
any clock, judged as the service's clock judges it (the first decision due one window
after the first sample, computed ``t0 + window_s``, not ``t[-1] - t0 >= window_s``, whose
rounding falls short of one window on most clocks: 2.3 - 0.3 is 1.9999999999999998)."""

from __future__ import annotations

from types import SimpleNamespace

import joblib
import numpy as np
import pandas as pd
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from terrain.errors import DataFormatError
from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.request import parse_request, planned_decisions
from terrain.serving.served import ServedStreamModel, served_settings

WHEELS = {"wheels": WHEEL_CHANNELS}


@pytest.fixture(scope="module")
def wheel_served(wheel_model, tmp_path_factory):
    """The session's wheel-only model (20 Hz clock, 2 s window) as the served pyfunc,
    loaded in-process."""
    path = tmp_path_factory.mktemp("srv21_window") / "pipeline.joblib"
    joblib.dump(wheel_model.pipeline, path)
    model = ServedStreamModel()
    model.load_context(SimpleNamespace(artifacts={"pipeline": str(path)},
                                       model_config=served_settings(wheel_model)))
    return model


def _wheels(t: np.ndarray) -> pd.DataFrame:
    """A long-format wheel request at the stamps ``t`` (a steady drive)."""
    rng = np.random.default_rng(0)
    n = t.size
    return pd.DataFrame({"stream": "wheels", "t_s": t,
                         "vel_l": 0.5 + 0.01 * rng.standard_normal(n),
                         "vel_r": 0.6 + 0.01 * rng.standard_normal(n),
                         "cur_l": 5.0 + 0.1 * rng.standard_normal(n),
                         "cur_r": 6.0 + 0.1 * rng.standard_normal(n)})


@settings(max_examples=40, deadline=None)
@given(t0=st.floats(0.0, 1e4, allow_nan=False), step=st.sampled_from([0.05, 0.1, 0.04]))
@example(t0=0.3, step=0.05)
@example(t0=7.7, step=0.1)
@example(t0=1.7e9 + 0.3, step=0.05)
def test_a_stream_of_exactly_one_window_is_taken_on_any_clock(t0, step):
    """Stamps ``t0 + k * step`` spanning nominally one 2 s window are taken whenever the
    service's first decision, due at ``t0 + 2.0``, is not after the last stamp (one
    decision planned); the stream one sample shorter is refused as too short."""
    n = int(round(2.0 / step))
    t = t0 + np.arange(n + 1) * step
    if t[0] + 2.0 <= t[-1]:
        run = parse_request(_wheels(t), WHEELS, 2.0, 10_000)
        assert planned_decisions(run, 2.0, 0.5) == 1
    else:   # the clock's rounding puts the last stamp before the first decision
        with pytest.raises(DataFormatError, match="too short"):
            parse_request(_wheels(t), WHEELS, 2.0, 10_000)
    with pytest.raises(DataFormatError, match="too short"):
        parse_request(_wheels(t[:-1]), WHEELS, 2.0, 10_000)


@pytest.mark.parametrize("t0", [0.0, 0.3, 7.7])
def test_the_served_model_answers_a_request_of_exactly_one_window(wheel_served, t0):
    """41 wheel samples 0.05 s apart from ``t0``: the service decides once, at
    ``t0 + 2.0``, the last sample. From 0.3 the request was refused ("it spans 2 s over 41
    sample(s); one window needs 2 s": 2.3 - 0.3 is 1.9999999999999998) though the
    service, given it, decides."""
    t = t0 + np.arange(41) * 0.05
    assert t[0] + 2.0 <= t[-1]
    out = wheel_served.decide(_wheels(t))
    assert len(out) == 1 and not out["dropped"].iloc[0]
    assert out["t_s"].iloc[0] == t[0] + 2.0


@pytest.mark.parametrize("stream, channels, top_hz", [("wheels", WHEEL_CHANNELS, 1000.0),
                                                      ("imu", IMU_CHANNELS, 2000.0)])
def test_a_stream_at_its_highest_nominal_rate_is_taken_one_beyond_refused(stream, channels,
                                                                          top_hz):
    """The nominal rates are a closed range (NOMINAL_RATE_HZ, "outside its nominal lo-hi
    Hz"): its top is taken, 0.1 % above refused (a mutant excluding the top survived)."""
    rng = np.random.default_rng(1)

    def request(rate_hz):
        t = np.arange(int(2.2 * rate_hz)) / rate_hz
        return pd.DataFrame({"stream": stream, "t_s": t,
                             **{c: (9.81 if c == "az" else 0.5)
                                + 0.01 * rng.standard_normal(t.size) for c in channels}})

    assert len(parse_request(request(top_hz), {stream: channels}, 2.0, 10**5)
               .streams[stream]) == int(2.2 * top_hz)
    with pytest.raises(DataFormatError, match=rf"implies {top_hz * 1.001:.4g} Hz, outside "
                                              rf"its nominal \S+-{top_hz:g} Hz"):
        parse_request(request(top_hz * 1.001), {stream: channels}, 2.0, 10**5)


@settings(max_examples=25, deadline=None)
@given(t0=st.one_of(st.floats(0.0, 1e5, allow_nan=False), st.floats(1.6e9, 1.8e9)),
       step=st.sampled_from([0.05, 0.1, 0.125, 0.15]), extra=st.sampled_from([-1, 0, 1]))
@example(t0=0.3, step=0.05, extra=0)
def test_a_request_about_one_window_long_is_taken_iff_the_service_decides_on_it(
        wheel_served, t0, step, extra):
    """A wheel stream one sample short of, exactly, or one sample past one window, on any
    clock: the served model answers it (its decisions as many as planned) exactly where
    the service, given the same samples, decides; else the request is refused as too
    short (never an answer of no decision, never a refusal of a stream decided on)."""
    from terrain.run import Run
    from terrain.serving import StreamService
    from terrain.serving.replay import replay_run

    t = t0 + np.arange(int(round(2.0 / step)) + 1 + extra) * step
    frame = _wheels(t)
    run = Run("request", "request", None, {"wheels": frame.drop(columns="stream")})
    service = StreamService(wheel_served.model, wheel_served.targets, wheel_served.config)
    due = len(replay_run(service, run, max_chunk=32))
    try:
        out = wheel_served.decide(frame)
    except DataFormatError as exc:
        assert "too short" in str(exc) and due == 0
    else:
        assert len(out) == due >= 1
        parsed = parse_request(frame, WHEELS, 2.0, 10_000)
        assert planned_decisions(parsed, 2.0, wheel_served.config.hop_s) == due
