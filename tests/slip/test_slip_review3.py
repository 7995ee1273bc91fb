"""Third review of the slip area (slip3): turning factor of dead reckoning, mutants of the
physics slip, the SAE conventions and the evaluation tables."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.slip.odometry import dead_reckon
from terrain.vehicles import HUSKY


@pytest.mark.parametrize("chi", [0.0, -2.0, np.array([1.0, 1.0, 0.0, 1.0, 1.0])])
def test_dead_reckon_refuses_a_turning_factor_that_is_not_positive(chi):
    # chi divides the wheels' yaw rate: 0 made the pose NaN from that sample on (a divide
    # warning only), a negative one turned the robot the other way without a word
    t = np.arange(5) * 0.1
    with pytest.raises(ConfigError, match="chi"):
        dead_reckon(t, np.full(5, 0.9), np.full(5, 1.1), HUSKY.track_m, chi=chi)


def test_dead_reckon_ignores_chi_when_the_gyro_gives_the_heading():
    # with the gyro's yaw rate chi is not used, so it is not checked either
    t = np.arange(5) * 0.1
    pose = dead_reckon(t, np.ones(5), np.ones(5), HUSKY.track_m, chi=0.0,
                       yaw_rate_rad_s=np.zeros(5))
    assert np.allclose(pose[:, 0], t) and np.allclose(pose[:, 1:], 0.0)


@pytest.mark.parametrize("track", [0.0, -0.5, np.nan, np.inf, True])
def test_endo_turning_slip_refuses_a_track_that_is_not_a_positive_number(track):
    # B yaw_rate closes eq. 27: a negative track gave other slips (alpha_r 0.22 against 0.12
    # at B = 0.5 m for vl 1, vr 1.5 m/s, yaw rate 0.3 rad/s), 0 dropped the measured turn
    # (0.17), NaN made every slip NaN, all without a word
    from terrain.slip.baselines import endo_turning_slip
    with pytest.raises(ConfigError, match="track_m"):
        endo_turning_slip(np.array([1.0]), np.array([1.5]), np.array([0.3]), track)
