"""Review tests of the desired-slip settings and the low-confidence fallback."""

from __future__ import annotations

import math

import pytest

from terrain.control.desired_slip import DesiredSlipConfig, build_slip_table, select_target
from terrain.errors import ConfigError


@pytest.mark.parametrize("kwargs, named", [
    # a confidence threshold above 1 (50 for 50 %) trusts no decision: always the fallback
    ({"min_confidence": 1.5}, "min_confidence"), ({"min_confidence": 50.0}, "min_confidence"),
    ({"min_confidence": -0.1}, "min_confidence"),
    # a cap of 1 is no cap at all: the range is (0, 1)
    ({"deformable_cap": 1.0}, "deformable_cap"), ({"deformable_cap": 0.0}, "deformable_cap"),
    ({"traction_fraction": 0.0}, "traction_fraction"),
    ({"braking_fraction": 1.0}, "braking_fraction")])
def test_settings_outside_their_ranges_are_config_errors_saying_which(kwargs, named):
    with pytest.raises(ConfigError, match=named):
        DesiredSlipConfig(**kwargs)


def test_the_ends_of_the_confidence_range_are_accepted_and_applied():
    """min_confidence 1 trusts only a certain decision; 0 trusts any finite one."""
    strict = build_slip_table(["ICE", "GRASS"], DesiredSlipConfig(min_confidence=1.0))
    assert select_target(strict, "GRASS", 1.0) is strict.entries["GRASS"]
    assert select_target(strict, "GRASS", 0.999) is strict.fallback
    lax = build_slip_table(["ICE", "GRASS"], DesiredSlipConfig(min_confidence=0.0))
    assert select_target(lax, "GRASS", 0.0) is lax.entries["GRASS"]
    assert select_target(lax, "GRASS", math.nan) is lax.fallback
