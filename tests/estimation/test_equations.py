"""The python-control style functions of terrain.estimation.equations: known values from the
seed's equations, Jacobians against finite differences, and the model classes using them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrain.estimation.agrimaro import AgriMaRoModel
from terrain.estimation.equations import agrimaro, skid_steer, skid_steer_slip
from terrain.estimation.model import finite_difference_jacobian
from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
from terrain.vehicles.swerve import AGRIMARO


def test_agrimaro_steady_turn_keeps_body_velocity():
    """Eqs. 4.33-4.34: in a steady turn the accelerometer reads the centripetal term
    (a_by = yaw_rate v_bx) and the body velocity does not change."""
    x = np.zeros(12)
    x[3], x[5], x[7] = 1.0, 0.5, 0.5 * 1.0
    nxt = agrimaro.f(x, None, 0.01, agrimaro.AgriMaRoEquationParams())
    assert nxt[3] == pytest.approx(1.0, abs=1e-15) and nxt[4] == pytest.approx(0.0, abs=1e-15)
    assert nxt[2] == pytest.approx(0.005) and nxt[0] == pytest.approx(0.01)


def test_agrimaro_wheel_and_camera_rows():
    """Eq. 6.6: a pure yaw rotation turns a wheel steered across its lever arm at
    r |d_i| / R_w, and the camera sees v_b + omega x d_cam."""
    params = agrimaro.AgriMaRoEquationParams.from_vehicle(AGRIMARO)
    x = np.zeros(12)
    x[5] = 0.4                                            # yaw rate, rad/s
    x[8:11] = [math.pi / 2, math.pi / 2, 0.0]             # wheels 1, 2 sideways, 3 straight
    z = agrimaro.h(x, params)
    (x1, _), (x2, _), (_, y3) = AGRIMARO.wheel_positions_m
    r = AGRIMARO.wheel_radius_m
    np.testing.assert_allclose(z[:3], [0.4 * x1 / r, 0.4 * x2 / r, -0.4 * y3 / r], atol=1e-12)
    dx, dy = AGRIMARO.camera_lever_arm_m[:2]
    np.testing.assert_allclose(z[10:12], [-0.4 * dy, 0.4 * dx], atol=1e-15)
    assert z[5] == 0.4 and z[12] == 0.4


@pytest.mark.parametrize("module,n", [(agrimaro, 12), (skid_steer, 4)])
def test_jacobians_of_the_equations(module, n):
    rng = np.random.default_rng(3)
    params = (agrimaro.AgriMaRoEquationParams() if module is agrimaro
              else skid_steer.SkidSteerEquationParams())
    for _ in range(5):
        x = rng.uniform(-1.0, 1.0, n)
        if module is skid_steer:
            x[1] = 0.5                                    # turning: ln(chi) column active
        num_F = finite_difference_jacobian(lambda v: module.f(v, None, 0.02, params), x)
        num_H = finite_difference_jacobian(lambda v: module.h(v, params), x)
        np.testing.assert_allclose(module.F(x, None, 0.02, params), num_F, atol=1e-7)
        np.testing.assert_allclose(module.H(x, params), num_H, atol=1e-6)


def test_model_classes_call_the_equations():
    rng = np.random.default_rng(4)
    x = rng.uniform(-1.0, 1.0, 12)
    model = AgriMaRoModel()
    np.testing.assert_array_equal(model.f(x, 0.01), agrimaro.f(x, None, 0.01,
                                                               model.equation_params))
    np.testing.assert_array_equal(model.H(x), agrimaro.H(x, model.equation_params))
    skid = SkidSteerModel(SkidSteerSettings(track_m=0.6))
    xs = np.array([0.5, 0.3, 0.01, math.log(1.5)])
    hx = skid_steer.h(xs, skid.equation_params)
    np.testing.assert_allclose(hx, [0.5 - 1.5 * 0.3 * 0.3, 0.5 + 1.5 * 0.3 * 0.3, 0.31])
    np.testing.assert_array_equal(skid.h(xs), hx)


def test_wheel_rim_speed_is_eq_4_20():
    v = agrimaro.wheel_rim_speed(1.0, 0.2, 0.5, 0.3, -0.4, 0.1)
    expected = (1.0 - 0.5 * -0.4) * math.cos(0.1) + (0.2 + 0.5 * 0.3) * math.sin(0.1)
    assert v == pytest.approx(expected, rel=1e-15)


def test_slip_augmented_wheel_row_is_the_sae_slip_of_its_state():
    # the rim speed the model predicts has the SAE slip of its state in traction and in
    # braking (seed 001 eqs. 7.1-7.2); 1 / (1 - s) in braking gave -0.167 for a state -0.2
    from terrain.slip import sae_slip
    params = skid_steer_slip.SkidSteerSlipEquationParams()
    x = np.array([1.0, 0.0, 0.0, 0.0, -0.2, 0.2, 0.0, 0.0])
    rims = skid_steer_slip.h(x, params)[:2]
    np.testing.assert_allclose(rims, [0.8, 1.25])
    np.testing.assert_allclose(sae_slip(rims, [1.0, 1.0], dead_band_m_s=0.0), [-0.2, 0.2])


@pytest.mark.parametrize("v, w, s1, s2", [(-1.0, 0.0, 0.2, -0.2), (0.8, 0.6, 0.3, -0.1),
                                          (-0.6, -0.8, -0.25, 0.4), (0.1, 1.0, 0.2, 0.2)])
def test_slip_augmented_wheel_rows_keep_the_sae_sign_reversing_and_turning(v, w, s1, s2):
    """Each side's predicted rim speed has the SAE slip of its state over that side's own
    ground speed ``v_bx -+ chi B yaw_rate / 2`` (seed 001 eqs. 7.1-7.2), also reversing
    (traction in reverse: rim faster backwards, slip < 0) and with the sides moving in
    opposite directions (spot turn, last case)."""
    from terrain.slip import sae_slip
    params = skid_steer_slip.SkidSteerSlipEquationParams()
    chi = 1.4
    x = np.array([v, w, 0.0, np.log(chi), s1, s2, 0.0, 0.0])
    rims = skid_steer_slip.h(x, params)[:2]
    half = chi * params.track_m * w / 2.0
    ground = np.array([v - half, v + half])
    np.testing.assert_allclose(sae_slip(rims, ground, dead_band_m_s=0.0), [s1, s2], rtol=1e-12)
    # the sign convention: a positive slip spins the rim ahead of the ground, either way
    assert np.all(np.sign(rims - ground) == np.sign([s1, s2]))


@pytest.mark.parametrize("slips", [(0.3, -0.4), (-0.1, 0.05), (0.97, -0.97)],
                         ids=["traction-braking", "small", "clipped"])
def test_slip_augmented_jacobians_match_finite_differences(slips):
    params = skid_steer_slip.SkidSteerSlipEquationParams()
    for v_bx in (1.2, -0.8):
        x = np.array([v_bx, 0.4, 0.01, math.log(1.5), *slips, 0.3, 0.05])
        num_F = finite_difference_jacobian(lambda v: skid_steer_slip.f(v, None, 0.02, params),
                                           x)
        num_H = finite_difference_jacobian(lambda v: skid_steer_slip.h(v, params), x)
        np.testing.assert_allclose(skid_steer_slip.F(x, None, 0.02, params), num_F, atol=1e-7)
        np.testing.assert_allclose(skid_steer_slip.H(x, params), num_H, atol=1e-6)
    if abs(slips[0]) > skid_steer_slip.MAX_SLIP:           # h ignores a clipped slip
        assert skid_steer_slip.H(x, params)[0, 4] == 0.0


def test_chi_is_a_consider_parameter_below_its_yaw_rate_threshold():
    """The ``ln(chi)`` column of the wheel rows is ``-+ chi B w / 2`` while turning and zero
    below ``chi_min_yaw_rate_rad_s`` (driving straight a gyro bias must not drag chi
    towards 0); the wheel rows themselves still use chi."""
    params = skid_steer.SkidSteerEquationParams(track_m=0.6, chi_min_yaw_rate_rad_s=0.05)
    chi = 1.5
    for w, column in ((0.3, 1.5 * 0.6 * 0.3 / 2), (-0.3, -1.5 * 0.6 * 0.3 / 2),
                      (0.05, 1.5 * 0.6 * 0.05 / 2), (0.049, 0.0), (0.0, 0.0), (-0.02, 0.0)):
        x = np.array([0.5, w, 0.0, math.log(chi)])
        H = skid_steer.H(x, params)
        np.testing.assert_allclose(H[:2, 3], [-column, column], atol=1e-15, err_msg=f"w {w}")
        np.testing.assert_allclose(skid_steer.h(x, params)[:2],
                                   [0.5 - chi * 0.6 * w / 2, 0.5 + chi * 0.6 * w / 2])


def test_slip_augmented_accelerometer_reads_gravity_as_the_simulator_does():
    """At rest on a nose-up grade the accelerometer reads ``+g sin(pitch)`` forward and
    ``g cos(pitch)`` up: the body-axes convention of the simulator's sensors
    (:func:`terrain.sim.sensors.gravity_specific_force`, pitch nose-up positive). A sign
    slip in both ``h`` and ``H`` passes the finite-difference check and would estimate
    every grade upside down."""
    from terrain.sim.sensors import gravity_specific_force
    params = skid_steer_slip.SkidSteerSlipEquationParams()
    for pitch in (0.1, -0.2):
        x = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3, pitch])
        ax, az = skid_steer_slip.h(x, params)[5:7]
        g_x, _, g_z = gravity_specific_force(np.array([pitch]), np.array([0.0]))
        assert ax == pytest.approx(0.3 + g_x[0], rel=1e-6)
        assert az == pytest.approx(g_z[0], rel=1e-6)
        assert np.sign(ax - 0.3) == np.sign(pitch)


def test_slip_state_wheel_rows_floor_one_minus_slip():
    """Eq. 4.22 with ``1 - s`` floored at SLIP_FLOOR: a slip state at or past 0.95 reads the
    rim speed of slip 0.95 (finite, also at s = 1) and has no slip column."""
    from terrain.estimation.slip_state import SLIP_FLOOR, SlipStateModel
    model = SlipStateModel()
    x = np.zeros(14)
    x[3] = 1.0                                           # 1 m/s forward, wheels straight
    r = model.vehicle.wheel_radius_m
    for s in (0.96, 0.99, 1.0, 1.5):
        x[8] = s
        hx, H = model.observation(x)
        assert hx[0] == pytest.approx(1.0 / (SLIP_FLOOR * r), rel=1e-12)
        assert H[0, 8] == 0.0
    x[8] = 0.5
    hx, H = model.observation(x)
    assert hx[0] == pytest.approx(1.0 / (0.5 * r)) and H[0, 8] == pytest.approx(1.0 / (0.25 * r))
