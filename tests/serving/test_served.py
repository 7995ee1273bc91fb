"""The served streaming model: raw streams in, the service's decisions out, typed 4xx errors.

The in-process tests go through MLflow's own request handler
(:func:`mlflow.pyfunc.scoring_server.invocations`, what ``/invocations`` runs); the tests of
the HTTP layer share one real ``terrain serve`` on 127.0.0.1 (the ``server`` fixture): bodies
MLflow's own parsers refuse, a missing Content-Type, a time jump, and SIGTERM (the last test,
which stops it). The startup checks of ``terrain serve`` run in-process (they fail before
serving).
"""

from __future__ import annotations

import http.client
import json
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from terrain.errors import (ClockError, ConfigError, DataFormatError, ImplausibleValueError,
                            NonFiniteError, NonNumericError, TimestampError, UnitError)
from terrain.run import WHEEL_CHANNELS
from terrain.serving.pyfunc import save_model
from terrain.serving import (StreamConfig, StreamService, TableTargets, decisions_frame,
                             replay_run)
from terrain.serving.request import parse_request, planned_decisions
from terrain.serving.served import (MAX_DECISIONS, _plausibility_flags, save_served_model,
                                    served_settings, smoothing_of)
from terrain.serving.smoothing import SmoothingConfig
from terrain.control import DesiredSlipConfig

COLUMNS = ["stream", "t_s", *WHEEL_CHANNELS]


@pytest.fixture(scope="module")
def model_dirs(wheel_model, tmp_path_factory):
    """(train model dir, served model dir) of the session's wheel-only model."""
    root = tmp_path_factory.mktemp("served")
    m = wheel_model
    save_model(root / "train", m.pipeline, m.channels, m.window, m.classes, {"dataset": "t"})
    save_served_model(root / "served", root / "train", served_settings(m, max_rows=5000))
    return root / "train", root / "served"


@pytest.fixture(scope="module")
def served(model_dirs):
    import mlflow.pyfunc
    return mlflow.pyfunc.load_model(str(model_dirs[1]))


@pytest.fixture(scope="module")
def request_frame(unseen_wheel_request):
    """12 s of the wheel stream of an unseen run, long format."""
    return unseen_wheel_request(12.0)


def _body(frame: pd.DataFrame) -> str:
    split = json.loads(frame.to_json(orient="split", index=False))
    return json.dumps({"dataframe_split": split})


def _call(served, frame):
    """(HTTP status, parsed JSON body) of MLflow's /invocations handler."""
    from mlflow.exceptions import MlflowException
    from mlflow.pyfunc import scoring_server

    try:
        res = scoring_server.invocations(_body(frame), "application/json", served, None)
    except MlflowException as exc:
        return exc.get_http_status_code(), json.loads(exc.serialize_as_json())
    return res.status, json.loads(res.response)


def test_answer_is_the_in_process_service(served, request_frame, wheel_model):
    status, body = _call(served, request_frame)
    assert status == 200
    got = pd.DataFrame(body["predictions"])
    service = StreamService(wheel_model, TableTargets(wheel_model.classes,
                                                      DesiredSlipConfig(min_confidence=0.5)),
                            StreamConfig(hop_s=0.5))
    run = parse_request(request_frame, {"wheels": WHEEL_CHANNELS}, 2.0, 10_000)
    want = decisions_frame(replay_run(service, run), wheel_model.classes)
    assert list(got.columns) == [*want.columns, "dropped", "ignored_columns",
                                 "n_ignored_columns"]
    # 12 s of stream: decisions every 0.5 s from the end of the first 2 s window on
    assert len(got) == len(want) >= 10
    assert np.allclose(np.diff(got["t_s"]), 0.5)
    assert got["t_s"].iloc[-1] <= request_frame["t_s"].iloc[-1]
    np.testing.assert_allclose(got["t_s"], want["t_s"])
    proba = [c for c in want.columns if c.startswith("proba_")]
    np.testing.assert_allclose(got[proba], want[proba], atol=1e-9)
    np.testing.assert_allclose(got[proba].sum(axis=1), 1.0, atol=1e-6)
    assert (got["terrain"] == want["terrain"].fillna("")).all()
    assert not got["dropped"].any()


@pytest.mark.parametrize("wide", [False, True])
def test_rows_of_a_stream_the_model_does_not_use_are_flagged_not_checked(served, request_frame,
                                                                         wide):
    """IMU rows sent to a wheel-only model are not read (even unsorted or as text): the
    answer is the wheels' and every window says the IMU was unused (it said nothing)."""
    status, plain = _call(served, request_frame)
    imu = pd.DataFrame({"stream": "imu", "t_s": ["9", "8", "x"], "ax": 0.1})
    frame = pd.concat([request_frame.astype({"t_s": object}), imu], ignore_index=True)
    if wide:
        frame = request_frame.drop(columns="stream").rename(columns={"t_s": "wheels_t_s"})
        frame["imu_t_s"] = np.nan
        frame.loc[:2, "imu_t_s"] = [9.0, 8.0, 7.0]
    status, body = _call(served, frame)
    assert status == 200, body
    got, want = pd.DataFrame(body["predictions"]), pd.DataFrame(plain["predictions"])
    assert (got["flags"] == "unused:imu").all() and (want["flags"] == "").all()
    pd.testing.assert_frame_equal(got.drop(columns="flags"), want.drop(columns="flags"))


@pytest.mark.parametrize("wide", [False, True])
def test_columns_the_model_does_not_know_are_named_in_the_answer(served, request_frame, wide):
    """Unknown columns (a CSV index, a typo of a channel, extra sensors) were ignored
    without a word (the answer was the plain one); every window now names them and their
    count, and the answer is otherwise unchanged."""
    frame = request_frame
    if wide:
        frame = frame.drop(columns="stream").rename(columns={"t_s": "wheels_t_s"})
    status, plain = _call(served, frame)
    extra = ["Unnamed: 0", "cur_left", "gps_lat", "x1", "x2", "x3", "x4"]
    status, body = _call(served, frame.assign(**{c: 1.0 for c in extra}))
    assert status == 200, body
    got, want = pd.DataFrame(body["predictions"]), pd.DataFrame(plain["predictions"])
    assert (want["n_ignored_columns"] == 0).all() and (want["ignored_columns"] == "").all()
    assert (got["n_ignored_columns"] == 7).all()
    assert (got["ignored_columns"]
            == "['Unnamed: 0', 'cur_left', 'gps_lat', 'x1', 'x2'] and 2 more").all()
    ignored = ["ignored_columns", "n_ignored_columns"]
    pd.testing.assert_frame_equal(got.drop(columns=ignored), want.drop(columns=ignored))


def test_wide_format_gives_the_same_answer(served, request_frame):
    wide = request_frame.drop(columns="stream").rename(columns={"t_s": "wheels_t_s"})
    assert _call(served, wide) == _call(served, request_frame)


@pytest.mark.parametrize("rows, words", [
    ([30], "holds values of the stream's channels"),         # stamp empty, values kept
    ([30, 31], "holds values of the stream's channels"),
    (["30 all"], "comes before a stamped row"),              # the whole row empty
])
def test_wide_format_empty_stamp_inside_a_stream_is_refused(served, request_frame, rows,
                                                            words):
    """An empty ``<stream>_t_s`` cell is refused as the long format refuses a null ``t_s``
    (it was skipped without a word: the row's values were lost and the answer changed);
    only a shorter stream's trailing cells may be empty."""
    wide = request_frame.drop(columns="stream").rename(columns={"t_s": "wheels_t_s"})
    for row in rows:
        if isinstance(row, str):
            wide.loc[int(row.split()[0])] = np.nan
        else:
            wide.loc[row, "wheels_t_s"] = np.nan
    status, body = _call(served, wide)
    assert status == 400, body
    msg = body["message"]
    assert msg.startswith("NonFiniteError: non-finite timestamp in stream 'wheels'"), msg
    assert words in msg and "column 'wheels_t_s', data row 30" in msg, msg
    # the long format's refusal of the same sample
    long = request_frame.copy()
    long.loc[30, "t_s"] = np.nan
    long_msg = _call(served, long)[1]["message"]
    assert long_msg.startswith("NonFiniteError: non-finite timestamp in stream 'wheels'")


def test_wide_format_trailing_empty_cells_are_accepted(served, request_frame):
    wide = request_frame.drop(columns="stream").rename(columns={"t_s": "wheels_t_s"})
    longer = pd.concat([wide, pd.DataFrame(np.nan, index=range(5), columns=wide.columns)],
                       ignore_index=True)
    assert _call(served, longer) == _call(served, wide)


def test_gap_and_isolated_nan_are_flagged_not_refused(served, request_frame):
    frame = request_frame.copy()
    frame.loc[20, "cur_l"] = np.nan  # isolated: the service drops the sample
    frame = frame.drop(index=range(40, 60))  # ~3 s gap: its windows are dropped
    status, body = _call(served, frame)
    assert status == 200
    got = pd.DataFrame(body["predictions"])
    assert got["flags"].str.contains("non_finite").any()
    dropped = got[got["dropped"]]
    assert len(dropped) and dropped["flags"].str.contains("gap").all()


@pytest.mark.parametrize("value", [np.inf, -np.inf])
def test_isolated_inf_is_flagged_as_a_nan_is_not_refused(served, request_frame, value):
    """An isolated inf is a non-finite sample, as a NaN: the windows holding it are flagged
    ``non_finite``; it was refused as a value beyond the channel's range."""
    from mlflow.pyfunc import scoring_server

    answers = []
    for bad in (np.nan, value):
        frame = request_frame.copy()
        frame.loc[20, "cur_l"] = bad
        # CSV: JSON from pandas would write the inf as null
        res = scoring_server.invocations(frame.to_csv(index=False), "text/csv", served, None)
        assert res.status == 200, res.response
        answers.append(pd.DataFrame(json.loads(res.response)["predictions"]))
    assert answers[1]["flags"].str.contains("non_finite").any()
    pd.testing.assert_frame_equal(answers[1], answers[0])
    # a finite value beyond the range is still refused
    frame = request_frame.copy()
    frame.loc[20, "cur_l"] = 1e6
    status, body = _call(served, frame)
    assert status == 400 and body["message"].startswith("ImplausibleValueError"), body


def _swap(f):
    f = f.copy()
    f.iloc[[5, 6]] = f.iloc[[6, 5]].to_numpy()
    return f


def _dup(f):
    f = f.copy()
    f.loc[6, "t_s"] = f.loc[5, "t_s"]
    return f


def _text(f):
    f = f.astype({"vel_l": object})
    f.loc[3, "vel_l"] = "fast"
    return f


def _ms(f):
    return f.assign(t_s=f["t_s"] * 1000.0)


def _fast(f):
    return f.assign(t_s=f["t_s"] / 1000.0)  # 6.5 kHz wheel reports


def _nan_burst(f):
    f = f.copy()
    f.loc[10:13, "vel_r"] = np.nan
    return f


BAD = {
    "missing channel": (lambda f: f.drop(columns="cur_l"), "MissingColumnError", "cur_l"),
    "missing stream": (lambda f: f.assign(stream="imu"), "MissingColumnError", "wheels"),
    "wrong type": (_text, "NonNumericError", "'fast'"),
    "unsorted time": (_swap, "TimestampError", "decreasing"),
    "duplicated time": (_dup, "TimestampError", "duplicated"),
    "time in ms": (_ms, "UnitError", "milliseconds"),
    "wrong rate": (_fast, "DataFormatError", "outside its nominal 1-1000 Hz"),
    "too short": (lambda f: f.head(8), "DataFormatError", "too short"),
    "NaN burst": (_nan_burst, "NonFiniteError", "burst of 4"),
    "implausible value": (lambda f: f.assign(cur_r=1e300), "ImplausibleValueError", "cur_r"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_malformed_request_is_a_typed_400(served, request_frame, case):
    make, error, words = BAD[case]
    status, body = _call(served, make(request_frame))
    assert status == 400
    assert body["message"].startswith(f"{error}: ") and words in body["message"]
    assert "stack_trace" not in body and "Traceback" not in body["message"]
    assert "Failed to predict" not in body["message"] and len(body["message"]) < 600


def test_row_limit(request_frame):
    with pytest.raises(DataFormatError, match="exceeds the limit of 10"):
        parse_request(request_frame, {"wheels": WHEEL_CHANNELS}, 2.0, 10)


def test_serve_refuses_a_non_loopback_host(model_dirs, capsys):
    from terrain.cli import main
    assert main(["serve", "--model", str(model_dirs[0]), "--host", "0.0.0.0"]) == 2
    assert "not a loopback address" in capsys.readouterr().err


def test_serve_says_an_empty_host_is_empty(tmp_path, capsys):
    # --host "" (an unset shell variable) said "--host is not a loopback address": the value
    # the user gave was not to be seen
    from terrain.cli import main
    model = str(tmp_path / "model")
    assert main(["serve", "--model", model, "--host", ""]) == 2
    assert capsys.readouterr().err.strip() == (
        "terrain serve: error: --host is empty (''): give a loopback address "
        "(127.0.0.1, ::1 or localhost)")
    assert main(["serve", "--model", model, "--host", "  "]) == 2
    assert "error: --host is blank (" in capsys.readouterr().err


def _error(served, frame) -> str:
    status, body = _call(served, frame)
    assert status == 400, body
    assert not body.get("stack_trace") and len(body["message"]) < 600
    return body["message"]


@pytest.mark.parametrize("value", ["gps", None, 7, "wheel"])
def test_unknown_stream_is_a_typed_400(served, request_frame, value):
    frame = request_frame.astype({"stream": object})
    frame.loc[[3, 9], "stream"] = value
    message = _error(served, frame)
    assert message.startswith("DataFormatError: unknown stream ")
    assert ("empty" if value is None else repr(value)) in message
    assert "'imu', 'wheels'" in message and "data rows 3, 9" in message


def test_boolean_in_a_number_column_is_a_typed_400(served, request_frame):
    frame = request_frame.astype({"cur_r": object})
    frame.loc[7, "cur_r"] = True  # JSON true, which pandas would read as 1.0
    message = _error(served, frame)
    assert message.startswith("NonNumericError: boolean value True")
    assert "column 'cur_r', data row 7" in message


def test_huge_integer_is_a_typed_400(served, request_frame):
    from mlflow.exceptions import MlflowException
    from mlflow.pyfunc import scoring_server

    frame = request_frame.assign(t_s=request_frame["t_s"].astype(object))
    frame.loc[2, "t_s"] = 123456.75
    body = _body(frame).replace("123456.75", "1" + "0" * 400)
    with pytest.raises(MlflowException) as info:
        scoring_server.invocations(body, "application/json", served, None)
    assert info.value.get_http_status_code() == 400
    assert info.value.message.startswith("ImplausibleValueError: number beyond the float")
    assert "column 't_s', data row 2" in info.value.message


def test_wheel_speeds_in_kmh_are_refused_as_the_readers_do(served, request_frame):
    """The readers' rule wheel_speed_units: above twice the Husky's top speed is certain."""
    message = _error(served, request_frame.assign(vel_l=3.4, vel_r=-3.4))
    assert message.startswith("UnitError: rule wheel_speed_units")
    # likely (above 1.2 x top speed): decided, every window flagged
    status, body = _call(served, request_frame.assign(vel_l=1.5, vel_r=-1.5))
    assert status == 200
    got = pd.DataFrame(body["predictions"])
    assert got["flags"].str.contains("warning:wheel_speed_units").all()


def test_plausibility_flags():
    checks = {"stuck": {"wheels.cur_l": [[5.0, 6.0]]},
              "warnings": ["request: rule gyro_units: gyro spread 0.5 rad/s ..."]}
    frame = pd.DataFrame({"t_s": [4.0, 6.5, 9.0], "window_age_s": 0.0,
                          "flags": ["", "gap", ""]})
    flags = _plausibility_flags(frame, 2.0, checks)
    assert flags == ["warning:gyro_units", "gap|stuck:wheels.cur_l|warning:gyro_units",
                     "warning:gyro_units"]
    held = _plausibility_flags(frame, 2.0, {}, {("wheels", "time_ahead"): 4})
    assert held == ["held:wheels", "gap|held:wheels", "held:wheels"]


@pytest.fixture(scope="module")
def long_unseen_run(borealtc_runs, train_runs):
    """An unseen run with an IMU whose wheel stream lasts over 31 s."""
    seen = {r.run_id for r in train_runs}
    return next(r for r in borealtc_runs if r.run_id not in seen and r.has_imu
                and float(r.streams["wheels"]["t_s"].iloc[-1]
                          - r.streams["imu"]["t_s"].iloc[0]) > 31.0)


def test_answer_is_strict_json_null_age_where_no_window_was_built(
        served_all, long_unseen_run):
    """A ``short`` decision (no window built: the streams do not overlap in it) has an
    infinite age in-process; the served answer writes it as null, never the bare token
    Infinity (not JSON, RFC 8259, which strict parsers refuse)."""
    from mlflow.pyfunc import scoring_server

    imu, wheels = long_unseen_run.streams["imu"], long_unseen_run.streams["wheels"]
    t0 = float(imu["t_s"].iloc[0])
    imu = imu[imu["t_s"] < t0 + 8.0].assign(stream="imu")
    wheels = wheels[wheels["t_s"] < t0 + 8.0].assign(stream="wheels")
    wheels["t_s"] += 6.0  # the first windows hold IMU samples only
    frame = pd.concat([imu, wheels], ignore_index=True)
    res = scoring_server.invocations(_body(frame), "application/json", served_all, None)
    assert res.status == 200, res.response

    def refuse(token):
        raise ValueError(f"non-standard JSON constant {token}")

    got = pd.DataFrame(json.loads(res.response, parse_constant=refuse)["predictions"])
    short = got["flags"].str.split("|").apply(lambda f: "short" in f)
    null = got["window_age_s"].isna()
    assert null.any() and short[null].all() and got.loc[null, "dropped"].all()
    age = got.loc[~null, "window_age_s"].astype(float)   # a short window may have an age
    assert len(age) and np.isfinite(age).all() and (age >= 0).all()


def test_windows_a_unit_rule_kept_from_the_classifier_are_dropped(served_all,
                                                                  long_unseen_run):
    """The service does not classify a window whose accelerometer reads in g
    (``accel_units``; the last 8 s of 30 here, so the request as a whole passes the
    readers' rule); the answer called such windows not dropped (only ``gap`` and ``short``
    counted), against its own definition of ``dropped``."""
    from mlflow.pyfunc import scoring_server

    imu, wheels = long_unseen_run.streams["imu"], long_unseen_run.streams["wheels"]
    t0 = float(imu["t_s"].iloc[0])
    imu = imu[imu["t_s"] < t0 + 30.0].assign(stream="imu")
    late = imu["t_s"] >= t0 + 22.0
    for c in ("ax", "ay", "az"):
        imu.loc[late, c] = imu.loc[late, c] / 9.80665
    wheels = wheels[wheels["t_s"] < t0 + 30.0].assign(stream="wheels")
    frame = pd.concat([imu, wheels], ignore_index=True)
    res = scoring_server.invocations(_body(frame), "application/json", served_all, None)
    assert res.status == 200, res.response
    got = pd.DataFrame(json.loads(res.response)["predictions"])
    units = got["flags"].str.split("|").apply(lambda f: "accel_units" in f)
    assert units.sum() >= 10
    assert got.loc[units, "dropped"].all()
    plain = got["flags"] == ""
    assert plain.sum() >= 10 and not got.loc[plain, "dropped"].any()


def test_windows_with_wheel_speeds_in_kmh_are_dropped(served, long_unseen_run):
    """Three speeds of 3.4 (km/h; under 1 % of the request's, so the request passes the
    readers' run-level rule) put the windows holding them over twice the Husky's top
    speed: those windows are flagged ``wheel_speed_units`` and dropped, the others not (the
    served model built its service without the vehicle, so the rule never ran and they
    were classified)."""
    wheels = long_unseen_run.streams["wheels"]
    frame = wheels[wheels["t_s"] < wheels["t_s"].iloc[0] + 30.0].assign(stream="wheels")
    frame = frame[COLUMNS].reset_index(drop=True)
    frame.loc[100:102, "vel_l"] = 3.4
    status, body = _call(served, frame)
    assert status == 200, body
    got = pd.DataFrame(body["predictions"])
    units = got["flags"].str.split("|").apply(lambda f: "wheel_speed_units" in f)
    assert 1 <= units.sum() <= 8 and (got["dropped"] == units).all()


def test_samples_still_held_when_the_request_ends_are_named_on_every_window(served_all,
                                                                            long_unseen_run):
    """A wheel stream that steps 20 s ahead of the IMU's clock near the end of a request is
    held until the IMU catches up, which it never does: the answer says so on every window
    (``held:wheels``) instead of ending early without a word; its decisions are those of the
    request without the stepped samples, as far as they go."""
    served = served_all
    imu, wheels = long_unseen_run.streams["imu"], long_unseen_run.streams["wheels"]
    t0 = float(imu["t_s"].iloc[0])
    imu = imu[imu["t_s"] < t0 + 10.0].assign(stream="imu")
    near = wheels[wheels["t_s"] < t0 + 9.0].assign(stream="wheels")
    ahead = wheels[(wheels["t_s"] >= t0 + 29.3) & (wheels["t_s"] < t0 + 30.0)]
    assert len(ahead) >= 3
    plain_req = pd.concat([imu, near], ignore_index=True)
    held_req = pd.concat([plain_req, ahead.assign(stream="wheels")], ignore_index=True)
    status, plain = _call(served, plain_req)
    assert status == 200, plain
    status, held = _call(served, held_req)
    assert status == 200, held
    plain, held = pd.DataFrame(plain["predictions"]), pd.DataFrame(held["predictions"])
    assert not plain["flags"].str.contains("held:").any()
    assert len(held) >= 10 and held["flags"].str.contains("held:wheels").all()
    cut = plain.iloc[:len(held)]
    pd.testing.assert_frame_equal(held.drop(columns="flags"), cut.drop(columns="flags"))
    # the request's clocks no longer overlap well either: the readers' rule says so too
    added = {"held:wheels", "warning:clock_overlap"}
    assert all(added <= set(x.split("|")) for x in held["flags"])
    strip = ["|".join(f for f in x.split("|") if f not in added) for x in held["flags"]]
    assert strip == list(cut["flags"])


def test_a_request_whose_only_decisions_would_need_held_samples_is_a_typed_400(
        served_all, long_unseen_run):
    """2.5 s of IMU and 1 s of wheels, then 1.5 s of wheels 20 s on: the wheels never reach
    the first decision's time before their step ahead, which is held for the IMU to catch
    up. Before, the answer was an empty 200; now a 400 names the held samples."""
    imu, wheels = long_unseen_run.streams["imu"], long_unseen_run.streams["wheels"]
    t0 = float(imu["t_s"].iloc[0])
    w = pd.concat([wheels[wheels["t_s"] < t0 + 1.0],
                   wheels[(wheels["t_s"] >= t0 + 20.0) & (wheels["t_s"] < t0 + 21.5)]])
    frame = pd.concat([imu[imu["t_s"] < t0 + 2.5].assign(stream="imu"),
                       w.assign(stream="wheels")], ignore_index=True)
    message = _error(served_all, frame)
    assert message.startswith("DataFormatError: no decision: ")
    assert "sample(s) of stream 'wheels' held (time_ahead) when the request ended" in message


def _synthetic(step_s: float, n: int) -> pd.DataFrame:
    rng = np.random.default_rng(0)
    return pd.DataFrame({"stream": "wheels", "t_s": 10.0 + np.arange(n) * step_s,
                         "vel_l": 0.2, "vel_r": 0.2, "cur_l": rng.uniform(5, 20, n),
                         "cur_r": rng.uniform(5, 20, n)})


def test_rate_at_the_nominal_bound_is_accepted_and_the_message_agrees():
    streams = {"wheels": WHEEL_CHANNELS}
    # 1 ms float steps imply 1000.0000000006 Hz: the nominal 1-1000 Hz (was refused)
    parse_request(_synthetic(0.001, 2500), streams, 2.0, 10_000)
    with pytest.raises(DataFormatError, match=r"implies 1010 Hz, outside its nominal "
                                              r"1-1000 Hz"):
        parse_request(_synthetic(0.00099, 2500), streams, 2.0, 10_000)


def test_request_errors_name_the_requests_own_row_and_time_column():
    """The range rule named the row within its stream (data row 5 for the request's row
    316, behind 311 IMU rows) and the clock and unit rules a column 'time' the request does
    not have, with 'file request and request' (HTTP fuzz)."""
    imu = pd.DataFrame({"stream": "imu", "t_s": 10.0 + np.arange(300) * 0.01,
                        "ax": 0.0, "ay": 0.0, "az": 9.81, "wx": 0.0, "wy": 0.0, "wz": 0.0})
    wheels = _synthetic(0.154, 20)
    wheels.loc[5, "cur_l"] = 1e6
    frame = pd.concat([imu, wheels], ignore_index=True)
    streams = {"wheels": WHEEL_CHANNELS, "imu": ["ax", "ay", "az", "wx", "wy", "wz"]}
    with pytest.raises(ImplausibleValueError, match=r"first 1e\+06 at row 305 \(file "
                                                    r"request, column 'cur_l', data row 305"):
        parse_request(frame, streams, 2.0, 10_000)
    frame.loc[frame["stream"] == "imu", "t_s"] += 100.0   # clocks 100 s apart
    frame.loc[305, "cur_l"] = 10.0
    with pytest.raises(ClockError) as info:
        parse_request(frame, streams, 2.0, 10_000)
    assert "both streams must start near time 0" in str(info.value)
    assert str(info.value).endswith("(file request, column 't_s')")
    with pytest.raises(UnitError) as info:     # a clock in ms
        parse_request(_synthetic(154.0, 20), {"wheels": WHEEL_CHANNELS}, 2.0, 10_000)
    assert str(info.value).endswith("(file request, column 't_s')")


@pytest.mark.parametrize("span_s, shown", [(1.9999999, "spans 1.9999999 s"),
                                           (1.5, "spans 1.5 s")])
def test_a_stream_just_short_of_a_window_says_by_how_much(span_s, shown):
    """A span under the window rounded to 3 digits read "spans 2 s ... needs 2 s"."""
    frame = _synthetic(0.1, 11)
    frame["t_s"] = np.linspace(10.0, 10.0 + span_s, 11)
    with pytest.raises(DataFormatError, match=rf"too short: it {shown} over 11 sample\(s\); "
                                              r"one window needs 2 s"):
        parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 10_000)


def test_a_stream_of_exactly_one_window_is_taken_and_makes_one_decision():
    """The bounds of a request's span: exactly one window (2.0 s, 1/8 s steps, exact in
    binary) is long enough and makes one decision, half a hop more makes two."""
    streams = {"wheels": WHEEL_CHANNELS}
    run = parse_request(_synthetic(0.125, 17), streams, 2.0, 100)
    assert planned_decisions(run, 2.0, 0.5) == 1
    assert planned_decisions(run, 2.5, 0.5) == 0
    assert planned_decisions(parse_request(_synthetic(0.125, 21), streams, 2.0, 100),
                             2.0, 0.5) == 2


def test_the_row_limit_and_the_lowest_nominal_rate_are_taken_at_their_bounds():
    streams = {"wheels": WHEEL_CHANNELS}
    frame = _synthetic(0.125, 20)
    assert len(parse_request(frame, streams, 2.0, 20).streams["wheels"]) == 20
    with pytest.raises(DataFormatError, match="request of 20 rows exceeds the limit of 19;"):
        parse_request(frame, streams, 2.0, 19)
    parse_request(_synthetic(1.0, 3), streams, 2.0, 100)   # 1 Hz: the nominal 1-1000 Hz
    with pytest.raises(DataFormatError, match=r"implies 0.9901 Hz, outside its nominal "
                                              r"1-1000 Hz"):
        parse_request(_synthetic(1.01, 3), streams, 2.0, 100)


@pytest.mark.parametrize("value, what", [(10.0, "decreasing timestamp 10.0 after 10.5"),
                                         (10.5, "duplicated timestamp 10.5 after 10.5")])
def test_a_time_error_names_the_row_that_goes_back(value, what):
    """As README's example: the row moved back in time is named, not the one before it."""
    frame = _synthetic(0.125, 20)
    frame.loc[5, "t_s"] = value
    with pytest.raises(TimestampError) as info:
        parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 100)
    assert what in str(info.value)
    assert str(info.value).endswith("(file request, column 't_s', data row 5 (0-based))")


def test_a_burst_of_two_non_finite_values_is_repaired_and_one_of_three_refused():
    frame = _synthetic(0.125, 20)
    frame.loc[[5, 6], "cur_l"] = np.nan
    run = parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 100)
    assert run.streams["wheels"]["cur_l"].isna().sum() == 2   # left to the service
    frame.loc[7, "cur_l"] = np.inf
    with pytest.raises(NonFiniteError, match=r"burst of 3 non-finite values \(more than 2 "
                                             r"are not repaired\) \(file request, column "
                                             r"'cur_l', data row 5"):
        parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 100)


def test_a_column_of_booleans_is_refused_not_read_as_ones():
    """JSON ``true`` in every row gives a boolean column, which NumPy would read as 1.0."""
    frame = _synthetic(0.125, 20).assign(vel_l=True)
    assert frame["vel_l"].dtype == bool
    with pytest.raises(NonNumericError, match=r"boolean value True where a number is "
                                              r"expected \(20 such value\(s\)\) \(file "
                                              r"request, column 'vel_l', data row 0"):
        parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 100)


def test_a_wide_row_past_the_last_stamp_holding_one_value_is_refused():
    """A value after its stream's last stamp would be dropped without a word."""
    wide = _synthetic(0.125, 20).drop(columns="stream").rename(columns={"t_s": "wheels_t_s"})
    wide.loc[20] = np.nan
    wide.loc[20, "cur_l"] = 12.0
    with pytest.raises(NonFiniteError) as info:
        parse_request(wide, {"wheels": WHEEL_CHANNELS}, 2.0, 100)
    assert "wheels_t_s is empty in a row that holds values of the stream's channels" \
        in str(info.value)
    assert str(info.value).endswith("(file request, column 'wheels_t_s', data row 20 "
                                    "(0-based))")


def test_time_columns_of_the_other_format_are_named_as_ignored():
    """A long request's ``<stream>_t_s`` columns, and a wide request's ``t_s``, are not
    read: they are named in the answer like any other unread column."""
    streams = {"wheels": WHEEL_CHANNELS}
    long = _synthetic(0.125, 20).assign(wheels_t_s=1.0, imu_t_s=2.0)
    assert parse_request(long, streams, 2.0, 100).meta["ignored_columns"] == [
        "wheels_t_s", "imu_t_s"]
    wide = long.drop(columns=["stream", "wheels_t_s"]).rename(columns={"t_s": "wheels_t_s"})
    wide = wide.assign(t_s=0.0, imu_t_s=np.nan)
    assert parse_request(wide, streams, 2.0, 100).meta["ignored_columns"] == ["t_s"]


def test_unknown_streams_are_listed_five_and_a_count():
    frame = _synthetic(0.125, 20).astype({"stream": object})
    frame.loc[3:9, "stream"] = list("abcdefg")
    with pytest.raises(DataFormatError) as info:
        parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 100)
    assert str(info.value).startswith("unknown stream 'a', 'b', 'c', 'd', 'e' and 2 more in 7 "
                                      "row(s), data rows 3")


def _replay(service_cls, model, frame):
    service = service_cls(model, TableTargets(model.classes,
                                              DesiredSlipConfig(min_confidence=0.5)),
                          StreamConfig(hop_s=0.5))
    run = parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 10_000)
    return decisions_frame(replay_run(service, run, max_chunk=32), model.classes)


def test_windows_over_a_gap_are_those_of_the_whole_grid_without_building_it(
        wheel_model, request_frame, monkeypatch):
    """The service aligns only its window's end of the streams' grid: the decisions over
    gaps, short and long, are those of the whole grid (how it aligned before), and no window
    builds more grid than its own (it built the whole gap, per window, so a request with
    one large time jump took minutes)."""
    from terrain.io.align import anchored_grid_tail
    from terrain.run import clock_slack
    from terrain.serving import service as service_module

    frame = request_frame.drop(index=range(15, 25))  # a hole of ~1.5 s
    frame.loc[frame.index >= frame.index[len(frame) // 2], "t_s"] += 40.0  # a jump of 40 s
    sizes = []

    def tail(times, rate_hz, anchor_s, n_last):
        out = anchored_grid_tail(times, rate_hz, anchor_s, n_last)
        sizes.append(out[0].size)
        return out

    monkeypatch.setattr(service_module, "anchored_grid_tail", tail)
    got = _replay(StreamService, wheel_model, frame)

    def whole_grid(times, rate_hz, anchor_s, n_last):
        # the whole grid through the anchor over the streams' overlap (the ends within
        # the clock's rounding), built point by point
        t0 = max(t[0] for t in times) - clock_slack(max(t[0] for t in times))
        t1 = min(t[-1] for t in times) + clock_slack(min(t[-1] for t in times))
        grid = [anchor_s - k / rate_hz for k in range(int((anchor_s - t0) * rate_hz) + 2)]
        grid = np.array(sorted(g for g in grid if t0 <= g <= t1))
        return grid[max(len(grid) - n_last, 0):], len(grid)

    monkeypatch.setattr(service_module, "anchored_grid_tail", whole_grid)
    want = _replay(StreamService, wheel_model, frame)
    pd.testing.assert_frame_equal(got, want)
    assert want["flags"].str.contains("gap").sum() > 80
    assert max(sizes) <= 2.0 * wheel_model.window.rate_hz


def test_decisions_are_bounded_before_any_work(served, request_frame, wheel_model):
    run = parse_request(request_frame, {"wheels": WHEEL_CHANNELS}, 2.0, 10_000)
    status, body = _call(served, request_frame)
    assert planned_decisions(run, 2.0, 0.5) - 1 <= len(body["predictions"]) \
        <= planned_decisions(run, 2.0, 0.5)
    frame = request_frame.copy()
    frame.loc[50:, "t_s"] += 1e5
    message = _error(served, frame)
    assert message.startswith("DataFormatError: request spanning ")
    assert f"above the limit of {MAX_DECISIONS}" in message and "column 't_s'" in message
    # the default bounds one request's work: 1000 s of stream at the 0.5 s hop
    assert MAX_DECISIONS == 2000


@pytest.mark.parametrize("last_s, status", [(1001.5, 200), (1002.0, 400)])
def test_the_decision_limit_is_reached_not_passed(served, request_frame, last_s, status):
    """A request spanning one window and 1999 hops makes exactly the 2,000 decisions
    allowed (answered, every one); half a hop more would make 2,001 (refused)."""
    frame = request_frame.assign(t_s=request_frame["t_s"] - request_frame["t_s"].iloc[0])
    frame.loc[frame.index >= 40, "t_s"] += last_s - frame["t_s"].iloc[-1]
    assert frame["t_s"].iloc[-1] == last_s
    got, body = _call(served, frame)
    assert got == status, body
    if status == 200:
        assert len(body["predictions"]) == MAX_DECISIONS
    else:
        assert "would make 2001 decisions" in body["message"]


def test_settings_are_checked(wheel_model):
    with pytest.raises(ConfigError, match="shorter than one period"):
        served_settings(wheel_model, hop_s=1e-4)
    with pytest.raises(ConfigError, match="max_decisions"):
        served_settings(wheel_model, max_decisions=0)
    with pytest.raises(ConfigError, match="reset_confidence"):
        served_settings(wheel_model, reset_confidence=2.0)
    with pytest.raises(ConfigError, match="dwell_s must be a finite number"):
        served_settings(wheel_model, dwell_s=float("inf"))


def test_reset_settings_round_trip_and_old_models_have_none(wheel_model):
    settings = served_settings(wheel_model, reset_confidence=0.8, reset_windows=3)
    assert smoothing_of(json.loads(json.dumps(settings))) == SmoothingConfig(
        reset_confidence=0.8, reset_windows=3)
    older = {k: v for k, v in served_settings(wheel_model).items()
             if not k.startswith("reset_")}
    assert smoothing_of(older) == SmoothingConfig()


@pytest.mark.parametrize("argv, words", [
    (["--port", "70000"], "--port 70000 is outside 1-65535"),
    (["--port", "-1"], "--port -1 is outside 1-65535"),
    (["--max-body-bytes", "-1"], "--max-body-bytes must be a positive number"),
    (["--max-decisions", "0"], "--max-decisions must be a positive number"),
    (["--min-confidence", "1.5"], "argument --min-confidence: must be a probability in [0, 1]"),
    (["--min-confidence", "nan"], "argument --min-confidence: must be a probability in [0, 1]"),
    (["--reset-confidence", "0"], "--reset-confidence must be > 0"),
    (["--reset-confidence", "0.9", "--dwell-s", "0"], "--dwell-s 0 turns off"),
    (["--max-connections", "0"], "--max-connections must be a positive number"),
    (["--max-connections", "100000000"], "does not fit the open-file limit"),
    (["--header-timeout-s", "0"], "--header-timeout-s must be a finite number of seconds > 0"),
    (["--header-timeout-s", "nan"], "--header-timeout-s must be a finite number"),
])
def test_serve_refuses_bad_numbers_in_one_line(model_dirs, capsys, argv, words):
    from terrain.cli import main
    try:
        code = main(["serve", "--model", str(model_dirs[0]), *argv])
    except SystemExit as exc:     # argparse's own usage error (an option's type)
        code = exc.code
    assert code == 2
    out, err = capsys.readouterr()
    assert words in err.strip().splitlines()[-1] and "serving" not in out


def test_serve_refuses_a_port_in_use_before_announcing(model_dirs, capsys):
    from terrain.cli import main
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["serve", "--model", str(model_dirs[0]), "--port", str(port)]) == 2
    out, err = capsys.readouterr()
    assert f"127.0.0.1:{port}" in err and "in use" in err and "serving" not in out
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("argv, shown", [
    (["--hop-s", "0.25"], "--hop-s 0.25"),
    (["--dwell-s", "0"], "--dwell-s 0"),
    (["--min-confidence", "0.8"], "--min-confidence 0.8"),
    (["--reset-confidence", "0.9"], "--reset-confidence 0.9"),
    (["--reset-confidence", "0.9", "--reset-windows", "3"],
     "--reset-confidence 0.9, --reset-windows 3"),
    (["--max-decisions", "10"], "--max-decisions 10"),
    (["--served-out", "SERVED_COPY"], "--served-out SERVED_COPY"),
])
def test_serve_refuses_wrapping_options_for_an_already_wrapped_model(model_dirs, capsys,
                                                                     tmp_path, argv, shown):
    """A served (wrapped) model carries its own settings: the options that set them were
    ignored without a word (--hop-s 0.25 served decisions every 0.5 s). Refused before the
    port is bound (one in use here, so that the command cannot go on to serve)."""
    from terrain.cli import main
    train, served = model_dirs
    copy = tmp_path / "copy"
    argv = [str(copy) if a == "SERVED_COPY" else a for a in argv]
    shown = shown.replace("SERVED_COPY", str(copy))
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["serve", "--model", str(served), "--port", str(port), *argv]) == 2
    out, err = capsys.readouterr()
    assert f"{shown}: {served} is an already wrapped model" in err, err
    assert not copy.exists()  # nothing wrapped, nothing written
    assert "carries its own settings" in err and f"--model {train.resolve()}" in err
    assert len(err.strip().splitlines()) == 1 and "serving" not in out


def test_serve_takes_an_already_wrapped_model_with_options_at_their_defaults(model_dirs,
                                                                             capsys):
    """Given at their defaults, the options are no change: the server goes on to bind its
    port (here one in use, so that it stops there)."""
    from terrain.cli import main
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["serve", "--model", str(model_dirs[1]), "--port", str(port),
                     "--hop-s", "0.5", "--dwell-s", "10", "--max-decisions",
                     str(MAX_DECISIONS)]) == 2
    out, err = capsys.readouterr()
    assert "in use" in err and "already wrapped" not in err


@pytest.mark.parametrize("kind", ["train", "served"])
def test_serve_refuses_a_model_that_is_not_a_classifier(model_dirs, tmp_path, capsys, kind):
    import joblib
    from terrain.cli import main

    bad = tmp_path / kind
    shutil.copytree(model_dirs[0] if kind == "train" else model_dirs[1], bad)
    joblib.dump({"not": "a classifier"}, bad / "artifacts" / "pipeline.joblib")
    assert main(["serve", "--model", str(bad), "--port", "0"]) == 2
    out, err = capsys.readouterr()
    assert "dict" in err and "not a fitted classifier" in err and "serving" not in out


def _post(url: str, body: bytes) -> tuple[int, dict]:
    req = urllib.request.Request(url, body, {"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=20) as res:
            return res.status, json.loads(res.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def _raw(base: str, body: bytes, content_type: str | None,
         timeout: float = 30) -> tuple[int, dict]:
    """(status, JSON body) of a POST to /invocations with exactly this Content-Type (or
    none at all: urllib would add one)."""
    conn = http.client.HTTPConnection(base.removeprefix("http://"), timeout=timeout)
    try:
        headers = {"Content-Length": str(len(body))}
        if content_type is not None:
            headers["Content-Type"] = content_type
        conn.request("POST", "/invocations", body, headers)
        res = conn.getresponse()
        return res.status, json.loads(res.read())
    finally:
        conn.close()


@pytest.fixture(scope="module")
def server(model_dirs, tmp_path_factory):
    """A real ``terrain serve`` of the wheel model on 127.0.0.1 (one for the module):
    ``(process, base URL, wrapped model dir)``; the last test stops it with SIGTERM."""
    log = tmp_path_factory.mktemp("serve_log") / "stderr.txt"
    with open(log, "wb") as err:
        proc = subprocess.Popen([sys.executable, "-m", "terrain.cli", "serve", "--model",
                                 str(model_dirs[0]), "--host", "127.0.0.1", "--port", "0",
                                 "--max-body-bytes", "100000", "--max-connections", "20"],
                                stdout=subprocess.PIPE, stderr=err, text=True)
    try:
        line, deadline = "", time.monotonic() + 60
        while not line.startswith("serving "):
            line = proc.stdout.readline()
            assert line or proc.poll() is None, log.read_text()[-2000:]
            assert time.monotonic() < deadline, "server did not start within 60 s"
        found = re.search(r"^serving (\S+) on (http://127\.0\.0\.1:\d+)/invocations", line)
        assert found, line
        base = found.group(2)
        # announced only once the port is bound and listening: no retry loop needed
        urllib.request.urlopen(base + "/ping", timeout=20).close()
        yield proc, base, Path(found.group(1))
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        proc.stdout.close()


def test_real_server_answers_and_survives_bad_requests(server, request_frame):
    proc, base, _ = server
    good = _body(request_frame).encode()
    status, body = _post(base + "/invocations", good)
    assert status == 200 and len(body["predictions"]) >= 10
    status, body = _post(base + "/invocations", _body(_dup(request_frame)).encode())
    assert status == 400 and body["message"].startswith("TimestampError: ")
    big = pd.concat([request_frame] * 40, ignore_index=True)
    status, body = _post(base + "/invocations", _body(big).encode())
    assert status == 413 and body["error_code"] == "REQUEST_LIMIT_EXCEEDED", body
    _one_line_typed(body, "DataFormatError")
    assert "exceeds the limit of 100000" in body["message"]
    status, body = _post(base + "/invocations", b'{"dataframe_split": ')
    assert status == 400, body
    _one_line_typed(body, "DataFormatError")
    assert "the request body is not valid JSON (" in body["message"], body
    assert _post(base + "/invocations", good)[0] == 200  # still up
    assert proc.poll() is None


def _one_line_typed(body: dict, error: str) -> None:
    """The answer is the project's one-line typed message, with no stack trace or dump."""
    assert body["message"].startswith(f"{error}: "), body
    assert not body.get("stack_trace") and "Traceback" not in json.dumps(body)
    assert "\n" not in body["message"] and len(body["message"]) <= 500


_HEADER = ",".join(COLUMNS).encode() + b"\n"
#: bodies MLflow's own parsers refuse, with the project's error each must answer
UNPARSABLE = {
    "empty csv": (b"", "text/csv", "EmptyFileError", "no CSV table"),
    "extra field": (_HEADER + b"wheels,1,2,3,4,5\nwheels,1,2,3,4,5,6\n", "text/csv",
                    "RaggedRowError", "line 3"),
    "unterminated quote": (_HEADER + b'"wheels,1,2,3,4,5\n', "text/csv", "DataFormatError",
                           "unterminated quote"),
    "garbage parquet": (b"garbage", "application/vnd.apache.parquet", "DataFormatError",
                        "Parquet"),
    "invalid json": (b'{"dataframe_split": [1,', "application/json", "DataFormatError",
                     "not valid JSON"),
    "not utf-8": (b"\xff\xfe", "text/csv", "EncodingError", "UTF-8"),
    # was "not valid JSON (UnicodeDecodeError('utf-8', b'{...the request's bytes...'"
    "not utf-8 json": (b'{"dataframe_split": {"columns": ["stream"], "data": [["wh\xff\xfe'
                       b'els"]]}}', "application/json", "EncodingError",
                       "not UTF-8 text (byte 0xff at byte 57)"),
    # MLflow's tensor formats: the message said only "got ndarray" / "got dict"
    "mlflow inputs tensor": (b'{"inputs": [[1, 2]]}', "application/json", "DataFormatError",
                             "got ndarray (MLflow's 'inputs' and 'instances' tensor formats"),
    "mlflow instances records": (b'{"instances": [{"t_s": 1}]}', "application/json",
                                 "DataFormatError", "got dict (MLflow's 'inputs'"),
    # MLflow's own message ("... Got {'columns'}.") before the guard checked the shape
    "split without data": (b'{"dataframe_split": {"columns": ["stream"]}}', "application/json",
                           "DataFormatError", "dataframe_split must be an object with "
                           "'columns' and 'data' (and optionally 'index'), got ['columns']"),
    "stream cell holding a list": (b'{"dataframe_split": {"columns": ["stream", "t_s"], '
                                   b'"data": [[["wheels"], 1]]}}', "application/json",
                                   "DataFormatError", "unknown stream list ['wheels'] in 1 row"),
    "deeply nested json": (b'{"dataframe_split": ' + b"[" * 50_000, "application/json",
                           "DataFormatError", "nests deeper"),
    "integer of 5000 digits": (b'{"dataframe_split": {"columns": ["t_s"], "data": [[1'
                               + b"0" * 5000 + b"]]}}", "application/json",
                               "ImplausibleValueError", "4300 digits"),
}


@pytest.mark.parametrize("case", sorted(UNPARSABLE))
def test_real_server_unparsable_body_is_a_typed_400(server, case):
    body, content_type, error, words = UNPARSABLE[case]
    status, answer = _raw(server[1], body, content_type)
    assert status == 400, answer
    _one_line_typed(answer, error)
    assert words in answer["message"]


def test_real_server_without_content_type_is_a_415(server, request_frame):
    status, body = _raw(server[1], request_frame.to_csv(index=False).encode(), None)
    assert status == 415
    _one_line_typed(body, "DataFormatError")
    assert "Content-Type" in body["message"] and "text/csv" in body["message"]
    status, body = _raw(server[1], b"x", "text/plain")  # MLflow's plain-text 415, as JSON
    assert status == 415 and body["error_code"] == "BAD_REQUEST", body
    _one_line_typed(body, "DataFormatError")
    # MLflow's own words kept, under the project's name for them
    assert body["message"].startswith("DataFormatError: unsupported request content type: ")
    assert "text/plain" in body["message"], body


def test_real_server_huge_integer_is_a_typed_400(server, request_frame):
    frame = request_frame.assign(vel_l=request_frame["vel_l"].astype(object))
    frame.loc[4, "vel_l"] = 123456.75
    body = _body(frame).replace("123456.75", "1" + "0" * 400).encode()
    status, answer = _raw(server[1], body, "application/json")
    assert status == 400
    _one_line_typed(answer, "ImplausibleValueError")
    assert "'vel_l'" in answer["message"] and "data row 4" in answer["message"]


def test_real_server_time_jump_is_bounded(server, request_frame):
    """A small request with one large time jump answers at once: the windows over the
    jump are dropped ``gap`` rows, and past the decision limit it is refused."""
    jumped = request_frame.copy()
    jumped.loc[40:, "t_s"] += 900.0
    start = time.monotonic()
    status, body = _raw(server[1], jumped.to_csv(index=False).encode(), "text/csv")
    assert status == 200
    got = pd.DataFrame(body["predictions"])
    assert len(got) >= 1800 and got["flags"].str.contains("gap").sum() >= 1790
    assert (got["dropped"] == got["flags"].str.contains("gap|short")).all()
    jumped.loc[40:, "t_s"] += 200.0  # past the default limit (1000 s at the 0.5 s hop)
    status, body = _raw(server[1], jumped.to_csv(index=False).encode(), "text/csv")
    assert status == 400 and f"above the limit of {MAX_DECISIONS}" in body["message"]
    _one_line_typed(body, "DataFormatError")
    assert time.monotonic() - start < 20  # was > 60 s (504) for a 1e4 s jump


@pytest.mark.parametrize("columns, expected", [
    (["stream", "t_s", "vel_l", "vel_r", "cur_l", "cur_l"], "duplicated column name(s) ['cur_l']"),
    (["stream", "t_s", "vel_l", "vel_r", "cur_l", ["cur_r"]], "column names must be text"),
])
def test_real_server_refuses_repeated_or_non_text_column_names(server, request_frame,
                                                               columns, expected):
    """A repeated channel would shift the channels after it (a wrong answer with 200), a
    list as a name made MLflow fail with 500: both are the typed 400, checked before
    MLflow parses the body; the same CSV header too."""
    split = json.loads(request_frame.to_json(orient="split", index=False))
    body = json.dumps({"dataframe_split": {"columns": columns, "data": split["data"]}})
    status, answer = _raw(server[1], body.encode(), "application/json")
    assert status == 400 and expected in answer["message"], answer
    _one_line_typed(answer, "DataFormatError")
    csv = request_frame.to_csv(index=False).replace("cur_r", "cur_l", 1).encode()
    status, answer = _raw(server[1], csv, "text/csv")
    assert status == 400 and "duplicated column name(s) ['cur_l']" in answer["message"]


#: bodies whose refusal names many of the request's own names: the guard's message listed
#: every one (a 5,000-name CSV header repeated: a 70 kB message, a dump of the request)
_NAMES = [f"c{i:05d}" for i in range(5000)]
LONG_LISTS = {
    "repeated csv header": ((",".join(_NAMES * 2) + "\n").encode(), "text/csv",
                            "DataFormatError", "duplicated column name(s) ['c00000', "
                            "'c00001', 'c00002', 'c00003', 'c00004'] and 4995 more"),
    "repeated split columns": (json.dumps({"dataframe_split": {"columns": _NAMES[:4000] * 2,
                                                               "data": []}}).encode(),
                               "application/json", "DataFormatError", "and 3995 more"),
    "record lacking keys": (json.dumps({"dataframe_records": [dict.fromkeys(_NAMES, 1),
                                                              {"c00000": 1}]}).encode(),
                            "application/json", "RaggedRowError",
                            "record 1 (0-based) lacks ['c00001', 'c00002', 'c00003', "
                            "'c00004', 'c00005'] and 4994 more"),
    "record with other keys": (json.dumps({"dataframe_records": [
        {"c00000": 1}, dict.fromkeys(_NAMES, 1)]}).encode(), "application/json",
        "RaggedRowError", "and 4994 more"),
    "long top-level key": (json.dumps({"k" * 30_000: 1, "y": 2}).encode(), "application/json",
                           "DataFormatError", "the JSON body has the key(s)"),
}


@pytest.mark.parametrize("case", sorted(LONG_LISTS))
def test_real_server_refusal_lists_are_bounded(server, case):
    """A refusal naming the request's columns or keys shows the first few and a count: the
    message stays one line of at most 500 characters, never a dump of the request."""
    body, content_type, error, words = LONG_LISTS[case]
    status, answer = _raw(server[1], body, content_type)
    assert status == 400, answer
    _one_line_typed(answer, error)
    assert words in answer["message"]
    assert _raw(server[1], b"stream,t_s\n", "text/csv")[0] == 400  # still answering


def test_real_server_refuses_a_parquet_body_by_its_metadata(server, request_frame):
    """300,000 rows compress to a few kB: refused from the file's metadata (rows over the
    model's limit) before anything is decoded."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    n = 300_000
    table = pa.table({"stream": pa.array(["wheels"] * n).dictionary_encode(),
                      "t_s": np.zeros(n), **{c: np.full(n, 0.1) for c in
                                             WHEEL_CHANNELS}})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink, compression="zstd")
    body = sink.getvalue().to_pybytes()
    assert len(body) < 100_000  # under the server's --max-body-bytes
    start = time.monotonic()
    status, answer = _raw(server[1], body, "application/vnd.apache.parquet")
    assert status == 400 and "request of 300000 rows exceeds the limit" in answer["message"]
    assert time.monotonic() - start < 5
    _one_line_typed(answer, "DataFormatError")


def test_real_server_refuses_a_chunked_body_that_also_claims_a_length(server):
    """Transfer-Encoding beside Content-Length: the guard would count the announced length
    while the body is read by its chunks (a way past --max-body-bytes)."""
    host, port = server[1].removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=10) as sock:
        sock.sendall(b"POST /invocations HTTP/1.1\r\nHost: x\r\nContent-Type: text/csv\r\n"
                     b"Content-Length: 10\r\nTransfer-Encoding: chunked\r\n\r\n"
                     b"5\r\nhello\r\n0\r\n\r\n")
        answer = b""
        while b"}" not in answer:  # the JSON answer follows the headers
            part = sock.recv(65536)
            assert part, answer
            answer += part
        answer = answer.decode()
    assert answer.startswith("HTTP/1.1 400") and "Content-Length and Transfer-Encoding" \
        in answer


@pytest.mark.parametrize("method, path, status", [("GET", "/invocations", 405),
                                                  ("POST", "/predict", 404),
                                                  # FastAPI's own pages and its 307 redirect
                                                  ("GET", "/docs", 404),
                                                  ("GET", "/openapi.json", 404),
                                                  ("POST", "/invocations/", 404)])
def test_real_server_wrong_endpoint_is_a_typed_answer(server, method, path, status):
    """Only the endpoints the message names answer (the redirect of ``/invocations/`` was
    an empty 307 that a client not following it read as no answer)."""
    conn = http.client.HTTPConnection(server[1].removeprefix("http://"), timeout=10)
    try:
        conn.request(method, path, b"x" if method == "POST" else None,
                     {"Content-Type": "text/csv", "Content-Length": "1"}
                     if method == "POST" else {})
        res = conn.getresponse()
        answer = json.loads(res.read())
    finally:
        conn.close()
    assert res.status == status
    _one_line_typed(answer, "UnknownEndpointError" if status == 404 else "MethodNotAllowedError")
    assert "POST /invocations" in answer["message"]
    assert ("trailing slash" in answer["message"]) == path.endswith("/")


@pytest.mark.parametrize("row", [0, -1])
def test_a_non_finite_first_or_last_sample_is_refused(served, request_frame, row):
    """As the readers: a sample is repaired only between two finite ones; dropped at the
    edge it would move the decision grid and lose a decision without a word."""
    frame = request_frame.copy()
    frame.loc[frame.index[row], "cur_l"] = np.nan
    message = _error(served, frame)
    assert message.startswith("NonFiniteError: stream 'wheels': non-finite value in its "
                              + ("first" if row == 0 else "last") + " sample")
    assert message.endswith(f"column 'cur_l', data row {frame.index[row]} (0-based))")


def test_an_accelerometer_in_g_is_refused_as_the_readers_do(borealtc_runs):
    from terrain.errors import UnitError
    from terrain.run import IMU_CHANNELS

    run = next(r for r in borealtc_runs if r.has_imu)
    imu = run.streams["imu"]
    imu = imu[imu["t_s"] < imu["t_s"].iloc[0] + 5.0].assign(stream="imu")
    streams = {"imu": IMU_CHANNELS}
    parse_request(imu, streams, 2.0, 10_000)  # m/s^2: accepted
    in_g = imu.assign(**{c: imu[c] / 9.81 for c in ("ax", "ay", "az")})
    with pytest.raises(UnitError, match="looks like units of g"):
        parse_request(in_g, streams, 2.0, 10_000)


def test_messages_show_cells_as_plain_values(served, request_frame):
    frame = request_frame.astype({"stream": object})
    frame.loc[2, "stream"] = np.float64(1.5)
    message = _error(served, frame)
    assert "unknown stream 1.5 in 1 row(s)" in message and "np." not in message


@pytest.mark.slow
def test_connections_that_never_send_a_byte_cannot_take_the_server_down(server,
                                                                        request_frame):
    # uvicorn times out no connection before its first request: 1,100 such connections
    # took a server with the common 1,024 open-file limit down (accept failed with EMFILE,
    # /ping timed out); beyond --max-connections (20 here) a new connection closes the
    # oldest one idle for MIN_IDLE_S, else it is answered 503 (never reset)
    import socket

    from terrain.serving.http import MIN_IDLE_S

    host, port = server[1].removeprefix("http://").split(":")
    idle = [socket.create_connection((host, int(port)), timeout=5) for _ in range(60)]
    try:
        for sock in idle[-5:]:          # beyond the bound, none idle yet: answered 503
            sock.settimeout(5.0)
            answer = sock.recv(4096)
            assert answer.startswith(b"HTTP/1.1 503 ")
            body = json.loads(answer.split(b"\r\n\r\n", 1)[1])
            assert body["message"].startswith("ServiceBusyError: server holds its 20 "
                                              "connections")
        time.sleep(MIN_IDLE_S + 0.2)    # the oldest ones are now idle for MIN_IDLE_S
        status, body = _raw(server[1], request_frame.to_csv(index=False).encode(),
                            "text/csv", timeout=20)
        assert status == 200 and len(body["predictions"]) >= 10
        sock = idle[0]                  # the oldest was closed by the server
        sock.settimeout(2.0)
        assert sock.recv(1) == b""
        sock = idle[19]                 # the newest kept one is still served
        sock.sendall(b"GET /ping HTTP/1.1\r\nHost: x\r\n\r\n")
        assert sock.recv(100).startswith(b"HTTP/1.1 200")
    finally:
        for sock in idle:
            sock.close()


def test_bounded_connections_protocol_takes_a_positive_bound():
    from terrain.serving.http import bounded_connections_protocol
    assert bounded_connections_protocol(1).limit == 1
    for bad in (0, -5, True, 2.5):
        with pytest.raises(ConfigError, match="max_connections"):
            bounded_connections_protocol(bad)


def _bad_bodies(frame: pd.DataFrame) -> list[tuple[str, bytes, str, str, str]]:
    """(case, body, content type, error class, words of the message) of bad requests a
    client may send, in the formats the README documents (srv15 review)."""
    csv = frame.to_csv(index=False).encode()
    header, *lines = csv.split(b"\n")
    nan_t = frame.astype({"t_s": object})
    nan_t.loc[4, "t_s"] = None
    records = json.dumps({"dataframe_records": json.loads(frame.to_json(orient="records"))})
    return [
        ("duplicated stamp csv", _dup(frame).to_csv(index=False).encode(), "text/csv",
         "TimestampError", "duplicated timestamp"),
        ("swapped rows records", json.dumps({"dataframe_records": json.loads(
            _swap(frame).to_json(orient="records"))}).encode(), "application/json",
         "TimestampError", "decreasing timestamp"),
        ("empty stamp csv", nan_t.to_csv(index=False).encode(), "text/csv",
         "NonFiniteError", "'t_s'"),
        ("text cell split", _body(_text(frame)).encode(), "application/json",
         "NonNumericError", "'fast'"),
        ("stamps in ms csv", _ms(frame).to_csv(index=False).encode(), "text/csv",
         "UnitError", "milliseconds"),
        ("missing channel csv", frame.drop(columns="cur_r").to_csv(index=False).encode(),
         "text/csv", "MissingColumnError", "cur_r"),
        ("misspelt stream", frame.assign(stream="wheel").to_csv(index=False).encode(),
         "text/csv", "DataFormatError", "unknown stream 'wheel'"),
        ("too short", frame.iloc[:5].to_csv(index=False).encode(), "text/csv",
         "DataFormatError", "too short"),
        ("header only", header + b"\n", "text/csv", "MissingColumnError", "stream=wheels"),
        ("bom and header only", b"\xef\xbb\xbf" + header + b"\n", "text/csv",
         "MissingColumnError", "stream=wheels"),
        ("truncated last line", b"\n".join([header, *lines[:30], lines[30][:9]]),
         "text/csv", "RaggedRowError", "line 32"),
        ("truncated json", records.encode()[:-40], "application/json", "DataFormatError",
         "not valid JSON"),
        ("utf-16 csv", csv.decode().encode("utf-16"), "text/csv", "EncodingError", "UTF-16"),
        ("csv sent as json", csv, "application/json", "DataFormatError", "not valid JSON"),
        ("unicode column twice", csv.replace(b"cur_r", b"\xc3\xa9", 1).replace(
            b"cur_l", b"\xc3\xa9", 1), "text/csv", "DataFormatError",
         "duplicated column name(s) ['\u00e9']"),
    ]


def test_real_server_answers_bad_requests_typed_and_keeps_answering(server, request_frame):
    """Every bad request of :func:`_bad_bodies` is a 400 with the project's one-line typed
    message naming what is wrong, and the server answers the next request (/ping after
    each, the good request at the end); a column with a non-ASCII name is named as sent."""
    proc, base, _ = server
    start = time.monotonic()
    for case, body, content_type, error, words in _bad_bodies(request_frame):
        status, answer = _raw(base, body, content_type)
        assert status == 400, (case, answer)
        _one_line_typed(answer, error)
        assert words in answer["message"], (case, answer["message"])
        with urllib.request.urlopen(base + "/ping", timeout=20) as res:
            assert res.status == 200, case
    extra = request_frame.assign(**{"température": 1.0})
    status, answer = _raw(base, extra.to_csv(index=False).encode(), "text/csv")
    assert status == 200, answer
    got = pd.DataFrame(answer["predictions"])
    assert (got["ignored_columns"] == "['température']").all()
    assert proc.poll() is None and time.monotonic() - start < 20


@pytest.mark.slow
def test_stopping_the_server_removes_its_wrapped_model(server):
    """SIGTERM (what ``kill`` and service managers send) stops the server gracefully and
    removes the temporary wrapped model. Last test of the module: it stops the server."""
    proc, _, served_dir = server
    assert served_dir.is_dir()
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 0
    assert not served_dir.exists() and not served_dir.parent.exists()


@pytest.mark.parametrize("offset_s", [1e9, 1e10, 2e11, 1e13, 1e15])
def test_timestamps_beyond_the_plausible_clock_are_refused_never_a_crash(
        served, request_frame, offset_s):
    # stamps beyond the service's plausible_time bound (1e11 s) were refused one by one
    # inside the service: the answer held no decision and no reason, and from 1e13 s the
    # empty decisions crashed it (500, AttributeError on the empty flags column)
    t0 = request_frame["t_s"].iloc[0]
    status, base = _call(served, request_frame.assign(t_s=request_frame["t_s"] - t0))
    frame = request_frame.assign(t_s=request_frame["t_s"] - t0 + offset_s)
    status, body = _call(served, frame)
    if offset_s < 1e11:
        assert status == 200
        got, want = pd.DataFrame(body["predictions"]), pd.DataFrame(base["predictions"])
        assert len(got) == len(want) >= 10
        np.testing.assert_allclose(got["t_s"] - offset_s, want["t_s"], atol=1e-5)
        assert list(got["terrain"]) == list(want["terrain"])
    else:
        assert status == 400
        message = body["message"]
        assert "TimestampError" in message and "beyond 1e+11 s" in message
        assert "data row 0" in message


@pytest.mark.parametrize("stamps, first", [
    # integer nanoseconds since an epoch, 1 ns apart: distinct as sent, equal as floats
    (lambda n: [10**18 + i for i in range(n)], "1e+18"),
    (lambda n: [-1e308 + 0.15 * i for i in range(n)], "-1e+308"),
])
def test_timestamps_beyond_the_plausible_clock_are_named_before_their_order(
        served, request_frame, stamps, first):
    # the order was checked first: distinct integer stamps beyond the float's resolution
    # were refused as "duplicated timestamp 1e+18 after 1e+18", which the client never sent
    frame = request_frame.astype({"t_s": object})
    frame["t_s"] = stamps(len(frame))
    message = _error(served, frame)
    assert message.startswith(f"TimestampError: stream 'wheels': {len(frame)} timestamp(s) "
                              f"beyond 1e+11 s, the first {float(first)!r}"), message
    assert "duplicated" not in message and "data row 0" in message


def test_a_request_of_50_000_columns_is_refused_in_linear_time(served):
    # the duplicate-name check counted every name in the whole list (quadratic): 50 000
    # columns held the server for ~45 s, so /ping timed out behind it
    from mlflow.exceptions import MlflowException
    from mlflow.pyfunc import scoring_server

    names = [f"c{i}" for i in range(50_000)]   # (pandas' to_json of it alone takes ~4 s)
    request = json.dumps({"dataframe_split": {"columns": names, "data": [[1.0] * 50_000] * 3}})
    start = time.perf_counter()
    with pytest.raises(MlflowException) as info:
        scoring_server.invocations(request, "application/json", served, None)
    elapsed = time.perf_counter() - start
    assert info.value.get_http_status_code() == 400
    assert "MissingColumnError" in str(info.value)
    assert elapsed < 15.0, elapsed       # a quadratic check takes ~45 s here; linear < 1 s
    dup = pd.DataFrame([[1.0] * 4] * 3, columns=["stream", "t_s", "vel_l", "vel_l"])
    status, body = _call(served, dup)
    assert status == 400 and "duplicated column name(s) ['vel_l']" in body["message"]


@pytest.mark.slow
def test_wrapping_says_nothing_of_the_signature_it_leaves_out(wheel_model, tmp_path):
    """The served model has no MLflow signature (a request is either layout, checked by
    parse_request with the project's typed errors); MLflow warned at every wrap that it
    could not infer one, which `terrain serve` printed before its first line. The warning
    is dropped for that save only: other records of the logger still pass, and the filter
    is gone afterwards."""
    import logging
    m = wheel_model
    save_model(tmp_path / "train", m.pipeline, m.channels, m.window, m.classes, {"dataset": "t"})
    log = logging.getLogger("mlflow.pyfunc")     # MLflow's loggers do not propagate
    filters = list(log.filters)
    records: list[logging.LogRecord] = []
    handler = logging.Handler(logging.INFO)
    handler.emit = records.append
    log.addHandler(handler)
    try:
        save_served_model(tmp_path / "served", tmp_path / "train", served_settings(m))
        log.warning("another warning")
        assert log.filters == filters          # the filter is gone after the save ...
        # ... so a plain save of the same entry point says it (the warning is real)
        import mlflow.pyfunc
        from terrain.serving import served
        mlflow.pyfunc.save_model(path=str(tmp_path / "bare"), python_model=str(
            Path(served.__file__).with_name("served_entry.py")))
    finally:
        log.removeHandler(handler)
    messages = [r.getMessage() for r in records]
    said = [i for i, t in enumerate(messages) if "infer model signature" in t]
    assert len(said) == 1 and messages.index("another warning") < said[0]
    assert (tmp_path / "served" / "MLmodel").exists()
    assert "signature" not in (tmp_path / "served" / "MLmodel").read_text()


@pytest.mark.slow
def test_the_served_model_decides_one_request_at_a_time_per_lane():
    """MLflow's server runs each prediction in a thread of its pool; CPU-bound requests
    deciding at once only contended (8 requests of 999 s: 47.6 s together against 8 x 3.9 s).
    One at a time, a short request waited 21 s behind seven long ones: short and long
    requests have a lane each. A long request is long by its rows or by its time span (a
    999 s wheel-only log holds only 6,488 rows: seven of them kept a 3 s request waiting
    9.5 s in the short lane)."""
    from terrain.serving.served import LONG_REQUEST_ROWS, LONG_REQUEST_S, ServedStreamModel

    model, active, most, order = ServedStreamModel(), {}, {}, []

    def decide(frame):
        lane = len(frame) > 100
        active[lane] = active.get(lane, 0) + 1
        most[lane] = max(most.get(lane, 0), active[lane])
        time.sleep(0.3 if lane else 0.01)
        active[lane] -= 1
        order.append(lane)
        return frame

    model.decide = decide
    # the stub's lane is read from the frame's length: 101 rows or more are the long ones
    span = np.linspace(0.0, LONG_REQUEST_S + 1.0, 101)
    longs = [pd.DataFrame(index=range(LONG_REQUEST_ROWS + 1)),      # by rows
             pd.DataFrame({"stream": "wheels", "t_s": span}),      # by span, long format
             pd.DataFrame({"wheels_t_s": span, "imu_t_s": span})]  # by span, wide format
    short = pd.DataFrame({"stream": "wheels", "t_s": np.linspace(0.0, 3.0, 9)})
    threads = [threading.Thread(target=model.predict, args=(None, frame))
               for frame in longs + [short] * 6]
    for thread in threads:
        thread.start()
        time.sleep(0.005)
    for thread in threads:
        thread.join()
    assert most == {True: 1, False: 1} and active == {True: 0, False: 0}
    assert order[:6] == [False] * 6      # the short ones did not wait for the long ones


@pytest.mark.parametrize("value", [5, "abc", None, np.float64(2.0)])
def test_a_request_that_is_no_table_is_a_typed_400_not_a_500(value):
    """``{"inputs": 5}``: MLflow hands the model a scalar; choosing its lane called len() on
    it, a TypeError answered 500 with a traceback in the log."""
    from mlflow.protos.databricks_pb2 import BAD_REQUEST, ErrorCode

    from terrain.serving.served import ServedInputError, ServedStreamModel, is_long

    assert is_long(value) is False
    model = ServedStreamModel()
    model.decide = lambda frame: parse_request(frame, {"wheels": ["vel_l"]}, 2.0, 100)
    with pytest.raises(ServedInputError) as raised:
        model.predict(None, value)
    assert raised.value.error_code == ErrorCode.Name(BAD_REQUEST)
    assert raised.value.message.startswith("DataFormatError: ")


def test_the_lane_of_a_table_with_unreadable_times_is_short():
    """Choosing the lane must not fail where the model's own checks answer: an integer of
    400 digits (float conversion overflows) or a repeated time column."""
    from terrain.serving.served import LONG_REQUEST_S, is_long

    assert not is_long(pd.DataFrame({"t_s": [10**400, 0]}, dtype=object))
    assert not is_long(pd.DataFrame([[0.0, 500.0]], columns=["t_s", "t_s"]))
    assert is_long(pd.DataFrame({"imu_t_s": [0.0, np.nan],
                                 "wheels_t_s": [1.0, 2.0 + LONG_REQUEST_S]}))
    assert not is_long(pd.DataFrame({"t_s": ["a", "b"]}))
