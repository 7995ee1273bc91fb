"""State of the simulated data grid spec (review est23)."""

from __future__ import annotations

from terrain.slip.dataset import SlipDataSpec


def test_spec_keeps_its_own_checked_axes():
    """A spec built from the caller's lists kept them: a value appended afterwards (a seed
    given twice) was simulated and counted twice past the check of repeated values."""
    terrains, scenarios, seeds = ["GRASS"], ["straight_accel"], [0, 1]
    spec = SlipDataSpec(terrains=terrains, scenarios=scenarios, seeds=seeds, duration_s=5.0)
    seeds.append(0)
    terrains.append("ICE")
    scenarios.clear()
    assert spec.seeds == (0, 1) and spec.terrains == ("GRASS",)
    assert spec.scenarios == ("straight_accel",)
    assert [c.seed for c in spec.configs()] == [0, 1]
    assert hash(spec) == hash(SlipDataSpec(terrains=("GRASS",), scenarios=("straight_accel",),
                                           seeds=(0, 1), duration_s=5.0))
