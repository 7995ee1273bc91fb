"""Audit review (aud5): selection settings that are no counts, the Findings sentences of
effects fitted with a negative sign, and the learned transfer's history lags."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.audit.selection import SelectionSettings
from terrain.errors import ConfigError


@pytest.mark.parametrize("kwargs, match", [
    (dict(n_bootstrap=10.5), r"n_bootstrap must be an integer in \[10, 100000\], got 10.5"),
    (dict(n_param_bootstrap=True), r"n_param_bootstrap must be an integer in \[0, 10000\]"),
    (dict(n_param_bootstrap=20.0), r"n_param_bootstrap must be an integer"),
    (dict(min_units=2.5), r"min_units must be an integer >= 2, got 2.5"),
    (dict(min_units=float("inf")), r"min_units must be an integer >= 2, got inf"),
    (dict(seed=float("nan")), r"seed must be an integer >= 0, got nan"),
    (dict(seed=1.5), r"seed must be an integer >= 0, got 1.5"),
    (dict(min_gain="0.1"), r"min_gain"),
])
def test_selection_settings_refuse_counts_and_seeds_that_are_no_integers(kwargs, match):
    # before: accepted, then numpy's TypeError at the first bootstrap draw (n_bootstrap
    # 10.5, seed NaN or 1.5), an OverflowError cutting runs into segments (min_units inf),
    # one parameter resample for True, a TypeError comparing text (min_gain "0.1")
    with pytest.raises(ConfigError, match=match):
        SelectionSettings(**kwargs)


def test_selection_settings_take_numpy_integers_and_the_documented_bounds():
    s = SelectionSettings(n_bootstrap=np.int64(10), n_param_bootstrap=0, min_units=2,
                          seed=np.int64(7), min_gain=0.0)
    assert (s.n_bootstrap, s.n_param_bootstrap, s.min_units, s.seed) == (10, 0, 2, 7)
    SelectionSettings(n_bootstrap=100_000, n_param_bootstrap=10_000)
