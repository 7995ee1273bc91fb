"""Second review pass of the desired-slip table's trust rules (terrain.control.desired_slip)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrain.control.desired_slip import DesiredSlipConfig
from terrain.errors import ConfigError


@pytest.mark.parametrize("age", [math.inf, math.nan, -math.inf])
def test_a_decision_age_limit_that_is_not_finite_is_refused(age):
    """max_decision_age_s is when a terrain decision turns stale and the conservative
    fallback applies (a classifier that stops deciding must leave its last class); inf
    passed the ``> 0`` check and then no decision ever went stale, the last class held for
    good. The controller's own max_input_age_s refuses inf already."""
    with pytest.raises(ConfigError, match="max_decision_age_s"):
        DesiredSlipConfig(max_decision_age_s=age)


def test_a_large_finite_decision_age_limit_is_accepted():
    assert DesiredSlipConfig(max_decision_age_s=3600.0).max_decision_age_s == 3600.0


@pytest.mark.parametrize("field, value", [("confidence", True), ("confidence", "0.9"),
                                          ("decision_age_s", "1.0"), ("decision_age_s", False)])
def test_select_target_refuses_a_confidence_or_age_that_is_not_a_number(field, value):
    # True was trusted as a confidence of 1; text raised numpy's / math's bare TypeError
    from terrain.control.desired_slip import build_slip_table, select_target
    table = build_slip_table(["ICE", "TILES"])
    kwargs = {"confidence": 0.9, "decision_age_s": 0.5, field: value}
    with pytest.raises(ConfigError, match=f"select_target.{field}"):
        select_target(table, "TILES", **kwargs)
    # None stays the documented "no confidence / no time": the fallback, no error
    assert select_target(table, "TILES", confidence=None) is table.fallback
    assert select_target(table, "TILES", 0.9, decision_age_s=None) is table.fallback
    assert select_target(table, "TILES", np.float32(0.9), np.float64(0.5)) is \
        table.entries["TILES"]
