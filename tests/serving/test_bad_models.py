"""A corrupt model directory or an unsupported model URI is a one-line ConfigError naming the
file (or the URI), in the library and in every command that loads a model."""

from __future__ import annotations

import json
import shutil
from types import SimpleNamespace

import joblib
import numpy as np
import pytest

from pipelines.live_terrain import LiveClassifier, classifier_applies, decision_hop_s
from terrain.cli import main
from terrain.errors import ConfigError
from terrain.serving import StreamModel, load_stream_model
from terrain.serving.model import PIPELINE_ARTIFACT, load_pipeline
from terrain.serving.pyfunc import TerrainModel, load_model, save_model


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory, wheel_model):
    """The wheel-only model saved as ``terrain train --model-out`` does (``hop_s: null``)."""
    path = tmp_path_factory.mktemp("saved") / "model"
    save_model(path, wheel_model.pipeline, wheel_model.channels, wheel_model.window,
               list(wheel_model.classes), {"dataset": "borealtc"}, progress=False)
    return path


def _truncate(p):
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])


def _random(p):
    p.write_bytes(np.random.default_rng(0).bytes(5000))


#: name -> (file of the model to damage, damage, words the message must hold)
CORRUPTIONS = {
    "truncated": (PIPELINE_ARTIFACT, _truncate, "cannot be read as a fitted model"),
    "empty": (PIPELINE_ARTIFACT, lambda p: p.write_bytes(b""),
              "cannot be read as a fitted model (EOFError"),
    "random_bytes": (PIPELINE_ARTIFACT, _random, "cannot be read as a fitted model"),
    "dict": (PIPELINE_ARTIFACT, lambda p: joblib.dump({"a": 1}, p),
             "holds a dict, not a fitted classifier with predict_proba and classes_"),
    "invalid_yaml": ("MLmodel", lambda p: p.write_text("a: [b\n  c: :\n"),
                     "not valid YAML (expected ',' or ']', but got ':' at line 2, column 4)"),
    "empty_mlmodel": ("MLmodel", lambda p: p.write_text(""), "empty or not a YAML mapping"),
    "no_metadata": ("MLmodel", lambda p: p.write_text("flavors: {}\n"), "no metadata mapping"),
    "bad_window": ("MLmodel", lambda p: p.write_text(p.read_text().replace(
        "  window_s: 2.0", "  window_s: two")), "metadata window_s must be a positive number"),
    # the live windows' wheel yaw rate divides by it: 0 made every window infinite
    "bad_track": ("MLmodel", lambda p: p.write_text(p.read_text().replace(
        "  track_m: 0.5708", "  track_m: 0")),
        "metadata track_m must be a positive number or null, got 0"),
}


@pytest.fixture(params=sorted(CORRUPTIONS))
def corrupt(request, model_dir, tmp_path):
    """A copy of the saved model with one file damaged: (dir, damaged file, expected text)."""
    rel, damage, words = CORRUPTIONS[request.param]
    path = tmp_path / "model"
    shutil.copytree(model_dir, path)
    damage(path / rel)
    return path, path / rel, words


def test_the_saved_model_loads(model_dir, wheel_model):
    model = load_stream_model(model_dir)
    assert model.classes == wheel_model.classes and model.metadata["hop_s"] is None
    pyfunc, meta = load_model(model_dir, progress=False)
    assert meta["channels"] == list(wheel_model.channels)


def test_library_loaders_name_the_damaged_file(corrupt):
    path, damaged, words = corrupt
    for load in (load_stream_model, lambda p: load_model(p, progress=False)):
        with pytest.raises(ConfigError) as exc:
            load(path)
        assert str(damaged.name) in str(exc.value) and words in str(exc.value)


@pytest.mark.parametrize("command", ["predict", "stream"])
def test_commands_answer_a_corrupt_model_in_one_line(command, corrupt, tmp_path, capsys,
                                                     monkeypatch):
    monkeypatch.chdir(tmp_path)
    path, damaged, words = corrupt
    runs = tmp_path / "runs"          # the model is checked before any run is read
    runs.mkdir()
    argv = ([command, "--model", str(path), str(runs), "--out", "x.csv"]
            + (["--no-progress"] if command == "predict" else []))
    assert main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in captured.err + captured.out
    assert err.startswith(f"terrain {command}: error: ")
    assert f"{damaged.parent.name}/{damaged.name}" in err and words in err
    assert not (tmp_path / "x.csv").exists()


def test_control_sim_answers_a_corrupt_model_in_one_line(model_dir, tmp_path, capsys,
                                                         monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "model"
    shutil.copytree(model_dir, path)
    joblib.dump(["not", "a", "model"], path / PIPELINE_ARTIFACT)
    assert main(["control-sim", "--json", str(tmp_path / "o.json"), "--vehicle", "husky",
                 "--terrain", "SNOW", "--scenario", "straight_accel", "--controller",
                 "traction", "--duration-s", "1", "--model", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pipeline.joblib: holds a list, not a fitted" in err


def test_served_pyfunc_loading_checks_the_pipeline(model_dir, tmp_path):
    """``mlflow models serve`` loads the model through TerrainModel.load_context."""
    bad = tmp_path / "pipeline.joblib"
    joblib.dump({"a": 1}, bad)
    with pytest.raises(ConfigError, match="pipeline.joblib: holds a dict"):
        TerrainModel().load_context(SimpleNamespace(artifacts={"pipeline": str(bad)},
                                                    model_config=None))
    model = TerrainModel()
    good = str(model_dir / PIPELINE_ARTIFACT)
    model.load_context(SimpleNamespace(artifacts={"pipeline": good}, model_config=None))
    assert hasattr(model._pipeline, "predict_proba")
    with pytest.raises(ConfigError, match="model config lacks"):
        TerrainModel().load_context(SimpleNamespace(artifacts={}, model_config={"x": 1}))


def test_load_pipeline_leaves_a_missing_file_to_the_os(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_pipeline(tmp_path / "absent.joblib")


@pytest.mark.parametrize("uri", ["http://127.0.0.1:1/x", "s3://nobucket/x", "gs://b/x"])
def test_unsupported_model_uris_list_the_supported_ones(uri, tmp_path, capsys, monkeypatch):
    with pytest.raises(ConfigError) as exc:
        load_model(uri)
    text = str(exc.value)
    assert repr(uri) in text
    assert "local model directory" in text and "models:/NAME/VERSION" in text \
        and "runs:/RUN_ID/PATH" in text
    monkeypatch.chdir(tmp_path)
    assert main(["predict", "--model", uri, str(tmp_path), "--out", "x.csv",
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unsupported model URI" in err


def test_a_file_uri_is_a_local_model_directory(model_dir):
    _, meta = load_model(model_dir.as_uri(), progress=False)
    assert meta["window_s"] == 2.0


def test_a_null_hop_means_the_streaming_default(model_dir, wheel_model):
    """``terrain train`` models store ``hop_s: null``: the live classifier then decides every
    StreamConfig.hop_s (0.5 s) instead of failing on float(None)."""
    model = load_stream_model(model_dir)
    assert model.metadata["hop_s"] is None
    live = LiveClassifier(model, "husky")
    assert live.service.config.hop_s == decision_hop_s(model) == 0.5
    ok, note = classifier_applies(model, "husky", "SNOW")
    assert ok and "a decision every 0.5 s" in note
    explicit = StreamModel(wheel_model.pipeline, wheel_model.channels, wheel_model.window,
                           wheel_model.classes, {"hop_s": 1.0})
    assert decision_hop_s(explicit) == 1.0


def test_control_sim_runs_with_a_null_hop_model(model_dir, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "o.json"
    assert main(["control-sim", "--json", str(out), "--vehicle", "husky", "--terrain", "SNOW",
                 "--scenario", "straight_accel", "--controller", "traction",
                 "--duration-s", "3", "--model", str(model_dir)]) == 0
    report = json.loads(out.read_text())
    assert "a decision every 0.5 s" in report["terrain_source"]
    # decisions from t = 2 s (the first window) every 0.5 s: 2.0, 2.5, 3.0 at most
    assert sum(n for k, n in report["terrain_decisions"].items() if k != "NONE") > 0


def test_serve_refuses_an_mlmodel_that_is_not_yaml_in_one_line(tmp_path, capsys):
    from terrain.cli import main

    bad = tmp_path / "m"
    bad.mkdir()
    (bad / "MLmodel").write_text("flavors: [unclosed\n")
    assert main(["serve", "--model", str(bad), "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert "not valid YAML" in err and str(bad / "MLmodel") in err
    assert len(err.strip().splitlines()) == 1
