"""Review tests of the audit (aud18): settings given as one value where a sequence is
expected, and properties of its pure helpers."""

from __future__ import annotations

import pytest

from terrain.audit import AuditSettings
from terrain.audit.effects import EffectSettings
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


@pytest.mark.parametrize("kwargs, field", [
    ({"threshold_quantiles": 0.5}, "threshold_quantiles"),
    ({"threshold_quantiles": "0.5"}, "threshold_quantiles"),
    ({"threshold_quantiles": (0.5, "0.3")}, r"threshold_quantiles\[1\]"),
    ({"threshold_quantiles": (0.5, True)}, r"threshold_quantiles\[1\]"),
    ({"negligible": 0.1}, "negligible"),
])
def test_effect_settings_refuse_a_sequence_setting_given_as_one_value(kwargs, field):
    # threshold_quantiles=0.5 and negligible=0.1 were bare "TypeError: 'float' object is not
    # iterable"; a quantile given as text ("0.3") passed float(q) and failed in the first
    # rate-dependent fit as numpy's "'<=' not supported between 'float' and 'numpy.str_'"
    with pytest.raises(ConfigError, match=rf"EffectSettings\.{field}"):
        EffectSettings(**kwargs)
    assert EffectSettings(threshold_quantiles=[0.25, 0.75]).threshold_quantiles == [0.25, 0.75]
