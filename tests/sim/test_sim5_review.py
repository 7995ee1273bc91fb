"""Review sim5: integrator arguments that were silently accepted or gave bare tracebacks,
and mutants of the sim / vehicles area that no test killed."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError, NonFiniteInputError, ShapeError
from terrain.sim.dynamics import integrate
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

HUSKY = get_vehicle("husky")
AGRIMARO = get_vehicle("agrimaro")
ASPHALT = (get_terrain("ASPHALT"),)
T = np.arange(21) * 0.01
CMD = np.column_stack([np.full(21, 0.5), np.zeros(21), np.zeros(21)])


def _run(vehicle=HUSKY, segment=25.0, slope=0.0, chi=1.0, offset=None):
    return integrate(vehicle, vehicle.contact_geometry(), ASPHALT, segment, T, CMD, slope,
                     chi, offset)


@pytest.mark.parametrize("name, kwargs", [
    ("slope_rad", {"slope": True}), ("slope_rad", {"slope": "0.1"}),
    ("slope_rad", {"slope": None}), ("chi", {"chi": True}), ("chi", {"chi": "1.2"}),
    ("segment_length_m", {"segment": True}), ("segment_length_m", {"segment": "5"})])
def test_integrate_refuses_a_boolean_or_text_for_a_number_naming_it(name, kwargs):
    # slope True ran on a 1 rad (57 deg) plane, chi and segment True as 1; text was a bare
    # TypeError from np.isfinite or from //
    with pytest.raises(ConfigError, match=name):
        _run(**kwargs)


@pytest.mark.parametrize("slope", [np.pi / 2, -2.0, 2.0 * np.pi])
def test_integrate_refuses_a_plane_steeper_than_vertical(slope):
    # 2 rad gave negative normal loads (cos < 0); 2 pi ran as a level plane
    with pytest.raises(ConfigError, match="slope_rad"):
        _run(slope=slope)


def test_integrate_keeps_a_downhill_plane():
    # a plane falling along +x: gravity pushes a vehicle facing +x forward
    p = _run(slope=-0.2)
    assert p.pose[-1, 0] > _run().pose[-1, 0]


def test_integrate_refuses_a_steering_offset_it_cannot_apply():
    # NaN: ValueError 'cannot convert float NaN to integer' deep in the step; two values for
    # three wheels: a bare broadcasting ValueError; on a skid-steer: silently ignored
    with pytest.raises(NonFiniteInputError, match="steer_offset_rad"):
        _run(AGRIMARO, offset=np.array([np.nan, 0.0, 0.0]))
    with pytest.raises(ShapeError, match="steer_offset_rad"):
        _run(AGRIMARO, offset=np.array([0.01, 0.0]))
    with pytest.raises(ConfigError, match="steer_offset_rad"):
        _run(HUSKY, offset=np.array([0.01, 0.0]))


def test_a_steering_offset_turns_the_agrimaro_off_its_straight_line():
    # the offset inside the dead band (seed 001 ch. 6.1.1) is applied to every wheel
    straight = _run(AGRIMARO)
    off = _run(AGRIMARO, offset=np.full(3, 0.02))
    assert np.allclose(off.delta[-1], straight.delta[-1] + 0.02, atol=1e-12)


def test_swerve_commands_keep_each_unit_on_the_solution_nearest_its_last_angle():
    # a crab direction turning from 80 to 100 deg: each unit steers on through 90 deg and
    # keeps rolling forward (mutant: without the previous angle, the solution within pi/2 of
    # 0 flipped every unit to -80 deg with its wheel reversed, a 180 deg steering jump)
    from terrain.sim.dynamics import wheel_commands

    ang = np.radians(np.linspace(80.0, 100.0, 41))
    cmd = np.column_stack([0.5 * np.cos(ang), 0.5 * np.sin(ang), np.zeros(41)])
    omega, delta, _ = wheel_commands(AGRIMARO, AGRIMARO.contact_geometry(), cmd)
    np.testing.assert_allclose(delta, np.repeat(ang[:, None], 3, axis=1), atol=1e-12)
    np.testing.assert_allclose(omega, 0.5 / AGRIMARO.wheel_radius_m, rtol=1e-12)


def test_the_closed_loop_snapshot_carries_the_attitude_of_its_pose_on_a_slope():
    # the hook's pitch (nose up) and roll (right side down) are slope_attitude of the pose
    # (mutant: the two swapped, so the online IMU's gravity went to the wrong axes)
    from terrain.sim.dynamics import slope_attitude

    t = np.arange(201) * 0.01
    cmd = np.column_stack([np.full(201, 0.3), np.zeros(201), np.full(201, 0.8)])
    snaps = []
    integrate(HUSKY, HUSKY.contact_geometry(), ASPHALT, 25.0, t, cmd, 0.2, 1.0,
              hook=lambda s: snaps.append(s))
    yaw = np.array([s.pose[2] for s in snaps])
    pitch, roll = slope_attitude(0.2, yaw)
    assert yaw[-1] > 0.5                 # it turned, so both angles vary
    np.testing.assert_allclose([s.pitch for s in snaps], pitch, atol=1e-12)
    np.testing.assert_allclose([s.roll for s in snaps], roll, atol=1e-12)
    assert snaps[0].pitch == pytest.approx(0.2, abs=1e-3)
