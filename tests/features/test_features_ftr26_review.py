"""Review ftr26: the seams between the features and the modules they read from.

The skid-steer kinematics ``V = (v_R + v_L) / 2``, ``Omega = (v_R - v_L) / (chi B)`` have one
home, :func:`terrain.vehicles.skid_steer.body_rates` ("NumPy callers, the observer and numba
code call it"); the derived wheel channels, the wheel-physics features and the slip features
call it (ideal drive, ``chi = 1``) instead of writing it out again, and what they give
crosses the seam unchanged: a tracked vehicle's run windowed by :func:`make_windows` gives the
yaw rate ``body_rates`` gives with its own track, and the wheel-physics features of the same
windows read the same yaw rate and mean speed as the derived channels hold.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import features.slip_features as slip_features_module
import features.windows as windows_module
from features.slip_features import INV_CHI_FLOOR_RAD_S, SLIP_CHANNELS, slip_feature_matrix
from features.wheel_physics import PHYSICS_FEATURES, WheelPhysicsFeatures, physics_features
from features.windows import (WindowConfig, derived_wheel_arrays, make_windows,
                              runs_track_m)
from terrain.sim.simulate import SimConfig, simulate
from terrain.vehicles import HUSKY, TRACKED, body_rates
from terrain.vehicles.icr import inverse_icr_factor

speeds = arrays(float, (3, 12), elements=st.floats(-3.0, 3.0, allow_nan=False))
tracks = st.floats(0.2, 2.0)


@pytest.fixture(scope="module")
def tracked_windows():
    run = simulate(SimConfig(vehicle="tracked", terrains=("SANDY_LOAM",), scenario="spin",
                             duration_s=6.0, seed=2))
    return run, make_windows([run], "wheels", WindowConfig(window_s=2.0))


def test_derived_wheel_channels_call_the_kinematics_home(monkeypatch):
    """derived_wheel_arrays (make_windows, the pyfunc and the live service derive their
    channels with it) wrote vel_mean and yaw_rate_wheels out itself; it calls body_rates."""
    seen = []

    def spy(v_l, v_r, track_m, chi):
        seen.append((track_m, chi))
        return body_rates(v_l, v_r, track_m, chi)

    monkeypatch.setattr(windows_module, "body_rates", spy)
    derived_wheel_arrays(np.ones(3), np.full(3, 2.0), np.ones(3), np.ones(3), 0.393)
    assert seen == [(0.393, 1.0)]


def test_slip_features_call_the_kinematics_home(monkeypatch):
    """slip_feature_matrix took the mean rim speed and the wheel yaw rate of inv_chi from
    its own formulas; it calls body_rates with the vehicle's track."""
    seen = []

    def spy(v_l, v_r, track_m, chi):
        seen.append((track_m, chi))
        return body_rates(v_l, v_r, track_m, chi)

    monkeypatch.setattr(slip_features_module, "body_rates", spy)
    x = np.random.default_rng(0).normal(size=(2, len(SLIP_CHANNELS), 20))
    slip_feature_matrix(x, SLIP_CHANNELS, 50.0, TRACKED)
    assert seen == [(TRACKED.track_m, 1.0)]


@settings(max_examples=40, deadline=None)
@given(v_l=speeds, v_r=speeds, track=tracks)
def test_derived_channels_equal_body_rates(v_l, v_r, track):
    """vel_mean and yaw_rate_wheels are body_rates' V and Omega at chi = 1, to the bit."""
    got = derived_wheel_arrays(v_l, v_r, np.zeros_like(v_l), np.zeros_like(v_l), track)
    v, w = body_rates(v_l, v_r, track, 1.0)
    np.testing.assert_array_equal(got["vel_mean"], v)
    np.testing.assert_array_equal(got["yaw_rate_wheels"], w)


@settings(max_examples=40, deadline=None)
@given(v_l=speeds, v_r=speeds, track=tracks)
def test_physics_operating_point_is_body_rates(v_l, v_r, track):
    """The compiled wheel-physics kernel's speed and yaw-rate command are body_rates' (the
    operating-point features: mean |V|, its std, mean |Omega|, its std)."""
    out = physics_features(v_l, v_r, np.ones_like(v_l), np.ones_like(v_l), 10.0, track)
    col = {name: out[:, j] for j, name in enumerate(PHYSICS_FEATURES)}
    v, w = body_rates(v_l, v_r, track, 1.0)
    np.testing.assert_allclose(col["vel_mean__abs_mean"], np.abs(v).mean(axis=1),
                               rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(col["yaw_rate_cmd__abs_mean"], np.abs(w).mean(axis=1),
                               rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(col["yaw_rate_cmd__std"], w.std(axis=1), rtol=1e-12,
                               atol=1e-13)
    np.testing.assert_array_equal(col["turning__fraction"],
                                  (np.abs(w) > 0.1).mean(axis=1))


def test_tracked_windows_carry_the_tracked_yaw_rate(tracked_windows):
    """make_windows derives a tracked run's yaw_rate_wheels with the tracked vehicle's track
    (0.393 m), as body_rates gives it, not with the Husky's (0.5708 m)."""
    _, ws = tracked_windows
    ch = list(ws.channels)
    x = ws.X
    _, w = body_rates(x[:, ch.index("vel_l")], x[:, ch.index("vel_r")], TRACKED.track_m, 1.0)
    assert np.abs(w).max() > 0.1          # the spin turns
    np.testing.assert_array_equal(x[:, ch.index("yaw_rate_wheels")], w)
    assert TRACKED.track_m != HUSKY.track_m


def test_physics_features_read_the_derived_channels_operating_point(tracked_windows):
    """Two paths, one answer: the wheel-physics features of a tracked run's windows, with the
    track a model trained on it uses (runs_track_m), read the yaw-rate command and the mean
    speed the derived channels of the same windows hold."""
    run, ws = tracked_windows
    ch = list(ws.channels)
    fx = WheelPhysicsFeatures(ws.channels, ws.rate_hz, short_s=None,
                              track_m=runs_track_m([run])).fit(ws.X)
    out = fx.transform(ws.X)
    col = {name: out[:, j] for j, name in enumerate(fx.get_feature_names_out())}
    yaw = ws.X[:, ch.index("yaw_rate_wheels")]
    vel = ws.X[:, ch.index("vel_mean")]
    np.testing.assert_allclose(col["yaw_rate_cmd__abs_mean"], np.abs(yaw).mean(axis=1),
                               rtol=1e-14)
    np.testing.assert_allclose(col["vel_mean__abs_mean"], np.abs(vel).mean(axis=1),
                               rtol=1e-14, atol=1e-15)


def test_inv_chi_is_the_icr_fit_on_the_vehicles_wheel_yaw_rate(tracked_windows):
    """inv_chi is terrain.vehicles.icr's fit of the gyro yaw rate on the wheel yaw rate of
    the vehicle given; on a tracked run the tracked vehicle's inv_chi is the Husky's times
    B_tracked / B_husky (the regressor scales by 1/B)."""
    run, _ = tracked_windows
    ws = make_windows([run], SLIP_CHANNELS, WindowConfig(window_s=2.0))
    ch = list(ws.channels)
    names, f = slip_feature_matrix(ws.X, ws.channels, ws.rate_hz, TRACKED)
    inv_chi = f[:, names.index("inv_chi")]
    commanded = (ws.X[:, ch.index("vel_r")] - ws.X[:, ch.index("vel_l")]) / TRACKED.track_m
    np.testing.assert_allclose(
        inv_chi, inverse_icr_factor(ws.X[:, ch.index("wz")], commanded, INV_CHI_FLOOR_RAD_S),
        rtol=1e-12)
    # the spin's gyro follows the tracked vehicle's commanded yaw rate (1/chi near 1 or below)
    assert 0.2 < np.median(inv_chi) <= 1.2


@settings(max_examples=30, deadline=None)
@given(amp=arrays(float, 16, elements=st.floats(0.05, 1.0)), k=st.floats(0.5, 20.0),
       track=tracks)
def test_viscous_current_is_per_rad_s_of_body_rates_yaw_rate(amp, k, track):
    """A spin in place (v_R = -v_L, no mean speed) whose side-current difference is
    k times body_rates' yaw rate gives cur_diff__viscous_a_s_per_rad = k A s/rad (the
    documented unit): the sign and the track of the yaw-rate command are the kinematics'."""
    v_r = (amp * np.where(np.arange(16) % 2, 1.0, -1.0))[None]
    _, w = body_rates(-v_r, v_r, track, 1.0)
    out = physics_features(-v_r, v_r, 5.0 - 0.5 * k * w, 5.0 + 0.5 * k * w, 10.0, track,
                           ridge=1e-12)
    d1 = out[0, PHYSICS_FEATURES.index("cur_diff__viscous_a_s_per_rad")]
    np.testing.assert_allclose(d1, k, rtol=1e-6)


def test_default_wheel_physics_read_default_windows_at_their_rate():
    """WheelPhysicsFeatures defaulted to 10 Hz while make_windows cuts on the 50 Hz aligned
    clock by default: the default features of default windows read an acceleration 5 times
    too small (m/s^2 per 0.1 s step instead of 0.02 s) and named a 20-sample tail of 0.4 s
    '__last2s', without a word. Both now default to the aligned clock: the default features
    of a simulated run's default windows equal those at the windows' own rate, and
    accel__abs_mean is the mean |dv/dt| of the windows' vel_mean in m/s^2."""
    run = simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",),
                             scenario="straight_accel", duration_s=6.0, seed=3))
    ws = make_windows([run], "wheels")
    default = WheelPhysicsFeatures(channels=ws.channels).fit(ws.X)
    own = WheelPhysicsFeatures(channels=ws.channels, rate_hz=ws.rate_hz).fit(ws.X)
    assert list(default.get_feature_names_out()) == list(own.get_feature_names_out())
    np.testing.assert_array_equal(default.transform(ws.X), own.transform(ws.X))
    ch = list(ws.channels)
    accel = np.abs(np.gradient(ws.X[:, ch.index("vel_mean")], 1.0 / ws.rate_hz, axis=1))
    col = list(default.get_feature_names_out()).index("accel__abs_mean")
    assert accel.mean(axis=1).max() > 0.1                   # the run accelerates
    np.testing.assert_allclose(default.transform(ws.X)[:, col], accel.mean(axis=1),
                               rtol=1e-12)


def test_slip_outputs_of_a_run_without_left_and_right_sides_say_so():
    """Vehicle names across the seam: an AgriMaRo run (terrain.run.VEHICLE_NAMES; its wheels
    stream holds wheels 1 and 2, no left and right side, and its parameters no track) was
    said to hold every input of the slip models (missing_slip_inputs None) while
    slip_model_outputs ended in a bare AttributeError ('AgriMaRoParams' object has no
    attribute 'track_m'); now it gives None and missing_slip_inputs says why."""
    from features.slip_outputs import missing_slip_inputs, slip_model_outputs

    run = simulate(SimConfig(vehicle="agrimaro", terrains=("GRASS",),
                             scenario="straight_accel", duration_s=5.0, seed=1))
    assert slip_model_outputs(run) is None
    assert "not a skid-steer vehicle (agrimaro" in missing_slip_inputs(run)


def test_chi_targets_use_each_runs_own_track_by_default(tracked_windows):
    """slip_targets' chi = mean(v_R - v_L) / (B mean(yaw_rate)) took the Husky's track by
    default whatever vehicle drove the runs, while make_windows derives the same windows'
    yaw_rate_wheels with each run's own (the tracked vehicle's 0.393 m): a tracked run's
    default chi was 0.393 / 0.5708 of its own, and (v_R - v_L) / (chi B) not its yaw rate.
    The default is now each run's own vehicle's track, so the true yaw rate comes back from
    the windows' yaw_rate_wheels / chi; an explicit track is kept as given."""
    from features.slip_features import slip_targets

    run, _ = tracked_windows
    ws = make_windows([run], ("vel_l", "vel_r", "yaw_rate_wheels"),
                      WindowConfig(window_s=2.0))
    Y = slip_targets([run], ws)
    turning = np.isfinite(Y["chi"].to_numpy())
    assert turning.sum() >= 2
    yaw_wheels = ws.X[:, 2].mean(axis=1)
    np.testing.assert_allclose((yaw_wheels / Y["chi"])[turning], Y["yaw_rate"][turning],
                               rtol=1e-9)
    np.testing.assert_array_equal(Y["chi"], slip_targets([run], ws, TRACKED.track_m)["chi"])
    husky = slip_targets([run], ws, HUSKY.track_m)["chi"].to_numpy()
    np.testing.assert_allclose(husky[turning],
                               Y["chi"][turning] * TRACKED.track_m / HUSKY.track_m, rtol=1e-12)
