"""The CNNs on a CUDA device: the paths only a GPU takes (skipped without one).

Issue 13: the same code uses a GPU when one is present and nothing requires one. The CPU
suite cannot reach the CUDA branches (the forked CUDA random streams, the direct forward on
the module's device, early stopping and the ensemble with CUDA members), so they are
checked here, on a GPU machine: ``python -m pytest tests/models/test_cuda.py``. The
GPU-trained model loading on a CPU-only machine is ``test_cnn.py``'s CUDA test.
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import FunctionTransformer, StandardScaler
from test_cnn import (FAST, _cuda_available, _planted,  # same folder (prepend mode)
                      proba_without_cuda)

from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
from terrain.models.ensemble import SoftVotingEnsemble

pytestmark = pytest.mark.skipif(not _cuda_available(), reason="needs a CUDA device")

#: the tests' fast settings, trained on the GPU
CUDA = {**FAST, "device": "cuda"}


def _on_cuda(model) -> bool:
    return next(model.net_.module_.parameters()).device.type == "cuda"


def test_fit_on_cuda_leaves_the_callers_cpu_and_cuda_random_streams_as_found():
    import torch
    X, y, _ = _planted(n_runs=4)
    torch.manual_seed(123)
    expected_cpu, expected_cuda = torch.rand(3), torch.rand(3, device="cuda")
    torch.manual_seed(123)
    model = RawCNNClassifier(**{**CUDA, "max_epochs": 1}).fit(X, y)
    assert _on_cuda(model)
    torch.testing.assert_close(torch.rand(3), expected_cpu)
    torch.testing.assert_close(torch.rand(3, device="cuda"), expected_cuda)


@pytest.mark.parametrize("cls", [RawCNNClassifier, SpectrogramCNNClassifier])
def test_direct_forward_on_cuda_equals_skorch_predict_proba(cls):
    X, y, groups = _planted()
    test = np.isin(groups, ["run6", "run7"])
    model = cls(**{**CUDA, "max_epochs": 30}).fit(X[~test], y[~test])
    assert _on_cuda(model)
    Z = model._standardise(model._inputs(X[test]))
    skorch = model.net_.predict_proba(Z)                  # skorch's DataLoader path
    proba = model.predict_proba(X[test])
    np.testing.assert_allclose(proba, skorch, rtol=0, atol=1e-5)
    single = np.concatenate([model.predict_proba(X[test][i:i + 1]) for i in range(5)])
    np.testing.assert_allclose(single, skorch[:5], rtol=0, atol=1e-5)
    assert (model.classes_[proba.argmax(axis=1)] == y[test]).mean() >= 0.9


def test_early_stopping_on_cuda_trains_on_whole_runs_only():
    X, y, groups = _planted()
    model = RawCNNClassifier(**{**CUDA, "max_epochs": 4}, early_stopping=True,
                             validation_splits=4).fit(X, y, groups=groups)
    assert _on_cuda(model)
    assert len(model.validation_groups_) == 2
    history = model.net_.history
    assert "valid_loss" in history[-1]
    n_train = sum(b["train_batch_size"] for b in history[0]["batches"] if "train_batch_size" in b)
    assert n_train == 6 * 12                               # 6 of 8 runs, 12 windows each
    fitted = ~np.isin(groups, model.validation_groups_)
    np.testing.assert_allclose(model.mean_[:, 0], X[fitted].mean(axis=(0, 2)), rtol=1e-5)


def test_ensemble_with_a_cuda_member_serves_on_a_cpu_only_machine(tmp_path):
    X, y, groups = _planted()
    test = np.isin(groups, ["run6", "run7"])
    # each channel's standard deviation (picklable: the CPU-only process loads it)
    linear = make_pipeline(FunctionTransformer(np.std, kw_args={"axis": 2}), StandardScaler(),
                           LogisticRegression())
    cnn = SpectrogramCNNClassifier(**{**FAST, "max_epochs": 30, "device": "auto"})
    ensemble = SoftVotingEnsemble([("linear", linear), ("cnn", cnn)], weights=[0.5, 0.5])
    ensemble.fit(X[~test], y[~test], groups=groups[~test])
    assert _on_cuda(ensemble.estimators_[1])
    on_gpu = ensemble.predict_proba(X[test])
    assert (ensemble.classes_[on_gpu.argmax(axis=1)] == y[test]).mean() >= 0.9
    np.testing.assert_allclose(proba_without_cuda(ensemble, X[test], tmp_path), on_gpu,
                               atol=1e-4)
