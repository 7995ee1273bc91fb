"""Review pass ctl10 of the decisions' table and flag helpers (terrain.serving.decisions)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import DataFormatError
from terrain.serving.decisions import Decision, decisions_frame, join_flags


def test_join_flags_refuses_columns_of_different_lengths():
    """One flag column short of a decision dropped the last decisions silently (``zip``):
    three decisions and a one-entry column gave one joined flag."""
    with pytest.raises(DataFormatError, match=r"3, 1"):
        join_flags(["a", "b", "c"], ["x"])
    assert join_flags(["a", "", None], ["x", "", "y|a"]) == ["a|x", "", "a|y"]
    assert join_flags() == []


def _decision(proba):
    return Decision(0.0, "ASPHALT", 0.9, np.asarray(proba, dtype=float), 0.1, -0.13, 0.0,
                    0.0, "")


def test_decisions_frame_refuses_probabilities_of_another_class_count():
    """A decision with two probabilities written under one class name raised pandas's bare
    '9 columns passed, passed data had 10 columns'; now a DataFormatError naming both."""
    with pytest.raises(DataFormatError, match=r"decision 1 .*2 probabilities.*1 class"):
        decisions_frame([_decision([1.0]), _decision([0.9, 0.1])], ["ASPHALT"])
    frame = decisions_frame([_decision([0.9, 0.1])], ["ASPHALT", "ICE"])
    assert frame["proba_ICE"].tolist() == [0.1]


def test_a_missing_flag_cell_read_back_from_csv_is_no_flag():
    """pandas reads an empty flags cell of a decisions CSV as NaN: no flag, never 'nan'."""
    import io

    import pandas as pd

    back = pd.read_csv(io.StringIO("t_s,flags\n0.5,\n1.0,gap\n"))
    assert np.isnan(back["flags"][0])
    assert join_flags(back["flags"], ["stale", ""]) == ["stale", "gap"]
    assert join_flags([np.float64("nan")], [None]) == [""]
