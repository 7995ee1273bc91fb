"""Second review of the physics slip: the bound of its terrain-probability setting."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.slip.physics import PhysicsSlipSettings, physics_slip
from terrain.vehicles import HUSKY


def test_a_minimum_probability_of_one_is_refused_and_just_below_one_is_kept():
    # [0, 1): at 1 every terrain a classifier gives less than certainty is dropped, and a
    # row without a certain terrain would fail later with "sum to 0 on some rows"
    with pytest.raises(ConfigError, match="min_probability must be in \\[0, 1\\)"):
        PhysicsSlipSettings(min_probability=1.0)
    settings = PhysicsSlipSettings(min_probability=0.99)
    cur, rim = np.full((2, 2), 8.0), np.full((2, 2), 1.0)
    out = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, np.zeros(2), settings=settings)
    assert np.isfinite(out.slip).all()


def test_run_pitch_prior_leaves_out_a_window_whose_pitch_std_is_unknown():
    # a window with a finite pitch but a NaN std is left out of both moments: the mean is
    # that of the other windows, and the variance is not made NaN
    from terrain.slip.physics import run_pitch_prior
    mean, var = run_pitch_prior(np.array([0.1, 0.2, 0.3, 0.9]),
                                np.array([0.01, 0.01, 0.01, np.nan]))
    assert mean == pytest.approx(0.2)
    assert var == pytest.approx(np.var([0.1, 0.2, 0.3]) - 0.01 ** 2)
