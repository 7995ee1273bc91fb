"""Live terrain classifier trained on simulated runs (pipelines/control_classifier.py) in the
closed loop: it reads the loop's own samples, causally, its decisions drive the controller
and terrain_accuracy is scored from them."""

from __future__ import annotations

import numpy as np
import pytest

from pipelines.control_classifier import CLASSIFIER_MODULES, decision_source, sim_classifier
from pipelines.live_terrain import LiveClassifier
from terrain.control.closed_loop import default_gains, run_closed_loop
from terrain.errors import ConfigError
from terrain.serving.model import load_stream_model
from terrain.sim.closed_loop import replay_observations
from terrain.sim.digest import simulator_digest, source_digest
from terrain.sim.simulate import SimConfig, simulate_with_physics

TERRAINS = ("SNOW", "ICE")


@pytest.fixture(scope="module")
def husky_classifier(tmp_path_factory):
    cache = tmp_path_factory.mktemp("classifier")
    path, info = sim_classifier("husky", TERRAINS, seeds=(2000,), scenarios=("straight_accel",),
                                duration_s=10.0, cache_dir=cache, reserved_seeds=(0,))
    return cache, path, info


@pytest.mark.slow
def test_sim_classifier_is_trained_once_and_cached(husky_classifier):
    cache, path, info = husky_classifier
    assert (path / "MLmodel").exists() and not info["cached"]
    # (10 s - 2 s) / 0.5 s + 1 = 17 windows per run; per terrain an uncontrolled run and a
    # closed-loop run with the traction controller on (the robot's logged runs include both)
    assert info["windows_per_class"] == {"ICE": 34, "SNOW": 34}
    assert info["controlled_runs"] and info["controlled_windows"] == 34
    assert info["controller"]["gains"] == list(default_gains("husky"))
    assert info["controller"]["estimator"] == "fused" and info["controller"]["feed_forward"]
    # the key covers the simulator's inputs that shape the training runs
    assert info["simulator"] == simulator_digest("husky", TERRAINS)
    assert simulator_digest("husky", TERRAINS) != simulator_digest("agrimaro", TERRAINS)
    # ... and the code that builds the model and drives its controlled runs
    assert info["code"] == source_digest(CLASSIFIER_MODULES)
    # the training code itself among them (an edit to it reused the stale cached model)
    assert "pipelines.control_classifier" in CLASSIFIER_MODULES
    again, info2 = sim_classifier("husky", TERRAINS, seeds=(2000,),
                                  scenarios=("straight_accel",), duration_s=10.0,
                                  cache_dir=cache)
    assert again == path and info2["cached"]


@pytest.mark.slow
def test_cache_key_follows_the_controller_of_the_training_runs(tmp_path):
    """Everything that changes the closed-loop training runs changes the cached model:
    gains, estimator, feed-forward, controlled runs or not; the defaults spelled out hit the
    cache."""
    kw = dict(seeds=(2000,), scenarios=("straight_accel",), duration_s=4.0, cache_dir=tmp_path)
    base, info = sim_classifier("husky", TERRAINS, **kw)
    assert info["controlled_windows"] == 10 and info["training_windows"] == 20   # 5 per run
    folders = {base}
    for change in (dict(gains=(5.0, 10.0)), dict(estimator="observer"),
                   dict(feed_forward=False), dict(controlled_runs=False)):
        path, other = sim_classifier("husky", TERRAINS, **kw, **change)
        assert not other["cached"] and other["key"] != info["key"], change
        folders.add(path)
    assert len(folders) == 5
    assert other["controller"] is None and other["controlled_windows"] == 0   # uncontrolled
    assert other["training_windows"] == 10
    same, again = sim_classifier("husky", TERRAINS, gains=default_gains("husky", "fused"),
                                 estimator="fused", feed_forward=True, **kw)
    assert same == base and again["cached"]
    with pytest.raises(ConfigError, match="ekf-vo"):
        sim_classifier("husky", TERRAINS, estimator="ekf-vo", **kw)


def test_classifier_seeds_never_overlap_evaluation_or_tuning_seeds(tmp_path):
    with pytest.raises(ConfigError, match="2001"):
        sim_classifier("husky", TERRAINS, seeds=(2001,), cache_dir=tmp_path,
                       reserved_seeds=(2001,))
    with pytest.raises(ConfigError, match="1000"):
        sim_classifier("husky", TERRAINS, seeds=(1000,), cache_dir=tmp_path)


def _observations(terrain, seed=0, duration=6.0):
    sim = simulate_with_physics(SimConfig(vehicle="husky", terrains=(terrain,),
                                          scenario="straight_accel", duration_s=duration,
                                          seed=seed))
    return list(replay_observations(sim))


def _feed(model, observations):
    live = LiveClassifier(model, "husky")
    for obs in observations:
        live.update(obs)
    return live


@pytest.mark.slow
def test_live_decision_at_t_uses_only_samples_taken_by_t(husky_classifier):
    """Causality: two sample streams equal up to 4 s (SNOW) and different after (ICE) give
    the same decision at every time up to 4 s, and different ones once the later samples
    fill a window."""
    _, path, _ = husky_classifier
    model = load_stream_model(path)
    snow, ice = _observations("SNOW"), _observations("ICE")
    mixed = [s if s.t_s <= 4.0 else i for s, i in zip(snow, ice)]
    a, b = _feed(model, snow), _feed(model, mixed)
    for obs in snow:
        if obs.t_s <= 4.0:
            assert a(obs.t_s) == b(obs.t_s), obs.t_s
    assert a(1.99) == (None, 0.0)                     # no 2 s window has ended yet
    assert a(2.0)[0] == "SNOW" and 0.5 < a(2.0)[1] <= 1.0
    assert a(6.0)[0] == "SNOW" and b(6.0)[0] == "ICE"   # window [4, 6) is all ICE in b
    assert a.n_windows == 9                           # 2.0, 2.5, ..., 6.0


@pytest.mark.slow
@pytest.mark.parametrize("terrain", TERRAINS)
def test_live_sim_decisions_drive_the_loop_and_are_scored(husky_classifier, terrain):
    cache, path, _ = husky_classifier
    provider, info = decision_source("live-sim", "husky", [terrain], [0],
                                     classifier_seeds=(2000,), cache_dir=cache)
    # decision_source trains on the grid's six terrains: a second, separate model
    assert info["model_dir"] != str(path) and info["classifier"]["seeds"] == [2000]
    live, table, note = provider(terrain)
    assert isinstance(live, LiveClassifier) and "loop's own samples" in note
    assert provider(terrain)[0] is not live           # a fresh classifier per run
    _, loop, m = run_closed_loop("husky", terrain, "straight_accel", True, 0, 6.0,
                                 table=table, live_terrain=live)
    decided = np.array([str(r["terrain"]).upper() for r in loop.log])
    t = np.array([r["t_s"] for r in loop.log])
    # the loop's decisions are the classifier's, made on the loop's own samples
    assert live.n_windows >= 8
    assert all(str(live(ti)[0]).upper() == d for ti, d in zip(t, decided))
    assert np.all(decided[t < 2.0 - 1e-9] == "NONE")  # before the first window: no decision
    assert m["terrain_accuracy"] == pytest.approx(np.mean(decided == terrain))
    assert m["terrain_decisions"]["NONE"] == int(np.sum(t < 2.0 - 1e-9))
    # recognised (6 classes: chance 1/6 of the 2/3 of steps after the first window), and not
    # 1 by construction
    assert 0.5 < m["terrain_accuracy"] < 1.0


@pytest.mark.slow
def test_live_terrain_and_a_decision_function_exclude_each_other(husky_classifier):
    _, path, _ = husky_classifier
    live = LiveClassifier(load_stream_model(path), "husky")
    with pytest.raises(ConfigError, match="not both"):
        run_closed_loop("husky", "ICE", "straight_accel", True, 0, 1.0,
                        terrain_decision=lambda t: ("ICE", 1.0), live_terrain=live)


def test_label_source_has_no_classifier():
    provider, info = decision_source("label", "husky", ["ICE"], [0])
    assert provider is None and info == {"terrain_source": "label"}
    with pytest.raises(ConfigError, match="--model"):
        decision_source("model", "husky", ["ICE"], [0])


@pytest.mark.slow
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


def test_a_stale_live_decision_falls_back():
    """A classifier that decided SNOW (confidence 0.9) at t = 0 and nothing since: at
    t = 60 s the decision is 60 s old, beyond the table's max_decision_age_s (4 s), so the
    loop must use the fallback. Before, LiveClassifier gave no decision time and the loop
    called select_target without an age: the loop used SNOW's 0.30 traction target."""
    from collections import deque

    from terrain.control.closed_loop import TractionLoop
    from terrain.control.desired_slip import build_slip_table
    from terrain.control.estimators import VelocityEstimate
    from terrain.control.traction import config_for_vehicle
    from terrain.sim.closed_loop import Observation

    live = object.__new__(LiveClassifier)      # no model needed: only the decision memory
    live._decisions = deque([(0.0, "SNOW", 0.9)])
    assert live(1.0) == ("SNOW", 0.9, 0.0) and live(-1.0) == (None, 0.0)

    class Fixed:
        name = limits = "stub"

        def update(self, obs):
            return VelocityEstimate(np.full(2, 10.0), np.full(2, 1.0), np.zeros(2), 1.0, 0.0)

    table = build_slip_table(["SNOW", "ICE"])
    cfg, n = config_for_vehicle("husky")
    loop = TractionLoop(cfg, n, Fixed(), table, live, feed_forward=False)
    empty = np.zeros((0, 3))
    for t in (2.0, 60.0):
        loop(Observation(t, np.full(2, 10.0), np.zeros((0, 4)), empty, empty,
                         np.zeros((0, 5)), empty, np.zeros((0, 7))))
    fresh, stale = loop.log
    assert fresh["target_traction"] == table.entries["SNOW"].traction == pytest.approx(0.30)
    assert stale["decision_age_s"] == 60.0
    assert stale["target_traction"] == table.fallback.traction < 0.01     # ICE's, was 0.30
