"""Review fixio of :func:`terrain.models.compare.history_predictions`: runs (``group``) of
mixed types are refused by the shared rule, as the other entry points refuse them."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import MixedTypesError
from terrain.models.compare import history_predictions


def _rows(groups) -> pd.DataFrame:
    return pd.DataFrame({"group": pd.Series(groups, dtype=object),
                         "t_start_s": [0.0, 0.0, 1.0, 1.0],
                         "proba_A": [0.9, 0.1, 0.1, 0.9], "proba_B": [0.1, 0.9, 0.9, 0.1]})


@pytest.mark.parametrize("groups, second", [([1, "1", 1, "1"], "str"),
                                            ([1, True, 1, True], "bool"),
                                            (["r1", 2, "r1", 2], "int")])
def test_runs_of_mixed_types_are_refused_naming_the_argument(groups, second):
    # run 1 and run "1" (both shown as 1) were two runs sorted by type, each its own history;
    # True beside 1 was one run ("given more than once"): now MixedTypesError, as in
    # SlipRegressor.fit and leave_one_out
    with pytest.raises(MixedTypesError, match=rf"history_predictions: group mixes values of "
                                              rf"type \w+ and {second}"):
        history_predictions(_rows(groups), ["A", "B"], 2)


@pytest.mark.parametrize("groups", [[1, 2, 1, 2], [1, 2.0, 1, 2.0], ["a", "b", "a", "b"]])
def test_runs_of_one_type_decide_as_before(groups):
    out = history_predictions(_rows(groups), ["A", "B"], 2)
    np.testing.assert_array_equal(out, np.array(["A", "B", "A", "A"], dtype=object))
