"""Review tests of the audit (aud18): settings given as one value where a sequence is
expected, and properties of its pure helpers."""

from __future__ import annotations

import pytest

from terrain.audit import AuditSettings
from terrain.errors import ConfigError


@pytest.mark.parametrize("factors", [1.5, "1.5", None])
def test_sweep_factors_given_as_one_value_are_refused_naming_the_field(factors):
    # AuditSettings(sweep_factors=1.5) was a bare "TypeError: 'float' object is not
    # iterable", and the text "1.5" was read letter by letter ("factors[0] ... got str '1'")
    with pytest.raises(ConfigError, match=r"AuditSettings\.sweep_factors.*sequence"):
        AuditSettings(sweep_factors=factors)
    assert AuditSettings(sweep_factors=[0.5, 1.0]).sweep_factors == [0.5, 1.0]
    assert AuditSettings(sweep_factors=()).sweep_factors == ()


def test_the_sweep_refuses_one_factor_given_as_a_number():
    from terrain.audit.core import lateral_friction_sweep

    with pytest.raises(ConfigError, match=r"lateral_friction_sweep: the factors must be a seq"):
        lateral_friction_sweep([], "ASPHALT", 1.5)
