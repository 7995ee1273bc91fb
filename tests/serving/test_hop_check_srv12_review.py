"""Review (srv12) of the decision hop's check against the model's clock
(:func:`terrain.serving.config.check_hop`, run by the service and at a served model's load)."""

from __future__ import annotations

import pytest

from terrain.errors import ConfigError
from terrain.serving.config import check_hop
from terrain.serving.served import check_settings


@pytest.mark.parametrize("hop_s, rate_hz, field", [
    (0.5, 0.0, "rate_hz"),            # ZeroDivisionError before
    (0.5, -20.0, "rate_hz"),          # taken before: a negative period passes every hop
    (0.5, "20 Hz", "rate_hz"),        # ValueError from float() before
    (None, 20.0, "hop_s"),            # TypeError before
    (True, 20.0, "hop_s"),            # taken as a 1 s hop before
])
def test_a_hop_or_clock_that_is_no_positive_number_is_a_config_error(hop_s, rate_hz, field):
    with pytest.raises(ConfigError, match=rf"check_hop\.{field}"):
        check_hop(hop_s, rate_hz)
    # a served model's model_config: refused at load with the same error
    settings = {"hop_s": hop_s, "rate_hz": rate_hz, "dwell_s": 10.0, "min_confidence": 0.5,
                "max_rows": 100, "max_decisions": 10}
    with pytest.raises(ConfigError, match=rf"check_hop\.{field}"):
        check_settings(settings)


def test_a_hop_of_one_period_or_more_is_taken():
    assert check_hop(0.05, 20.0) == 0.05 and check_hop(0.5, 20) == 0.5
    with pytest.raises(ConfigError, match="shorter than one period"):
        check_hop(0.04, 20.0)
