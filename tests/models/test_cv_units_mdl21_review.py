"""Renaming a run must not change the run-grouped split units (mdl21): a time block of a
single-run class (``<run>@block<k>``) must never take the id of another run."""

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from terrain.errors import ConfigError
from terrain.models.cv import split_single_run_classes


def test_a_block_named_as_another_run_is_refused():
    labels = np.array(["x"] * 4 + ["y"] * 4 + ["y"] * 2)
    runs = np.array(["a"] * 4 + ["a@block0"] * 4 + ["c"] * 2, dtype=object)
    t = np.r_[np.arange(4), np.arange(4), np.arange(2)].astype(float)
    with pytest.raises(ConfigError, match="a@block0"):
        split_single_run_classes(labels, runs, t, 2)


@settings(max_examples=100, deadline=None)
@example(["y", "x", "y", "z", "z"], [1, 1, 0, 2, 2], 2, "r1@block0")
@given(st.lists(st.sampled_from(["x", "y", "z"]), min_size=5, max_size=5),
       st.lists(st.integers(0, 4), min_size=1, max_size=25),
       st.integers(2, 4), st.sampled_from(["b", "r1@block0", "r2@block1", "zz"]))
def test_renaming_a_run_renames_its_units_only(run_labels, rows, n_blocks, new_name):
    # every run holds one terrain; a class of one run is cut into time blocks
    labels = np.array([run_labels[r] for r in rows])
    runs = np.array([f"r{r}" for r in rows], dtype=object)
    t = np.arange(len(rows), dtype=float)
    base, split = split_single_run_classes(labels, runs, t, n_blocks)
    renamed = np.where(runs == "r0", new_name, runs).astype(object)
    try:
        other, split2 = split_single_run_classes(labels, renamed, t, n_blocks)
    except ConfigError:
        # only where a block name of the renamed runs is the id of another run
        assert "@block" in new_name
        return
    assert split2 == split
    # the same partition of the windows into units
    pairs = set(zip(base.tolist(), other.tolist()))
    assert len(pairs) == len(set(base.tolist())) == len(set(other.tolist()))
