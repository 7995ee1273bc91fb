"""Second review pass of the desired-slip table's trust rules (terrain.control.desired_slip)."""

from __future__ import annotations

import math

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
