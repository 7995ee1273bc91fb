"""A small wheel-only and an IMU+wheel model fitted on real BorealTC runs, and the latter
served (session scope)."""

from __future__ import annotations

from types import MappingProxyType, SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig, make_windows
from terrain.models.experiment import inference_pipeline
from terrain.models.svm import SVMConfig
from terrain.run import WHEEL_CHANNELS
from terrain.serving import StreamModel
from terrain.serving.model import training_steps_s


def _fit(runs, signals, rate_hz):
    config = WindowConfig(window_s=2.0, rate_hz=rate_hz)
    ws = make_windows(runs, signals, config)
    pipe = inference_pipeline(ws, SVMConfig(probability=True)).fit(ws.X, ws.labels.astype(str))
    classes = tuple(str(c) for c in np.unique(ws.labels.astype(str)))
    # as `terrain train` writes it: the training runs' sample step of each channel
    steps = training_steps_s(runs, ws.channels)
    return StreamModel(pipe, ws.channels, config, classes,
                       MappingProxyType({"channel_steps_s": steps}))


@pytest.fixture(scope="session")
def train_runs(borealtc_runs):
    """Two runs with IMU per terrain class (the rest stays unseen)."""
    out = []
    for terrain in sorted({r.terrain for r in borealtc_runs}):
        out += [r for r in borealtc_runs if r.terrain == terrain and r.has_imu][:2]
    return out


@pytest.fixture(scope="session")
def unseen_wheel_request(borealtc_runs, train_runs):
    """``make(seconds)``: the first ``seconds`` of the wheel stream of the first run outside
    ``train_runs``, as a request sends it (long format: ``stream, t_s`` and the wheel
    channels, as logged)."""
    seen = {r.run_id for r in train_runs}
    wheels = next(r for r in borealtc_runs if r.run_id not in seen).streams["wheels"]

    def make(seconds: float) -> pd.DataFrame:
        w = wheels[wheels["t_s"] < wheels["t_s"].iloc[0] + seconds]
        return w.assign(stream="wheels")[["stream", "t_s", *WHEEL_CHANNELS]].reset_index(
            drop=True)
    return make


@pytest.fixture(scope="session")
def wheel_model(train_runs):
    """Wheel-only model (derived wheel channels included) on a 20 Hz clock."""
    return _fit(train_runs, "wheels", 20.0)


@pytest.fixture(scope="session")
def all_model(train_runs):
    """IMU + wheel model on a 50 Hz clock."""
    return _fit(train_runs, "all", 50.0)


@pytest.fixture(scope="session")
def served_all(all_model, tmp_path_factory):
    """The IMU + wheel model, served (loaded as ``mlflow models serve`` does)."""
    import mlflow.pyfunc

    from terrain.serving.pyfunc import save_model
    from terrain.serving.served import save_served_model, served_settings

    root, m = tmp_path_factory.mktemp("served_all"), all_model
    save_model(root / "train", m.pipeline, m.channels, m.window, m.classes,
               {"dataset": "t", "channel_steps_s": m.metadata["channel_steps_s"]})
    save_served_model(root / "served", root / "train", served_settings(m))
    return mlflow.pyfunc.load_model(str(root / "served"))


@pytest.fixture(scope="module")
def served_wheels(wheel_model, tmp_path_factory):
    """The wheel-only model as the served pyfunc, loaded in process as the scoring server
    loads it (``load_context`` as MLflow calls it); one per test module, so a module's
    requests see no other module's."""
    import joblib

    from terrain.serving.served import ServedStreamModel, served_settings

    path = tmp_path_factory.mktemp("served_wheels") / "pipeline.joblib"
    joblib.dump(wheel_model.pipeline, path)
    context = SimpleNamespace(artifacts={"pipeline": str(path)},
                              model_config=served_settings(wheel_model))
    model = ServedStreamModel()
    model.load_context(context)
    return model
