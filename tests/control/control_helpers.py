"""Building the controller's inputs in a test."""

from __future__ import annotations

import numpy as np

from terrain.sim.closed_loop import Observation


def observation(t_s: float, omega_low_level, imu=None, wheels=None, currents=None,
                imu_full=None) -> Observation:
    """One call's :class:`~terrain.sim.closed_loop.Observation` of a two-side skid-steer,
    with no sample of the streams not given.

    Parameters
    ----------
    t_s : float
        Time of the call, s.
    omega_low_level : array-like, shape (m,)
        Low-level wheel speed command, rad/s.
    imu, wheels, currents, imu_full : ndarray, optional
        Rows of those streams (``Observation``'s shapes); None: no sample (the camera and
        steering streams never have one).

    Returns
    -------
    Observation
    """
    return Observation(t_s, np.asarray(omega_low_level, float),
                       np.zeros((0, 4)) if imu is None else imu,
                       np.zeros((0, 3)) if wheels is None else wheels, np.zeros((0, 3)),
                       np.zeros((0, 5)), np.zeros((0, 3)) if currents is None else currents,
                       np.zeros((0, 7)) if imu_full is None else imu_full)
