"""terrain.errors.config_positive: the one check of a positive (or non-negative) setting."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError, config_positive


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf"), -np.inf])
def test_a_value_that_is_not_finite_and_positive_is_named_with_its_owner(value):
    with pytest.raises(ConfigError, match=rf"^HuskyParams\.mass_kg must be a finite value > 0, "
                                          rf"got {value!r}"):
        config_positive("HuskyParams", track_m=0.57, mass_kg=value)


def test_zero_passes_where_allowed_and_text_is_not_a_number():
    config_positive("SoilParams", allow_zero=True, cohesion_pa=0.0, unit_weight_n_m3=np.float32(1))
    with pytest.raises(ConfigError, match=r"SoilParams\.cohesion_pa must be a finite value >= 0"):
        config_positive("SoilParams", allow_zero=True, cohesion_pa=-1.0)
    with pytest.raises(ConfigError, match=r"bekker_sinkage_m\.n must be a real number"):
        config_positive("bekker_sinkage_m", n="0.7")


def test_listed_shows_the_first_items_and_counts_the_others():
    from terrain.errors import listed
    assert listed(["a", "b"]) == "['a', 'b']"
    assert listed([f"c{i}" for i in range(7)], 3) == "['c0', 'c1', 'c2'] and 4 more"
    assert listed(["x" * 40], show=lambda s: s[:4]) == "['xxxx']"
