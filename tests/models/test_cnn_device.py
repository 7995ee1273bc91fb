"""benchmarks/cnn_device.py: one CNN cross-validated per device under the headline protocol."""

from __future__ import annotations

import runpy
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from terrain.models.cnn import RawCNNClassifier

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "cnn_device.py"


def _planted_cell(cell, blocks):
    """Windows of 10 runs, two terrains told apart by a 20 Hz vibration on channel 0."""
    rng = np.random.default_rng(cell.seed)
    t = np.arange(100) / 100.0
    X, y, runs = [], [], []
    for r in range(10):
        label = "A" if r % 2 == 0 else "B"
        for _ in range(8):
            w = rng.normal(0.0, 1.0, (2, t.size))
            if label == "B":
                w[0] += 1.5 * np.sin(2 * np.pi * 20.0 * t + rng.uniform(0, 2 * np.pi))
            X.append(w)
            y.append(label)
            runs.append(f"run{r}")
    runs = np.asarray(runs)
    ws = SimpleNamespace(X=np.asarray(X, dtype=np.float32), channels=("c0", "c1"),
                         rate_hz=100.0, run_ids=runs, t_start_s=np.zeros(len(runs)),
                         t_end_s=np.ones(len(runs)))
    return ws, np.asarray(y), runs, None


def test_device_rows_cross_validate_on_the_requested_device(monkeypatch):
    rows_of = runpy.run_path(str(SCRIPT))["device_rows"]
    made = []

    def small_cnn(config, channels, rate_hz, dataset, seed):
        # a device torch cannot use: the script must replace it by the requested one
        made.append(config)
        return RawCNNClassifier(max_epochs=15, width=8, batch_size=32, random_state=seed,
                                device="no-such-device")

    monkeypatch.setitem(rows_of.__globals__, "cell_windows", _planted_cell)
    monkeypatch.setitem(rows_of.__globals__, "make_model", small_cnn)
    rows = rows_of("cnn", "cpu", [0, 1], threads=1, time_windows=2)
    assert [(r["device"], r["seed"]) for r in rows] == [("cpu", 0), ("cpu", 1)]
    assert all(r["accuracy"] >= 0.9 and r["macro_f1"] >= 0.9 for r in rows)
    assert all(r["fit_s_per_fold"] > 0 and r["infer_ms_per_window"] > 0 for r in rows)
    assert {c.kind for c in made} == {"cnn"} and {c.n_threads for c in made} == {1}
    with pytest.raises(RuntimeError):     # the device really reaches torch
        rows_of("cnn", "no-such-device", [0], threads=1, time_windows=2)
