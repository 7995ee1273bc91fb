"""The served answer equals the sample-by-sample replay when one stream outlasts the others.

The served model replays a request in chunks of up to 32 samples of one stream; a stream's
staleness is judged from the first sample of its newest push, so a slow stream's last run
(a 6.5 Hz wheel stream goes 32 samples, 4.9 s, after the IMU stopped) made none of the
decisions it was due: the answer ended where the IMU did and said nothing of the wheel
samples after it (7 decisions, against 14 sample by sample, the last 7 dropped ``short`` /
``stale`` windows).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from terrain.serving import decisions_frame
from terrain.serving.replay import interleave, replay_run
from terrain.serving.request import parse_request
from terrain.serving.service import StreamService


@pytest.fixture(scope="module")
def both_streams(borealtc_runs, train_runs):
    """10 s of IMU and wheels of an unseen run, long format."""
    seen = {r.run_id for r in train_runs}
    run = next(r for r in borealtc_runs if r.run_id not in seen and r.has_imu)
    parts = []
    for s in ("imu", "wheels"):
        f = run.streams[s]
        parts.append(f[f["t_s"] < f["t_s"].iloc[0] + 10.0].assign(stream=s))
    return pd.concat(parts, ignore_index=True)


def _served(served, frame):
    from mlflow.pyfunc import scoring_server

    split = json.loads(frame.to_json(orient="split", index=False))
    res = scoring_server.invocations(json.dumps({"dataframe_split": split}),
                                     "application/json", served, None)
    assert res.status == 200, res.response
    return pd.DataFrame(json.loads(res.response)["predictions"])


def _sample_by_sample(served, frame):
    model = served.unwrap_python_model()
    service = StreamService(model.model, model.targets, model.config)
    run = parse_request(frame, {s: service.streams[s] for s in service.needed_streams},
                        model.model.window.window_s, 10**6)
    return decisions_frame(replay_run(service, run), model.model.classes)


@pytest.mark.parametrize("stops", [("imu", 5.0), ("imu", 8.0), ("wheels", 5.0),
                                   ("imu", 3.0)])
def test_a_stream_that_outlasts_the_others_gets_the_decisions_it_is_due(
        served_all, both_streams, stops):
    stream, at = stops
    f = both_streams
    t0 = float(f["t_s"].min())
    frame = f[~((f["stream"] == stream) & (f["t_s"] > t0 + at))].reset_index(drop=True)
    got, want = _served(served_all, frame), _sample_by_sample(served_all, frame)
    assert len(got) == len(want)
    np.testing.assert_allclose(got["t_s"], want["t_s"])
    # (the served answer adds the run-level findings: here the clocks' short overlap)
    run_level = ["|".join(x for x in f.split("|") if not x.startswith("warning:"))
                 for f in got["flags"]]
    assert run_level == list(want["flags"])
    np.testing.assert_allclose(got["confidence"], want["confidence"], atol=1e-9)
    # the streams' last common second is decided; the rest reach dropped windows
    assert got["t_s"].iloc[-1] >= float(frame["t_s"].max()) - 1.5
    tail = got[got["t_s"] > t0 + at + 1.0]
    assert tail["dropped"].all() and tail["flags"].str.contains("stale").all()


def test_a_run_of_one_stream_ends_with_its_last_sample_alone(both_streams):
    """Chunks: consecutive samples of one stream, at most max_chunk, the last of each run
    alone (the staleness of the others is judged from it, as sample by sample)."""
    from terrain.run import Run

    f = both_streams
    run = Run("r", "r", None, {s: f[f["stream"] == s].drop(columns="stream")
                               for s in ("imu", "wheels")})
    chunks = list(interleave(run, ("imu", "wheels"), max_chunk=32))
    assert sum(len(t) for _, t, _ in chunks) == len(f)
    assert max(len(t) for _, t, _ in chunks) <= 32
    ends = [i for i in range(len(chunks) - 1) if chunks[i][0] != chunks[i + 1][0]]
    assert ends and all(len(chunks[i][1]) == 1 for i in [*ends, len(chunks) - 1])
    times = np.concatenate([t for _, t, _ in chunks])
    assert (np.diff(times) >= 0).all()
