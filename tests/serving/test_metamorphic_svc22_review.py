"""Review tests (svc22): metamorphic relations between the public entry points of serving.

The served model answers the same for the same samples in the long format, the wide format,
any column order and any interleaving of the long rows that keeps each stream in time order;
``terrain stream``'s in-process replay (one by one) decides as the served model (chunks of
32) on the same samples; the forward filter's closed-form skip is the prediction steps one by
one, decided class included, and without hysteresis it decides the argmax. A shift of every
clock by the same time changes no probability (it was a strict xfail: the window's grid
followed a float tie of the look-back bound with an IMU stamp).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import example, given, settings, strategies as st

from terrain.control import DesiredSlipConfig
from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS, Run
from terrain.serving import StreamConfig, StreamService, TableTargets
from terrain.serving.replay import replay_recorded
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig

STREAMS = (("imu", IMU_CHANNELS), ("wheels", WHEEL_CHANNELS))
SECONDS = 8.0


@pytest.fixture(scope="module")
def unseen_long(borealtc_runs, train_runs):
    """The first 8 s of an unseen run with IMU, as a long-format request (IMU rows first)."""
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.run_id not in seen and r.has_imu)
    parts = []
    for s, chans in STREAMS:
        f = run.streams[s]
        f = f[f["t_s"] < f["t_s"].iloc[0] + SECONDS]
        parts.append(f[["t_s", *chans]].assign(stream=s))
    columns = ["stream", "t_s", *IMU_CHANNELS, *WHEEL_CHANNELS]
    return pd.concat(parts, ignore_index=True)[columns]


@pytest.fixture(scope="module")
def answer(served_all, unseen_long):
    return served_all.predict(unseen_long)


def _wide(long: pd.DataFrame) -> pd.DataFrame:
    cols = []
    for s, chans in STREAMS:
        f = long[long["stream"] == s][["t_s", *chans]].reset_index(drop=True)
        cols.append(f.rename(columns={"t_s": f"{s}_t_s"}))
    return pd.concat(cols, axis=1)


@pytest.mark.slow
def test_long_wide_any_column_order_and_any_row_interleaving_answer_the_same(
        served_all, unseen_long, answer):
    """One request in four forms: the wide format, the long one with its columns in another
    order, and with its rows of both streams interleaved in time order (ties either way) or
    shuffled between the streams keeping each in time order: every answer equals the first,
    cell for cell."""
    rng = np.random.default_rng(22)
    assert len(answer) == 12
    wide = _wide(unseen_long)
    forms = {"wide": wide,
             "wide, columns reversed": wide[wide.columns[::-1]],
             "long, columns shuffled": unseen_long[list(rng.permutation(unseen_long.columns))]}
    for ties in ("imu", "wheels"):
        key = (unseen_long["stream"] != ties).astype(int)
        forms[f"time order, {ties} first at a tie"] = unseen_long.assign(_k=key).sort_values(
            ["t_s", "_k"], kind="stable").drop(columns="_k")
    # a random merge of the two streams' rows, each stream keeping its own order
    which = rng.permutation(np.r_[np.zeros((unseen_long.stream == "imu").sum(), int),
                                  np.ones((unseen_long.stream == "wheels").sum(), int)])
    rows = [np.flatnonzero(unseen_long.stream == s) for s, _ in STREAMS]
    counters = [0, 0]
    order = []
    for w in which:
        order.append(rows[w][counters[w]])
        counters[w] += 1
    forms["shuffled between the streams"] = unseen_long.iloc[order]
    for name, frame in forms.items():
        got = served_all.predict(frame)
        pd.testing.assert_frame_equal(got, answer, obj=name)


def test_terrain_stream_replay_decides_as_the_served_model(all_model, unseen_long, answer):
    """``terrain stream``'s replay (every sample pushed one by one) and the served model
    (chunks of 32) on the same samples with the same settings: the same decision times,
    terrains, probabilities, targets and window ages (the served answer adds the run-level
    plausibility columns; here both carry no flag)."""
    streams = {s: unseen_long[unseen_long.stream == s][["t_s", *c]].reset_index(drop=True)
               for s, c in STREAMS}
    run = Run("r", "t", None, streams, vehicle="husky")
    service = StreamService(all_model, TableTargets(all_model.classes,
                                                    DesiredSlipConfig(min_confidence=0.5)),
                            StreamConfig(hop_s=0.5, min_confidence=0.5,
                                         smoothing=SmoothingConfig(dwell_s=10.0)))
    frame = replay_recorded(service, run).frame
    cols = [c for c in frame.columns if c not in ("flags", "window_age_s")]
    pd.testing.assert_frame_equal(frame[cols].reset_index(drop=True),
                                  answer[cols].reset_index(drop=True), check_dtype=False)
    np.testing.assert_array_equal(frame["window_age_s"].to_numpy(float),
                                  answer["window_age_s"].to_numpy(float))
    assert (frame["flags"] == "").all() and (answer["flags"] == "").all()


def test_a_shift_of_every_clock_changes_no_probability(served_all, unseen_long, answer):
    """Every stamp of every stream moved by 2.3 s: the decision times move by 2.3 s and
    nothing else changes (probabilities to 1e-9, the rest exactly)."""
    shifted = served_all.predict(unseen_long.assign(t_s=unseen_long["t_s"] + 2.3))
    np.testing.assert_allclose(shifted["t_s"] - 2.3, answer["t_s"], atol=1e-9)
    num = [c for c in answer.columns if c.startswith("proba_") or c == "confidence"]
    np.testing.assert_allclose(shifted[num].to_numpy(float), answer[num].to_numpy(float),
                               atol=1e-9)
    rest = [c for c in answer.columns if c not in num and c != "t_s"]
    pd.testing.assert_frame_equal(shifted[rest], answer[rest])


_q = st.lists(st.floats(0, 1), min_size=3, max_size=3).map(np.array)


@settings(max_examples=60, deadline=None)
@given(qs=st.lists(_q, min_size=1, max_size=8), n=st.integers(0, 40),
       dwell=st.floats(0.3, 100.0), hyst=st.sampled_from([0.0, 0.05, 0.3]))
@example(qs=[np.array([0.0, 0.0, 1.0])], n=9, dwell=0.7578125, hyst=0.0)
def test_skip_is_n_prediction_steps_and_no_hysteresis_decides_the_argmax(qs, n, dwell, hyst):
    """After any windows, ``skip(n)`` leaves the filter where ``n`` calls ``update(None)``
    leave it (probabilities to 1e-12, the same decided class); the probabilities stay a
    distribution; with ``hysteresis=0`` every decided class holds the largest filtered
    probability. Found: ``q = (0, 0, 1)``, a dwell of 0.76 s and 9 steps without a window
    put class 0 one ulp ahead of class 2 near the uniform distribution and ``update(None)``
    switched to it, ``skip(9)`` kept class 2."""
    config = SmoothingConfig(dwell_s=dwell, hysteresis=hyst)
    a, b = ForwardFilter(3, 0.5, config), ForwardFilter(3, 0.5, config)
    for q in qs:
        for f in (a, b):
            decided, p = f.update(q)
            assert np.all(p >= 0) and abs(p.sum() - 1) < 1e-9
            if hyst == 0:
                assert p[decided] == p.max()
    a.skip(n)
    for _ in range(n):
        decided, p = b.update(None)
        if hyst == 0:   # (no evidence keeps the class: its lead may be rounding's 1 ulp)
            assert p[decided] >= p.max() - 1e-12
    np.testing.assert_allclose(a.p, b.p, atol=1e-12)
    assert abs(a.p.sum() - 1) < 1e-9
    assert a.current == b.current


def _invocations(served, frame: pd.DataFrame) -> list:
    """The predictions MLflow's /invocations handler answers for ``frame`` sent as JSON
    ``dataframe_split``."""
    import json

    from mlflow.pyfunc import scoring_server

    body = json.dumps({"dataframe_split": json.loads(frame.to_json(orient="split",
                                                                   index=False))})
    res = scoring_server.invocations(body, "application/json", served, None)
    assert res.status == 200, res.response
    return json.loads(res.response)["predictions"]


def test_json_long_and_wide_bodies_answer_as_the_in_process_predict(served_all, unseen_long,
                                                                    answer):
    """The long and the wide request sent as JSON ``dataframe_split`` (the wide one's
    trailing wheel cells written as null) through MLflow's handler: the same predictions,
    which are the in-process answer (to 1e-9: pandas writes the request's numbers with 10
    significant digits)."""
    long = _invocations(served_all, unseen_long)
    assert _invocations(served_all, _wide(unseen_long)) == long
    got = pd.DataFrame(long)
    assert list(got.columns) == list(answer.columns)
    num = [c for c in answer.columns if answer[c].dtype.kind == "f"]
    np.testing.assert_allclose(got[num].to_numpy(float), answer[num].to_numpy(float),
                               atol=1e-9)
    assert got["terrain"].tolist() == answer["terrain"].tolist()
    assert got["flags"].tolist() == answer["flags"].tolist()


@pytest.mark.parametrize("dwell", [None, 10.0])
def test_without_hysteresis_a_lead_of_a_thousandth_switches_the_decided_class(dwell):
    """``hysteresis=0`` decides the argmax however small its lead: a window giving the second
    class 0.5005 against 0.4995 moves the decision to it at once without the filter, and
    after enough such windows with it."""
    f = ForwardFilter(2, 0.5, SmoothingConfig(dwell_s=dwell, hysteresis=0.0))
    assert f.update(np.array([0.6, 0.4]))[0] == 0
    for _ in range(200):
        decided, p = f.update(np.array([0.4995, 0.5005]))
        assert decided == int(np.argmax(p))
    assert decided == 1


def test_steps_without_a_window_keep_the_decided_class_near_the_uniform_distribution():
    """The property's falsifying example: 9 prediction steps bring ``(0.01, 0.01, 0.98)`` to
    the uniform distribution up to rounding, which put class 0 one ulp ahead; without
    hysteresis ``update(None)`` switched the decided class to it (a terrain without any
    evidence), where ``skip(9)`` kept class 2."""
    config = SmoothingConfig(dwell_s=0.7578125, hysteresis=0.0)
    one_by_one, skipped = ForwardFilter(3, 0.5, config), ForwardFilter(3, 0.5, config)
    for f in (one_by_one, skipped):
        assert f.update(np.array([0.0, 0.0, 1.0]))[0] == 2
    decided = [one_by_one.update(None)[0] for _ in range(9)]
    skipped.skip(9)
    assert decided == [2] * 9 and skipped.current == 2
    # the next window decides again, as usual
    assert one_by_one.update(np.array([0.5, 0.3, 0.2]))[0] == 0
