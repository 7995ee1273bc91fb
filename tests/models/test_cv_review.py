"""Review tests of the cross-validation protocols (seeds, votes, metrics, splits)."""

from __future__ import annotations

import numpy as np
from sklearn.model_selection import StratifiedKFold

from terrain.models.cv import PAPER_RANDOM_STATE, iter_splits
from terrain.models.experiment import MAX_SEED, ExperimentConfig


def _partitions(n_per_class=10):
    """Two classes, one window per 5 s partition, partitions of distinct runs."""
    labels = np.array(["a"] * n_per_class + ["b"] * n_per_class)
    groups = np.array([f"r{i}#0" for i in range(2 * n_per_class)], dtype=object)
    return labels, groups


def test_the_paper_split_takes_every_seed_the_config_accepts():
    # ExperimentConfig accepts seeds up to MAX_SEED; 21 + MAX_SEED used to reach NumPy's
    # bare "Seed must be between 0 and 2**32 - 1" ValueError inside StratifiedKFold
    assert ExperimentConfig(protocol="paper", seeds=(MAX_SEED,)).seeds == (MAX_SEED,)
    labels, groups = _partitions()
    folds = list(iter_splits("paper", labels, groups, MAX_SEED, 5))
    assert len(folds) == 5
    tested = np.sort(np.concatenate([test for _, test in folds]))
    assert np.array_equal(tested, np.arange(len(labels)))
    # seed 0 is still the published split (random_state 21)
    ref = StratifiedKFold(5, shuffle=True, random_state=PAPER_RANDOM_STATE)
    for (_, test), (_, ref_test) in zip(iter_splits("paper", labels, groups, 0, 5),
                                        ref.split(groups, labels)):
        assert np.array_equal(test, ref_test)
