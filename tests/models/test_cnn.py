"""CNN terrain classifiers: sklearn contract, planted effects, determinism, no leakage."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import numpy as np
import pytest
from sklearn.model_selection import StratifiedGroupKFold
from sklearn.utils.estimator_checks import parametrize_with_checks

from terrain.errors import ConfigError, ShapeError
from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier, log_spectrogram

RATE_HZ = 100.0
#: small, fast settings for the tests (the library defaults are the measured ones)
FAST = dict(max_epochs=15, width=8, batch_size=32, n_threads=1, device="cpu")


def _planted(n_runs: int = 8, per_run: int = 12, seed: int = 0):
    """Two terrains: ``B`` adds a 20 Hz vibration on channel 0; channel 1 has offset 5."""
    rng = np.random.default_rng(seed)
    t = np.arange(200) / RATE_HZ
    X, y, groups = [], [], []
    for r in range(n_runs):
        label = "A" if r % 2 == 0 else "B"
        for _ in range(per_run):
            w = rng.normal(0.0, 1.0, (3, t.size))
            w[1] += 5.0
            if label == "B":
                w[0] += 1.5 * np.sin(2 * np.pi * 20.0 * t + rng.uniform(0, 2 * np.pi))
            X.append(w)
            y.append(label)
            groups.append(f"run{r}")
    return np.asarray(X, dtype=np.float32), np.asarray(y), np.asarray(groups)


#: the contract checks test the interface, not learning: 2 epochs keep them fast
CONTRACT = dict(FAST, max_epochs=2, width=4)
#: scikit-learn's training check wants > 83 % training accuracy on 2-feature tabular blobs,
#: read here as a 2-sample, 1-channel signal; 2 epochs of a CNN are not meant to reach it
#: (learning is tested on planted signals below).
NOT_A_TABULAR_MODEL = ("2 epochs of a CNN over time are not a model of 2-feature tabular "
                       "blobs; learning is tested on planted windows")
#: sample weights set how often a window is drawn in an epoch (a seeded weighted sampler):
#: a weight of 2 equals a duplicated window in expectation, not bit for bit
WEIGHTS_ARE_DRAWS = ("weights are drawing probabilities of a seeded sampler, equal to "
                     "duplicated windows in expectation only; tested in "
                     "tests/models/test_run_balanced_models.py")


@pytest.mark.slow
@parametrize_with_checks([RawCNNClassifier(**CONTRACT),
                          SpectrogramCNNClassifier(segment_s=0.04, hop_s=0.02, **CONTRACT)],
                         expected_failed_checks=lambda est: {
                             "check_classifiers_train": NOT_A_TABULAR_MODEL,
                             "check_sample_weight_equivalence_on_dense_data":
                                 WEIGHTS_ARE_DRAWS})
def test_cnns_follow_sklearn_contract(estimator, check):
    check(estimator)


@pytest.mark.parametrize("model", [RawCNNClassifier(**FAST),
                                   SpectrogramCNNClassifier(**{**FAST, "max_epochs": 40})])
def test_planted_vibration_is_learned_on_unseen_runs(model):
    X, y, groups = _planted()
    test = np.isin(groups, ["run6", "run7"])
    model.fit(X[~test], y[~test])
    assert (model.predict(X[test]) == y[test]).mean() >= 0.9
    proba = model.predict_proba(X[test])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-6)
    assert list(model.classes_) == ["A", "B"]


def test_same_seed_same_model_other_seed_other_model():
    X, y, _ = _planted(n_runs=4)
    p = [RawCNNClassifier(**{**FAST, "max_epochs": 3}, random_state=s).fit(X, y)
         .predict_proba(X) for s in (0, 0, 1)]
    np.testing.assert_array_equal(p[0], p[1])
    assert np.abs(p[0] - p[2]).max() > 1e-4


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
@pytest.mark.parametrize("layout", ["fortran", "transposed view"])
def test_memory_layout_of_the_windows_does_not_change_the_model(cls, layout):
    # the windowing hands out a transposed view, a joblib worker a C-contiguous memmap:
    # the same values must train the same network (float32 sums follow the layout)
    X, y, _ = _planted(n_runs=4)
    other = (np.asfortranarray(X) if layout == "fortran"
             else np.ascontiguousarray(X.transpose(0, 2, 1)).transpose(0, 2, 1))
    assert np.array_equal(other, X) and not other.flags.c_contiguous
    a = cls(**{**FAST, "max_epochs": 1}).fit(X, y)
    b = cls(**{**FAST, "max_epochs": 1}).fit(other, y)
    np.testing.assert_array_equal(b.mean_, a.mean_)
    np.testing.assert_array_equal(b.predict_proba(X), a.predict_proba(X))
    np.testing.assert_array_equal(a.predict_proba(other), a.predict_proba(X))


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_fitted_net_holds_its_module_only_where_skorch_maps_devices(cls):
    # the network is handed to skorch as a class, so its weights are pickled only as
    # skorch's ``module_``, which skorch maps to the available device when loading: a
    # net trained on a GPU then loads on a CPU-only robot (see the CUDA test below)
    X, y, _ = _planted(n_runs=4)
    model = cls(**{**FAST, "max_epochs": 2}).fit(X, y)
    assert isinstance(model.net_.module, type)
    assert isinstance(model.net_.module_, model.net_.module)
    again = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(again.predict_proba(X), model.predict_proba(X))


def _cuda_available() -> bool:
    import torch
    return torch.cuda.is_available()


@pytest.mark.skipif(not _cuda_available(), reason="needs a CUDA device")
def test_gpu_trained_model_serves_on_a_cpu_only_machine(tmp_path):
    X, y, groups = _planted()
    test = np.isin(groups, ["run6", "run7"])
    model = SpectrogramCNNClassifier(**{**FAST, "max_epochs": 40, "device": "auto"})
    model.fit(X[~test], y[~test])
    assert next(model.net_.module_.parameters()).device.type == "cuda"
    on_gpu = model.predict_proba(X[test])
    assert (model.classes_[on_gpu.argmax(axis=1)] == y[test]).mean() >= 0.9
    np.testing.assert_allclose(proba_without_cuda(model, X[test], tmp_path), on_gpu, atol=1e-4)


def proba_without_cuda(model, X, folder) -> np.ndarray:
    """``model.predict_proba(X)`` in a new process that sees no CUDA device (a robot's CPU):
    the model is pickled to ``folder`` and loaded there; every CNN it holds must be on the
    CPU after loading."""
    (folder / "model.pkl").write_bytes(pickle.dumps(model))
    np.save(folder / "x.npy", X)
    code = ("import pickle, sys, warnings, numpy as np, torch; warnings.simplefilter('ignore');"
            "assert not torch.cuda.is_available();"
            "m = pickle.loads(open(sys.argv[1] + '/model.pkl', 'rb').read());"
            "nets = [e for e in getattr(m, 'estimators_', [m]) if hasattr(e, 'net_')];"
            "assert nets and all(next(e.net_.module_.parameters()).device.type == 'cpu'"
            " for e in nets);"
            "np.save(sys.argv[1] + '/p.npy', m.predict_proba(np.load(sys.argv[1] + '/x.npy')))")
    done = subprocess.run([sys.executable, "-c", code, str(folder)], capture_output=True,
                          text=True, env={**os.environ, "CUDA_VISIBLE_DEVICES": ""})
    assert done.returncode == 0, done.stderr[-2000:]
    return np.load(folder / "p.npy")


def test_normalisation_statistics_come_from_the_training_windows_only():
    X, y, _ = _planted(n_runs=4)
    model = RawCNNClassifier(**{**FAST, "max_epochs": 1}).fit(X[:24], y[:24])
    np.testing.assert_allclose(model.mean_[:, 0], X[:24].mean(axis=(0, 2)), rtol=1e-5)
    np.testing.assert_allclose(model.scale_[:, 0], X[:24].std(axis=(0, 2)), rtol=1e-4)
    assert abs(model.mean_[1, 0] - 5.0) < 0.1       # the planted offset of channel 1


def test_early_stopping_validates_on_whole_held_out_runs():
    X, y, groups = _planted()
    with pytest.raises(ConfigError, match="groups"):
        RawCNNClassifier(**FAST, early_stopping=True).fit(X, y)
    model = RawCNNClassifier(**{**FAST, "max_epochs": 4}, early_stopping=True,
                             validation_splits=4).fit(X, y, groups=groups)
    history = model.net_.history
    assert "valid_loss" in history[-1]
    # the network was trained on whole runs only: 6 of 8 runs (12 windows each)
    assert model.net_.history[0]["batches"][0]["train_batch_size"] == FAST["batch_size"]
    n_train = sum(b["train_batch_size"] for b in history[0]["batches"] if "train_batch_size" in b)
    assert n_train == 6 * 12
    # the fitted model does not carry the validation windows with it
    assert model.net_.train_split is None


def test_early_stopping_class_weights_count_the_training_runs_only():
    # runs of 4 to 20 windows: the runs the grouped validation split holds out change
    # the class balance of the windows the network trains on
    X, y, groups = _planted(per_run=20)
    sizes = (20, 4, 20, 4, 4, 4, 20, 12)
    keep = np.concatenate([np.flatnonzero(groups == f"run{r}")[:n]
                           for r, n in enumerate(sizes)])
    X, y, groups = X[keep], y[keep], groups[keep]
    model = RawCNNClassifier(**{**FAST, "max_epochs": 1}, early_stopping=True,
                             validation_splits=4).fit(X, y, groups=groups)
    _, y_idx = np.unique(y, return_inverse=True)
    fit_idx, _ = next(StratifiedGroupKFold(4, shuffle=True, random_state=model.random_state)
                      .split(X, y_idx, groups))
    counts = np.bincount(y_idx[fit_idx], minlength=2)
    every_window = np.bincount(y_idx, minlength=2)
    assert counts[0] / counts[1] != pytest.approx(every_window[0] / every_window[1], rel=0.05)
    np.testing.assert_allclose(model.net_.criterion_.weight.numpy(),
                               counts.sum() / (2 * counts), rtol=1e-6)


def test_early_stopping_normalisation_statistics_leave_out_the_validation_runs():
    # the validation runs held out for early stopping are unseen data for the network:
    # its input scaling must not be fitted on them either (it was, before the split)
    X, y, groups = _planted()
    X = X.copy()
    model = RawCNNClassifier(**{**FAST, "max_epochs": 1}, early_stopping=True,
                             validation_splits=4)
    model.fit(X, y, groups=groups)
    val = np.isin(groups, model.validation_groups_)
    assert 0 < val.sum() < len(X)
    np.testing.assert_allclose(model.mean_[:, 0], X[~val].mean(axis=(0, 2)), rtol=1e-5)
    np.testing.assert_allclose(model.scale_[:, 0], X[~val].std(axis=(0, 2)), rtol=1e-4)
    assert not np.allclose(model.mean_[:, 0], X.mean(axis=(0, 2)), rtol=1e-5)


def test_fit_leaves_the_callers_torch_random_stream_as_it_found_it():
    import torch
    X, y, _ = _planted(n_runs=4)
    torch.manual_seed(123)
    expected = torch.rand(3)
    torch.manual_seed(123)
    RawCNNClassifier(**{**FAST, "max_epochs": 1}).fit(X, y)
    torch.testing.assert_close(torch.rand(3), expected)


def test_log_spectrogram_peaks_at_the_tone_frequency():
    t = np.arange(200) / RATE_HZ
    X = np.sin(2 * np.pi * 20.0 * t)[None, None, :].astype(np.float32)
    spec, freqs = log_spectrogram(X, RATE_HZ, segment_s=0.5, hop_s=0.1)
    assert spec.shape == (1, 1, 26, 16)               # 50-sample segments, 10-sample hop
    assert freqs[spec[0, 0].mean(axis=1).argmax()] == pytest.approx(20.0)


def test_band_limit_zeroes_bins_above_the_native_nyquist_of_low_rate_channels():
    X, y, _ = _planted(n_runs=4)
    model = SpectrogramCNNClassifier(**{**FAST, "max_epochs": 1},
                                     band_limits_hz=(np.inf, 3.25, np.inf)).fit(X, y)
    assert model.mask_[1, :, 0].sum() == 2             # 0 and 2 Hz bins (2 Hz resolution)
    assert model.mask_[0].all() and model.mask_[2].all()
    Z = model._standardise(model._inputs(X))
    assert not Z[:, 1, 2:].any()
    with pytest.raises(ConfigError, match="band_limits_hz"):
        SpectrogramCNNClassifier(**FAST, band_limits_hz=(1.0,)).fit(X, y)


def test_noise_copy_of_the_training_spectra():
    """augment_noise_std adds one perturbed copy per window: same labels, the original
    spectra first, zero-mean noise of that standard deviation, masked bins kept at zero,
    reproducible from the seed; 0 leaves the training set as it is."""
    model = SpectrogramCNNClassifier(rate_hz=RATE_HZ, augment_noise_std=0.3, random_state=4)
    rng = np.random.default_rng(1)
    Z = rng.normal(size=(50, 3, 26, 8)).astype(np.float32)
    y = np.arange(50) % 2
    model.mask_ = np.ones((3, 26, 1), dtype=np.float32)
    model.mask_[2, 13:] = 0.0                      # a low-rate channel's bins above Nyquist
    Z = Z * model.mask_
    Z2, y2 = model._augmented(Z, y)
    assert Z2.shape == (100, 3, 26, 8) and Z2.dtype == np.float32
    np.testing.assert_array_equal(Z2[:50], Z)
    np.testing.assert_array_equal(y2, np.concatenate([y, y]))
    noise = (Z2[50:] - Z)[:, :2]
    assert abs(noise.mean()) < 0.01 and abs(noise.std() - 0.3) < 0.01
    assert not Z2[50:, 2, 13:].any()
    np.testing.assert_array_equal(model._augmented(Z, y)[0], Z2)
    small = SpectrogramCNNClassifier(rate_hz=RATE_HZ, augment_noise_std=0.1, random_state=4)
    small.mask_ = None
    assert abs((small._augmented(Z, y)[0][50:] - Z).std() - 0.1) < 0.005
    plain = SpectrogramCNNClassifier(rate_hz=RATE_HZ)
    assert plain._augmented(Z, y)[0] is Z
    with pytest.raises(ConfigError, match="augment_noise_std"):
        SpectrogramCNNClassifier(augment_noise_std=-0.1)._augmented(Z, y)


def test_noise_copy_still_learns_the_planted_vibration():
    X, y, groups = _planted()
    train = np.isin(groups, [f"run{r}" for r in range(6)])
    model = SpectrogramCNNClassifier(rate_hz=RATE_HZ, augment_noise_std=0.3, random_state=0,
                                     **FAST).fit(X[train], y[train])
    assert (model.predict(X[~train]) == y[~train]).mean() > 0.9


def test_early_stopping_never_holds_out_every_run_of_a_class():
    # A, B with 4 runs each and C with one: StratifiedGroupKFold(5, seed 3)'s first split
    # held out C's only run, so the network was trained on A and B alone, C kept in
    # classes_ with an untrained output, without a word
    rng = np.random.default_rng(0)
    runs = [("A", f"a{i}") for i in range(4)] + [("B", f"b{i}") for i in range(4)] + [("C", "c0")]
    X = np.concatenate([rng.normal(size=(10, 2, 32)) + k for k in range(len(runs))])
    y = np.repeat([lab for lab, _ in runs], 10)
    groups = np.repeat([run for _, run in runs], 10)
    _, y_idx = np.unique(y, return_inverse=True)
    _, first_val = next(StratifiedGroupKFold(5, shuffle=True, random_state=3)
                        .split(X, y_idx, groups))
    assert "c0" in set(groups[first_val])          # the split the fit used to take
    model = RawCNNClassifier(**{**FAST, "max_epochs": 1}, early_stopping=True,
                             random_state=3).fit(X, y, groups=groups)
    held = set(model.validation_groups_)
    assert held and "c0" not in held
    assert set(y[~np.isin(groups, list(held))]) == {"A", "B", "C"}
    # one run per class: every split holds out some class's only run; refused, named
    one_each = np.isin(groups, ["a0", "b0", "c0"])
    with pytest.raises(ConfigError, match="'A'"):
        RawCNNClassifier(**{**FAST, "max_epochs": 1}, early_stopping=True,
                         validation_splits=2).fit(X[one_each], y[one_each],
                                                  groups=groups[one_each])


def test_early_stopping_over_fewer_runs_than_validation_splits_is_a_config_error():
    # three runs for validation_splits=5 reached scikit-learn's bare ValueError "Cannot have
    # number of splits n_splits=5 greater than the number of groups: 3."
    rng = np.random.default_rng(0)
    X = rng.normal(size=(30, 2, 32)).astype(np.float32)
    y = np.repeat(["A", "B", "A"], 10)
    groups = np.repeat(["r0", "r1", "r2"], 10)
    model = RawCNNClassifier(**{**FAST, "max_epochs": 1}, early_stopping=True)
    with pytest.raises(ConfigError, match=r"early stopping splits its training windows by run "
                                          r"into 5 inner folds \(validation_splits\): it got 3 "
                                          r"runs \(runs r0, r1, r2\) and needs at least 5"):
        model.fit(X, y, groups=groups)
    with pytest.raises(ConfigError, match="validation_splits must be an integer >= 2"):
        model.set_params(validation_splits=1).fit(X, y, groups=groups)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_windows_of_another_length_than_the_training_ones_are_refused(cls):
    # global pooling runs the network on any length: windows of 200 samples after training
    # on 64 were answered ([[0.55, 0.45]] from the raw CNN) off the training distribution
    rng = np.random.default_rng(0)
    X = rng.normal(size=(30, 2, 64)).astype(np.float32)
    y = np.repeat(["A", "B", "A"], 10)
    model = cls(**{**FAST, "max_epochs": 1}).fit(X, y)
    assert model.window_shape_ == (2, 64)
    with pytest.raises(ShapeError, match=r"windows of shape \(2, 64\).* got \(2, 200\)"):
        model.predict_proba(rng.normal(size=(1, 2, 200)).astype(np.float32))
    proba = model.predict_proba(X)
    # a model saved before the shape was recorded predicts as it did
    old = pickle.loads(pickle.dumps(model))
    del old.window_shape_
    np.testing.assert_array_equal(old.predict_proba(X), proba)
    assert old.predict_proba(rng.normal(size=(1, 2, 200)).astype(np.float32)).shape == (1, 2)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_inputs_are_standardised_per_channel_or_per_bin_and_a_constant_channel_stays_finite(cls):
    # the raw CNN scales each channel, the spectrogram CNN each channel's frequency bin; a
    # channel constant over the training windows (a current at rest) divides by 1, not 0
    X, y, _ = _planted(n_runs=4)
    X = X.copy()
    X[:, 2] = 0.25
    model = cls(**{**FAST, "max_epochs": 1}).fit(X, y)
    Z = model._standardise(model._inputs(X))
    axes = (0, 2) if cls is RawCNNClassifier else (0, 3)
    np.testing.assert_allclose(Z[:, :2].mean(axis=axes), 0.0, atol=1e-3)
    np.testing.assert_allclose(Z[:, :2].std(axis=axes), 1.0, rtol=1e-3)
    assert (model.scale_[2] == 1.0).all() and not Z[:, 2].any()
    assert np.isfinite(model.predict_proba(X)).all()


def test_log_spectrogram_known_values_and_a_segment_longer_than_the_window():
    # a constant c through a periodic Hann window of n samples: DC bin |c sum(hann)|^2
    # = |c n / 2|^2, one frame
    # per hop; a segment longer than the window is clipped to it (one frame)
    c, n = 0.5, 100
    X = np.full((1, 1, n), c, dtype=np.float32)
    spec, freqs = log_spectrogram(X, RATE_HZ, segment_s=0.4, hop_s=0.2)
    assert spec.shape == (1, 1, 21, 4) and freqs[1] == pytest.approx(2.5)
    np.testing.assert_allclose(spec[0, 0, 0], np.log10((c * 40 / 2) ** 2),
                               rtol=1e-5)
    whole, freqs = log_spectrogram(X, RATE_HZ, segment_s=2.0, hop_s=0.2)
    assert whole.shape == (1, 1, n // 2 + 1, 1) and freqs[1] == pytest.approx(1.0)
    np.testing.assert_allclose(whole[0, 0, 0, 0], np.log10((c * n / 2) ** 2),
                               rtol=1e-5)


def test_band_mask_keeps_the_bin_at_the_limit():
    model = SpectrogramCNNClassifier(rate_hz=RATE_HZ, segment_s=0.5, band_limits_hz=(np.inf, 4.0))
    mask = model._band_mask(200, (1, 2, 26, 8))
    assert mask[0].all() and mask[1, :, 0].tolist() == [1.0] * 3 + [0.0] * 23   # 0, 2, 4 Hz


def test_the_seed_draws_the_initial_weights():
    # with lr 0 the network keeps its initial weights (one batch: the same normalisation
    # statistics whatever the order), so the seeds' probabilities differ by their weights
    X, y, _ = _planted(n_runs=4)
    still = {**FAST, "max_epochs": 1, "lr": 0.0, "batch_size": len(X)}
    p = [RawCNNClassifier(**still, random_state=s).fit(X, y).predict_proba(X) for s in (0, 1)]
    assert np.abs(p[0] - p[1]).max() > 1e-3


def test_fit_hands_on_its_weight_decay_and_restores_the_thread_count():
    import torch
    X, y, _ = _planted(n_runs=2)
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        model = RawCNNClassifier(**{**FAST, "max_epochs": 1}, weight_decay=0.123).fit(X, y)
        assert torch.get_num_threads() == 2                   # FAST trains on 1 thread
    finally:
        torch.set_num_threads(before)
    assert model.net_.optimizer_.param_groups[0]["weight_decay"] == 0.123


def test_early_stopping_keeps_the_best_validated_network():
    import torch
    X, y, groups = _planted()
    model = RawCNNClassifier(**{**FAST, "max_epochs": 20, "lr": 0.03}, early_stopping=True,
                             validation_splits=4, patience=2).fit(X, y, groups=groups)
    losses = [epoch["valid_loss"] for epoch in model.net_.history]
    assert losses[-1] > min(losses)               # it went on past its best epoch
    val = np.isin(groups, model.validation_groups_)
    assert val.sum() <= FAST["batch_size"]        # one validation batch: the epoch's loss
    Z = torch.as_tensor(model._standardise(model._inputs(X[val])))
    target = torch.as_tensor(np.searchsorted(model.classes_, y[val]))
    with torch.inference_mode():
        loss = model.net_.criterion_(model.net_.module_.eval()(Z), target).item()
    assert loss == pytest.approx(min(losses), rel=1e-5)


def test_early_stopping_with_window_weights_draws_from_the_training_runs_only():
    # run-balanced weights (ModelConfig.run_balanced) with early stopping: the sampler
    # draws among the windows of the training runs, as many as they hold
    X, y, groups = _planted()
    model = RawCNNClassifier(**{**FAST, "max_epochs": 1}, early_stopping=True,
                             validation_splits=4).fit(X, y, groups=groups,
                                                      sample_weight=np.linspace(0.5, 2, len(y)))
    batches = model.net_.history[0]["batches"]
    assert sum(b["train_batch_size"] for b in batches if "train_batch_size" in b) == 6 * 12


def test_networks_drop_out_while_training_only():
    import torch

    from terrain.models.nets import Raw1dNet, Spectrogram2dNet
    with torch.random.fork_rng():
        torch.manual_seed(0)
        for net, shape in ((Raw1dNet(2, 3, width=4, dropout=0.5), (4, 2, 64)),
                           (Spectrogram2dNet(2, 3, width=4, dropout=0.5), (4, 2, 26, 8))):
            x = torch.randn(shape)
            net.train()
            assert not torch.equal(net(x), net(x))
            net.eval()
            assert torch.equal(net(x), net(x))
