"""Two commands at once (cli25): two ``control-grid`` / ``control-sim`` runs building the
same live-sim classifier cache entry (pipelines/control_classifier.py)."""

from __future__ import annotations

import dataclasses
import json
import threading
import time

import numpy as np
import pandas as pd

from pipelines import control_classifier
from tests.threads import at_once


@dataclasses.dataclass(frozen=True)
class _Run:
    run_id: str = "sim"
    meta: dict = dataclasses.field(default_factory=dict)


class _Pipe:
    classes_ = np.array(["ICE", "SNOW"])

    def fit(self, X, y):
        return self

    def predict(self, X):
        return np.array(["ICE", "SNOW"])


def _cheap_training(monkeypatch, saves):
    """sim_classifier without its simulations and SVM; ``save_model`` writes a model
    folder slowly (the window in which a second process trains the same entry)."""
    cc = control_classifier
    monkeypatch.setattr(cc, "simulate", lambda config: _Run())
    monkeypatch.setattr(cc, "simulator_digest", lambda *a: "sim")
    monkeypatch.setattr(cc, "source_digest", lambda *a: "code")
    monkeypatch.setattr(cc, "make_windows", lambda runs, signals, cfg: _Windows())
    monkeypatch.setattr(cc, "make_model", lambda *a: _Pipe())
    # the saved model's channel_steps_s (the training runs' steps): _Run has no streams
    monkeypatch.setattr(cc, "training_steps_s", lambda runs, channels: {"wz": 0.01})
    monkeypatch.setattr(cc, "runs_to_model_input",
                        lambda *a: [pd.DataFrame({"wz": np.zeros(200)})])

    def save_model(path, *args, **kwargs):
        path.mkdir(parents=True)
        (path / "python_model.pkl").write_text(threading.current_thread().name)
        time.sleep(0.2)
        (path / "MLmodel").write_text(threading.current_thread().name)
        saves.append(threading.current_thread().name)

    monkeypatch.setattr(cc, "save_model", save_model)


class _Windows:
    labels = np.array(["ICE", "SNOW"])
    run_ids = np.array(["a", "b"])
    X = np.zeros((2, 1, 4))
    channels = ("wz",)

    def __len__(self):
        return 2


def test_two_runs_training_the_same_classifier_at_once_both_get_a_whole_model(
        tmp_path, monkeypatch):
    # both trained under the one fixed staging name model.tmp: the second removed the
    # first's half-written folder, and the first failed (FileNotFoundError) or moved the
    # second's half model into the cache
    saves: list = []
    _cheap_training(monkeypatch, saves)

    def train(i):
        return control_classifier.sim_classifier(
            "husky", ("ICE", "SNOW"), seeds=(2000,), scenarios=("straight_accel",),
            cache_dir=tmp_path, controlled_runs=False)

    results = at_once(2, train)
    errors = [r for r in results if isinstance(r, BaseException)]
    assert not errors, errors
    (path_a, info_a), (path_b, info_b) = results
    assert path_a == path_b and info_a["key"] == info_b["key"]
    files = sorted(p.name for p in path_a.iterdir())
    assert files == ["MLmodel", "python_model.pkl"]
    # one training's model, whole (not one file of each)
    assert (path_a / "MLmodel").read_text() == (path_a / "python_model.pkl").read_text()
    assert sorted(p.name for p in path_a.parent.iterdir()) == ["info.json", "model"]
    json.loads((path_a.parent / "info.json").read_text())
    # and the next call reads the cache
    assert control_classifier.sim_classifier(
        "husky", ("ICE", "SNOW"), seeds=(2000,), scenarios=("straight_accel",),
        cache_dir=tmp_path, controlled_runs=False)[1]["cached"]


def test_a_whole_model_another_run_moved_in_meanwhile_is_kept_not_replaced(tmp_path,
                                                                           monkeypatch):
    # a third run may have found it complete and be reading it: replacing it (rmtree, then
    # rename) pulled the files from under that reader
    saves: list = []
    _cheap_training(monkeypatch, saves)
    real_save = control_classifier.save_model

    def save_model(path, *args, **kwargs):
        real_save(path, *args, **kwargs)
        other = path.parent.parent / "model"     # another run finished first
        other.mkdir()
        (other / "MLmodel").write_text("other run\n")
        (other / "python_model.pkl").write_text("other run\n")

    monkeypatch.setattr(control_classifier, "save_model", save_model)
    path, info = control_classifier.sim_classifier(
        "husky", ("ICE", "SNOW"), seeds=(2000,), scenarios=("straight_accel",),
        cache_dir=tmp_path, controlled_runs=False)
    assert not info["cached"]
    assert (path / "MLmodel").read_text() == "other run\n"
    assert sorted(p.name for p in path.parent.iterdir()) == ["info.json", "model"]
