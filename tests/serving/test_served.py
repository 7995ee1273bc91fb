"""The served streaming model: raw streams in, the service's decisions out, typed 4xx errors.

The in-process tests go through MLflow's own request handler
(:func:`mlflow.pyfunc.scoring_server.invocations`, what ``/invocations`` runs); the last
test starts a real ``terrain serve`` on 127.0.0.1 and checks it survives bad requests.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError
from terrain.run import WHEEL_CHANNELS
from terrain.serving.pyfunc import save_model
from terrain.serving import (StreamConfig, StreamService, TableTargets, decisions_frame,
                             replay_run)
from terrain.serving.served import parse_request, save_served_model, served_settings
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
def request_frame(borealtc_runs, train_runs):
    """12 s of the wheel stream of an unseen run, long format."""
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.run_id not in seen)
    w = run.streams["wheels"]
    w = w[w["t_s"] < w["t_s"].iloc[0] + 12.0]
    return w.assign(stream="wheels")[COLUMNS].reset_index(drop=True)


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
    assert list(got.columns) == list(want.columns) + ["dropped"]
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


def test_wide_format_gives_the_same_answer(served, request_frame):
    wide = request_frame.drop(columns="stream").rename(columns={"t_s": "wheels_t_s"})
    assert _call(served, wide) == _call(served, request_frame)


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


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _post(url: str, body: bytes) -> tuple[int, dict]:
    req = urllib.request.Request(url, body, {"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=20) as res:
            return res.status, json.loads(res.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def test_real_server_answers_and_survives_bad_requests(model_dirs, request_frame):
    port = _free_port()
    proc = subprocess.Popen([sys.executable, "-m", "terrain.cli", "serve", "--model",
                             str(model_dirs[0]), "--host", "127.0.0.1", "--port", str(port),
                             "--max-body-bytes", "100000"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 45
        while True:
            assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
            try:
                urllib.request.urlopen(base + "/ping", timeout=2).close()
                break
            except OSError:
                assert time.monotonic() < deadline, "server did not start within 45 s"
                time.sleep(0.3)
        good = _body(request_frame).encode()
        status, body = _post(base + "/invocations", good)
        assert status == 200 and len(body["predictions"]) >= 10
        status, body = _post(base + "/invocations", _body(_dup(request_frame)).encode())
        assert status == 400 and body["message"].startswith("TimestampError: ")
        big = pd.concat([request_frame] * 40, ignore_index=True)
        status, body = _post(base + "/invocations", _body(big).encode())
        assert status == 413 and "exceeds the limit of 100000" in body["message"]
        status, body = _post(base + "/invocations", b'{"dataframe_split": ')
        assert 400 <= status < 500 and "Traceback" not in json.dumps(body)
        assert _post(base + "/invocations", good)[0] == 200  # still up
    finally:
        proc.terminate()
        proc.wait(timeout=10)
