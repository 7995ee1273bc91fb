"""Review test (mdl11): a window CNN predicts on windows in the layout it was fitted on, as
its predict_proba docstring now says (2-D windows were documented as "one channel"
everywhere, while a model fitted on 3-D one-channel windows refuses them 2-D)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.models.cnn import RawCNNClassifier


def test_predict_takes_the_layout_fit_was_given():
    X = np.random.default_rng(0).normal(size=(12, 1, 16)).astype(np.float32)
    y = np.array(["A", "B"] * 6)
    three = RawCNNClassifier(max_epochs=1, width=4, device="cpu", n_threads=1).fit(X, y)
    two = RawCNNClassifier(max_epochs=1, width=4, device="cpu", n_threads=1).fit(X[:, 0], y)
    assert (three.n_features_in_, two.n_features_in_) == (1, 16)
    np.testing.assert_allclose(three.predict_proba(X[:3]).sum(axis=1), 1.0, rtol=1e-6)
    np.testing.assert_allclose(two.predict_proba(X[:3, 0]).sum(axis=1), 1.0, rtol=1e-6)
    with pytest.raises(ValueError, match="X has 16 features"):
        three.predict_proba(X[:3, 0])
    with pytest.raises(ValueError, match="X has 1 features"):
        two.predict_proba(X[:3])
