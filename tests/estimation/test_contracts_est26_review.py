"""Contracts between the estimators and the modules they read (review est26).

Each test crosses a seam with the real producer and the real consumer: the simulator's runs
and truth (:mod:`terrain.sim`), the vehicle catalogue (:mod:`terrain.vehicles`), the
terramechanics constants and slip (:mod:`terrain.terramechanics`) against the filters of
:mod:`terrain.estimation`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError
from terrain.estimation.agrimaro import agrimaro_samples, estimate_agrimaro
from terrain.estimation.equations.skid_steer_slip import (STANDARD_GRAVITY_M_S2,
                                                          SkidSteerSlipEquationParams, h)
from terrain.estimation.skid_steer import (SkidSteerModel, SkidSteerSettings,
                                           estimate_skid_steer, icr_chi)
from terrain.estimation.slip_state import SlipStateModel
from terrain.run import TIME, Run
from terrain.sim.effects import Effects
from terrain.sim.forces import contact_layout, velocity_maps
from terrain.sim.sensors import gravity_specific_force
from terrain.sim.simulate import SimConfig, simulate
from terrain.terramechanics.resistance import G_M_S2
from terrain.terramechanics.slip import sae_slip
from terrain.vehicles import get_vehicle
from terrain.vehicles.icr import chi_from_truth


def _turning_run(vehicle: str, n: int = 400, rate_hz: float = 100.0) -> Run:
    """A steady left turn of the vehicle at chi 1.5 with rolling sides (its own track)."""
    t = np.arange(n) / rate_hz
    track = get_vehicle(vehicle).track_m
    v, w, chi = 0.4, 0.5, 1.5
    vel_l = np.full(n, v - chi * track * w / 2.0)
    vel_r = np.full(n, v + chi * track * w / 2.0)
    streams = {"wheels": pd.DataFrame({TIME: t, "vel_l": vel_l, "vel_r": vel_r}),
               "imu": pd.DataFrame({TIME: t, "ax": 0.0, "ay": v * w, "wz": np.full(n, w)})}
    return Run(f"sim/ASPHALT/{vehicle}", "sim", "ASPHALT", streams, vehicle=vehicle)


@pytest.mark.slow
def test_skid_steer_filter_takes_the_runs_vehicle_track_simulated_tracked_run():
    """A simulated tracked run (track 0.393 m) with a planted ICR expansion: the skid-steer
    EKF, given only the run, estimates the chi that the truth gives (chi_from_truth with the
    simulator's own track). With the Husky's 0.5708 m it read 1.03 against a true 1.44."""
    run = simulate(SimConfig(vehicle="tracked", terrains=("ASPHALT",), scenario="random",
                             duration_s=40.0, seed=1, effects=Effects(icr_expansion=1.4)))
    params = get_vehicle(run.vehicle)
    tr = run.streams["truth"]
    r = params.contact_geometry().wheel_radius_m
    chi_true = chi_from_truth(tr["omega_1"] * r, tr["omega_2"] * r, tr["yaw_rate"],
                              params.track_m)
    chi = icr_chi(estimate_skid_steer(run))[-1]
    assert chi == pytest.approx(chi_true, rel=0.1)
    assert estimate_skid_steer(run).meta["track_m"] == params.track_m


@settings(max_examples=10, deadline=None)
@given(vehicle=st.sampled_from(["husky", "tracked"]))
def test_skid_steer_default_settings_are_the_runs_vehicle(vehicle):
    """Without settings the filter is the one built for the run's vehicle: the same answer,
    bit for bit, as with ``SkidSteerSettings(track_m=<that vehicle>.track_m)``, and a steady
    turn at chi 1.5 on that vehicle's track is read as chi 1.5."""
    run = _turning_run(vehicle)
    own = estimate_skid_steer(run, SkidSteerSettings(track_m=get_vehicle(vehicle).track_m))
    default = estimate_skid_steer(run)
    np.testing.assert_array_equal(default.x, own.x)
    assert icr_chi(default)[-1] == pytest.approx(1.5, rel=0.02)


def test_skid_steer_filter_refuses_a_steered_vehicle():
    """An AgriMaRo run (three steered wheels; its ``wheels`` stream holds wheels 1 and 2,
    on the axle line x = -+0.5075 m, not a left and a right side) is no input of the
    skid-steer EKF: a ConfigError names the vehicle, with or without settings."""
    run = _turning_run("husky")
    run = Run("sim/ASPHALT/agri", "sim", "ASPHALT", dict(run.streams), vehicle="agrimaro")
    with pytest.raises(ConfigError, match="agrimaro"):
        estimate_skid_steer(run)
    with pytest.raises(ConfigError, match="agrimaro"):
        estimate_skid_steer(run, SkidSteerSettings())


@settings(max_examples=30, deadline=None)
@given(pitch=st.floats(-0.5, 0.5), accel=st.floats(-3.0, 3.0))
def test_accelerometer_rows_read_the_simulators_gravity(pitch, accel):
    """The slip filter's accelerometer rows at pitch ``p`` and acceleration ``a`` are the
    simulator's gravity specific force plus ``a`` on x (to round-off of two sine
    implementations): one gravity, the
    terramechanics' ``G_M_S2``, which the simulator's IMU uses (the estimator had its own
    copy of 9.80665)."""
    assert STANDARD_GRAVITY_M_S2 is G_M_S2
    assert SkidSteerSlipEquationParams().gravity_m_s2 is G_M_S2
    x = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, accel, pitch])
    hx = h(x)
    g_x, _, g_z = gravity_specific_force(np.array([pitch]), np.array([0.0]))
    assert hx[5] == pytest.approx(accel + float(g_x[0]), rel=1e-14, abs=1e-14)
    assert hx[6] == pytest.approx(float(g_z[0]), rel=1e-14)


@settings(max_examples=20, deadline=None)
@example(v=1.0, s=-0.2)
@example(v=-1.0, s=0.2)
@given(v=st.floats(-2.0, 2.0).filter(lambda v: abs(v) > 0.1), s=st.floats(-0.5, 0.5))
def test_slip_state_model_slip_is_the_sae_slip_of_its_rim_speed(v, s):
    """The rim speed that the ch. 4.3 wheel rows predict for slip state ``s`` at ground
    speed ``v`` (straight, wheels aligned) has SAE slip ``s`` (terramechanics' sae_slip, the
    simulator's truth slip), braking and in reverse too."""
    model = SlipStateModel()
    x = np.zeros(14)
    x[3], x[8:11] = v, s
    rim = model.observation(x)[0][:3] * model.vehicle.wheel_radius_m
    np.testing.assert_allclose(sae_slip(rim, np.full(3, v), dead_band_m_s=0.0), s,
                               atol=1e-9)


@pytest.mark.parametrize("vehicle", ["husky", "tracked"])
def test_agrimaro_filter_refuses_a_skid_steer_run(vehicle):
    """A skid-steer run (its ``wheels`` stream: the left and right sides) is no input of the
    AgriMaRo EKF, which read ``vel_l, vel_r`` as its wheels 1 and 2 (on the axle line at
    x = -+0.5075 m) over the AgriMaRo's wheel radius and ran without a word: a ConfigError
    names the vehicle (estimate_agrimaro and agrimaro_samples)."""
    run = _turning_run(vehicle)
    with pytest.raises(ConfigError, match=vehicle):
        estimate_agrimaro(run)
    with pytest.raises(ConfigError, match=vehicle):
        agrimaro_samples(run)


@settings(max_examples=60, deadline=None)
@given(v=st.floats(-2.0, 2.0), w=st.floats(-1.0, 1.0), log_chi=st.floats(0.0, 1.0),
       s1=st.floats(-0.9, 0.9), s2=st.floats(-0.9, 0.9))
def test_slip_filter_slip_states_are_the_sae_slip_of_their_rim_speeds(v, w, log_chi, s1, s2):
    """The slip-augmented skid-steer filter's ``slip_1`` (left) and ``slip_2`` (right) are
    terramechanics' SAE slip (``sae_slip``, the simulator's truth slip, no floor or dead
    band) of the rim speeds its wheel rows predict over each side's ground speed
    ``v -+ chi B yaw_rate / 2``: traction and braking, forward and in reverse, turning either
    way."""
    track = SkidSteerSlipEquationParams().track_m
    chi = float(np.exp(log_chi))
    ground = np.array([v - chi * track * w / 2.0, v + chi * track * w / 2.0])
    assume(np.all(np.abs(ground) > 1e-3))
    x = np.array([v, w, 0.0, log_chi, s1, s2, 0.0, 0.0])
    rim = h(x)[:2]
    np.testing.assert_allclose(sae_slip(rim, ground, dead_band_m_s=0.0), [s1, s2],
                               rtol=1e-9, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(vehicle=st.sampled_from(["husky", "tracked"]), chi=st.floats(1.0, 5.0),
       v=st.floats(-2.0, 2.0), vy=st.floats(-0.5, 0.5), w=st.floats(-2.0, 2.0))
def test_filter_wheel_rows_are_the_simulators_contact_line_speeds(vehicle, chi, v, vy, w):
    """One skid-steer kinematics: the 4-state EKF's wheel rows (``vel_l, vel_r`` at zero slip)
    equal the longitudinal speeds of the simulator's kinematic contact lines (its
    ``icr_expansion`` chi placing them at ``chi y``, :func:`terrain.sim.forces.velocity_maps`)
    of the left (motor 0) and right (motor 1) contacts, for the vehicle's own track; the
    lateral body speed does not enter either."""
    params = get_vehicle(vehicle)
    geometry = params.contact_geometry()
    layout = contact_layout(geometry, params.mass_kg, 0.0, chi)
    maps = velocity_maps(layout, np.zeros(len(layout.x_m)))
    v_long = maps.long_kinematic @ np.array([v, vy, w])
    sides = [v_long[geometry.motor_of_contact == m] for m in (0, 1)]
    model = SkidSteerModel(SkidSteerSettings(track_m=params.track_m))
    hx = model.observation(np.array([v, w, 0.0, np.log(chi)]))[0]
    for side, rows in zip((0, 1), sides):
        np.testing.assert_allclose(rows, hx[side], rtol=1e-12, atol=1e-12)
    assert geometry.motor_names[:2] == ("left", "right")
