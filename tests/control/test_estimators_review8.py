"""Eighth review pass of the online slip estimators (terrain.control.estimators): what each
estimator hands the controller, and the inputs of its pseudo-measurement and noise floor."""

from __future__ import annotations

import numpy as np
import pytest
from control_helpers import observation

import terrain.control.estimators as estimators
from terrain.control.estimators import AgriMaRoVisualOdometryEKF, FusedSlipObserver
from terrain.sim.closed_loop import Observation

EMPTY = np.zeros((0, 4))


def _agrimaro_obs(t, wheels=EMPTY, imu_full=np.zeros((0, 7))):
    return Observation(t, np.zeros(3), EMPTY, wheels, EMPTY, np.zeros((0, 5)), EMPTY,
                       imu_full)


def test_the_agrimaro_ekf_skips_a_non_finite_wheel_sample():
    """An encoder sample holding NaN (a dropout of one hub motor's encoder) is left out of
    the filter and must not become the latest encoder speed handed to the controller, as
    in the Husky's estimators: 2 rad/s on every wheel, then (3, NaN, 3) keeps (2, 2, 2)."""
    est = AgriMaRoVisualOdometryEKF()
    est.update(_agrimaro_obs(0.1, np.array([[0.05, 2.0, 2.0, 2.0]])))
    e = est.update(_agrimaro_obs(0.2, np.array([[0.15, 3.0, np.nan, 3.0]])))
    np.testing.assert_array_equal(e.omega_meas_rad_s, [2.0, 2.0, 2.0])
    e = est.update(_agrimaro_obs(0.3, np.array([[0.25, 4.0, 4.0, 4.0]])))
    np.testing.assert_array_equal(e.omega_meas_rad_s, [4.0, 4.0, 4.0])


def test_the_fused_observer_hands_on_its_acceleration_state():
    """``a_local_m_s2`` is the filter's ``accel_x`` state (which selects the controller's
    traction / steady / braking mode), not another state: 3 s of 0.5 m/s^2 on the clean
    IMU with wheels at the matching speed (no slip) give 0.5 m/s^2 on both sides, the
    pitch state staying near 0."""
    est = FusedSlipObserver("husky", None, imu="clean")
    r = est.vehicle.wheel_radius_m
    for k in range(1, 301):
        t = 0.01 * k
        wheels = np.array([[t, 0.5 * t / r, 0.5 * t / r]]) if k % 5 == 0 else None
        e = est.update(observation(t, np.zeros(2), imu=np.array([[t, 0.5, 0.0, 0.0]]),
                                   wheels=wheels))
    np.testing.assert_allclose(e.a_local_m_s2, [0.5, 0.5], atol=0.02)
    assert e.a_local_m_s2[0] == est.x[estimators.STATE_NAMES.index("accel_x")]
    assert abs(est.x[estimators.STATE_NAMES.index("pitch")]) < 0.01


def test_the_fused_observers_physics_slip_reads_the_pitch_state(monkeypatch):
    """The physics slip's normal loads (and the slope's share of the traction) come from the
    filter's pitch state at the time of the pseudo-measurement (the batch fusion's pitch),
    not from level ground."""
    seen = []
    real = estimators.physics_slip

    def spy(vehicle, probs, cur, rim, pitch, *args, **kwargs):
        seen.append(float(np.asarray(pitch)[0]))
        return real(vehicle, probs, cur, rim, pitch, *args, **kwargs)

    monkeypatch.setattr(estimators, "physics_slip", spy)
    est = FusedSlipObserver("husky", lambda t: ("SNOW", 1.0))
    pitch = estimators.STATE_NAMES.index("pitch")
    est.x[pitch] = 0.12
    est.update(observation(0.3, np.ones(2), wheels=np.array([[0.1, 5.0, 5.0]]),
                           currents=np.array([[0.1, 4.0, 4.0], [0.2, 4.0, 4.0]])))
    assert seen and seen[0] == pytest.approx(est.x[pitch], abs=1e-3)
    assert abs(seen[0]) > 0.1


def _averaged_blocks(values):
    """Feed one 0.1 s block of identical ``ax`` samples per value (100 Hz, 11 samples per
    block: the block closes at the sample 0.1 s after its first); return the std after each
    block."""
    est = AgriMaRoVisualOdometryEKF(imu="full-averaged", accel_std_m_s2=0.8)
    stds, t = [], 0.0
    for v in values:
        for _ in range(11):
            est.update(_agrimaro_obs(t, imu_full=np.array([[t, 0, 0, 0, v, 0.0, 9.81]])))
            t = round(t + 0.01, 10)
        stds.append(est.accel_block_std_m_s2.copy())
    return stds


def test_the_averaged_view_floors_a_block_means_noise_at_the_white_noise_of_its_samples():
    """Identical samples have no spread between block means, so the variance used is the
    floor ``accel_std^2 / n``: 0.8 / sqrt(11) m/s^2 for 11 samples per block, not 0.8."""
    stds = _averaged_blocks([0.3, 0.3, 0.3, 0.3])
    np.testing.assert_allclose(stds[-1], 0.8 / np.sqrt(11), rtol=1e-12)


def test_the_averaged_view_trusts_the_measured_variance_from_two_block_differences_on():
    """One difference of block means is no variance estimate: after the second block (one
    difference, 0 -> 3 m/s^2 on ax) the floor still applies; from the third block (two
    differences) the mean of ``(M_k - M_k-1)^2 / 2`` does: (4.5 + 0) / 2 on ax."""
    stds = _averaged_blocks([0.0, 3.0, 3.0])
    np.testing.assert_allclose(stds[1], 0.8 / np.sqrt(11), rtol=1e-12)
    np.testing.assert_allclose(stds[2], [np.sqrt(2.25), 0.8 / np.sqrt(11)], rtol=1e-12)


def test_the_agrimaro_full_view_reads_ax_ay_wz_from_the_full_imus_columns():
    """``full``: the model's ``ax, ay, wz`` rows get the full IMU's columns 4, 5 and 3
    (``t, wx, wy, wz, ax, ay, az``): 1 s of a forward 0.5 m/s^2 at 100 Hz moves the
    acceleration state ``ax`` towards 0.5 and leaves ``ay`` near 0."""
    est = AgriMaRoVisualOdometryEKF(imu="full")
    for k in range(1, 101):
        t = 0.01 * k
        est.update(_agrimaro_obs(t, imu_full=np.array([[t, 0.0, 0.0, 0.0, 0.5, 0.0, 9.81]])))
    ax, ay = est.ekf.x[6], est.ekf.x[7]
    assert 0.3 < ax < 0.6 and abs(ay) < 0.05


def test_the_fused_observer_takes_no_pseudo_measurement_under_an_uncatalogued_decision():
    """A decided class outside the terrain catalogue has no traction curve to invert: no
    pseudo-measurement (counted 0, the estimate stale), and no error in the loop."""
    est = FusedSlipObserver("husky", lambda t: ("MARS_REGOLITH", 1.0))
    e = est.update(observation(0.3, np.ones(2), wheels=np.array([[0.1, 5.0, 5.0]]),
                               currents=np.array([[0.1, 4.0, 4.0], [0.2, 4.0, 4.0]])))
    assert est.pseudo_count == 0 and e.age_s == float("inf")
