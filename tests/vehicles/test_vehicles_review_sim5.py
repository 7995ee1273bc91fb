"""Review sim5 (vehicles): ICR thresholds that were taken as given, and kinematic invariants
that no test pinned (mutants that survived)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.vehicles.icr import chi_from_truth, inverse_icr_factor

W = np.array([0.5, -0.5, 0.3])
B = 0.5
# a vehicle turning as if its track were 1.5 B wide
V_L, V_R = -0.5 * 1.5 * B * W, 0.5 * 1.5 * B * W


@pytest.mark.parametrize("threshold", [float("nan"), True, "0.1", -0.1])
def test_chi_from_truth_refuses_a_threshold_that_is_not_a_yaw_rate(threshold):
    # NaN left every sample out and reported NaN ("never turns") for a turning run, True
    # was a 1 rad/s threshold, text a bare UFuncTypeError
    with pytest.raises(ConfigError, match="min_yaw_rate_rad_s"):
        chi_from_truth(V_L, V_R, W, B, threshold)


def test_chi_from_truth_finds_the_planted_expansion():
    assert chi_from_truth(V_L, V_R, W, B) == pytest.approx(1.5)
    assert chi_from_truth(V_L, V_R, W, B, 0.0) == pytest.approx(1.5)


@pytest.mark.parametrize("floor", [float("nan"), float("inf"), True, "0.1", -0.1])
def test_inverse_icr_factor_refuses_a_floor_that_is_not_a_yaw_rate(floor):
    # NaN gave a = NaN for every window, silently; -0.1 acted as +0.1 (squared)
    with pytest.raises(ConfigError, match="floor_rad_s"):
        inverse_icr_factor(W, W, floor_rad_s=floor)


@pytest.mark.parametrize("field, value", [
    ("wheel_positions_m", ((True, 0.0), (0.5075, 0.0), (0.0, -0.756))),
    ("camera_lever_arm_m", (0.6685, -0.26875, False)),
    ("camera_lever_arm_m", (0.6685, -0.26875, np.bool_(False)))])
def test_agrimaro_geometry_refuses_a_boolean_coordinate(field, value):
    # True was taken as a wheel at x = 1 m, False as a lever arm of 0 m
    from dataclasses import replace

    from terrain.vehicles import AGRIMARO
    with pytest.raises(ConfigError, match=field):
        replace(AGRIMARO, **{field: value})


@pytest.mark.slow
def test_tracked_turning_resistance_converges_with_the_track_discretisation():
    # the docstring said no physical quantity depends on n_segments; one point per track has
    # no turning resistance (it spins at the commanded rate), 5 points are within 5 % of 20
    from dataclasses import replace

    from terrain.sim.dynamics import integrate
    from terrain.terramechanics.catalogue import get_terrain
    from terrain.vehicles import TRACKED

    t = np.arange(801) * 0.01
    cmd = np.column_stack([np.full(801, 0.2), np.zeros(801), np.full(801, 0.5)])
    yaw_rate = {}
    for n in (1, 5, 20):
        veh = replace(TRACKED, n_segments=n)
        p = integrate(veh, veh.contact_geometry(), (get_terrain("SANDY_LOAM"),), 1e9, t, cmd,
                      0.0, 1.0)
        yaw_rate[n] = p.twist[-1, 2]
    assert yaw_rate[5] == pytest.approx(0.144, abs=0.002)
    assert yaw_rate[5] == pytest.approx(yaw_rate[20], rel=0.05)
    assert yaw_rate[1] > 3.0 * yaw_rate[5]


def test_a_lossless_gearbox_is_accepted_and_a_gain_refused():
    # efficiency in (0, 1]: 1 is an ideal gearbox (mutant: refused), above 1 creates energy
    from dataclasses import replace

    from terrain.vehicles import HUSKY
    assert replace(HUSKY.motor, efficiency=1.0).efficiency == 1.0
    with pytest.raises(ConfigError, match="efficiency"):
        replace(HUSKY.motor, efficiency=1.01)
