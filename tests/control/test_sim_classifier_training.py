"""The live-sim classifier's training runs and cache (pipelines/control_classifier.py).

The classifier is trained on closed-loop runs driven by the controller it will serve: its
gains, estimator and feed-forward flag must reach those runs, not only the cache key. The
cache must not hand back a model whose training record is missing, nor one trained on runs
of another length, and the classifier's seeds may never be the evaluation seeds.
"""

from __future__ import annotations

import json

import pytest

import pipelines.control_classifier as control_classifier
from pipelines.control_classifier import decision_source, sim_classifier
from terrain.errors import ConfigError

TERRAINS = ("SNOW", "ICE")
#: one 4 s straight run per terrain (5 windows each), one seed
FAST = dict(seeds=(2000,), scenarios=("straight_accel",), duration_s=4.0)


@pytest.mark.slow
def test_the_controlled_training_runs_use_the_given_controller(tmp_path, monkeypatch):
    calls = []
    real = control_classifier.run_closed_loop

    def recording(vehicle, terrain, scenario, controller_on, seed, duration_s, gains,
                  **kwargs):
        calls.append(dict(gains=gains, controller_on=controller_on, **kwargs))
        return real(vehicle, terrain, scenario, controller_on, seed, duration_s, gains,
                    **kwargs)

    monkeypatch.setattr(control_classifier, "run_closed_loop", recording)
    _, info = sim_classifier("husky", TERRAINS, cache_dir=tmp_path, gains=(5.0, 10.0),
                             estimator="observer", feed_forward=False, **FAST)
    assert len(calls) == len(TERRAINS) and info["controlled_windows"] == 10
    for call in calls:
        assert call == dict(gains=(5.0, 10.0), controller_on=True, estimator="observer",
                            feed_forward=False)


@pytest.mark.slow
def test_a_cached_model_without_its_training_record_is_trained_again(tmp_path):
    path, info = sim_classifier("husky", TERRAINS, cache_dir=tmp_path, **FAST)
    record = path.parent / "info.json"
    record.unlink()
    again, info2 = sim_classifier("husky", TERRAINS, cache_dir=tmp_path, **FAST)
    assert again == path and not info2["cached"]
    assert json.loads(record.read_text())["key"] == info["key"]
    assert not (path.parent / "model.tmp").exists()        # the staging folder is moved


@pytest.mark.slow
def test_runs_of_another_length_train_another_model(tmp_path):
    path, info = sim_classifier("husky", TERRAINS, cache_dir=tmp_path, **FAST)
    other, info2 = sim_classifier("husky", TERRAINS, cache_dir=tmp_path,
                                  **{**FAST, "duration_s": 5.0})
    assert other != path and not info2["cached"] and info2["key"] != info["key"]
    # longer runs, more 2 s windows: 6 per run against 5 (2 runs per terrain)
    assert (info["training_windows"], info2["training_windows"]) == (20, 24)


def test_the_evaluation_seeds_are_never_training_seeds_of_the_loops_classifier(tmp_path):
    with pytest.raises(ConfigError, match="2000"):
        decision_source("live-sim", "husky", ["ICE"], [2000], classifier_seeds=(2000, 2001),
                        cache_dir=tmp_path)
    assert not any(tmp_path.iterdir())                       # refused before any training
