"""Review pass ctl10 of the decisions' table and flag helpers (terrain.serving.decisions)."""

from __future__ import annotations

import pytest

from terrain.errors import DataFormatError
from terrain.serving.decisions import join_flags


def test_join_flags_refuses_columns_of_different_lengths():
    """One flag column short of a decision dropped the last decisions silently (``zip``):
    three decisions and a one-entry column gave one joined flag."""
    with pytest.raises(DataFormatError, match=r"3, 1"):
        join_flags(["a", "b", "c"], ["x"])
    assert join_flags(["a", "", None], ["x", "", "y|a"]) == ["a|x", "", "a|y"]
    assert join_flags() == []
