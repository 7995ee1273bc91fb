"""Review tests of the window CNNs: spectrogram sample counts, the chunked forward, the
arguments the network and skorch are built with, typed refusals, seeded augmentation."""

from __future__ import annotations

import numpy as np
import pytest
import skorch
from scipy.signal import get_window
from sklearn.base import clone
from test_cnn import FAST, RATE_HZ, _planted  # same folder (pytest's default prepend import)
from torch import nn

from terrain.errors import ConfigError, ShapeError
from terrain.models.cnn import (POWER_FLOOR, RawCNNClassifier, SpectrogramCNNClassifier,
                                log_spectrogram)
from terrain.models.nets import Raw1dNet, Spectrogram2dNet

ONE_EPOCH = {**FAST, "max_epochs": 1}


def test_segment_and_hop_are_the_nearest_whole_samples_and_frames_are_hann_spectra():
    # 0.29 s * 100 Hz is 28.999999999999996 in floating point: 29 samples, not 28
    rng = np.random.default_rng(0)
    X = rng.normal(size=(2, 1, 200)).astype(np.float32)
    spec, freqs = log_spectrogram(X, RATE_HZ, segment_s=0.29, hop_s=0.29)
    assert spec.shape == (2, 1, 15, 6)                # (200 - 29) // 29 + 1 frames
    assert freqs[1] == pytest.approx(RATE_HZ / 29)
    # frames end at the newest sample (review mdl23): the (200 - 29) % 29 = 26 oldest
    # samples are in no frame; the taper is the periodic Hann window
    for k in (0, 5):
        frame = X[1, 0, 26 + 29 * k:26 + 29 * k + 29] * get_window("hann", 29)
        np.testing.assert_allclose(spec[1, 0, :, k],
                                   np.log10(np.abs(np.fft.rfft(frame)) ** 2 + POWER_FLOOR),
                                   rtol=1e-4, atol=1e-4)
    # a hop under half a sample is one sample: every segment start
    assert log_spectrogram(X, RATE_HZ, segment_s=0.29, hop_s=0.001)[0].shape == (2, 1, 15, 172)
    # the classifier's bin frequencies (and so its band mask) are those of its spectra
    model = SpectrogramCNNClassifier(rate_hz=RATE_HZ, segment_s=0.29, hop_s=0.29)
    mask = model.set_params(band_limits_hz=(7.0,))._band_mask(200, (2, 1, 15, 6))
    np.testing.assert_array_equal(model.freqs_hz_, freqs)
    assert mask[0, :, 0].tolist() == [1.0, 1.0, 1.0] + [0.0] * 12   # 0, 3.4, 6.9 Hz kept


def test_a_silent_channel_sits_at_the_power_floor_not_at_minus_infinity():
    spec, _ = log_spectrogram(np.zeros((1, 2, 100), dtype=np.float32), RATE_HZ, 0.2, 0.1)
    np.testing.assert_allclose(spec, np.log10(POWER_FLOOR), rtol=1e-6)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_more_windows_than_one_forward_batch_each_get_their_own_row(cls):
    # predict_proba runs the network over slices of 1024 windows: every window gets
    # exactly one row, the one it gets when predicted alone
    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 16)).astype(np.float32)     # 2-D: one channel of 16 samples
    y = np.arange(40) % 2
    X[y == 1] += 1.0
    model = cls(**ONE_EPOCH, **({} if cls is RawCNNClassifier else
                                {"segment_s": 0.08, "hop_s": 0.04})).fit(X, y)
    many = rng.normal(size=(2100, 16)).astype(np.float32)
    proba = model.predict_proba(many)
    assert proba.shape == (2100, 2)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-6)
    for i in (0, 1023, 1024, 2047, 2048, 2099):
        np.testing.assert_allclose(proba[i], model.predict_proba(many[i:i + 1])[0], atol=1e-5)
    np.testing.assert_array_equal(model.predict(many),
                                  model.classes_[proba.argmax(axis=1)])


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_width_and_dropout_reach_the_network_and_survive_clone_and_set_params(cls):
    X, y, _ = _planted(n_runs=2, per_run=6)
    model = cls(**{**ONE_EPOCH, "width": 4}, dropout=0.125).fit(X, y)
    bands = 1 if cls is RawCNNClassifier else 8
    module = model.net_.module_
    assert module.head.in_features == 2 * 4 * bands and module.head.out_features == 2
    assert [m.p for m in module.modules() if isinstance(m, nn.Dropout)] == [0.125]
    again = clone(model).set_params(width=6, dropout=0.25)
    assert again.get_params() == {**model.get_params(), "width": 6, "dropout": 0.25}
    assert not hasattr(again, "net_")
    module = again.fit(X, y).net_.module_
    assert module.head.in_features == 2 * 6 * bands
    assert [m.p for m in module.modules() if isinstance(m, nn.Dropout)] == [0.25]


def test_networks_have_their_documented_layers():
    raw = Raw1dNet(n_channels=3, n_classes=4, width=4)
    convs = [m for m in raw.body if isinstance(m, nn.Conv1d)]
    assert [(c.in_channels, c.out_channels, c.kernel_size[0], c.stride[0], c.padding[0])
            for c in convs] == [(3, 4, 7, 2, 3), (4, 4, 5, 1, 2), (4, 8, 3, 1, 1)]
    kinds = [type(m).__name__ for m in raw.body]
    assert kinds == ["Conv1d", "BatchNorm1d", "ReLU", "MaxPool1d", "Conv1d", "BatchNorm1d",
                     "ReLU", "MaxPool1d", "Conv1d", "BatchNorm1d", "ReLU",
                     "AdaptiveAvgPool1d", "Flatten", "Dropout"]
    spec = Spectrogram2dNet(n_channels=3, n_classes=4, width=4, n_bands=5)
    kinds = [type(m).__name__ for m in spec.body]
    assert kinds == ["Conv2d", "BatchNorm2d", "ReLU", "MaxPool2d", "Conv2d", "BatchNorm2d",
                     "ReLU", "AdaptiveAvgPool2d", "Flatten", "Dropout"]
    # averaged over time (the last axis), kept in 5 frequency bands
    pool = next(m for m in spec.body if isinstance(m, nn.AdaptiveAvgPool2d))
    assert tuple(pool.output_size) == (5, 1)
    assert spec.head.in_features == 2 * 4 * 5 and spec.head.out_features == 4


def test_windows_of_more_than_three_dimensions_are_refused():
    X = np.zeros((6, 2, 3, 16), dtype=np.float32)
    with pytest.raises(ValueError, match="expected 2-D or 3-D windows, got 4-D"):
        RawCNNClassifier(**ONE_EPOCH).fit(X, np.arange(6) % 2)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_windows_of_another_channel_count_or_not_finite_are_refused(cls):
    X, y, _ = _planted(n_runs=2, per_run=6)
    model = cls(**ONE_EPOCH).fit(X, y)
    with pytest.raises(ValueError, match="X has 2 features, but .* expecting 3 features"):
        model.predict_proba(X[:, :2])
    bad = X.copy()
    bad[0, 1, 5] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        model.predict_proba(bad)
    with pytest.raises(ValueError, match="NaN"):
        cls(**ONE_EPOCH).fit(bad, y)


@pytest.mark.parametrize("weights, why", [
    (-np.ones(12), "negative"), (np.zeros(12), "all zero"),
    (np.r_[np.ones(11), np.nan], "not finite"), (np.r_[np.ones(11), np.inf], "not finite")])
def test_unusable_window_weights_are_refused(weights, why):
    X, y, _ = _planted(n_runs=2, per_run=6)
    with pytest.raises(ValueError, match="sample_weight must be finite and >= 0"):
        RawCNNClassifier(**ONE_EPOCH).fit(X, y, sample_weight=weights)


def test_zero_weights_are_allowed_when_some_are_positive():
    X, y, _ = _planted(n_runs=2, per_run=6)
    weights = np.r_[np.zeros(3), np.ones(9)]
    model = RawCNNClassifier(**ONE_EPOCH).fit(X, y, sample_weight=weights)
    assert model.predict_proba(X).shape == (12, 2)


class _Spy:
    """Records the keyword arguments each skorch ``NeuralNetClassifier`` is built with."""

    def __init__(self, monkeypatch):
        import torch
        self.kwargs, self.threads = [], []
        spy, real = self, skorch.NeuralNetClassifier

        class Recording(real):
            def __init__(self, *args, **kwargs):
                spy.kwargs.append(dict(kwargs))
                spy.threads.append(torch.get_num_threads())
                super().__init__(*args, **kwargs)

        monkeypatch.setattr(skorch, "NeuralNetClassifier", Recording)


@pytest.mark.parametrize("seed", [0, 7])
def test_the_shuffling_generator_is_seeded_by_random_state(monkeypatch, seed):
    spy = _Spy(monkeypatch)
    X, y, _ = _planted(n_runs=2, per_run=6)
    RawCNNClassifier(**ONE_EPOCH, random_state=seed).fit(X, y)
    (kwargs,) = spy.kwargs
    assert kwargs["iterator_train__shuffle"] is True
    assert kwargs["iterator_train__generator"].initial_seed() == seed


def test_weighted_draws_with_a_noise_copy_cover_both_copies(monkeypatch):
    # the noise copy doubles the training windows: the sampler draws as many windows as
    # there are, with replacement, with each original window's weight on its copy too
    spy = _Spy(monkeypatch)
    X, y, _ = _planted(n_runs=2, per_run=6)
    w = np.linspace(0.5, 2.0, 12)
    SpectrogramCNNClassifier(**ONE_EPOCH, augment_noise_std=0.3, random_state=5).fit(
        X, y, sample_weight=w)
    sampler = spy.kwargs[0]["iterator_train__sampler"]
    assert spy.kwargs[0]["iterator_train__shuffle"] is False
    assert sampler.num_samples == 24 and sampler.replacement
    np.testing.assert_allclose(sampler.weights.numpy(), np.r_[w, w])
    assert sampler.generator.initial_seed() == 5


def test_same_seed_same_spectrogram_model_with_a_noise_copy():
    X, y, _ = _planted(n_runs=2, per_run=6)
    p = [SpectrogramCNNClassifier(**{**FAST, "max_epochs": 2}, augment_noise_std=0.3,
                                  random_state=s).fit(X, y).predict_proba(X) for s in (3, 3)]
    np.testing.assert_array_equal(p[0], p[1])


def test_training_runs_on_n_threads_and_prediction_restores_the_callers_count(monkeypatch):
    import torch
    spy = _Spy(monkeypatch)
    X, y, _ = _planted(n_runs=2, per_run=6)
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        model = RawCNNClassifier(**ONE_EPOCH).fit(X, y)         # FAST: n_threads=1
        assert spy.threads == [1] and torch.get_num_threads() == 2
        model.predict_proba(X)                                  # a small batch: 1 thread
        assert torch.get_num_threads() == 2
        model.predict_proba(np.repeat(X, 6, axis=0))            # 72 windows: n_threads
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


def test_labels_of_another_length_or_a_single_class_are_refused():
    X, y, _ = _planted(n_runs=2, per_run=6)
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        RawCNNClassifier(**ONE_EPOCH).fit(X, y[:-1])
    with pytest.raises(ValueError, match="need at least 2 classes, got 1 class"):
        RawCNNClassifier(**ONE_EPOCH).fit(X, np.full(len(y), "A"))


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_shorter_windows_than_the_training_ones_are_refused_too(cls):
    X, y, _ = _planted(n_runs=2, per_run=6)
    model = cls(**ONE_EPOCH).fit(X, y)
    with pytest.raises(ShapeError, match=r"windows of shape \(3, 200\).* got \(3, 150\)"):
        model.predict_proba(X[:, :, :150])


@pytest.mark.parametrize("setting, value", [
    ("segment_s", 0.0), ("segment_s", -0.5), ("hop_s", 0.0), ("hop_s", float("nan")),
    ("rate_hz", 0.0), ("rate_hz", -100.0), ("rate_hz", float("inf"))])
def test_spectrogram_settings_that_are_not_finite_and_positive_are_config_errors(setting,
                                                                                 value):
    # segment_s=0 trained silently on 2-sample Hann segments, which are all zero (every
    # bin at the power floor: nothing to learn); rate_hz=0 raised ZeroDivisionError,
    # rate_hz=-100 gave negative bin frequencies that every band limit kept
    X, y, _ = _planted(n_runs=2, per_run=6)
    settings = {"rate_hz": RATE_HZ, "segment_s": 0.5, "hop_s": 0.2, setting: value}
    with pytest.raises(ConfigError, match=f"{setting} must be a finite value > 0"):
        log_spectrogram(X, **settings)
    with pytest.raises(ConfigError, match=f"{setting} must be a finite value > 0"):
        SpectrogramCNNClassifier(**ONE_EPOCH, **settings).fit(X, y)


@pytest.mark.parametrize("segment_s, n_samples", [(0.02, 200), (0.01, 200), (0.5, 2)])
def test_a_segment_of_two_samples_gives_a_spectrum_not_a_constant_image(segment_s, n_samples):
    # 0.02 s at 100 Hz is 2 samples: np.hanning(2) is [0, 0], so every bin sat at the power
    # floor and the network trained on a constant; 0.01 s was clipped up to those 2, and a
    # 2-sample window clipped every segment down to them. Now rectangular: sum and difference
    X = np.random.default_rng(1).normal(size=(2, 1, n_samples)).astype(np.float32)
    spec, freqs = log_spectrogram(X, RATE_HZ, segment_s=segment_s, hop_s=0.1)
    assert freqs.tolist() == [0.0, RATE_HZ / 2]
    start = (n_samples - 2) % 10                      # the frames end at the newest sample
    pair = X[..., start:start + 2]
    expect = np.stack([pair.sum(-1), pair[..., 0] - pair[..., 1]], axis=-1)
    np.testing.assert_allclose(spec[..., 0], np.log10(expect ** 2 + POWER_FLOOR), rtol=1e-4)
    assert np.ptp(spec) > 1.0
