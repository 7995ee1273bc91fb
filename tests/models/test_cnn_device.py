"""benchmarks/cnn_device.py: one CNN cross-validated per device under the headline protocol."""

from __future__ import annotations

import runpy
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from test_cnn import _planted  # same folder (pytest's default prepend import mode)

from terrain.models.cnn import RawCNNClassifier

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "cnn_device.py"


def _planted_cell(cell, blocks):
    """The planted two-terrain windows of test_cnn.py (a 20 Hz vibration), 10 runs."""
    X, y, runs = _planted(n_runs=10, per_run=8, seed=cell.seed)
    ws = SimpleNamespace(X=X, channels=("c0", "c1", "c2"), rate_hz=100.0, run_ids=runs,
                         t_start_s=np.zeros(len(runs)), t_end_s=np.ones(len(runs)))
    return ws, y, runs, None


@pytest.mark.slow
def test_device_rows_cross_validate_on_the_requested_device(monkeypatch):
    rows_of = runpy.run_path(str(SCRIPT))["device_rows"]
    made = []

    def small_cnn(config, channels, rate_hz, dataset, seed):
        # a device torch cannot use: the script must replace it by the requested one
        made.append(config)
        return RawCNNClassifier(max_epochs=15, width=8, batch_size=32, random_state=seed,
                                device="no-such-device", n_threads=config.n_threads)

    monkeypatch.setitem(rows_of.__globals__, "cell_windows", _planted_cell)
    monkeypatch.setitem(rows_of.__globals__, "make_model", small_cnn)
    rows = rows_of("cnn", "cpu", [0, 1], threads=1, time_windows=2)
    assert [(r["device"], r["seed"]) for r in rows] == [("cpu", 0), ("cpu", 1)]
    assert all(r["accuracy"] >= 0.9 and r["macro_f1"] >= 0.9 for r in rows)
    assert all(r["fit_s_per_fold"] > 0 and r["infer_ms_per_window"] > 0 for r in rows)
    assert {c.kind for c in made} == {"cnn"} and {c.n_threads for c in made} == {1}
    with pytest.raises(RuntimeError):     # the device really reaches torch
        rows_of("cnn", "no-such-device", [0], threads=1, time_windows=2)
