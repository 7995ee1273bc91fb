"""Review (srv12) of the served model's row and decision limits: a count, refused with a
ConfigError naming the setting when it is not a whole number >= 1."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from features.windows import WindowConfig
from terrain.errors import ConfigError
from terrain.serving.served import check_settings, served_settings

SETTINGS = {"hop_s": 0.5, "rate_hz": 20.0, "dwell_s": 10.0, "min_confidence": 0.5,
            "max_rows": 100, "max_decisions": 10}


@pytest.mark.parametrize("key", ["max_rows", "max_decisions"])
@pytest.mark.parametrize("value", [float("nan"), float("inf"), None, "abc", "100", 2.7, True,
                                   -3])
def test_a_limit_that_is_no_whole_count_is_refused_naming_it(key, value):
    # before: NaN, inf, None and "abc" escaped as ValueError / OverflowError / TypeError
    # (a model's YAML model_config failed to load with Python's words), 2.7 was taken as 2
    # rows and True as 1, "100" as 100
    check_settings(SETTINGS)
    with pytest.raises(ConfigError, match=rf"^{key} must be an integer >= 1, got "):
        check_settings({**SETTINGS, key: value})


def test_served_settings_does_not_round_a_fractional_limit_before_checking_it():
    model = SimpleNamespace(channels=("vel_l",), classes=("ICE", "SNOW"),
                            window=WindowConfig(window_s=2.0, rate_hz=20.0), metadata={})
    settings = served_settings(model, max_rows=5000, max_decisions=300)
    assert settings["max_rows"] == 5000 and settings["max_decisions"] == 300
    assert type(settings["max_rows"]) is int
    for key in ("max_rows", "max_decisions"):
        with pytest.raises(ConfigError, match=rf"^{key} must be an integer >= 1, got 2\.7"):
            served_settings(model, **{key: 2.7})
