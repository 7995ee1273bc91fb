"""Review tests of a model directory's metadata: written, read back the same; a bad or
missing setting refused with the file and the key named."""

from __future__ import annotations

import joblib
import pytest
import yaml
from sklearn.dummy import DummyClassifier

from features.windows import HUSKY_TRACK_M
from terrain.errors import ConfigError
from terrain.serving.model import (PIPELINE_ARTIFACT, StreamModel, load_stream_model,
                                   model_track_m, read_model_metadata)

META = {"channels": ["acc_x", "vel_l", "yaw_rate_wheels"], "classes": ["ICE", "SNOW"],
        "window_s": 1.5, "rate_hz": 50.0, "hop_s": None, "track_m": 0.42,
        "dataset": "borealtc"}


def _model_dir(tmp_path, meta):
    path = tmp_path / "model"
    (path / PIPELINE_ARTIFACT).parent.mkdir(parents=True)
    clf = DummyClassifier(strategy="prior").fit([[0.0], [1.0]], ["ICE", "SNOW"])
    joblib.dump(clf, path / PIPELINE_ARTIFACT)
    (path / "MLmodel").write_text(yaml.safe_dump({"flavors": {}, "metadata": meta}))
    return path


def test_saved_metadata_reads_back_the_same(tmp_path):
    path = _model_dir(tmp_path, META)
    assert read_model_metadata(path) == META
    model = load_stream_model(path)
    assert model.channels == tuple(META["channels"]) and model.classes == ("ICE", "SNOW")
    assert (model.window.window_s, model.window.rate_hz) == (1.5, 50.0)
    assert model_track_m(model.metadata) == 0.42
    assert model_track_m({**META, "track_m": None}) == HUSKY_TRACK_M
    # a derived wheel channel needs all four measured wheel channels
    assert model.raw_channels == ("acc_x", "vel_l", "vel_r", "cur_l", "cur_r")


@pytest.mark.parametrize("key, value", [
    ("window_s", True), ("rate_hz", None), ("window_s", "2"), ("track_m", 0),
    ("hop_s", -0.5), ("classes", []), ("channels", "acc_x")])
def test_a_bad_setting_is_refused_naming_the_file_and_the_key(tmp_path, key, value):
    path = _model_dir(tmp_path, {**META, key: value})
    with pytest.raises(ConfigError) as exc:
        read_model_metadata(path)
    assert str(path / "MLmodel") in str(exc.value) and key in str(exc.value)


@pytest.mark.parametrize("key", ["channels", "classes", "window_s", "rate_hz"])
def test_a_missing_setting_is_refused_naming_the_file_and_the_key(tmp_path, key):
    path = _model_dir(tmp_path, {k: v for k, v in META.items() if k != key})
    with pytest.raises(ConfigError, match=f"metadata lacks \\['{key}'\\]") as exc:
        read_model_metadata(path)
    assert str(path / "MLmodel") in str(exc.value)


def test_a_model_without_derived_channels_needs_only_its_own():
    model = StreamModel(None, ("vel_l", "acc_x"), None, ("ICE",))
    assert model.raw_channels == ("vel_l", "acc_x")
