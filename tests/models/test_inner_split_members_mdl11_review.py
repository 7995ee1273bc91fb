"""Review tests (mdl11): inner splits by run (early stopping, ensemble weights, grouped
search) over classes with fewer windows than inner folds are a ConfigError naming the
setting, not scikit-learn's bare ValueError."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression

from terrain.errors import ConfigError
from terrain.models.cnn import RawCNNClassifier
from terrain.models.cv import class_keeping_split
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.svm import SVMConfig, make_search

# six runs of one window each: enough runs for 4 inner folds, but no class has 4 windows
Y = np.array(list("AAABBB"))
GROUPS = np.array(["a1", "a2", "a3", "b1", "b2", "b3"])
X = np.random.default_rng(0).normal(size=(6, 2))


def test_class_keeping_split_refuses_classes_smaller_than_the_folds():
    # scikit-learn's StratifiedGroupKFold raised "n_splits=4 cannot be greater than the
    # number of members in each class"
    with pytest.raises(ConfigError, match=r"validation_splits.*no class has 4 windows"):
        class_keeping_split(Y, GROUPS, 4, 0, "early stopping", "validation_splits",
                            "early_stopping=False")


def test_a_class_as_large_as_the_folds_is_enough():
    y = np.array(list("AAAABB"))
    groups = np.array(["a1", "a2", "a3", "a4", "b1", "b2"])
    fit_idx, held_idx = class_keeping_split(y, groups, 4, 0, "early stopping",
                                            "validation_splits", "early_stopping=False")
    assert set(y[fit_idx]) == {"A", "B"} and held_idx.size


@pytest.mark.parametrize("make, setting", [
    (lambda: SoftVotingEnsemble([("a", LogisticRegression()), ("b", LogisticRegression())],
                                inner_splits=4), "inner_splits"),
    (lambda: make_search(SVMConfig(inner_splits=4)), "SVMConfig.inner_splits"),
    (lambda: RawCNNClassifier(early_stopping=True, validation_splits=4, max_epochs=1,
                              device="cpu"), "validation_splits"),
])
def test_inner_splits_over_too_few_windows_name_the_setting(make, setting):
    X3 = X[:, None, :].repeat(8, axis=2) if "CNN" in repr(make()) else X
    with pytest.raises(ConfigError, match=setting):
        make().fit(X3, Y, groups=GROUPS)
