"""The EKF channel ``ekf_icr_chi`` is chi itself, not its logarithm (review ftr32).

The filter estimates ``ln(chi)``; the channel is ``exp`` of that state. On a straight window
chi is unobservable and stays at its prior median ``chi0``; reading the state itself
(``ln 1.5 = 0.41``) passed the default suite (only a slow test caught it).
"""

import numpy as np
import pytest

from features.ekf_signals import EKF_CHANNELS, window_ekf_channels
from terrain.estimation.skid_steer import SkidSteerSettings

CHANNELS = ["vel_l", "vel_r", "wz"]


@pytest.mark.parametrize("chi0", [1.5, 2.0, 0.8])
def test_chi_of_a_straight_window_is_its_prior(chi0):
    X = np.zeros((2, 3, 60))
    X[:, 0] = X[:, 1] = 0.5            # straight at 0.5 m/s, no yaw rate
    out = window_ekf_channels(X, CHANNELS, 50.0,
                              settings=SkidSteerSettings(track_m=0.5708, chi0=chi0))
    chi = out[:, EKF_CHANNELS.index("ekf_icr_chi")]
    np.testing.assert_allclose(chi, chi0, rtol=1e-12)
