"""Review srv7a of the served model's answer: a request whose streams each span a window but
hold none together made no decision and was answered an empty 200 (``{"predictions": []}``),
with no row and no reason."""

from __future__ import annotations

import json

import pandas as pd
import pytest


@pytest.fixture(scope="module")
def imu_run(borealtc_runs, train_runs):
    """An unseen run with an IMU and over 5 s of both streams."""
    seen = {r.run_id for r in train_runs}
    return next(r for r in borealtc_runs if r.run_id not in seen and r.has_imu
                and float(r.streams["wheels"]["t_s"].iloc[-1]
                          - r.streams["imu"]["t_s"].iloc[0]) > 5.0)


def _answer(served, frame):
    """(HTTP status, parsed JSON body) of MLflow's /invocations handler."""
    from mlflow.exceptions import MlflowException
    from mlflow.pyfunc import scoring_server

    split = json.loads(frame.to_json(orient="split", index=False))
    try:
        res = scoring_server.invocations(json.dumps({"dataframe_split": split}),
                                         "application/json", served, None)
    except MlflowException as exc:
        return exc.get_http_status_code(), json.loads(exc.serialize_as_json())
    return res.status, json.loads(res.response)


def _request(run, imu_s, wheels_s):
    """Long-format request of the run's IMU and wheel samples in the given spans (s from
    the IMU's first sample)."""
    imu, wheels = run.streams["imu"], run.streams["wheels"]
    t0 = float(imu["t_s"].iloc[0])
    parts = [f[(f["t_s"] >= t0 + a) & (f["t_s"] <= t0 + b)].assign(stream=s)
             for s, f, (a, b) in (("imu", imu, imu_s), ("wheels", wheels, wheels_s))]
    return pd.concat(parts, ignore_index=True)


@pytest.mark.parametrize("imu_s, wheels_s", [((0.0, 2.05), (1.5, 4.0)),
                                             ((0.0, 3.0), (2.9, 5.0))])
def test_streams_that_hold_no_window_together_are_a_typed_400_not_an_empty_answer(
        served_all, imu_run, imu_s, wheels_s):
    """IMU 0-2.05 s and wheels 1.5-4 s (0.55 s together, the window is 2 s): the first
    decision is due at 3.5 s, which the IMU never reaches and the wheels never pass by
    stale_s. Before: 200 ``{"predictions": []}``; now a 400 naming the streams' spans."""
    status, body = _answer(served_all, _request(imu_run, imu_s, wheels_s))
    assert status == 400, body
    message = body["message"]
    assert message.startswith("DataFormatError: no decision: "), message
    assert "imu " in message and "wheels " in message and "window of 2 s" in message


def test_streams_that_hold_a_window_together_still_make_decisions(served_all, imu_run):
    status, body = _answer(served_all, _request(imu_run, (0.0, 4.0), (1.5, 4.0)))
    assert status == 200 and len(body["predictions"]) >= 1, body


def test_a_time_column_of_no_known_stream_does_not_choose_the_lane():
    """A column the model ignores (``gps_t_s``: another sensor's epoch stamps) put a robot's
    short request in the long lane, behind bulk logs; the lane is chosen by ``t_s`` and the
    known streams' ``<stream>_t_s`` only (the columns the model reads)."""
    from terrain.serving.served import LONG_REQUEST_S, is_long

    short = pd.DataFrame({"wheels_t_s": [0.0, 1.0, 2.0], "gps_t_s": [1.7e9, 1.7e9 + 1.0, 0.0]})
    assert not is_long(short)
    assert is_long(short.assign(wheels_t_s=[0.0, 1.0, LONG_REQUEST_S + 1.0]))
