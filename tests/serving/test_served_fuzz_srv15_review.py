"""Fuzz of the served model's request path with Hypothesis (srv15 review).

Request bodies in the formats the README documents (CSV, JSON ``dataframe_split`` and
``dataframe_records``; long format with a ``stream`` column, wide with ``<stream>_t_s``)
with random corruptions go through the request guard's body checks
(:func:`terrain.serving.body.body_refusal`) and MLflow's own ``/invocations`` handler: the
answer is either decisions or a 4xx whose one-line message starts with a
:mod:`terrain.errors` class, never a 500 or a bare Python or pandas exception.
"""

from __future__ import annotations

import asyncio
import json

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrain.run import WHEEL_CHANNELS
from terrain.serving.http import RequestGuard
from terrain.serving.pyfunc import save_model
from terrain.serving.served import save_served_model, served_settings
from terrain.serving.service import UNCLASSIFIED_FLAGS

COLUMNS = ["stream", "t_s", *WHEEL_CHANNELS]
TYPED = ("DataFormatError", "MissingColumnError", "NonNumericError", "NonFiniteError",
         "TimestampError", "EmptyFileError", "EncodingError", "RaggedRowError",
         "ImplausibleValueError", "UnitError", "ClockError")


@pytest.fixture(scope="module")
def served(wheel_model, tmp_path_factory):
    import mlflow.pyfunc

    root, m = tmp_path_factory.mktemp("served_fuzz"), wheel_model
    save_model(root / "train", m.pipeline, m.channels, m.window, m.classes, {"dataset": "t"})
    save_served_model(root / "served", root / "train", served_settings(m, max_rows=5000))
    return mlflow.pyfunc.load_model(str(root / "served"))


@pytest.fixture(scope="module")
def base(unseen_wheel_request):
    """4 s of the wheel stream of an unseen run, long format."""
    return unseen_wheel_request(4.0)


@pytest.fixture(scope="module")
def guarded(served):
    """MLflow's scoring app of the served model behind the request guard, as ``terrain
    serve`` builds it (:func:`pipelines.serve.build_app`), called in-process."""
    from mlflow.pyfunc import scoring_server

    return RequestGuard(scoring_server.init(served), max_body_bytes=10**7, max_rows=5000)


def answer(app, body: bytes, content_type: str | None) -> tuple[int, dict]:
    """(status, JSON answer) of a POST of ``body`` to ``/invocations`` of ``app``."""
    headers = [(b"content-length", str(len(body)).encode())]
    if content_type is not None:
        headers.append((b"content-type", content_type.encode()))
    scope = {"type": "http", "method": "POST", "path": "/invocations", "raw_path":
             b"/invocations", "query_string": b"", "headers": headers, "http_version": "1.1",
             "scheme": "http", "server": ("127.0.0.1", 5000), "client": ("127.0.0.1", 1),
             "root_path": ""}
    sent: list[dict] = []

    async def receive():
        return {"type": "http.request", "body": body, "more_body": False}

    async def send(message):
        sent.append(message)

    asyncio.run(app(scope, receive, send))
    status = next(m["status"] for m in sent if m["type"] == "http.response.start")
    return status, json.loads(b"".join(m.get("body", b"") for m in sent
                                       if m["type"] == "http.response.body"))


def _cell(value) -> str:
    """A cell as a JSON value (a non-finite float as null, as pandas writes it)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        value = None
    return json.dumps(value)


def encode(frame: pd.DataFrame, fmt: str) -> tuple[bytes, str]:
    """``frame`` as a body of ``fmt`` (``csv``, ``split``, ``records``), repeated column
    names kept (a record then holds a key twice)."""
    if fmt == "csv":
        return frame.to_csv(index=False).encode(), "text/csv"
    names = [json.dumps(str(c)) for c in frame.columns]
    rows = frame.itertuples(index=False, name=None)
    if fmt == "split":
        data = ",".join("[" + ",".join(_cell(v) for v in row) + "]" for row in rows)
        doc = '{"dataframe_split": {"columns": [' + ",".join(names) + '], "data": [' + data
        return (doc + "]}}").encode(), "application/json"
    data = ",".join("{" + ",".join(f"{k}: {_cell(v)}" for k, v in zip(names, row)) + "}"
                    for row in rows)
    return ('{"dataframe_records": [' + data + "]}").encode(), "application/json"


CELLS = st.one_of(st.just(""), st.just("nan"), st.just("inf"), st.just("-inf"),
                  st.just("abc"), st.just(True), st.just(None), st.just("1e400"),
                  st.just(1e308), st.just(-1e300), st.just("é"), st.just("\ufeff1"),
                  st.just(" 1.5 "), st.just(10**30), st.just("0x10"), st.just("1,5"),
                  st.floats(allow_nan=True, allow_infinity=True),
                  st.integers(-10**20, 10**20), st.text(max_size=5))


@st.composite
def corrupted(draw, base_frame):
    frame = base_frame.copy().astype(object)
    n = len(frame)
    for _ in range(draw(st.integers(0, 3))):
        kind = draw(st.sampled_from(["cell", "drop_col", "extra_col", "dup_row", "swap_rows",
                                     "drop_rows", "truncate", "rename", "stream",
                                     "scale_t", "shift_t"]))
        n = len(frame)
        if kind == "cell" and n:
            row = draw(st.integers(0, n - 1))
            col = draw(st.sampled_from(list(frame.columns)))
            frame.iat[row, list(frame.columns).index(col)] = draw(CELLS)
        elif kind == "drop_col" and len(frame.columns) > 1:
            frame = frame.drop(columns=[draw(st.sampled_from(list(frame.columns)))])
        elif kind == "extra_col":
            name = draw(st.sampled_from(["idx", "gps_t_s", " t_s", "Vel_L", "imu_t_s", "wx",
                                         "", "é"]))
            if name not in frame.columns:
                frame[name] = draw(CELLS)
        elif kind == "dup_row" and n:
            row = draw(st.integers(0, n - 1))
            frame = pd.concat([frame.iloc[:row + 1], frame.iloc[row:]], ignore_index=True)
        elif kind == "swap_rows" and n > 1:
            i = draw(st.integers(0, n - 2))
            order = list(range(n))
            order[i], order[i + 1] = order[i + 1], order[i]
            frame = frame.iloc[order].reset_index(drop=True)
        elif kind == "drop_rows" and n:
            a = draw(st.integers(0, n - 1))
            b = draw(st.integers(a, min(n, a + 40)))
            frame = frame.drop(index=range(a, b)).reset_index(drop=True)
        elif kind == "truncate":
            frame = frame.iloc[:draw(st.integers(0, n))].reset_index(drop=True)
        elif kind == "rename" and len(frame.columns):
            col = draw(st.sampled_from(list(frame.columns)))
            frame = frame.rename(columns={col: draw(st.sampled_from(
                ["T_S", "wheel", "stream ", "vel_l", "t", "time"]))})
        elif kind == "stream" and list(frame.columns).count("stream") == 1 and n:
            row = draw(st.integers(0, n - 1))
            frame.loc[row, "stream"] = draw(st.sampled_from(["imu", "Wheels", "", None, 1,
                                                             "wheel"]))
        elif kind == "scale_t" and list(frame.columns).count("t_s") == 1:
            factor = draw(st.sampled_from([1e-3, 1e3, 1e9, -1.0, 0.0, 10.0, 0.1]))
            frame["t_s"] = pd.to_numeric(frame["t_s"], errors="coerce") * factor
        elif kind == "shift_t" and list(frame.columns).count("t_s") == 1:
            shift = draw(st.sampled_from([1e6, 1e9, -1e3, 1e12, 0.5]))
            frame["t_s"] = pd.to_numeric(frame["t_s"], errors="coerce") + shift
        frame = frame.astype(object)
    return frame


def check_answer(status: int, doc: dict) -> None:
    if status == 200:
        got = pd.DataFrame(doc["predictions"])
        assert len(got), doc
        reason = [not UNCLASSIFIED_FLAGS.isdisjoint(f.split("|")) for f in got["flags"]]
        assert got["dropped"].tolist() == reason
        assert (got.loc[~got["dropped"], "confidence"].astype(float) > 0).all()
        return
    assert 400 <= status < 500, (status, doc)
    assert doc["message"].split(":")[0] in TYPED, doc["message"]
    assert "\n" not in doc["message"] and "Traceback" not in json.dumps(doc)


@pytest.mark.slow
@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data(), fmt=st.sampled_from(["csv", "split", "records"]))
def test_a_corrupted_request_is_decided_or_a_typed_4xx(guarded, base, data, fmt):
    frame = data.draw(corrupted(base))
    body, content_type = encode(frame, fmt)
    check_answer(*answer(guarded, body, content_type))


@st.composite
def byte_corrupted(draw, base_frame):
    frame = draw(corrupted(base_frame))
    body, content_type = encode(frame, draw(st.sampled_from(["csv", "split", "records"])))
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["bom", "cut", "crlf", "header_only", "empty", "ctype",
                                     "insert", "delete_line", "dup_line", "utf16"]))
        if kind == "bom":
            body = b"\xef\xbb\xbf" + body
        elif kind == "cut" and body:
            body = body[:draw(st.integers(0, len(body) - 1))]
        elif kind == "crlf":
            body = body.replace(b"\n", b"\r\n")
        elif kind == "header_only":
            body = body.split(b"\n")[0] + b"\n"
        elif kind == "empty":
            body = b""
        elif kind == "ctype":
            content_type = draw(st.sampled_from(["text/csv", "application/json",
                                                 "text/csv; charset=utf-8",
                                                 "application/JSON", "TEXT/CSV"]))
        elif kind == "insert":
            at = draw(st.integers(0, len(body)))
            body = body[:at] + draw(st.sampled_from([b",", b'"', b"\n", b"\xc3\xa9", b"{",
                                                     b"]", b"\x00", b" ", b"e", b"-"])) + body[at:]
        elif kind == "delete_line":
            lines = body.split(b"\n")
            i = draw(st.integers(0, len(lines) - 1))
            body = b"\n".join(lines[:i] + lines[i + 1:])
        elif kind == "dup_line":
            lines = body.split(b"\n")
            i = draw(st.integers(0, len(lines) - 1))
            body = b"\n".join(lines[:i + 1] + lines[i:])
        elif kind == "utf16":
            body = body.decode("utf-8", "replace").encode("utf-16")
    return body, content_type


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_a_corrupted_body_is_decided_or_a_typed_4xx(guarded, base, data):
    body, content_type = data.draw(byte_corrupted(base))
    check_answer(*answer(guarded, body, content_type))


@pytest.fixture(scope="module")
def two_streams(borealtc_runs, train_runs):
    """5 s of the IMU and wheel streams of an unseen run, long format (IMU rows first)."""
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.run_id not in seen and r.has_imu)
    parts = []
    for name, f in run.streams.items():
        t0 = max(float(g["t_s"].iloc[0]) for g in run.streams.values())
        parts.append(f[(f["t_s"] >= t0) & (f["t_s"] < t0 + 5.0)].assign(stream=name))
    frame = pd.concat(parts, ignore_index=True)
    return frame[["stream", "t_s", *[c for c in frame.columns if c not in ("stream", "t_s")]]]


@pytest.fixture(scope="module")
def guarded_all(served_all):
    """The IMU + wheel served model behind the request guard."""
    from mlflow.pyfunc import scoring_server

    return RequestGuard(scoring_server.init(served_all), max_body_bytes=10**7)


@pytest.fixture(scope="module")
def two_streams_answer(guarded_all, two_streams):
    """The answer to ``two_streams`` as a ``dataframe_split`` table."""
    status, doc = answer(guarded_all, *encode(two_streams, "split"))
    assert status == 200 and len(doc["predictions"]) >= 5, doc
    return doc


def _interleaved(frame: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    """``frame``'s rows in a random interleaving of its streams, each stream's rows in
    their own order, and its columns in a random order."""
    labels = frame["stream"].to_numpy()
    slots = rng.permutation(labels)
    order = np.empty(len(frame), dtype=int)
    for stream in np.unique(labels):
        order[slots == stream] = np.flatnonzero(labels == stream)
    return frame.iloc[order, rng.permutation(frame.shape[1])].reset_index(drop=True)


@pytest.mark.slow
@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), fmt=st.sampled_from(["csv", "split", "records"]))
def test_interleaving_column_order_and_format_do_not_change_the_decisions(
        guarded_all, two_streams, two_streams_answer, seed, fmt):
    want = two_streams_answer
    frame = _interleaved(two_streams, np.random.default_rng(seed))
    status, got = answer(guarded_all, *encode(frame, fmt))
    assert status == 200, got
    assert got == want


def _wide(frame: pd.DataFrame) -> pd.DataFrame:
    """The long ``frame`` in the wide format: ``<stream>_t_s`` and the stream's channels
    side by side, a shorter stream's trailing cells empty."""
    parts = []
    for stream, part in frame.groupby("stream", sort=False):
        part = part.drop(columns="stream").dropna(axis=1, how="all")
        parts.append(part.rename(columns={"t_s": f"{stream}_t_s"}).reset_index(drop=True))
    return pd.concat(parts, axis=1)


@pytest.mark.slow
@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data(), fmt=st.sampled_from(["csv", "split", "records"]))
def test_a_gap_or_a_cut_keeps_every_due_decision_in_the_answer(guarded_all, two_streams,
                                                               data, fmt):
    """Every decision due (one per hop from one window after the streams start) is a row
    of the answer, a dropped one (``gap``) where samples are missing: the wide format and
    the long one agree."""
    frame = two_streams
    for _ in range(data.draw(st.integers(0, 2))):
        stream = data.draw(st.sampled_from(["imu", "wheels"]))
        rows = np.flatnonzero(frame["stream"].to_numpy() == stream)
        if len(rows) < 3:
            continue
        a = data.draw(st.integers(1, len(rows) - 2))
        b = data.draw(st.integers(a, len(rows) - 1))
        frame = frame.drop(index=frame.index[rows[a:b]])
    frame = frame.reset_index(drop=True)
    status, long = answer(guarded_all, *encode(frame, fmt))
    status_wide, wide = answer(guarded_all, *encode(_wide(frame), fmt))
    if status != 200:   # the same refusal (naming t_s, or imu_t_s in the wide format)
        assert status == status_wide == 400 and long["message"].split(":")[0] in TYPED, long
        assert wide["message"].split(":")[0] == long["message"].split(":")[0], wide
        return
    assert (status_wide, wide) == (status, long)
    got = pd.DataFrame(long["predictions"])
    start, end = frame["t_s"].min(), frame["t_s"].max()
    due = start + 2.0 + 0.5 * np.arange(int(np.floor((end - start - 2.0) / 0.5)) + 1)
    if any(f.startswith("held:") for f in "|".join(got["flags"]).split("|")):
        due = due[:len(got)]   # samples held when the request ended: said on every window
    np.testing.assert_allclose(got["t_s"], due, atol=0.03)   # the 50 Hz model's grid
    flags = [set(f.split("|")) for f in got["flags"]]
    assert got["dropped"].tolist() == [bool(f & {"gap", "short"}) for f in flags]
    # the readers' gap rule on the whole request (a step over 3 x the stream's median),
    # where it is clear-cut: a window of [end - 2 s, end) that a step over 3.05 x crosses
    # by 0.05 s is a gap (or short, decided before the hole's end came), one that no step
    # over 2.95 x comes within 0.05 s of is not
    # (from the streams' start: their first steps are judged against the training step)
    holes: dict[float, list] = {3.05: [], 2.95: []}
    for _, part in frame.groupby("stream"):
        t = part["t_s"].to_numpy()
        step = np.diff(t)
        for factor, found in holes.items():
            found += [(a, b) for a, b in zip(t[:-1], t[1:])
                      if b - a > factor * np.median(step)]
    for t, age, f in zip(got["t_s"], got["window_age_s"], flags):
        end = t - (age or 0.0)   # the window ends window_age_s before its decision
        if any(b > end - 1.95 and a < end - 0.05 for a, b in holes[3.05]):
            assert f & {"gap", "short"}, (t, f, holes)
        elif not any(b > end - 2.05 and a < end + 0.05 for a, b in holes[2.95]) and t > 2.1:
            assert "gap" not in f, (t, f, holes)
    if len(frame) == len(two_streams):
        assert not got["dropped"].any()


@pytest.mark.parametrize("stream, kept, resume, decisions", [
    ("imu", 1, 305, [2.5, 3.0, 3.5, 4.0, 4.5]), ("imu", 2, 305, [2.5, 3.0, 3.5, 4.0, 4.5]),
    ("wheels", 1, 12, [2.0, 2.5, 3.0, 3.5])])
def test_a_window_across_a_hole_after_a_streams_first_samples_is_a_gap(
        guarded_all, two_streams, stream, kept, resume, decisions):
    """A stream sends ``kept`` sample(s) from 0 s, then nothing until its sample
    ``resume`` (the IMU at 3.05 s, the 6.5 Hz wheels at 1.85 s). The first windows across
    the hole were classified (no flag, not dropped) on values drawn as a straight line
    over it: the stream's usual step was the median of the one or two steps known through
    the window, the hole itself. Every window starting before the hole's end is a gap."""
    rows = np.flatnonzero(two_streams["stream"].to_numpy() == stream)
    frame = two_streams.drop(index=two_streams.index[rows[kept:resume]])
    status, doc = answer(guarded_all, *encode(frame.reset_index(drop=True), "split"))
    assert status == 200, doc
    got = pd.DataFrame(doc["predictions"]).set_index("t_s")
    assert got.loc[decisions, "dropped"].all(), got[["flags", "dropped"]]
    assert (got.loc[decisions, "flags"] == "gap").all()
    assert not got.drop(index=decisions)["flags"].str.contains("gap").any()


def test_two_holes_after_a_streams_first_sample_make_the_first_window_a_gap(
        guarded_all, two_streams):
    """The wheels (6.5 Hz) send their sample at 0 s, then 0.615 s, then 1.69 s and on
    regularly: the window [0, 2) of the decision at 2 s rests on values drawn over two
    holes of 4 and 7 usual steps. It was classified unflagged: the usual step was the
    median of the four steps known (0.615, 1.077, 0.154, 0.154 s -> 0.385 s), which the
    holes dominate (found by a Hypothesis draw of the test above, stop 90); with fewer
    than 8 steps known the smallest stands for the usual one."""
    rows = np.flatnonzero(two_streams["stream"].to_numpy() == "wheels")
    frame = two_streams.drop(index=two_streams.index[np.r_[rows[1:4], rows[5:11]]])
    status, doc = answer(guarded_all, *encode(frame.reset_index(drop=True), "csv"))
    assert status == 200, doc
    got = pd.DataFrame(doc["predictions"]).set_index("t_s")
    assert "gap" in got.loc[2.0, "flags"].split("|"), got[["flags", "dropped"]]


def test_one_hole_after_a_streams_second_sample_makes_the_first_window_a_gap(
        guarded_all, two_streams):
    """The wheels (6.5 Hz) send their samples at 0 and 0.615 s, then from 2 s on
    regularly: the window [0, 2) rests on values drawn over holes of 4 and 9 usual
    steps; the smallest step known through it, 0.615 s, is itself a hole. It was
    classified unflagged (a strict xfail, stop 91): no step known was a usual one; the
    training runs' step of the wheel channels (the model's ``channel_steps_s``, 0.154 s)
    caps the smallest step while few are known."""
    rows = np.flatnonzero(two_streams["stream"].to_numpy() == "wheels")
    frame = two_streams.drop(index=two_streams.index[np.r_[rows[1:4], rows[5:13]]])
    status, doc = answer(guarded_all, *encode(frame.reset_index(drop=True), "csv"))
    assert status == 200, doc
    got = pd.DataFrame(doc["predictions"]).set_index("t_s")
    assert "gap" in got.loc[2.0, "flags"].split("|"), got[["flags", "dropped"]]


@pytest.mark.parametrize("channel", ["vel_l", "vel_r"])
def test_an_isolated_inf_wheel_speed_is_a_non_finite_sample_not_km_h(guarded, base, channel):
    """One inf among the wheel speeds (a fuzzed JSON ``Infinity``) refused the request,
    "UnitError: rule wheel_speed_units: 99th-percentile wheel speed inf ... km/h": the
    run-level rule took the inf into its percentile; as a NaN, it is a non-finite sample
    the windows holding it are flagged for."""
    answers = []
    for bad in (np.nan, np.inf):
        frame = base.copy()
        frame.loc[10, channel] = bad
        status, doc = answer(guarded, frame.to_csv(index=False).encode(), "text/csv")
        assert status == 200, doc
        answers.append(doc)
    assert answers[1] == answers[0]
    assert "non_finite" in "|".join(pd.DataFrame(answers[1]["predictions"])["flags"])


def test_wheel_speeds_in_km_h_are_refused_with_a_missing_sample_among_them(guarded, base):
    """Wheel speeds in km/h are refused (rule wheel_speed_units) with or without an
    isolated missing sample: a NaN among them made the rule's percentile NaN, and the
    request passed it as m/s."""
    kmh = base.assign(vel_l=3.6 * base["vel_l"] + 3.0, vel_r=3.6 * base["vel_r"] + 3.0)
    for missing in (False, True):
        frame = kmh.copy()
        if missing:
            frame.loc[10, "vel_l"] = np.nan
        status, doc = answer(guarded, frame.to_csv(index=False).encode(), "text/csv")
        assert status == 400, (missing, doc)
        assert doc["message"].startswith("UnitError: rule wheel_speed_units"), doc
