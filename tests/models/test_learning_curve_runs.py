"""The training share of benchmarks/learning_curve_runs.py."""

from __future__ import annotations

import runpy
from pathlib import Path

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
