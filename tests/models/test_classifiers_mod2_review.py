"""Review tests (mod2) of the window classifiers: the seeds that draw the CNNs' validation
runs and noise copies, the device choice, and the soft-voting ensemble's contract."""

from __future__ import annotations

import numpy as np
import pytest
from test_cnn import FAST, RATE_HZ, _planted  # same folder (pytest's default prepend import)

from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
from terrain.models.cv import class_keeping_split

ONE_EPOCH = {**FAST, "max_epochs": 1}


def test_the_seed_draws_the_early_stopping_validation_runs():
    # random_state is documented as the seed of the validation split too: two seeds hold
    # out the runs of two different class-keeping splits, each that seed's own (seed 0:
    # runs 3 and 6, seed 1: runs 0 and 7)
    X, y, groups = _planted(n_runs=8, per_run=2)
    held = []
    for seed in (0, 1):
        model = RawCNNClassifier(**{**ONE_EPOCH, "width": 2}, early_stopping=True,
                                 validation_splits=4, random_state=seed)
        model.fit(X[..., :32], y, groups=groups)
        _, val = class_keeping_split(y, groups, 4, seed, "early stopping",
                                     "validation_splits", "early_stopping=False")
        assert model.validation_groups_.tolist() == sorted(set(groups[val]))
        held.append(model.validation_groups_.tolist())
    assert held[0] != held[1]


def test_the_seed_draws_the_noise_copy():
    Z = np.random.default_rng(1).normal(size=(6, 2, 5, 3)).astype(np.float32)
    y = np.arange(6) % 2

    def copy(seed):
        model = SpectrogramCNNClassifier(rate_hz=RATE_HZ, augment_noise_std=0.3,
                                         random_state=seed)
        model.mask_ = None
        return model._augmented(Z, y)[0][6:]

    np.testing.assert_array_equal(copy(3), copy(3))
    assert np.abs(copy(3) - copy(4)).min() > 0        # no bin shares its noise draw


@pytest.mark.parametrize("cuda, expected", [(True, "cuda"), (False, "cpu")])
def test_auto_device_is_cuda_exactly_when_torch_has_it(monkeypatch, cuda, expected):
    import torch
    monkeypatch.setattr(torch.cuda, "is_available", lambda: cuda)
    assert RawCNNClassifier(device="auto")._device() == expected
    assert RawCNNClassifier(device="cpu")._device() == "cpu"     # an explicit choice stays
