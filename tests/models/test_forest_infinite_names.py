"""The compiled forest names where its input is infinite (the count, the first one's column
and row), as the slip model does: one rule, terrain.errors.refuse_infinite."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.ensemble import ExtraTreesClassifier

from terrain.errors import NonFiniteInputError, refuse_infinite
from terrain.tree_predict import forest_proba, pack_forest


def _packed():
    rng = np.random.default_rng(0)
    X = rng.standard_normal((40, 3))
    return pack_forest(ExtraTreesClassifier(5, random_state=0).fit(X, X[:, 0] > 0))


@pytest.mark.parametrize("value", [np.inf, -np.inf, 1e39])   # 1e39: beyond float32
def test_an_infinite_feature_is_named_by_column_and_row(value):
    X = np.zeros((4, 3))
    X[2, 1] = value
    X[3, 0] = np.inf
    with pytest.raises(NonFiniteInputError, match=r"forest_proba: X holds 2 infinite "
                       r"value\(s\), the first in column 1, row 2 \(0-based\): infinite, or "
                       r"too large for float32"):
        forest_proba(_packed(), X)


def test_nan_is_a_missing_feature_not_refused():
    X = np.zeros((2, 3))
    X[0, 2] = np.nan
    assert forest_proba(_packed(), X).shape == (2, 2)
    refuse_infinite("owner", X)         # passes: NaN is missing, not infinite


def test_the_refusal_names_a_column_by_its_name_where_given():
    with pytest.raises(NonFiniteInputError, match=r"^f: X holds 1 infinite value\(s\), the "
                       r"first in column 'pitch', row 0 \(0-based\)$"):
        refuse_infinite("f", np.array([[0.0, -np.inf]]), ["wz", "pitch"])
