"""The training share of benchmarks/learning_curve_runs.py."""

from __future__ import annotations

import runpy
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "learning_curve_runs.py"


def test_training_run_share_counts_units_not_windows():
    share = runpy.run_path(str(SCRIPT))["training_run_share"]
    groups = np.repeat([f"r{i}" for i in range(10)], [1, 1, 1, 1, 1, 1, 1, 1, 1, 91])
    # seed 0: two folds of 5 runs each; seed 1: folds of 1 and 9 runs (the big run alone)
    folds = pd.DataFrame({
        "seed": [0] * 100 + [1] * 100,
        "fold": [0] * 5 + [1] * 95 + [0] * 91 + [1] * 9,
        "group": list(groups[:5]) + list(groups[5:]) + list(groups[9:]) + list(groups[:9])})
    # seed 0: 0.5 and 0.5; seed 1: 0.9 and 0.1 -> mean 0.5, whatever the window counts
    assert share(groups, folds) == 0.5
    one = folds[(folds.seed == 1) & (folds.fold == 0)]
    assert share(groups, one) == 0.9


def _window_spread(X):
    """Per-channel standard deviation of raw windows ``(n, channels, samples)``."""
    return X.std(axis=2)


def test_main_runs_on_the_cells_windows(monkeypatch, tmp_path, capsys):
    # the real cell_windows returns a CellWindows of 7 fields: the script must take the
    # first three (unpacking four crashed every run of the script)
    import sys

    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import FunctionTransformer
    from test_cnn import _planted  # same folder (pytest's default prepend import mode)

    from terrain.models.compare import CellWindows

    main = runpy.run_path(str(SCRIPT))["main"]
    X, y, runs = _planted(n_runs=8, per_run=6, seed=0)
    ws = SimpleNamespace(X=X, channels=("c0", "c1", "c2"), rate_hz=100.0, run_ids=runs,
                         t_start_s=np.tile(np.arange(6.0) * 2, 8),
                         t_end_s=np.tile(np.arange(6.0) * 2 + 2, 8))
    monkeypatch.setitem(main.__globals__, "cell_windows",
                        lambda cell, blocks: CellWindows(ws, y, runs, None, (), 0, ()))
    monkeypatch.setitem(main.__globals__, "make_model", lambda *a: make_pipeline(
        FunctionTransformer(_window_spread), LogisticRegression()))
    out = tmp_path / "curve.csv"
    monkeypatch.setattr(sys, "argv", ["learning_curve_runs.py", "--splits", "2", "--seeds",
                                      "0", "--models", "svm", "--out", str(out),
                                      "--no-mlflow"])
    assert main() == 0
    table = pd.read_csv(out)
    assert set(table["model"]) == {"svm"} and set(table["history"]) == {1, 10}
    assert (table["training_run_share"] == 0.5).all()
    assert (table["accuracy_mean"] >= 0.9).all()
