"""Review (mdl25): what a CNN fit that fails in training leaves behind.

The fit sets torch's process-wide thread count to ``n_threads`` and seeds torch's global
generator: both must be back as they were when the training raises (an interrupted fit in a
comparison cell left the next cell of that worker on the wrong thread count), and the
model itself as it was (unfitted, or its previous fit whole).
"""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")
skorch = pytest.importorskip("skorch")

from terrain.models.cnn import RawCNNClassifier  # noqa: E402


def _windows():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(12, 2, 32))
    y = np.array(["A", "B"] * 6)
    return X, y


def test_a_failing_training_restores_threads_random_stream_and_model(monkeypatch):
    X, y = _windows()
    model = RawCNNClassifier(max_epochs=1, batch_size=4, n_threads=1, random_state=0)
    model.fit(X, y)
    fitted = dict(vars(model))
    before = torch.get_num_threads()
    torch.set_num_threads(before + 1)
    try:
        state = torch.random.get_rng_state()

        def interrupted(self, *args, **kwargs):
            assert torch.get_num_threads() == 1       # the fit's own thread count
            raise KeyboardInterrupt

        monkeypatch.setattr(skorch.NeuralNetClassifier, "fit", interrupted)
        with pytest.raises(KeyboardInterrupt):
            model.fit(X[::-1], y)
        assert torch.get_num_threads() == before + 1
        assert torch.equal(torch.random.get_rng_state(), state)
        assert vars(model).keys() == fitted.keys()
        assert model.net_ is fitted["net_"]
    finally:
        torch.set_num_threads(before)
