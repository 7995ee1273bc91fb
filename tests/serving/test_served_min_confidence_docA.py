"""``terrain serve --min-confidence`` reaches the served model's slip targets.

The served model (``terrain/serving/served.py``) builds its desired-slip table with the
model's ``min_confidence`` (README, "Served model": the threshold below which the
conservative target is used). Every served test used the default 0.5, the table's own
default, so a served model that built its table with ``DesiredSlipConfig()`` passed them
all (mutant); with ``--min-confidence 0.2`` that model refuses every request, since the
service will not take a provider whose own threshold (0.5) is above its own.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from terrain.control import DesiredSlipConfig
from terrain.serving import (StreamConfig, StreamService, TableTargets, decisions_frame,
                             replay_run)
from terrain.serving.pyfunc import save_model
from terrain.serving.request import parse_request
from terrain.serving.served import save_served_model, served_settings

WHEELS = ["vel_l", "vel_r", "cur_l", "cur_r"]


@pytest.mark.parametrize("min_confidence", [0.2, 0.9])
def test_the_served_targets_use_the_models_min_confidence(wheel_model, unseen_wheel_request,
                                                          tmp_path, min_confidence):
    import mlflow.pyfunc
    from mlflow.pyfunc import scoring_server

    m = wheel_model
    save_model(tmp_path / "train", m.pipeline, m.channels, m.window, m.classes,
               {"dataset": "t"})
    save_served_model(tmp_path / "served", tmp_path / "train",
                      served_settings(m, min_confidence=min_confidence, max_rows=5000))
    served = mlflow.pyfunc.load_model(str(tmp_path / "served"))
    frame = unseen_wheel_request(12.0)
    split = json.loads(frame.to_json(orient="split", index=False))
    res = scoring_server.invocations(json.dumps({"dataframe_split": split}),
                                     "application/json", served, None)
    assert res.status == 200, res.response
    got = pd.DataFrame(json.loads(res.response)["predictions"])

    service = StreamService(m, TableTargets(m.classes,
                                            DesiredSlipConfig(min_confidence=min_confidence)),
                            StreamConfig(hop_s=0.5, min_confidence=min_confidence))
    want = decisions_frame(replay_run(service, parse_request(
        frame, {"wheels": tuple(WHEELS)}, 2.0, 10_000)), m.classes)
    assert len(got) == len(want) >= 10
    for column in ("target_slip_traction", "target_slip_braking", "target_slip_steady"):
        np.testing.assert_allclose(got[column], want[column], atol=1e-12)
    # below the threshold the conservative target (at 0.9 some decisions are below it)
    fallback = TableTargets(m.classes, DesiredSlipConfig()).target_for(None, 0.0, False)
    fell_back = np.isclose(got["target_slip_traction"], fallback.traction)
    low = got["confidence"] < min_confidence
    assert (fell_back[low]).all() and (low.any() or min_confidence < 0.5)


def test_terrain_serves_options_reach_the_wrapped_models_settings(wheel_model, tmp_path):
    # README, "Served model": --hop-s, --dwell-s, --min-confidence, --reset-* and
    # --max-decisions are the wrapped model's settings (mutants: pipelines/serve.py passing
    # 0.5 for args.min_confidence or for args.hop_s, no test failed)
    import yaml

    from pipelines.serve import wrap_model
    from terrain.cli import build_parser

    m = wheel_model
    save_model(tmp_path / "train", m.pipeline, m.channels, m.window, m.classes,
               {"dataset": "t"})
    args = build_parser().parse_args(
        ["serve", "--model", str(tmp_path / "train"), "--hop-s", "1.0", "--dwell-s", "20",
         "--min-confidence", "0.3", "--reset-confidence", "0.8", "--reset-windows", "3",
         "--max-decisions", "100"])
    out = wrap_model(tmp_path / "train", tmp_path / "served", args)
    config = yaml.safe_load((out / "MLmodel").read_text())["flavors"]["python_function"][
        "config"]
    assert {k: config[k] for k in ("hop_s", "dwell_s", "min_confidence", "reset_confidence",
                                   "reset_windows", "max_decisions")} == {
        "hop_s": 1.0, "dwell_s": 20.0, "min_confidence": 0.3, "reset_confidence": 0.8,
        "reset_windows": 3, "max_decisions": 100}
