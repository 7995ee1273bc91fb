"""The experiment configuration: refused before any data where it is wrong, and each setting
reaching the windows, the logged parameters and what ``run_cv`` returns (on the shipped Vulpi
runs: 15 runs, 4 classes, DIRT_ROAD a single run)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from terrain.errors import ConfigError
from terrain.models.experiment import (MAX_SEED, ExperimentConfig, fit_pipeline, load_windows,
                                       run_cv)
from terrain.models.svm import SVMConfig


@pytest.mark.parametrize("kwargs, match", [
    # --search builds the SVM's grid search: with a CNN it would cross-validate an SVM
    (dict(model="cnn", search=True), "--search tunes the SVM"),
    (dict(protocol="kfold"), "unknown protocol 'kfold'"),
    (dict(train_hop_s=0.0), "train_hop_s must be a finite value > 0"),
    (dict(train_hop_s=-1.0), "train_hop_s must be a finite value > 0"),
    (dict(train_hop_s=float("nan")), "train_hop_s must be a finite value > 0"),
    # text raised Python's TypeError in the comparison
    (dict(train_hop_s="0.5"), "train_hop_s must be a real number, got str '0.5'"),
    (dict(train_hop_s=0.001), "under one sample at 100 Hz"),        # BorealTC's IMU rate
    (dict(seeds=(True,)), "seeds must be one or more integers"),
    (dict(seeds=(1.5,)), "seeds must be one or more integers"),
    (dict(cnn_seeds=0), "cnn_seeds must be an integer"),
    (dict(n_threads=0), "n_threads must be an integer"),
])
def test_config_is_refused_before_any_data(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        ExperimentConfig(**kwargs)


def test_config_takes_numpys_whole_seed_range():
    assert ExperimentConfig(seeds=(0, MAX_SEED)).seeds == (0, MAX_SEED)


def test_params_log_the_effective_paper_windows():
    # the paper protocol cuts 1.7 s windows every 0.1 s in 5 s partitions at the dataset's
    # rate, whatever the (default) window_s / hop_s / rate_hz fields hold
    params = ExperimentConfig(protocol="paper", seeds=(0, 4)).as_params()
    assert (params["window_s"], params["hop_s"], params["train_hop_s"], params["partition_s"],
            params["rate_hz"]) == (1.7, 0.1, 0.1, 5.0, 100.0)
    assert params["seeds"] == "0,4" and params["signals"] == "all"
    assert params["n_threads"] == 0 and params["svm_C"] == SVMConfig().C and "svm" not in params


def test_rate_and_steady_settings_reach_the_windows(vulpi_runs):
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",))
    native = load_windows(config, runs=vulpi_runs)
    assert native.rate_hz == 50.0 and native.X.shape[2] == 100      # 2 s at Vulpi's 50 Hz
    slow = load_windows(replace(config, rate_hz=25.0), runs=vulpi_runs)
    assert slow.rate_hz == 25.0 and slow.X.shape[2] == 50 and len(slow) == len(native)


@pytest.mark.parametrize("protocol", ["grouped", "paper"])
def test_steady_only_drops_the_unsteady_windows_under_every_protocol(vulpi_runs, protocol):
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), protocol=protocol)
    every = load_windows(config, runs=vulpi_runs)
    steady = load_windows(replace(config, steady_only=True), runs=vulpi_runs)
    dropped = steady.counts["dropped_unsteady"]
    assert every.counts["dropped_unsteady"] == 0 and dropped > 0
    assert len(steady) == len(every) - dropped


def test_run_cv_returns_and_notes_what_it_windowed(vulpi_runs):
    config = ExperimentConfig(dataset="vulpi", signals=("wheels",), seeds=(0,),
                              steady_only=True, single_run_blocks=3)
    res = run_cv(config, runs=vulpi_runs)
    assert res.n_runs == len(vulpi_runs) == 15 and res.n_windows > res.n_runs
    note = f"{res.counts['dropped_unsteady']} window(s) dropped unsteady"
    assert note in res.input_notes and note in res.report.notes
    # the single-run class is cut into the blocks asked, not the default 5
    assert any("DIRT_ROAD has a single run: cut into 3 contiguous time block(s) (of 3 asked)"
               in n for n in res.report.notes)
    assert res.report.folds["n_test"].sum() == res.n_windows


def test_fit_pipeline_refuses_ekf_channels_a_served_model_is_not_given(vulpi_runs):
    # they come from a causal EKF over the whole run: the served model gets raw signals
    config = ExperimentConfig(dataset="vulpi", signals=("all+ekf",), seeds=(0,))
    with pytest.raises(ConfigError, match="EKF-derived channels are for cross-validation"):
        fit_pipeline(config, runs=vulpi_runs)


@pytest.mark.parametrize("model, window_ekf", [("cnn", False), ("svm", True)])
def test_run_cv_builds_each_seeds_model_with_that_seed_and_its_window_ekf(
        vulpi_runs, monkeypatch, model, window_ekf):
    # every fold's model comes from factory(seed): a factory that left the seed out would
    # train the same network under every seed; the SVM with --window-ekf takes the raw
    # windows and appends the EKF channels per window (features of the raw signals alone
    # would silently drop them)
    from types import SimpleNamespace

    import terrain.models.experiment as experiment
    from terrain.models.window_ekf import WindowEKFClassifier

    seen = {}

    def fake_cv(factory, X, *args, **kwargs):
        seen.update(factory=factory, X=X)
        return SimpleNamespace(notes=[])

    monkeypatch.setattr(experiment, "cross_validate", fake_cv)
    run_cv(ExperimentConfig(dataset="vulpi", model=model, window_ekf=window_ekf, seeds=(0,)),
           runs=vulpi_runs)
    assert seen["X"].ndim == 3                       # raw windows, not window features
    est = seen["factory"](7)
    if window_ekf:
        assert isinstance(est, WindowEKFClassifier)
        est = est.estimator
    # (the SVM pipeline: the seed of its calibrated SVC step)
    assert {v for k, v in est.get_params().items() if k.endswith("random_state")} == {7}


def test_a_seed_beyond_numpys_range_is_refused():
    with pytest.raises(ConfigError, match="seeds must be one or more integers"):
        ExperimentConfig(seeds=(MAX_SEED + 1,))
