"""Review tm9 of the integrator and force model (terrain/sim/dynamics.py, forces.py):
boolean arrays refused where numbers are meant, and physical invariants of short runs
(a standing vehicle stays still, a mirrored command gives a mirrored run, a braked vehicle
holds on a grade below its friction limit, the step converges as dt shrinks)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim.dynamics import integrate
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

HUSKY = get_vehicle("husky")
AGRIMARO = get_vehicle("agrimaro")
ASPHALT = (get_terrain("ASPHALT"),)
T = np.arange(21) * 0.01


def _run(t_s=T, twist=None, vehicle=HUSKY, terrains=ASPHALT, slope=0.0, **kw):
    twist = np.zeros((len(t_s), 3)) if twist is None else twist
    return integrate(vehicle, vehicle.contact_geometry(), terrains, np.inf, t_s, twist,
                     slope, 1.0, **kw)


def test_a_boolean_command_is_refused():
    # np.ones((n, 3), bool) drove the Husky at v_x = 1 m/s, v_y = 1 m/s, 1 rad/s
    with pytest.raises(ConfigError, match="twist_cmd.*booleans"):
        _run(twist=np.ones((len(T), 3), dtype=bool))


def test_a_boolean_time_grid_is_refused():
    # [False, True] was a bare numpy TypeError (boolean subtract)
    with pytest.raises(ConfigError, match="t_s.*booleans"):
        _run(t_s=np.array([False, True]))


def test_a_boolean_steering_offset_is_refused():
    # [True, False, True] steered units 1 and 3 by 1 rad (57 deg)
    with pytest.raises(ConfigError, match="steer_offset_rad.*booleans"):
        _run(vehicle=AGRIMARO, steer_offset_rad=np.array([True, False, True]))


def test_a_boolean_hook_correction_is_refused():
    # the hook's [True, True] added 1 rad/s to both motors' commands
    with pytest.raises(ConfigError, match="hook.*booleans"):
        _run(hook=lambda snap: np.array([True, True]))
