"""Review tests (sim23): a desired-slip table is a frozen record: it does not share its
entries with the caller who built it, and it copies and pickles (a service or loop holding
it can be copied)."""

from __future__ import annotations

import copy
import pickle

import pytest

from terrain.control import build_slip_table, select_target
from terrain.control.desired_slip import SlipTable


def test_changing_the_dict_given_leaves_the_table_alone():
    """A hand-built table kept the caller's dict: deleting a class from it afterwards sent
    that class to the fallback (and an entry added later was served without its fallback
    having seen it)."""
    built = build_slip_table(["GRASS", "ICE"])
    entries = dict(built.entries)
    table = SlipTable(entries, built.fallback, built.config)
    del entries["GRASS"]
    assert select_target(table, "GRASS", 1.0).terrain == "GRASS"
    with pytest.raises(TypeError):
        table.entries["SNOW"] = built.fallback


@pytest.mark.parametrize("copier", [copy.copy, copy.deepcopy,
                                    lambda t: pickle.loads(pickle.dumps(t))],
                         ids=["copy", "deepcopy", "pickle"])
def test_a_table_copies_and_pickles(copier):
    """Its read-only entries (a mappingproxy) made copy.deepcopy and pickle fail with a bare
    TypeError; the copy serves the same targets."""
    table = build_slip_table(["GRASS", "ICE"])
    twin = copier(table)
    assert twin == table
    assert dict(twin.entries) == dict(table.entries)
    for label in ("GRASS", "ICE", None):
        assert select_target(twin, label, 1.0) == select_target(table, label, 1.0)
    with pytest.raises(TypeError):
        twin.entries["SNOW"] = table.fallback
