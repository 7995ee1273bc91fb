"""What a failed or interrupted ``terrain serve`` leaves behind (srv22 review): the exit
status, the ``--served-out`` folder, the bound socket, the signal handlers."""

from __future__ import annotations

import argparse
import os
import signal
import socket
import warnings
from pathlib import Path

import numpy as np
import pytest
from sklearn.dummy import DummyClassifier

from features.windows import WindowConfig
from pipelines import serve
from terrain.errors import ConfigError
from terrain.run import WHEEL_CHANNELS
from terrain.serving.pyfunc import save_model


@pytest.fixture(scope="module")
def train_dir(tmp_path_factory) -> Path:
    """A tiny ``terrain train --model-out`` directory (a prior classifier on wheel windows)."""
    root = tmp_path_factory.mktemp("serve_failures")
    classes = ["ASPHALT", "GRASS"]
    clf = DummyClassifier(strategy="prior").fit(np.zeros((4, 4, 40)), classes * 2)
    return save_model(root / "train", clf, list(WHEEL_CHANNELS),
                      WindowConfig(window_s=2.0, rate_hz=20.0), classes, {"dataset": "t"},
                      progress=False)


def _args(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    serve.add_arguments(parser)
    return parser.parse_args(list(argv))


def _interrupt_while_wrapping(monkeypatch, signum: int) -> None:
    """The signal arrives while the model is being read for wrapping (handlers in force)."""
    real = serve.load_stream_model

    def read_then_signal(path):
        model = real(path)
        os.kill(os.getpid(), signum)
        return model
    monkeypatch.setattr(serve, "load_stream_model", read_then_signal)


@pytest.mark.parametrize("signum, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_before_serving_is_not_a_success(train_dir, tmp_path, monkeypatch, capsys,
                                                  signum, status):
    # stopped while wrapping, nothing served and --served-out not written, the command said
    # "stopped" and exited 0, as after serving and stopping gracefully: a script or service
    # manager took the wrapped model it asked for as written
    out = tmp_path / "kept" / "served"
    _interrupt_while_wrapping(monkeypatch, signum)
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResourceWarning)
        got = serve.main(_args("--model", str(train_dir), "--port", "0",
                               "--served-out", str(out)))
    printed = capsys.readouterr().out
    assert got == status, printed
    assert not out.exists() and not list(out.parent.glob(".served.partial-*"))
    assert "before serving" in printed and f"--served-out {out} not written" in printed
    assert {s: signal.getsignal(s) for s in before} == before


def test_a_failed_start_closes_its_socket_and_frees_the_port(train_dir, monkeypatch):
    # the model fails to load in MLflow after the port was bound: the port is free again
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()

    def broken(*_, **__):
        raise ConfigError("broken served model")
    monkeypatch.setattr(serve, "build_app", broken)
    before = _open_sockets()
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResourceWarning)
        with pytest.raises(ConfigError, match="broken served model") as failed:
            serve.main(_args("--model", str(train_dir), "--port", str(port)))
        # closed by main itself, not by the collector once the traceback goes
        assert _open_sockets() == before, failed.traceback[-1]
    again = serve.bind_port("127.0.0.1", port)
    again.listen(1)
    again.close()


def _open_sockets() -> int:
    """Sockets this process holds open (Linux: its file descriptors naming a socket)."""
    fds = Path("/proc/self/fd")
    if not fds.is_dir():
        pytest.skip("needs /proc/self/fd")
    count = 0
    for fd in fds.iterdir():
        try:
            count += os.readlink(fd).startswith("socket:")
        except OSError:     # the listing's own descriptor, closed meanwhile
            pass
    return count


def test_a_failed_reload_leaves_the_served_model_as_it_was(train_dir, tmp_path):
    # load_context wrote the new settings before reading the pipeline: a reload whose
    # pipeline file was broken left the old classifier under the new settings (here a
    # max_rows of 3, which then refused every request the loaded model had answered)
    from types import SimpleNamespace

    from terrain.serving.model import PIPELINE_ARTIFACT, load_stream_model
    from terrain.serving.served import ServedStreamModel, served_settings

    model = load_stream_model(train_dir)
    served = ServedStreamModel()
    good = served_settings(model)
    served.load_context(SimpleNamespace(model_config=good, artifacts={
        "pipeline": str(train_dir / PIPELINE_ARTIFACT)}))
    before = (dict(served.settings), served.model, served.targets, served.config)
    broken = tmp_path / "pipeline.joblib"
    broken.write_bytes(b"not a joblib file")
    with pytest.raises(ConfigError, match="cannot be read as a fitted model"):
        served.load_context(SimpleNamespace(model_config={**good, "max_rows": 3},
                                            artifacts={"pipeline": str(broken)}))
    after = (served.settings, served.model, served.targets, served.config)
    assert after == before


def test_a_failed_reload_leaves_the_terrain_pyfunc_as_it_was(train_dir, tmp_path):
    # TerrainModel.load_context wrote the new channels, window and classes before reading
    # the pipeline: a reload whose pipeline was broken left the old classifier with another
    # model's channels (its windows cut to the new window, in the new channel order)
    from types import SimpleNamespace

    from terrain.serving.model import PIPELINE_ARTIFACT
    from terrain.serving.pyfunc import TerrainModel

    config = {"channels": list(WHEEL_CHANNELS), "classes": ["ASPHALT", "GRASS"],
              "window": {"window_s": 2.0, "hop_s": None, "rate_hz": 20.0}, "track_m": 0.55}
    model = TerrainModel()
    model.load_context(SimpleNamespace(model_config=config, artifacts={
        "pipeline": str(train_dir / PIPELINE_ARTIFACT)}))
    before = (model.channels, model.window, model.classes, model.track_m, model._pipeline)
    broken = tmp_path / "pipeline.joblib"
    broken.write_bytes(b"")
    other = {"channels": ["wx", "wy"], "classes": ["ICE"], "track_m": 1.0,
             "window": {"window_s": 1.0, "hop_s": None, "rate_hz": 100.0}}
    with pytest.raises(ConfigError, match="cannot be read as a fitted model"):
        model.load_context(SimpleNamespace(model_config=other,
                                           artifacts={"pipeline": str(broken)}))
    assert (model.channels, model.window, model.classes, model.track_m,
            model._pipeline) == before


def test_a_signal_while_wrapping_removes_the_temporary_model(train_dir, tmp_path, monkeypatch,
                                                             capsys):
    # no --served-out: the model is wrapped into a temporary folder, gone after the signal
    import tempfile

    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    real = serve.save_served_model

    def save_then_signal(out, *rest):
        real(out, *rest)
        os.kill(os.getpid(), signal.SIGTERM)
        return out
    monkeypatch.setattr(serve, "save_served_model", save_then_signal)
    assert serve.main(_args("--model", str(train_dir), "--port", "0")) == 143
    assert "stopped (SIGTERM) before serving\n" in capsys.readouterr().out
    assert list(scratch.iterdir()) == []
