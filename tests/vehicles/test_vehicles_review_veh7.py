"""Review veh7: impossible geometry of the skid-steer wrappers, chi of a recording with no
commanded turn, Endo's ratio at a standing left track, and pinned values of the vehicle
kinematics against the seed equations."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.vehicles import skid_steer_forward, skid_steer_inverse


@pytest.mark.parametrize("kwargs", [dict(track_m=0.0), dict(track_m=-0.5),
                                    dict(track_m=float("nan")), dict(track_m=True),
                                    dict(track_m=0.5, chi=0.0), dict(track_m=0.5, chi=-1.5),
                                    dict(track_m=0.5, chi=float("inf")),
                                    dict(track_m=0.5, chi=True)])
def test_skid_steer_wrappers_refuse_an_impossible_track_or_chi(kwargs):
    # track 0 gave an infinite yaw rate, a negative track or chi one of the wrong sign
    # (a left turn read as a right turn), True a 1 m track
    with pytest.raises(ConfigError, match="track_m|chi"):
        skid_steer_forward(np.array([1.0]), np.array([2.0]), **kwargs)
    with pytest.raises(ConfigError, match="track_m|chi"):
        skid_steer_inverse(np.array([1.0]), np.array([0.5]), **kwargs)


def test_skid_steer_forward_pins_seed_000_eq_3():
    # V_G = (eta_R v_R + eta_L v_L) / 2, Omega = (eta_R v_R - eta_L v_L) / (chi 2 d):
    # v_L = 1, v_R = 2, eta_L = 0.9, eta_R = 0.8, B = 0.5, chi = 1.25:
    # V_G = (1.6 + 0.9) / 2 = 1.25, Omega = (1.6 - 0.9) / 0.625 = 1.12 (left turn, > 0)
    v, r = skid_steer_forward(np.array([1.0]), np.array([2.0]), 0.5, eta_left=0.9,
                              eta_right=0.8, chi=1.25)
    assert v[0] == pytest.approx(1.25, rel=1e-12)
    assert r[0] == pytest.approx(1.12, rel=1e-12)
    vl, vr = skid_steer_inverse(np.array([1.0]), np.array([0.4]), 0.5, chi=1.5)
    # v -+ chi B r / 2 = 1 -+ 0.15: the left (inner) side slower in a left turn
    assert (vl[0], vr[0]) == (pytest.approx(0.85, rel=1e-12), pytest.approx(1.15, rel=1e-12))


def test_icr_expansion_factor_of_no_commanded_turn_is_unknown_not_dug_in():
    from terrain.vehicles.icr import icr_expansion_factor, inverse_icr_factor

    # a straight run (x = 0: the ICR at infinity) says nothing about chi; it returned inf,
    # the answer reserved for a vehicle that does not turn the commanded way
    straight = np.zeros(20)
    assert np.isnan(icr_expansion_factor(np.full(20, 0.05), straight))
    assert np.isnan(icr_expansion_factor(straight, straight))
    assert np.isnan(icr_expansion_factor(np.empty(0), np.empty(0)))     # no sample
    assert np.isnan(inverse_icr_factor(np.full(20, 0.05), straight))     # the same as 1/chi
    # a commanded turn the vehicle does not follow is still inf
    assert icr_expansion_factor(straight, np.full(20, 0.3)) == np.inf


def test_endo_ratio_pins_seed_003_eq_27_and_refuses_a_standing_left_track():
    from terrain.errors import EstimationError
    from terrain.vehicles import endo_slip_ratio_ratio

    # alpha_l / alpha_r = -sgn(v_r v_l) |v_r / v_l|^n: v_l = 0.1, v_r = 0.4, n = 0.5 ->
    # -sqrt(4) = -2; a counter-rotating pair (v_l = -0.1) gives +2
    got = endo_slip_ratio_ratio(np.array([0.1, -0.1]), np.array([0.4, 0.4]), n=0.5)
    np.testing.assert_allclose(got, [-2.0, 2.0], rtol=1e-12)
    # v_l = 0: |v_r / 0|^n times sgn(0) was NaN with a RuntimeWarning
    with pytest.raises(EstimationError, match=r"v_left_m_s.*index 1"):
        endo_slip_ratio_ratio(np.array([0.1, 0.0]), np.array([0.4, 0.4]))
    for n in (float("nan"), -0.8, True):
        with pytest.raises(ConfigError, match="n"):
            endo_slip_ratio_ratio(np.array([0.1]), np.array([0.4]), n=n)


def test_swerve_geometry_with_coincident_wheels_is_refused():
    from terrain.vehicles import AgriMaRoParams

    # three steering axes at one point: H of eq. 2.3 has rank 2, the yaw rate of eq. 2.4
    # cannot be solved (H^+ gave 0 rad/s for any wheel speeds)
    with pytest.raises(ConfigError, match="wheel_positions_m"):
        AgriMaRoParams(wheel_positions_m=((0.2, 0.1), (0.2, 0.1), (0.2, 0.1)))


@pytest.mark.parametrize("bad", [float("nan"), -1.0, True])
def test_swerve_inverse_refuses_a_bad_min_speed(bad):
    from terrain.vehicles import swerve_inverse

    # NaN: no unit ever kept its angle (a standing unit snapped to 0 or -pi)
    with pytest.raises(ConfigError, match="min_speed_m_s"):
        swerve_inverse(np.zeros(3), min_speed_m_s=bad)


def test_swerve_inverse_standing_unit_keeps_its_angle_and_reverse_flips():
    from terrain.vehicles import AGRIMARO, swerve_inverse

    prev = np.array([0.3, -0.2, 1.0])
    d, w = swerve_inverse(np.zeros(3), delta_prev_rad=prev)
    np.testing.assert_array_equal(d, prev)
    np.testing.assert_array_equal(w, 0.0)
    # reversing at 0.5 m/s from straight ahead: angle 0 kept, wheels turn backward
    d, w = swerve_inverse(np.array([0.0, -0.5, 0.0]), delta_prev_rad=np.zeros(3))
    np.testing.assert_allclose(np.abs(d), 0.0, atol=1e-12)
    np.testing.assert_allclose(w, -0.5 / AGRIMARO.wheel_radius_m, rtol=1e-12)
    # sideways to the left (v_y > 0): every unit at +pi/2, wheels forward
    d, w = swerve_inverse(np.array([0.0, 0.0, 0.5]))
    np.testing.assert_allclose(d, np.pi / 2, rtol=1e-12)
    np.testing.assert_allclose(w, 0.5 / AGRIMARO.wheel_radius_m, rtol=1e-12)


def test_chi_from_truth_leaves_out_a_sample_turning_exactly_at_the_threshold():
    from terrain.vehicles.icr import chi_from_truth

    # "turning faster than min_yaw_rate_rad_s": the sample at exactly 0.1 rad/s is left out,
    # so chi = 0.6 / 0.4 = 1.5 from the one at 0.4 rad/s (B = 1); with it the fit would be
    # (0.6 * 0.4 + 0.5 * 0.1) / (0.16 + 0.01) = 1.706
    left = np.zeros(2)
    right = np.array([0.6, 0.5])
    w = np.array([0.4, 0.1])
    assert chi_from_truth(left, right, w, 1.0, min_yaw_rate_rad_s=0.1) == pytest.approx(
        1.5, rel=1e-12)


@pytest.mark.parametrize("delta, omega", [(np.zeros(2), np.zeros(2)),
                                          (np.zeros(3), np.zeros(4)),
                                          (np.zeros((5, 3)), np.zeros((4, 3)))])
def test_swerve_forward_names_a_wrong_shape(delta, omega):
    from terrain.errors import ShapeError
    from terrain.vehicles import swerve_forward

    # NumPy's bare "matmul: Input operand 1 has a mismatch" / broadcast ValueError before
    with pytest.raises(ShapeError, match="delta_rad"):
        swerve_forward(delta, omega)
