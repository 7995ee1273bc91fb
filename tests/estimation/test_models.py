"""Analytic Jacobians of every model against central finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.estimation.agrimaro import (AgriMaRoEKFSettings, AgriMaRoModel,
                                         noise_derived_settings)
from terrain.estimation.model import finite_difference_jacobian
from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
from terrain.estimation.skid_steer_slip import SkidSteerSlipModel
from terrain.estimation.slip_state import SlipStateModel

MODELS = {
    "agrimaro-body": AgriMaRoModel(),
    "agrimaro-eq6.2": AgriMaRoModel(settings=AgriMaRoEKFSettings(coriolis="eq6.2")),
    "slip-state-ch4": SlipStateModel(),
    "slip-state-camera": SlipStateModel(accel="direct", camera=True),
    "skid-steer": SkidSteerModel(SkidSteerSettings(chi0=1.4)),
}
#: Every model class and option, for the near-singular states below.
EDGE_MODELS = {**MODELS, "slip-state-direct": SlipStateModel(accel="direct"),
               "slip-state-ch4-camera": SlipStateModel(camera=True),
               "skid-steer-slip": SkidSteerSlipModel()}


def _random_state(model, rng):
    x = rng.uniform(-1.0, 1.0, model.n_states)
    for j, name in enumerate(model.state_names):
        if name.startswith("slip"):
            x[j] = rng.uniform(-0.3, 0.6)
        if name == "log_icr_chi":
            x[j] = rng.uniform(0.0, 1.0)
        if name == "yaw_rate":       # chi is only corrected above 0.05 rad/s (skid-steer)
            x[j] = rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 1.0)
    return x


@pytest.mark.parametrize("name", list(MODELS))
def test_jacobians_match_finite_differences(name):
    model = MODELS[name]
    rng = np.random.default_rng(11)
    for _ in range(5):
        x = _random_state(model, rng)
        dt = rng.uniform(0.005, 0.05)
        fx, F = model.transition(x, dt)
        np.testing.assert_allclose(fx, model.f(x, dt))
        np.testing.assert_allclose(F, finite_difference_jacobian(lambda v: model.f(v, dt), x),
                                   rtol=1e-6, atol=1e-8)
        hx, H = model.observation(x)
        assert hx.shape == (model.n_measurements,)
        assert H.shape == (model.n_measurements, model.n_states)
        np.testing.assert_allclose(H, finite_difference_jacobian(model.h, x), rtol=1e-6,
                                   atol=1e-8)


@pytest.mark.parametrize("name", list(MODELS))
def test_model_noise_and_priors_are_valid(name):
    model = MODELS[name]
    n, m = model.n_states, model.n_measurements
    assert model.x0.shape == (n,) and model.P0.shape == (n, n)
    assert (model.R_diag > 0).all() and model.R_diag.shape == (m,)
    Q = model.Q(0.01)
    assert Q.shape == (n, n) and np.linalg.eigvalsh(Q).min() >= 0
    rows = sorted(r for rs in model.sensor_rows.values() for r in rs)
    assert rows == list(range(m))          # sensors partition the measurement rows
    y = model.residual(np.full(m, 3.1), np.full(m, -3.1))
    for r in model.angle_rows:
        assert abs(y[r]) < 0.1              # 6.2 rad apart on the circle = 0.083 rad


def test_agrimaro_defaults_are_the_thesis_final_tuning():
    s = AgriMaRoEKFSettings()
    assert s.p0_diag[8:11] == (1.5e-4,) * 3 and s.p0_diag[11] == 1e-4          # eq. 6.9
    assert s.r_diag[:3] == (0.05,) * 3 and s.r_diag[10:] == (5e-5, 5e-5, 1e-3, 5e-4)  # 6.13
    assert s.q_diag == (0.5, 0.5, 0.08, 0.08, 0.08, 0.15, 0.12, 0.12, 0.002, 0.002, 0.002,
                        0.002)                                                 # eq. 6.14
    assert s.alpha("cam") == 0.2 and s.alpha("omega") == 0.0 and s.alpha("imu") == 0.1
    model = AgriMaRoModel()
    np.testing.assert_allclose(np.diag(model.Q(0.01)), s.q_diag)      # per filter step
    nd = AgriMaRoModel(settings=noise_derived_settings())
    np.testing.assert_allclose(np.diag(nd.Q(0.02)), 2 * np.diag(nd.Q(0.01)))


def test_camera_lever_arm_is_inside_h():
    model = AgriMaRoModel()
    x = np.zeros(12)
    x[3], x[5] = 1.0, 0.5                     # v_bx 1 m/s, yaw rate 0.5 rad/s
    hx = model.h(x)
    dx, dy, _ = model.vehicle.camera_lever_arm_m
    # eq. 6.6: v_cam = v_B + omega x d_cam
    assert hx[10] == pytest.approx(1.0 - 0.5 * dy)
    assert hx[11] == pytest.approx(0.5 * dx)


@pytest.mark.parametrize("kwargs", [dict(r_diag=(1.0,) * 13), dict(q_per="hour"),
                                    dict(coriolis="left"), dict(ema_alpha=(("cam", 1.5),)),
                                    dict(r_diag=(0.0,) + (1.0,) * 13)])
def test_bad_settings_raise_config_error(kwargs):
    with pytest.raises(ConfigError):
        AgriMaRoEKFSettings(**kwargs)


def _edge_states(model, rng):
    """States at the edges of the models' trigonometry and kinematics: body at rest (zero
    speed and yaw rate), wheels steered to +-90 deg (and 180 deg), heading at +-pi and past
    it. Kept away from the deliberate kinks, which a finite difference straddles: the
    skid-steer ln(chi) column below its yaw-rate threshold, a floored or clipped slip, a
    slip-augmented side's ground speed of exactly 0, and a slip-in-state wheel at rest with a
    slip (the SAE rim speed, ``v (1 + s)`` or ``v / (1 - s)`` by the sign of ``v s``, turns
    its slope at ``v = 0``: at rest those slips are 0)."""
    names = model.state_names
    skid = "log_icr_chi" in names
    out = []
    for k in range(24):
        x = rng.uniform(-1.5, 1.5, model.n_states)
        for j, name in enumerate(names):
            if name == "yaw":
                x[j] = (np.pi, -np.pi, np.pi - 1e-9, 3.0 * np.pi, -2.5 * np.pi, x[j])[k % 6]
            elif name.startswith("delta"):
                x[j] = rng.choice([np.pi / 2, -np.pi / 2, np.pi, 0.0])
            elif name.startswith("slip"):
                x[j] = rng.uniform(-0.5, 0.5) if skid or k % 2 else 0.0
            elif name in ("v_bx", "v_by") and k % 2 == 0:
                x[j] = 0.3 if skid else 0.0               # at rest (skid: off the kink)
            elif name == "yaw_rate":
                x[j] = (rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 1.0) if skid
                        else 0.0 if k % 2 == 0 else x[j])
            elif name == "pitch":
                x[j] = rng.choice([0.0, np.pi / 2, -np.pi / 2])
        if skid and "slip_1" in names:                    # both sides' ground speed > 0
            x[0] = 0.3 + 0.6 * 0.5708 * abs(x[1])
        out.append(x)
    return out


@pytest.mark.parametrize("name", list(EDGE_MODELS))
def test_jacobians_match_finite_differences_at_near_singular_states(name):
    model = EDGE_MODELS[name]
    rng = np.random.default_rng(19)
    for x in _edge_states(model, rng):
        for dt in (0.01, 0.05):
            fx, F = model.transition(x, dt)
            np.testing.assert_allclose(
                F, finite_difference_jacobian(lambda v: model.f(v, dt), x), rtol=1e-6,
                atol=1e-8, err_msg=f"F at {x}")
        hx, H = model.observation(x)
        np.testing.assert_allclose(H, finite_difference_jacobian(model.h, x), rtol=1e-6,
                                   atol=1e-7, err_msg=f"H at {x}")


@pytest.mark.parametrize("kwargs,match", [
    (dict(q_per="steps"), "q_per"),
    (dict(q_diag=(-1e-3,) * 14), "q_diag"),
    (dict(q_diag=(float("nan"),) * 14), "q_diag"),
    (dict(p0_diag=(float("inf"),) * 14), "p0_diag"),
    (dict(p0_diag=(-1e-6,) + (1e-6,) * 13), "p0_diag"),
    (dict(r_diag=(0.0,) + (1e-5,) * 9), "r_diag needs 10 finite values > 0")])
def test_slip_state_model_refuses_a_tuning_that_is_not_a_covariance(kwargs, match):
    """SlipStateModel checked only the lengths of p0_diag and q_diag, not q_per: q_per='steps'
    ran silently as per-second noise (Q 1e-10 instead of 1e-8 at 100 Hz) and q_diag of -1e-3
    gave negative variances (P_diag -0.137 after 1 s, no error)."""
    with pytest.raises(ConfigError, match=match):
        SlipStateModel(**kwargs)


def test_skid_steer_measurement_noise_is_the_squared_stds_with_the_wheel_inflation():
    s = SkidSteerSettings(wheel_std_m_s=0.03, gyro_std_rad_s=0.01)
    np.testing.assert_allclose(SkidSteerModel(s).R_diag, [9e-4, 9e-4, 1e-4], rtol=1e-12)
    # a wheel stream interpolated 4x: its variance (not the gyro's) counts 4 times
    np.testing.assert_allclose(SkidSteerModel(s, wheel_r_scale=4.0).R_diag,
                               [3.6e-3, 3.6e-3, 1e-4], rtol=1e-12)


@pytest.mark.parametrize("dt", [0.01, 0.1, 0.5])
def test_skid_steer_slip_process_noise_is_the_exact_white_jerk_discretisation(dt):
    """``(v_bx, a_x)`` driven by white jerk of density q: Q = q [[dt^3/3, dt^2/2],
    [dt^2/2, dt]], computed here independently by Van Loan's matrix exponential
    (Van Loan 1978, IEEE TAC 23(3), eq. for Q_d); the other states ``diag(q) dt``."""
    from scipy.linalg import expm
    from terrain.estimation.skid_steer_slip import SkidSteerSlipSettings
    settings = SkidSteerSlipSettings(jerk_psd=0.7)
    Q = SkidSteerSlipModel(settings).Q(dt)
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    Gq = np.diag([0.0, 0.7])
    M = expm(np.block([[-A, Gq], [np.zeros((2, 2)), A.T]]) * dt)
    Qd = M[2:, 2:].T @ M[:2, 2:]
    np.testing.assert_allclose(Q[np.ix_([0, 6], [0, 6])], Qd, rtol=1e-10)
    others = [1, 2, 3, 4, 5, 7]
    np.testing.assert_allclose(np.diag(Q)[others],
                               np.asarray(settings.q_diag)[others] * dt, rtol=1e-12)
    assert np.count_nonzero(Q - np.diag(np.diag(Q))) == 2          # only the (v, a) pair
