"""Review (mdl28): torch's thread count under CNN fits and predictions in threads.

torch keeps the thread count per thread, and a thread takes the process-wide count last set
(by any thread) on its first torch call. A fit or prediction that sets its own count and
puts the old one back must not let another thread, started meanwhile, take the temporary
count for the process's: it then put that count back as the process's, and every thread
started later (a served request, a joblib worker) ran on it.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

torch = pytest.importorskip("torch")
skorch = pytest.importorskip("skorch")

from terrain.models.cnn import RawCNNClassifier  # noqa: E402


def _windows(n=12):
    rng = np.random.default_rng(0)
    return rng.normal(size=(n, 2, 32)), np.array(["A", "B"] * (n // 2))


def _in_new_thread(fn):
    """``fn()`` run in a fresh thread, its result (raises what it raised)."""
    box = {}

    def run():
        try:
            box["value"] = fn()
        except BaseException as err:     # noqa: BLE001 - handed to the caller
            box["error"] = err

    t = threading.Thread(target=run)
    t.start()
    t.join(30)
    if "error" in box:
        raise box["error"]
    return box.get("value")


@pytest.fixture
def two_threads():
    """torch's process-wide count set to 2 (restored afterwards)."""
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    yield 2
    torch.set_num_threads(before)


def _slow_forward(module, seconds):
    forward = module.forward

    def slow(*args, **kwargs):
        time.sleep(seconds)
        return forward(*args, **kwargs)
    return slow


@pytest.mark.slow
def test_overlapping_predictions_leave_new_threads_the_process_count(two_threads):
    X, y = _windows()
    models = [RawCNNClassifier(max_epochs=1, batch_size=4, random_state=s).fit(X, y)
              for s in (0, 1)]
    # the first prediction (1 thread: a small batch) is still running when the second
    # thread starts; the second puts its count back last
    models[0].net_.module_.forward = _slow_forward(models[0].net_.module_, 0.2)
    models[1].net_.module_.forward = _slow_forward(models[1].net_.module_, 0.5)
    inside = threading.Event()
    first_forward = models[0].net_.module_.forward

    def first_marked(*args, **kwargs):
        inside.set()
        return first_forward(*args, **kwargs)
    models[0].net_.module_.forward = first_marked
    expected = [m.predict_proba(X[:3]) for m in models]

    inside.clear()
    out = {}
    a = threading.Thread(target=lambda: out.setdefault(0, models[0].predict_proba(X[:3])))
    a.start()
    assert inside.wait(10)

    def second():
        out[1] = models[1].predict_proba(X[:3])
    b = threading.Thread(target=second)
    b.start()
    a.join(30)
    b.join(30)
    np.testing.assert_array_equal(out[0], expected[0])
    np.testing.assert_array_equal(out[1], expected[1])
    assert _in_new_thread(torch.get_num_threads) == two_threads


@pytest.mark.slow
def test_a_fit_started_beside_another_keeps_the_process_count(two_threads, monkeypatch):
    X, y = _windows()
    inside = threading.Event()
    seen = []
    fit = skorch.NeuralNetClassifier.fit

    def watched(self, *args, **kwargs):
        seen.append(torch.get_num_threads())
        inside.set()
        time.sleep(0.3)
        return fit(self, *args, **kwargs)

    monkeypatch.setattr(skorch.NeuralNetClassifier, "fit", watched)
    a = threading.Thread(target=lambda: RawCNNClassifier(
        max_epochs=1, batch_size=4, n_threads=1).fit(X, y))
    a.start()
    assert inside.wait(10)
    # a fit on torch's own count (n_threads None), in a thread started while the first
    # fit trains on 1 thread: it trains on the process's 2, and leaves them
    _in_new_thread(lambda: RawCNNClassifier(max_epochs=1, batch_size=4).fit(X, y))
    a.join(30)
    assert seen == [1, two_threads]
    assert _in_new_thread(torch.get_num_threads) == two_threads


def test_a_failing_fit_or_prediction_frees_the_locks_for_other_threads(monkeypatch):
    from terrain.models import cnn

    X, y = _windows()
    model = RawCNNClassifier(max_epochs=1, batch_size=4, n_threads=1).fit(X, y)

    def broken(*args, **kwargs):
        raise RuntimeError("training broke")

    forward = model.net_.module_.forward
    model.net_.module_.forward = broken
    with pytest.raises(RuntimeError, match="training broke"):
        model.predict_proba(X[:2])
    model.net_.module_.forward = forward
    monkeypatch.setattr(skorch.NeuralNetClassifier, "fit", broken)
    with pytest.raises(RuntimeError, match="training broke"):
        RawCNNClassifier(max_epochs=1, batch_size=4, n_threads=1).fit(X, y)

    def take_both():
        got = [lock.acquire(timeout=5) for lock in (cnn._TORCH_RNG_LOCK,
                                                    cnn._TORCH_THREADS_LOCK)]
        for lock, held in zip((cnn._TORCH_RNG_LOCK, cnn._TORCH_THREADS_LOCK), got):
            if held:
                lock.release()
        return got
    assert _in_new_thread(take_both) == [True, True]


def test_a_fit_started_beside_a_prediction_trains_on_the_process_count(two_threads,
                                                                       monkeypatch):
    X, y = _windows()
    model = RawCNNClassifier(max_epochs=1, batch_size=4).fit(X, y)
    inside = threading.Event()
    forward = _slow_forward(model.net_.module_, 0.3)

    def marked(*args, **kwargs):
        inside.set()
        return forward(*args, **kwargs)
    model.net_.module_.forward = marked
    seen = []
    fit = skorch.NeuralNetClassifier.fit

    def watched(self, *args, **kwargs):
        seen.append(torch.get_num_threads())
        return fit(self, *args, **kwargs)

    monkeypatch.setattr(skorch.NeuralNetClassifier, "fit", watched)
    a = threading.Thread(target=model.predict_proba, args=(X[:3],))    # 1 thread meanwhile
    a.start()
    assert inside.wait(10)
    # a fit on torch's own count, in a thread started during that prediction
    _in_new_thread(lambda: RawCNNClassifier(max_epochs=1, batch_size=4).fit(X, y))
    a.join(30)
    assert seen == [two_threads]
    assert _in_new_thread(torch.get_num_threads) == two_threads
