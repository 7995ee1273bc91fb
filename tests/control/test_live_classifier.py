"""Live terrain classifier trained on simulated runs (pipelines/control_classifier.py) in the
closed loop: its decisions drive the controller and terrain_accuracy is scored from them."""

from __future__ import annotations

import numpy as np
import pytest

from pipelines.control_classifier import decision_source, sim_classifier
from terrain.control.closed_loop import run_closed_loop
from terrain.errors import ConfigError

TERRAINS = ("SNOW", "ICE")


@pytest.fixture(scope="module")
def husky_classifier(tmp_path_factory):
    cache = tmp_path_factory.mktemp("classifier")
    path, info = sim_classifier("husky", TERRAINS, seeds=(2000,), scenarios=("straight_accel",),
                                duration_s=10.0, cache_dir=cache, reserved_seeds=(0,))
    return cache, path, info


def test_sim_classifier_is_trained_once_and_cached(husky_classifier):
    cache, path, info = husky_classifier
    assert (path / "MLmodel").exists() and not info["cached"]
    assert info["windows_per_class"] == {"ICE": 17, "SNOW": 17}   # (10 s - 2 s) / 0.5 s + 1
    again, info2 = sim_classifier("husky", TERRAINS, seeds=(2000,),
                                  scenarios=("straight_accel",), duration_s=10.0,
                                  cache_dir=cache)
    assert again == path and info2["cached"]


def test_classifier_seeds_never_overlap_evaluation_or_tuning_seeds(tmp_path):
    with pytest.raises(ConfigError, match="2001"):
        sim_classifier("husky", TERRAINS, seeds=(2001,), cache_dir=tmp_path,
                       reserved_seeds=(2001,))
    with pytest.raises(ConfigError, match="1000"):
        sim_classifier("husky", TERRAINS, seeds=(1000,), cache_dir=tmp_path)


@pytest.mark.parametrize("terrain", TERRAINS)
def test_live_sim_decisions_drive_the_loop_and_are_scored(husky_classifier, terrain):
    cache, path, _ = husky_classifier
    provider, info = decision_source("live-sim", "husky", [terrain], [0], 6.0,
                                     classifier_seeds=(2000,), cache_dir=cache)
    # decision_source trains on the grid's six terrains: a second, separate model
    assert info["model_dir"] != str(path) and info["classifier"]["seeds"] == [2000]
    decide, table, note = provider(terrain, "straight_accel", 0)
    assert decide is not None and "live classifier" in note
    assert decide(1.9) == (None, 0.0)                 # no 2 s window has ended yet
    label, conf = decide(5.0)
    assert label in table.entries and 0.0 < conf <= 1.0
    _, loop, m = run_closed_loop("husky", terrain, "straight_accel", True, 0, 6.0,
                                 table=table, terrain_decision=decide)
    decided = np.array([str(r["terrain"]).upper() for r in loop.log])
    t = np.array([r["t_s"] for r in loop.log])
    assert np.all(decided[t < 2.0 - 1e-9] == "NONE")  # before the first window: no decision
    assert m["terrain_accuracy"] == pytest.approx(np.mean(decided == terrain))
    assert m["terrain_decisions"]["NONE"] == int(np.sum(t < 2.0 - 1e-9))
    assert 0.5 < m["terrain_accuracy"] < 1.0          # recognised, and not 1 by construction


def test_label_source_has_no_classifier():
    provider, info = decision_source("label", "husky", ["ICE"], [0], 5.0)
    assert provider is None and info == {"terrain_source": "label"}
    with pytest.raises(ConfigError, match="--model"):
        decision_source("model", "husky", ["ICE"], [0], 5.0)


@pytest.mark.parametrize("vehicle", ["husky", "agrimaro"])
def test_undecided_loop_limits_the_start_up_on_the_fallbacks_terrain(vehicle):
    from terrain.control import build_slip_table
    from terrain.control.closed_loop import fallback_basis

    table = build_slip_table(["SNOW", "ICE", "TILES"])
    assert fallback_basis(table) == "ICE"   # ICE's traction target is the smallest
    undecided = (lambda t: (None, 0.0))
    off = run_closed_loop(vehicle, "ICE", "straight_accel", False, 3, 4.0, table=table,
                          terrain_decision=undecided)[2]
    on = run_closed_loop(vehicle, "ICE", "straight_accel", True, 3, 4.0, table=table,
                         terrain_decision=undecided)[2]
    assert on["terrain_accuracy"] == 0.0 and on["terrain_decisions"] == {"NONE": 201}
    assert on["peak_slip"] < 0.6 * off["peak_slip"]   # feed-forward on ICE's curve acts
