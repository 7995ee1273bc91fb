"""Review of the vehicle estimation models (skid-steer, AgriMaRo, the compiled loop and the
consistency statistics): behaviour the other tests of ``tests/estimation`` left open."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError


@pytest.mark.parametrize("kwargs,match", [
    (dict(dof=0), "dof"), (dict(dof=-3), "dof"), (dict(dof=np.nan), "dof"),
    (dict(dof=np.inf), "dof"), (dict(n_samples=np.nan), "n_samples")])
def test_chi2_bounds_of_an_impossible_dof_or_sample_count_are_refused(kwargs, match):
    """``mean_chi2_bounds(0, 10)``, ``(-3, 10)`` and ``(3, nan)`` returned ``(nan, nan)``:
    a consistency test against them is silently never inside."""
    from scipy import stats

    from terrain.estimation.consistency import mean_chi2_bounds
    args = dict(dof=3, n_samples=10) | kwargs
    with pytest.raises(ConfigError, match=match):
        mean_chi2_bounds(**args)
    assert mean_chi2_bounds(3, 10) == pytest.approx(
        (stats.chi2.ppf(0.025, 30) / 10, stats.chi2.ppf(0.975, 30) / 10))
