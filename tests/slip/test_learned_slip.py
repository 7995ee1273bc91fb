"""Learned slip model, seed baselines, slip-compensated odometry and `terrain slip-fit`."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest

from features.slip_features import slip_table, terrain_columns
from terrain.cli import main as cli_main
from terrain.errors import ConfigError, ShapeError, TimeStepError
from terrain.slip.baselines import (endo_turning_slip, fit_pitch_slip, observer_slip,
                                    pitch_slip, slip_ratio_as_sae)
from terrain.slip.dataset import SlipDataSpec, simulated_runs
from terrain.slip.evaluation import error_table, odometry_errors, steady_straight
from terrain.slip.learned import SLIP_OUTPUTS, SlipRegressor
from terrain.errors import DataWarning
from terrain.slip.odometry import BRAKING_SLIP_FLOOR, dead_reckon
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.terramechanics.slip import ground_speed_from_slip, sae_slip
from terrain.vehicles import HUSKY, endo_slip_ratio_ratio

TINY = SlipDataSpec(terrains=("SANDY_LOAM", "SNOW"), scenarios=("straight_accel", "random"),
                    seeds=(0, 1, 100), duration_s=14.0)


@pytest.fixture(scope="module")
def tiny_table(tmp_path_factory):
    runs = simulated_runs(TINY, tmp_path_factory.mktemp("slipcache"))
    X, Y, meta = slip_table(runs, HUSKY, TERRAIN_NAMES)
    return runs, X, Y, meta


def test_ground_speed_inverts_sae_slip():
    rim = np.array([1.0, 1.0, 0.5, -0.8, 0.3])
    v = np.array([0.7, 1.2, 0.5, -0.5, 0.0])
    s = sae_slip(rim, v, dead_band_m_s=0.0)
    np.testing.assert_allclose(ground_speed_from_slip(rim, s), v, atol=1e-12)


def test_dead_reckon_holds_a_braking_slip_at_its_floor_and_says_so():
    # odometry had its own copy of the slip inverse that held slip at -0.95 without a word
    # (slip -0.98 on a 0.02 m/s rim: 0.40 m/s against the inverse's 1.00)
    t = np.linspace(0.0, 1.0, 11)
    rim = np.full_like(t, 0.5)
    slip = np.full_like(t, -0.2)
    slip[3:5] = -0.98
    with pytest.warns(DataWarning, match="2 of 11 slips below -0.95"):
        pose = dead_reckon(t, rim, rim, HUSKY.track_m, slip, np.full_like(t, -0.2))
    held = np.where(slip < BRAKING_SLIP_FLOOR, BRAKING_SLIP_FLOOR, slip)
    ground = 0.5 * (ground_speed_from_slip(rim, held) + ground_speed_from_slip(rim, -0.2))
    assert pose[-1, 0] == pytest.approx(np.trapezoid(ground, t))
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # no floor reached: no warning
        dead_reckon(t, rim, rim, HUSKY.track_m, np.full_like(t, -0.9), np.full_like(t, 0.3))


def test_dead_reckon_holds_a_slip_above_one_at_one_and_says_so():
    # a learned slip of 1.1 (no SAE slip exceeds 1, sae_slip's saturation) was clipped to 1,
    # the rim spinning on a contact at rest, without a word
    t = np.linspace(0.0, 1.0, 11)
    rim = np.full_like(t, 0.5)
    slip = np.full_like(t, 0.2)
    slip[2:5] = 1.1
    with pytest.warns(DataWarning, match="3 of 11 slips above 1"):
        pose = dead_reckon(t, rim, rim, HUSKY.track_m, slip, slip)
    ground = ground_speed_from_slip(rim, np.minimum(slip, 1.0))
    assert pose[-1, 0] == pytest.approx(np.trapezoid(ground, t))
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # slip 1 itself is the saturation, no warning
        dead_reckon(t, rim, rim, HUSKY.track_m, np.ones_like(t), np.ones_like(t))


def test_dead_reckon_integrates_with_the_midpoint_heading_and_trapezoidal_rates():
    """Coarse steps (0.1 s), closed forms: a half circle of radius 1 (v 1 m/s, yaw rate
    1 rad/s, gyro) ends at (0, 2) (each step's chord along the midpoint heading, short of
    the arc by 1 - sinc(0.05) = 4e-4; along the start heading it lands 0.1 m off in x; a
    full circle closes either way). Yaw rate and speed ramping as t over 1 s: yaw and
    distance 0.5 exactly (trapezoid; the left sample gives 0.45). Sliding sideways at
    1 m/s while turning at 1 rad/s for pi / 2 s: (cos(pi/2) - 1, sin(pi/2)) = (-1, 1)."""
    t = np.linspace(0.0, np.pi, 32)
    one = np.ones_like(t)
    pose = dead_reckon(t, one, one, HUSKY.track_m, yaw_rate_rad_s=one)
    np.testing.assert_allclose(pose[-1], [0.0, 2.0, np.pi], atol=2e-3)
    t = np.linspace(0.0, 1.0, 11)
    assert dead_reckon(t, 0 * t, 0 * t, HUSKY.track_m, yaw_rate_rad_s=t)[-1, 2] == \
        pytest.approx(0.5, abs=1e-12)
    np.testing.assert_allclose(dead_reckon(t, t, t, HUSKY.track_m)[-1], [0.5, 0.0, 0.0],
                               atol=1e-12)
    t = np.linspace(0.0, np.pi / 2, 41)
    zero = np.zeros_like(t)
    pose = dead_reckon(t, zero, zero, HUSKY.track_m, lateral_m_s=1.0,
                       yaw_rate_rad_s=np.ones_like(t))
    np.testing.assert_allclose(pose[-1, :2], [-1.0, 1.0], atol=2e-3)


def test_dead_reckon_reversing_is_the_mirror_of_driving_forward():
    """SAE slip in the rim's direction: backing at rim -0.5 m/s with slip -0.2 (traction in
    reverse, eq. 7.1 mirrored) moves at -0.5 (1 - 0.2) = -0.4 m/s; braking in reverse
    (slip +0.2) at -0.5 / (1 - 0.2) = -0.625 m/s, the mirror of the forward values."""
    t = np.linspace(0.0, 1.0, 11)
    rim = np.full_like(t, 0.5)
    for s, ground in ((0.2, 0.4), (-0.2, 0.625)):
        fwd = dead_reckon(t, rim, rim, HUSKY.track_m, np.full_like(t, s), np.full_like(t, s))
        back = dead_reckon(t, -rim, -rim, HUSKY.track_m, np.full_like(t, -s),
                           np.full_like(t, -s))
        assert fwd[-1, 0] == pytest.approx(ground) and back[-1, 0] == pytest.approx(-ground)


def test_dead_reckon_straight_and_circle():
    t = np.linspace(0.0, 10.0, 1001)
    pose = dead_reckon(t, np.full_like(t, 0.5), np.full_like(t, 0.5), HUSKY.track_m)
    np.testing.assert_allclose(pose[-1], [5.0, 0.0, 0.0], atol=1e-9)
    # slip 0.2 on both sides: ground speed 0.4 m/s
    pose = dead_reckon(t, np.full_like(t, 0.5), np.full_like(t, 0.5), HUSKY.track_m,
                       np.full_like(t, 0.2), np.full_like(t, 0.2))
    assert pose[-1, 0] == pytest.approx(4.0)
    # a full circle with chi = 2 takes twice the time: after T the yaw is pi, not 2 pi
    vl, vr = 0.3, 0.5
    period = 2 * np.pi * HUSKY.track_m / (vr - vl)
    t = np.linspace(0.0, period, 20001)
    pose = dead_reckon(t, np.full_like(t, vl), np.full_like(t, vr), HUSKY.track_m)
    np.testing.assert_allclose(pose[-1, :2], 0.0, atol=1e-6)
    pose2 = dead_reckon(t, np.full_like(t, vl), np.full_like(t, vr), HUSKY.track_m, chi=2.0)
    assert pose2[-1, 2] == pytest.approx(np.pi)
    # a gyro reading the true yaw rate (wheels' / chi) gives the chi = 2 path without chi
    gyro = np.full_like(t, (vr - vl) / (2.0 * HUSKY.track_m))
    pose3 = dead_reckon(t, np.full_like(t, vl), np.full_like(t, vr), HUSKY.track_m,
                        chi=5.0, yaw_rate_rad_s=gyro)
    np.testing.assert_allclose(pose3, pose2, atol=1e-9)
    with pytest.raises(ShapeError):
        dead_reckon(t, np.full_like(t, vl), np.full_like(t, vr), HUSKY.track_m,
                    yaw_rate_rad_s=gyro[:5])
    with pytest.raises(TimeStepError):
        dead_reckon(t[::-1], np.full_like(t, vl), np.full_like(t, vr), HUSKY.track_m)
    with pytest.raises(ShapeError):
        dead_reckon(t, np.full(3, vl), np.full_like(t, vr), HUSKY.track_m)


def test_pitch_slip_recovers_a_planted_line():
    rng = np.random.default_rng(0)
    pitch = rng.uniform(-0.3, 0.3, 200)
    terr = np.where(np.arange(200) < 100, "SNOW", "ICE")
    slip = np.where(terr == "SNOW", 0.1 + 0.5 * pitch, 0.02 + 0.1 * pitch)
    coef = fit_pitch_slip(pitch, slip, terr)
    assert coef["SNOW"] == pytest.approx((0.1, 0.5))
    assert coef["ICE"] == pytest.approx((0.02, 0.1))
    np.testing.assert_allclose(pitch_slip(coef, pitch, terr), slip, atol=1e-12)


def test_endo_turning_slip_recovers_planted_slips():
    vl, vr = np.array([0.2, -0.3]), np.array([0.5, 0.4])
    a_r = np.array([0.1, 0.15])
    a_l = endo_slip_ratio_ratio(vl, vr) * a_r
    yaw = (vr * (1 - a_r) - vl * (1 - a_l)) / HUSKY.track_m
    np.testing.assert_allclose(endo_turning_slip(vl, vr, yaw, HUSKY.track_m),
                               np.column_stack([a_l, a_r]), atol=1e-12)
    assert np.isnan(endo_turning_slip(np.array([0.5]), np.array([0.5]), np.array([0.0]),
                                      HUSKY.track_m)).all()


def test_observer_finds_no_slip_in_slip_free_turning():
    t = np.arange(0, 20, 0.01)
    vl, vr = np.full_like(t, 0.3), np.full_like(t, 0.5)
    yaw = (vr - vl) / HUSKY.track_m * t
    s = observer_slip(t, yaw, vl, vr, HUSKY.track_m / 2)
    np.testing.assert_allclose(s[-1], 0.0, atol=1e-3)
    # the right (outer) side slipping by 0.2: the yaw-only observer cannot split the yaw
    # deficit between the sides, but its slips reproduce the gyro's yaw rate and put the
    # slip on the right (left 1 - eta < 0 < right 1 - eta)
    rate = (0.8 * vr - vl) / HUSKY.track_m
    s = observer_slip(t, rate * t, vl, vr, HUSKY.track_m / 2)
    implied = (vr * (1 - s[:, 1]) - vl * (1 - s[:, 0])) / HUSKY.track_m
    np.testing.assert_allclose(implied[-1], rate[-1], rtol=1e-3)
    assert s[-1, 0] < -0.01 and s[-1, 1] > 0.1


@pytest.mark.slow
def test_targets_and_features_on_simulated_runs(tiny_table):
    runs, X, Y, meta = tiny_table
    assert len(X) == len(Y) == len(meta) > 0
    assert set(SLIP_OUTPUTS) <= set(Y.columns)
    assert {"phys_slip_l", "p__SNOW", "pitch", "inv_chi"} <= set(X.columns)
    assert not X.drop(columns=terrain_columns(X.columns)).filter(like="p__").shape[1]
    steady = steady_straight(meta, Y["yaw_rate"].to_numpy())
    snow = steady & (meta["terrain"] == "SNOW").to_numpy()
    assert Y.loc[snow, "slip_1"].median() > 0.1               # soft snow slips
    # random commands turn: chi is defined there and > 1 (skid-steer turns less than the wheels say)
    turning = np.isfinite(Y["chi"].to_numpy())
    assert turning.any() and np.nanmedian(Y["chi"]) > 1.0


def test_inv_chi_uses_the_vehicles_own_track():
    """``inv_chi`` regresses the gyro yaw rate on the wheel yaw rate ``(v_R - v_L)/B`` of the
    vehicle given, not the windows' ``yaw_rate_wheels`` channel (here Husky's, which
    make_windows gave every run before it read the run's vehicle): a tracked vehicle
    (B = 0.393 m) turning at chi = 2 gave 0.73, not 0.5."""
    from features.slip_features import (INV_CHI_FLOOR_RAD_S, SLIP_CHANNELS,
                                        slip_feature_matrix)
    from features.windows import HUSKY_TRACK_M
    from terrain.vehicles import TRACKED

    rate = 50.0
    t = np.arange(100) / rate
    vel_diff = 0.2 + 0.1 * np.sin(2 * np.pi * 0.5 * t)
    values = {c: np.zeros_like(t) for c in SLIP_CHANNELS}
    values.update(vel_l=0.5 - 0.5 * vel_diff, vel_r=0.5 + 0.5 * vel_diff, vel_diff=vel_diff,
                  yaw_rate_wheels=vel_diff / HUSKY_TRACK_M, az=np.full_like(t, 9.81))
    for vehicle in (HUSKY, TRACKED):
        values["wz"] = vel_diff / (2.0 * vehicle.track_m)          # chi = 2
        x = np.stack([values[c] for c in SLIP_CHANNELS])[None]
        names, cols = slip_feature_matrix(x, SLIP_CHANNELS, rate, vehicle)
        wheel_yaw = vel_diff / vehicle.track_m     # the ridge floor pulls the gain below 0.5
        ridge = (wheel_yaw ** 2).sum() / ((wheel_yaw ** 2).sum()
                                          + t.size * INV_CHI_FLOOR_RAD_S ** 2)
        assert cols[0, names.index("inv_chi")] == pytest.approx(0.5 * ridge)
        assert ridge > 0.97


def test_window_pitch_removes_the_wheel_speed_slope_from_the_accelerometer():
    """A Husky climbing a 0.1 rad slope while speeding up at 0.5 m/s^2: the accelerometer
    reads ``g sin(p) + dv/dt`` forward and ``g cos(p)`` up; the window's ``vel_mean__slope``
    is the 0.5 m/s^2 and its ``pitch`` the 0.1 rad (adding the slope instead of removing it
    passed every test)."""
    from features.slip_features import SLIP_CHANNELS, slip_feature_matrix

    rate, g, p, a = 50.0, 9.81, 0.1, 0.5
    t = np.arange(100) / rate
    v = 0.3 + a * t
    values = {c: np.zeros_like(t) for c in SLIP_CHANNELS}
    values.update(vel_l=v, vel_r=v, ax=np.full_like(t, g * np.sin(p) + a),
                  az=np.full_like(t, g * np.cos(p)))
    x = np.stack([values[c] for c in SLIP_CHANNELS])[None]
    names, cols = slip_feature_matrix(x, SLIP_CHANNELS, rate, HUSKY)
    assert cols[0, names.index("vel_mean__slope")] == pytest.approx(a)
    assert cols[0, names.index("pitch")] == pytest.approx(p)


def _with_truth(columns, keep=None):
    """A 10 s simulated GRASS run whose truth stream is replaced by ``columns(t)`` (a dict of
    truth columns of its clock ``t``), its rows where ``keep(t)`` (all when None)."""
    from dataclasses import replace as replace_run

    from terrain.sim import SimConfig, simulate

    run = simulate(SimConfig(terrains=("GRASS",), scenario="straight_accel", duration_s=10.0,
                             seed=0))
    t = run.streams["truth"]["t_s"].to_numpy()
    truth = pd.DataFrame({"t_s": t, **columns(t)})
    if keep is not None:
        truth = truth[keep(t)]
    return replace_run(run, streams={**run.streams, "truth": truth})


def test_slip_targets_are_the_truth_means_of_each_window_and_its_mid_terrain():
    """Targets against a planted truth stream: ``slip_1 = t``, ``slip_2 = 2 t``,
    ``v_by = -t``, ``yaw_rate = 0.5``, terrain GRASS before 5 s and SNOW after. Each target
    is the mean over the window's samples [t_start, t_end), the label the one at the window's
    middle (the lateral velocity read from the yaw rate column, and the label at the window's
    start, passed every test)."""
    from features.slip_features import slip_targets, slip_windows

    run = _with_truth(lambda t: {"slip_1": t, "slip_2": 2 * t, "v_by": -t,
                                 "yaw_rate": np.full_like(t, 0.5),
                                 "terrain": np.where(t < 5.0, "GRASS", "SNOW")})
    t = run.streams["truth"]["t_s"].to_numpy()
    ws = slip_windows([run])
    Y = slip_targets([run], ws)
    assert len(ws) >= 6
    for i in range(len(ws)):
        inside = (t >= ws.t_start_s[i]) & (t < ws.t_end_s[i])
        assert Y["slip_1"][i] == pytest.approx(t[inside].mean())
        assert Y["slip_2"][i] == pytest.approx(2 * t[inside].mean())
        assert Y["v_by"][i] == pytest.approx(-t[inside].mean())
        assert Y["yaw_rate"][i] == pytest.approx(0.5)
        mid = 0.5 * (ws.t_start_s[i] + ws.t_end_s[i])
        assert Y["terrain"][i] == ("GRASS" if mid < 5.0 else "SNOW")


def test_slip_targets_of_a_window_without_truth_samples_are_nan_not_zero():
    """A window whose span holds no sample of the truth stream (a hole in it) has no target:
    NaN, so that the model is not trained on a made-up slip of 0."""
    from features.slip_features import slip_targets, slip_windows

    run = _with_truth(lambda t: {"slip_1": 0.2, "slip_2": 0.3, "v_by": 0.01,
                                 "yaw_rate": 0.5, "terrain": "GRASS"},
                      keep=lambda t: (t < 3.9) | (t >= 6.1))
    ws = slip_windows([run])
    Y = slip_targets([run], ws)
    inside = (ws.t_start_s >= 3.9) & (ws.t_end_s <= 6.1)
    assert inside.sum() == 1                       # the window [4, 6) s
    assert Y.loc[inside, ["slip_1", "slip_2", "v_by", "yaw_rate", "chi"]].isna().all().all()
    np.testing.assert_allclose(Y.loc[~inside, "slip_1"], 0.2)
    np.testing.assert_allclose(Y.loc[~inside, "slip_2"], 0.3)


def test_slip_targets_of_windows_from_a_run_not_given_name_it():
    """A bare KeyError before."""
    from features.slip_features import slip_targets, slip_windows

    run = _with_truth(lambda t: {"slip_1": 0.2, "slip_2": 0.3, "v_by": 0.01,
                                 "yaw_rate": 0.5, "terrain": "GRASS"})
    with pytest.raises(ConfigError, match=rf"run {run.run_id!r} is not among the 0 run\(s\)"):
        slip_targets([], slip_windows([run]))


def test_slip_target_chi_uses_the_track_width_given():
    """``chi = mean(v_R - v_L) / (B mean(yaw_rate))`` with the vehicle's own track B (a
    tracked vehicle's 0.393 m, not Husky's), NaN below the turning-rate floor."""
    from dataclasses import replace as replace_ws

    from features.slip_features import MIN_TURN_RATE_RAD_S, slip_targets, slip_windows
    from terrain.vehicles import TRACKED

    run = _with_truth(lambda t: {"slip_1": 0.0, "slip_2": 0.0, "v_by": 0.0,
                                 "yaw_rate": np.where(t < 5.0, 0.5, 0.5 * MIN_TURN_RATE_RAD_S),
                                 "terrain": "GRASS"})
    ws = slip_windows([run])
    X = ws.X.copy()
    X[:, ws.channels.index("vel_r")] = X[:, ws.channels.index("vel_l")] + 0.4
    ws = replace_ws(ws, X=X)
    turning = ws.t_end_s <= 5.0 + 1e-9
    assert 0 < turning.sum() < len(ws)
    for track in (HUSKY.track_m, TRACKED.track_m):
        chi = slip_targets([run], ws, track_m=track)["chi"].to_numpy()
        np.testing.assert_allclose(chi[turning], 0.4 / (track * 0.5))
        assert np.isnan(chi[ws.t_start_s >= 5.0]).all()


def test_slip_target_chi_is_defined_from_a_turn_of_0_1_rad_s():
    """docs/slip_learning.md section 2: ``chi`` is a target on windows where the robot turns,
    |yaw rate| >= 0.1 rad/s: 0.12 rad/s gives one, 0.08 rad/s none (hand mutant: the floor
    at 0.2 rad/s, no test failed: the test above reads the floor from the constant)."""
    from features.slip_features import slip_targets, slip_windows

    run = _with_truth(lambda t: {"slip_1": 0.0, "slip_2": 0.0, "v_by": 0.0,
                                 "yaw_rate": np.where(t < 5.0, 0.12, -0.08),
                                 "terrain": "GRASS"})
    ws = slip_windows([run])
    chi = slip_targets([run], ws)["chi"].to_numpy()
    first, second = ws.t_end_s <= 5.0 + 1e-9, ws.t_start_s >= 5.0
    assert first.any() and second.any()
    assert np.isfinite(chi[first]).all() and np.isnan(chi[second]).all()


def test_slip_features_refuse_probabilities_of_another_number_of_windows():
    """Terrain probabilities must have one row per window: a table of the wrong length is a
    ConfigError naming both counts (it failed inside NumPy on broadcasting)."""
    from features.slip_features import slip_features, slip_windows

    run = _with_truth(lambda t: {"slip_1": 0.0, "slip_2": 0.0, "v_by": 0.0, "yaw_rate": 0.0,
                                 "terrain": "GRASS"})
    ws = slip_windows([run])
    probs = pd.DataFrame({"GRASS": np.ones(len(ws) + 1)})
    with pytest.raises(ConfigError, match=f"{len(ws) + 1} probability rows for {len(ws)} "
                                          "windows"):
        slip_features(ws, HUSKY, probs)
    assert slip_features(ws, HUSKY, probs.iloc[:-1]).shape[0] == len(ws)


def test_physics_slip_columns_follow_their_side():
    """The side drawing more current (left, 12 A against 3 A) slips more: ``phys_slip_l``
    is the left side's physics slip (the left column read from the right side passed every
    test)."""
    from features.slip_features import SLIP_CHANNELS, slip_feature_matrix

    rate = 50.0
    t = np.arange(100) / rate
    values = {c: np.zeros_like(t) for c in SLIP_CHANNELS}
    values.update(vel_l=np.full_like(t, 0.5), vel_r=np.full_like(t, 0.5),
                  cur_l=np.full_like(t, 12.0), cur_r=np.full_like(t, 3.0),
                  cur_diff=np.full_like(t, -9.0), az=np.full_like(t, 9.81))
    x = np.stack([values[c] for c in SLIP_CHANNELS])[None]
    names, cols = slip_feature_matrix(x, SLIP_CHANNELS, rate, HUSKY,
                                      {"SANDY_LOAM": np.array([1.0])})
    left, right = cols[0, names.index("phys_slip_l")], cols[0, names.index("phys_slip_r")]
    assert left > right > 0.0


def test_physics_slip_columns_take_each_input_from_its_own_window_statistic():
    """The physics slip of a window speeding up at 0.4 m/s^2 with noisy currents and
    accelerometer is :func:`terrain.slip.physics.physics_slip` of: the sides' mean currents
    and rim speeds, the wheel angular acceleration slope / r (rad/s^2), the sides' current
    spreads, the pitch std of the ``ax`` samples; ``phys_std`` is the mean of the two
    sides' std (the acceleration as slope * r, the spreads or the pitch noise read from
    another channel, and the larger side's std each passed every test)."""
    from features.calculators import std
    from features.slip_features import SLIP_CHANNELS, slip_feature_matrix
    from terrain.slip.physics import (physics_slip, pitch_from_accelerometer,
                                      pitch_std_from_accelerometer)

    rate, a = 50.0, 0.4
    t = np.arange(100) / rate
    rng = np.random.default_rng(3)
    v = 0.3 + a * t
    values = {c: np.zeros_like(t) for c in SLIP_CHANNELS}
    values.update(vel_l=v, vel_r=1.1 * v, cur_l=6.0 + 1.5 * rng.standard_normal(t.size),
                  cur_r=4.0 + 0.3 * rng.standard_normal(t.size),
                  ax=a + 2.0 * rng.standard_normal(t.size), ay=0.3 * rng.standard_normal(t.size),
                  az=np.full_like(t, 9.81))
    x = np.stack([values[c] for c in SLIP_CHANNELS])[None]
    probs = {"SANDY_LOAM": np.array([1.0])}
    names, cols = slip_feature_matrix(x, SLIP_CHANNELS, rate, HUSKY, probs,
                                      current_rate_hz=rate)
    r_w = HUSKY.contact_geometry().wheel_radius_m
    slope = 0.5 * (1.0 + 1.1) * a
    cur = np.array([[values["cur_l"].mean(), values["cur_r"].mean()]])
    rim = np.array([[v.mean(), 1.1 * v.mean()]])
    pitch = pitch_from_accelerometer(np.array([values["ax"].mean()]), np.zeros(1),
                                     np.array([9.81]), np.array([slope]))
    want = physics_slip(HUSKY, probs, cur, rim, pitch, np.full((1, 2), slope / r_w),
                        n_averaged=100, current_within_std_a=std(
                            np.stack([values["cur_l"], values["cur_r"]])[None]),
                        pitch_std_rad=pitch_std_from_accelerometer(values["ax"][None]))
    assert cols[0, names.index("vel_mean__slope")] == pytest.approx(slope)
    assert cols[0, names.index("phys_slip_l")] == pytest.approx(want.slip[0, 0])
    assert cols[0, names.index("phys_slip_r")] == pytest.approx(want.slip[0, 1])
    assert cols[0, names.index("phys_std")] == pytest.approx(want.std[0].mean())
    # the inputs matter: the two sides' std differ, the acceleration moves the slip
    assert abs(want.std[0, 0] - want.std[0, 1]) > 0.05 * want.std[0].mean()
    steady = physics_slip(HUSKY, probs, cur, rim, pitch, np.zeros((1, 2)), n_averaged=100)
    assert abs(steady.slip[0, 0] - want.slip[0, 0]) > 1e-3


@pytest.mark.slow
def test_learned_model_on_held_out_seed(tiny_table):
    runs, X, Y, meta = tiny_table
    test = (meta["seed"] == 100).to_numpy()
    y = Y[list(SLIP_OUTPUTS)].to_numpy()
    model = SlipRegressor(max_iter=100).fit(X[~test], y[~test])
    pred = model.predict(X[test])
    assert pred.shape == (test.sum(), len(SLIP_OUTPUTS))
    steady = steady_straight(meta, Y["yaw_rate"].to_numpy())[test]
    table = error_table(pred, y[test], meta[test].reset_index(drop=True), steady)
    assert (table["median_abs_err"] < 0.02).all()
    zero = error_table(np.zeros_like(pred), y[test], meta[test].reset_index(drop=True), steady)
    # a 10-window table per terrain: the factor moves with small feature changes (SANDY_LOAM
    # 0.012 -> 0.016 when the normal load got its pitch-noise correction); the held-out
    # target itself is measured by `terrain slip-fit` (docs/slip_learning.md)
    assert (table["median_abs_err"].to_numpy() < 0.25 * zero["median_abs_err"].to_numpy()).all()
    with pytest.raises(ShapeError):
        SlipRegressor().fit(X, y[:, :2])


def test_error_table_counts_the_side_windows_it_scores():
    """A model undefined on some windows (eq. 27 in straight driving: NaN) is scored on the
    rest; the table says on how many (its n_windows counted every window of the group, so a
    median over 2 of 8 side-windows read as one over all 4 windows)."""
    meta = pd.DataFrame({"run_id": ["a", "a", "b", "b"], "terrain": ["SNOW"] * 4})
    truth = np.zeros((4, 2))
    pred = np.array([[0.1, 0.3], [np.nan, np.nan], [np.nan, np.nan], [np.nan, 0.2]])
    row = error_table(pred, truth, meta, np.ones(4, bool)).iloc[0]
    assert row["n_windows"] == 4 and row["n_runs"] == 2
    assert row["n_scored"] == 3 and row["median_abs_err"] == pytest.approx(0.2)
    empty = error_table(np.full((4, 2), np.nan), truth, meta, np.ones(4, bool)).iloc[0]
    assert empty["n_scored"] == 0 and np.isnan(empty["median_abs_err"])


def test_slip_fit_summary_is_standard_json_with_null_for_a_figure_not_computed():
    """With no slipping run held out, the median reduction over slipping runs is NaN; the
    summary file wrote it as a bare ``NaN`` token, which is not JSON (strict readers refuse
    it); it is ``null`` beside ``slipping_runs`` 0."""
    from pipelines.slip_fit import _summary
    from terrain.io.jsonfile import strict_json

    errors = pd.DataFrame({"windows": ["steady_straight"], "terrain": ["SNOW"],
                           "split": ["held-out seeds"], "model": ["learned"],
                           "median_abs_err": [0.01]})
    odo = pd.DataFrame({"scenario": ["orchard"], "slid_off": [False], "plain_err_pct": [1.0],
                        "compensated_err_pct": [0.5], "compensated_gyro_err_pct": [0.4],
                        "gyro_heading_err_pct": [0.3], "reduction_pct": [50.0]})

    def strict(token):
        raise ValueError(f"not JSON: {token}")

    text = strict_json(_summary(errors, odo))
    loaded = json.loads(text, parse_constant=strict)
    assert loaded["odometry.orchard.slipping_runs"] == 0
    assert loaded["odometry.orchard.slipping_median_reduction_pct"] is None
    assert loaded["held-out_seeds.learned.SNOW.median_abs_err"] == pytest.approx(0.01)


def test_compensated_odometry_beats_plain_with_true_slip(tiny_table):
    runs, X, Y, meta = tiny_table
    truth = np.where(np.isnan(Y[list(SLIP_OUTPUTS)].to_numpy()), 1.0,
                     Y[list(SLIP_OUTPUTS)].to_numpy())
    ids = [r for r in meta["run_id"].unique() if "/SNOW/straight_accel/" in r]
    odo = odometry_errors(runs, meta, truth, HUSKY.track_m, ids)
    assert (odo["plain_err_pct"] > 10).all()                  # 17 % slip on snow
    assert (odo["compensated_err_pct"] < 0.2 * odo["plain_err_pct"]).all()


@pytest.mark.slow
def test_slip_fit_command(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # an earlier CLI call in this process exported its store (mlflow.set_tracking_uri)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    out = tmp_path / "out"
    rc = cli_main(["slip-fit", "--terrains", "SANDY_LOAM", "SNOW", "--scenarios",
                   "straight_accel", "random", "--train-seeds", "0", "1", "--test-seeds",
                   "100", "--duration-s", "14", "--orchard-duration-s", "70",
                   "--cache-dir", str(tmp_path / "cache"), "--out", str(out), "--no-register"])
    assert rc == 0
    summary = json.loads((out / "summary.json").read_text())
    odo = pd.read_csv(out / "odometry.csv")
    assert set(odo["scenario"]) == {"orchard_70s"} and len(odo) == 2   # one headland turn
    assert summary["odometry.orchard_70s.gyro_reduction_of_median_pct"] > 60
    calib = pd.read_csv(out / "std_calibration.csv")
    assert calib["coverage_2std"].between(0.3, 1.0).all()
    assert summary["held-out_seeds.learned.SNOW.median_abs_err"] < 0.02
    assert summary["held-out_seeds.zero.SNOW.median_abs_err"] > 0.1
    errors = pd.read_csv(out / "slip_errors.csv")
    assert {"held-out seeds", "leave-one-scenario-out", "leave-one-terrain-out",
            "leave-one-terrain-out-physics"} <= set(
        errors["split"])
    assert (tmp_path / "mlflow.db").exists()


def test_slip_fit_refuses_a_too_long_orchard_run_before_simulating(tmp_path, monkeypatch,
                                                                   capsys):
    """An ``--orchard-duration-s`` the simulator refuses (over 7200 s) is an error before any
    run is simulated or fitted, naming the option (it was SimConfig's bare message after
    the whole grid had been simulated and fitted)."""
    import pipelines.slip_fit as slip_fit

    def no_simulation(*args, **kwargs):
        raise AssertionError("runs simulated before the options were checked")

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    monkeypatch.setattr(slip_fit, "simulated_runs", no_simulation)
    rc = cli_main(["slip-fit", "--terrains", "SNOW", "--scenarios", "straight_accel",
                   "--duration-s", "14", "--orchard-duration-s", "8000",
                   "--cache-dir", str(tmp_path / "cache"), "--out", str(tmp_path / "out"),
                   "--no-register"])
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("terrain slip-fit: error: --orchard-duration-s:") and "7200" in err
    assert not (tmp_path / "mlflow.db").exists()


def test_variance_moment_of_the_calibrated_std(tiny_table):
    """``predict_std(moment="variance")`` scales the bulk (median) calibration so the mean
    normalised squared out-of-fold residual is 1: what a Kalman filter needs as variance."""
    from terrain.errors import ConfigError
    runs, X, Y, meta = tiny_table
    y = Y[list(SLIP_OUTPUTS)].to_numpy()
    model = SlipRegressor(max_iter=50).fit(X, y, groups=meta["run_id"].to_numpy())
    median, var = model.predict_std(X[:20]), model.predict_std(X[:20], moment="variance")
    k = model.calibration_["mean_normalised_sq"]
    assert k > 1.0                        # heavy tails: the mean exceeds the chi2(1) median
    np.testing.assert_allclose(var, median * np.sqrt(k))
    with pytest.raises(ConfigError):
        model.predict_std(X[:2], moment="mean")


def test_too_few_runs_to_calibrate_the_std_is_said_and_scored_as_unknown():
    # 2 training runs for 3 calibration folds: the std was skipped without a word and the
    # coverage table read 0.0 (as if the std were badly over-confident) instead of unknown
    import warnings

    import pandas as pd

    from terrain.errors import DataWarning
    from terrain.slip.evaluation import std_calibration_table
    from terrain.slip.learned import SlipRegressor

    rng = np.random.default_rng(0)
    X = rng.normal(size=(200, 4))
    y = np.column_stack([0.1 * X[:, 0], 0.1 * X[:, 1], 1.0 + 0 * X[:, 0], 0 * X[:, 0]])
    model = SlipRegressor(calibration_folds=3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.fit(X, y, groups=np.repeat(["run0", "run1"], 100))
    assert any(issubclass(w.category, DataWarning) and "not calibrated" in str(w.message)
               for w in caught)
    std = model.predict_std(X)
    assert np.isnan(std).all()
    table = std_calibration_table(model.predict(X), std, y, pd.DataFrame({"scenario": "a"},
                                  index=range(200)), np.ones(200, bool))
    assert np.isnan(table.loc[0, "coverage_1std"]) and np.isnan(table.loc[0, "coverage_2std"])


def test_dead_reckon_refuses_slips_and_factors_of_another_length_by_name():
    # a slip, chi or lateral velocity of another length than the times reached numpy's bare
    # "operands could not be broadcast together with shapes (5,) (3,)" (ValueError), though
    # the docstring promises ShapeError
    t = np.arange(5.0)
    v = np.ones(5)
    for kwargs in ({"slip_left": np.zeros(3)}, {"slip_right": np.zeros(3)},
                   {"chi": np.ones(3)}, {"lateral_m_s": np.ones(3)}):
        with pytest.raises(ShapeError, match=next(iter(kwargs))):
            dead_reckon(t, v, v, HUSKY.track_m, **kwargs)
    dead_reckon(t, v, v, HUSKY.track_m, np.zeros(5), 0.0, chi=2.0, lateral_m_s=0.1)


def test_slip_model_refuses_a_missing_target_or_a_flat_feature_table_by_name():
    # a NaN slip or lateral-velocity target reached scikit-learn's bare "Input y contains
    # NaN." (ValueError) and a 1-D feature table numpy's "tuple index out of range"
    # (IndexError); only chi may be NaN (undefined when not turning)
    from terrain.errors import NonFiniteInputError
    rng = np.random.default_rng(0)
    X = rng.standard_normal((60, 3))
    y = np.column_stack([0.01 * X[:, 0], 0.01 * X[:, 0], np.full(60, np.nan), X[:, 1]])
    for col in (0, 1, 3):
        bad = y.copy()
        bad[[4, 7], col] = np.nan
        with pytest.raises(NonFiniteInputError, match=f"2 of 60 .*{SLIP_OUTPUTS[col]}"):
            SlipRegressor(max_iter=3).fit(X, bad)
    with pytest.raises(ShapeError, match="X must"):
        SlipRegressor(max_iter=3).fit(X[:, 0], y)
    SlipRegressor(max_iter=3).fit(X, y)     # chi NaN everywhere: no turning, allowed


def test_observer_window_without_imu_samples_has_no_slip():
    # a window that holds no IMU sample (here past the end of the IMU stream) got the mean
    # of no samples as 0 / 1 = slip 0, a valid slip that error_table then scored
    from terrain.run import Run
    from terrain.slip.evaluation import observer_window_slip
    t = np.arange(0.0, 10.0, 0.01)
    imu = pd.DataFrame({"t_s": t, "wz": np.full_like(t, 0.2)})
    wheels = pd.DataFrame({"t_s": t, "vel_l": np.full_like(t, 0.4), "vel_r": np.full_like(t, 0.6)})
    run = Run("sim/X/orchard/0", "sim", "ASPHALT", {"imu": imu, "wheels": wheels})
    meta = pd.DataFrame({"run_id": [run.run_id] * 2, "t_start_s": [2.0, 12.0],
                         "t_end_s": [4.0, 14.0]})
    out = observer_window_slip([run], meta, HUSKY.track_m)
    assert np.isfinite(out[0]).all()
    assert np.isnan(out[1]).all()


def test_the_seeds_slip_ratio_is_read_as_sae_slip():
    # forward traction agrees; braking and reversing do not (the SAE slip divides by the
    # larger speed and is signed by the direction of travel)
    rim = np.array([1.0, 0.8, -0.3, -0.8, 0.0, 0.5])
    ground = np.array([0.9, 1.0, -0.2, -1.0, 0.0, np.nan])
    alpha = 1.0 - np.divide(ground, rim, out=np.zeros_like(rim), where=rim != 0)
    np.testing.assert_allclose(slip_ratio_as_sae(rim, alpha),
                               [0.1, -0.2, -1 / 3, 0.2, 0.0, np.nan], atol=1e-12)


def test_baselines_are_scored_in_the_convention_of_the_truth():
    # Endo's eq. 27 puts the inner side of a turn in braking (alpha_l < 0); it was scored
    # as alpha against the truth's SAE slip (-0.25 where SAE says -0.20)
    from terrain.run import Run
    from terrain.slip.evaluation import baseline_predictions
    vl, vr = np.array([0.2]), np.array([0.5])
    a_r = np.array([0.1])
    a_l = endo_slip_ratio_ratio(vl, vr) * a_r
    assert a_l[0] < 0
    yaw = (vr * (1 - a_r) - vl * (1 - a_l)) / HUSKY.track_m
    t = np.arange(0.0, 10.0, 0.01)
    imu = pd.DataFrame({"t_s": t, "wz": np.full_like(t, yaw[0])})
    wheels = pd.DataFrame({"t_s": t, "vel_l": np.full_like(t, vl[0]),
                           "vel_r": np.full_like(t, vr[0])})
    run = Run("sim/X/orchard/0", "sim", "ASPHALT", {"imu": imu, "wheels": wheels})
    X = pd.DataFrame({"pitch": [0.0], "vel_l__mean": vl, "vel_r__mean": vr, "wz__mean": yaw,
                      "phys_slip_l": [0.0], "phys_slip_r": [0.0]})
    meta = pd.DataFrame({"run_id": [run.run_id], "terrain": ["ASPHALT"], "t_start_s": [2.0],
                         "t_end_s": [4.0]})
    out = baseline_predictions(X, np.zeros((1, 2)), meta, np.ones(1, dtype=bool), [run],
                               HUSKY.track_m)
    np.testing.assert_allclose(out["endo"], [[a_l[0] / (1 - a_l[0]), a_r[0]]], atol=1e-12)
    alpha = observer_slip(t, np.cumsum(np.r_[0.0, np.diff(t) * yaw[0]]), wheels["vel_l"],
                          wheels["vel_r"], 0.5 * HUSKY.track_m)
    sae = slip_ratio_as_sae(np.column_stack([wheels["vel_l"], wheels["vel_r"]]), alpha)
    window = (t >= 2.0) & (t < 4.0)
    np.testing.assert_allclose(out["observer"][0], sae[window].mean(axis=0), atol=1e-9)


def test_pitch_slip_fit_counts_the_windows_it_leaves_out():
    pitch = np.array([0.0, 0.1, np.nan, 0.2, 0.3])
    slip = np.array([0.1, 0.15, 0.2, np.nan, 0.25])
    with pytest.warns(DataWarning, match="2 of 5 windows"):
        coef = fit_pitch_slip(pitch, slip, ["SNOW"] * 5)
    assert coef["SNOW"] == pytest.approx((0.1, 0.5))


def test_odometry_error_of_a_run_that_does_not_move_is_nan_not_a_crash():
    # a run with a true path of length 0 raised ZeroDivisionError
    from terrain.run import Run
    from terrain.slip.evaluation import odometry_errors
    t = np.arange(0.0, 10.0, 0.1)
    still = pd.DataFrame({"t_s": t, "vel_l": 0.0, "vel_r": 0.0})
    truth = pd.DataFrame({"t_s": t, "x": 0.0, "y": 0.0})
    run = Run("sim/ASPHALT/parked/0", "sim", "ASPHALT", {"wheels": still, "truth": truth})
    meta = pd.DataFrame({"run_id": [run.run_id] * 2, "t_start_s": [0.0, 2.0],
                         "t_end_s": [2.0, 4.0]})
    out = odometry_errors([run], meta, np.zeros((2, 4)) + [0, 0, 1, 0], HUSKY.track_m,
                          [run.run_id])
    assert out.loc[0, "distance_m"] == 0.0
    assert np.isnan(out.loc[0, ["plain_err_pct", "compensated_err_pct"]].astype(float)).all()


def test_dead_reckon_refuses_no_sample_nan_times_and_a_non_positive_track():
    # an empty input gave a pose of shape (1, 3), a NaN time passed the order check (NaN
    # compares False) and spread NaN, a track of 0 divided by zero
    t = np.arange(0.0, 1.0, 0.1)
    v = np.full_like(t, 0.5)
    with pytest.raises(ShapeError, match="no sample"):
        dead_reckon(np.zeros(0), np.zeros(0), np.zeros(0), HUSKY.track_m)
    with pytest.raises(TimeStepError, match="finite"):
        dead_reckon(np.where(t == t[3], np.nan, t), v, v, HUSKY.track_m)
    with pytest.raises(ConfigError, match="track_m"):
        dead_reckon(t, v, v, 0.0)
    assert dead_reckon(t, v, v, 0.0, yaw_rate_rad_s=np.zeros_like(t))[-1, 0] == \
        pytest.approx(0.45)


def test_std_calibration_counts_the_side_windows_its_coverage_is_over():
    # 3 of 8 side-windows without a prediction: the coverage 0.6 was over the other 5, and
    # the table did not say so (error_table's n_scored does)
    import pandas as pd

    from terrain.slip.evaluation import std_calibration_table

    pred = np.array([[0.01, 0.02], [np.nan, np.nan], [0.0, 0.05], [0.03, np.nan]])
    table = std_calibration_table(pred, np.full((4, 2), 0.02), np.zeros((4, 2)),
                                  pd.DataFrame({"scenario": ["a"] * 4}), np.ones(4, bool))
    assert table.loc[0, "n_windows"] == 4 and table.loc[0, "n_scored"] == 5
    assert table.loc[0, "coverage_1std"] == pytest.approx(3 / 5)
    no_std = std_calibration_table(pred, np.full((4, 2), np.nan), np.zeros((4, 2)),
                                   pd.DataFrame({"scenario": ["a"] * 4}), np.ones(4, bool))
    assert no_std.loc[0, "n_scored"] == 0 and np.isnan(no_std.loc[0, "coverage_1std"])


def test_endo_turning_slip_counts_the_slips_it_clips():
    # a yaw rate against the wheels' turn gave alpha_l -4.68, alpha_r 2.15, returned as -1
    # and 1 without a word
    import warnings

    from terrain.errors import DataWarning

    vl, vr = np.array([0.2, 0.2, 0.5]), np.array([0.5, 0.5, 0.5])
    with pytest.warns(DataWarning, match="2 of 4 slips"):
        out = endo_turning_slip(vl, vr, np.array([0.5, -3.0, 0.0]), HUSKY.track_m)
    np.testing.assert_array_equal(out[1], [-1.0, 1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        endo_turning_slip(vl[:1], vr[:1], np.array([0.5]), HUSKY.track_m)


def _still_run(run_id="sim/ASPHALT/a/0", imu=False):
    """A 10 s run driving straight at 0.5 m/s (wheels, truth, optionally an IMU)."""
    from terrain.run import Run
    t = np.arange(0.0, 10.0, 0.1)
    streams = {"wheels": pd.DataFrame({"t_s": t, "vel_l": 0.5, "vel_r": 0.5}),
               "truth": pd.DataFrame({"t_s": t, "x": 0.5 * t, "y": 0.0})}
    if imu:
        streams["imu"] = pd.DataFrame({"t_s": t, "wz": 0.0})
    return Run(run_id, "sim", "ASPHALT", streams)


def test_odometry_and_observer_name_the_run_they_cannot_evaluate():
    # a run id without windows raised np.interp's bare "array of sample points is empty", an
    # unknown run id a bare KeyError 'nope', a run without an IMU KeyError 'imu'
    from terrain.errors import EstimationError
    from terrain.slip.evaluation import observer_window_slip
    run = _still_run()
    other = pd.DataFrame({"run_id": ["sim/SNOW/b/0"], "t_start_s": [0.0], "t_end_s": [2.0]})
    own = other.assign(run_id=run.run_id)
    pred = np.array([[0.0, 0.0, 1.0, 0.0]])
    with pytest.raises(ConfigError, match="sim/ASPHALT/a/0.*no window"):
        odometry_errors([run], other, pred, HUSKY.track_m, [run.run_id])
    with pytest.raises(ConfigError, match="'nope'.*not among"):
        odometry_errors([run], own, pred, HUSKY.track_m, ["nope"])
    with pytest.raises(ConfigError, match="sim/SNOW/b/0.*not among"):
        observer_window_slip([run], other, HUSKY.track_m)
    with pytest.raises(EstimationError, match="sim/ASPHALT/a/0 has no imu stream"):
        observer_window_slip([run], own, HUSKY.track_m)
    assert np.isfinite(observer_window_slip([_still_run(imu=True)], own, HUSKY.track_m)).all()


def test_chi_clip_of_the_odometry_and_yaw_checks_is_counted_and_said():
    # a predicted chi of 9 was clipped to 5 (and 0.2 to 0.5) without a word
    from terrain.slip.evaluation import CHI_RANGE, measured_checks
    assert CHI_RANGE == (0.5, 5.0)
    run = _still_run()
    # turning: chi divides the wheel yaw rate (on a straight run any chi gives the same
    # pose, so an unclipped 9 passed for the clipped 5)
    run.streams["wheels"]["vel_r"] = 0.6
    meta = pd.DataFrame({"run_id": [run.run_id] * 2, "t_start_s": [0.0, 6.0],
                         "t_end_s": [2.0, 8.0]})
    wild = np.array([[0.0, 0.0, 9.0, 0.0], [0.0, 0.0, 9.0, 0.0]])
    with pytest.warns(DataWarning, match=r"chi of 100 of 100 wheel samples \(1 of 1 runs\) "
                                         r"outside \[0.5, 5\]"):
        clipped = odometry_errors([run], meta, wild, HUSKY.track_m, [run.run_id])
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # in range: no warning, same figures
        same = odometry_errors([run], meta, np.where(wild == 9.0, 5.0, wild), HUSKY.track_m,
                               [run.run_id])
    pd.testing.assert_frame_equal(clipped, same)
    other = odometry_errors([run], meta, np.where(wild == 9.0, 2.0, wild), HUSKY.track_m,
                            [run.run_id])
    assert abs(other.loc[0, "compensated_err_pct"] - same.loc[0, "compensated_err_pct"]) > 1
    X = pd.DataFrame({"wz__mean": [0.3, 0.3, 0.0], "vel_diff__mean": [0.2, 0.2, 0.0],
                      "cur_l__mean": 1.0, "cur_r__mean": 1.0, "phys_slip_l": 0.0,
                      "phys_slip_r": 0.0})
    # chi 3, not 2: the clipped 0.5 and 2 are reciprocal, so chi multiplying the wheel yaw
    # rate instead of dividing it gave the same RMS and passed
    pred = np.array([[0.0, 0.0, 0.2, 0.0], [0.0, 0.0, 3.0, 0.0], [0.0, 0.0, 9.0, 0.0]])
    with pytest.warns(DataWarning, match=r"chi of 1 of 2 turning windows outside"):
        checks = measured_checks(X, pred, np.array(["a", "a", "a"]), np.array(["S"] * 3),
                                 HUSKY.track_m)
    expected = np.sqrt(np.mean((0.3 - 0.2 / (np.array([0.5, 3.0]) * HUSKY.track_m)) ** 2))
    assert checks.loc[0, "yaw_rms_compensated_rad_s"] == pytest.approx(expected)


def test_error_and_calibration_tables_keep_windows_without_a_label():
    # windows whose terrain/scenario was missing were dropped by pandas' groupby: 2 of 4
    # windows vanished from error_table, 1 of 4 from std_calibration_table, without a word
    from terrain.slip.evaluation import std_calibration_table
    meta = pd.DataFrame({"run_id": list("abcd"), "terrain": ["SNOW", None, "SNOW", np.nan],
                         "scenario": ["x", None, "x", "y"]})
    pred, truth = np.full((4, 2), 0.1), np.zeros((4, 2))
    table = error_table(pred, truth, meta, np.ones(4, bool))
    assert table["n_windows"].tolist() == [2, 2]
    assert table.loc[0, "terrain"] == "SNOW" and pd.isna(table.loc[1, "terrain"])
    calib = std_calibration_table(pred, np.full((4, 2), 0.2), truth, meta, np.ones(4, bool))
    assert calib["n_windows"].tolist() == [2, 1, 1]
    assert calib["scenario"].tolist()[:2] == ["x", "y"] and pd.isna(calib.loc[2, "scenario"])


def test_slip_data_spec_refuses_a_fractional_seed_and_a_text_duration():
    # seeds=(1.7,) was simulated and labelled as seed 1 (configs() took int() before SimConfig
    # could refuse it), a duration '10' raised TypeError "'>' not supported"
    with pytest.raises(ConfigError, match=r"seeds must be an integer >= 0, got 1.7"):
        SlipDataSpec(("SNOW",), ("random",), (1.7,), 10.0)
    with pytest.raises(ConfigError, match="SlipDataSpec.duration_s must be a real number"):
        SlipDataSpec(("SNOW",), ("random",), (1,), "10")
    assert [c.seed for c in SlipDataSpec(("SNOW",), ("random",), (np.int64(3),), 10.0)
            .configs()] == [3]


def test_slip_model_refuses_an_infinite_chi_target():
    # chi = inf was taken for "not turning" (NaN) and left out of the chi fit without a word
    from terrain.errors import NonFiniteInputError
    rng = np.random.default_rng(0)
    X = rng.standard_normal((60, 3))
    y = np.column_stack([0.01 * X[:, 0], 0.01 * X[:, 0], np.full(60, 2.0), X[:, 1]])
    y[[3, 9], 2] = np.inf
    with pytest.raises(NonFiniteInputError, match="2 of 60 .*infinite chi"):
        SlipRegressor(max_iter=3).fit(X, y)


def test_slip_model_says_when_chi_is_a_constant():
    # with 30 turning windows (fewer than 2 min_samples_leaf = 40) chi was predicted as
    # their median, 1.368 on every window, without a word
    rng = np.random.default_rng(0)
    X = rng.standard_normal((200, 3))
    y = np.column_stack([np.zeros(200), np.zeros(200), np.full(200, np.nan), np.zeros(200)])
    y[:30, 2] = 1.5 + X[:30, 0]
    with pytest.warns(DataWarning, match=r"30 turning training window\(s\), fewer than 40.*"
                                         r"constant chi 1.368"):
        model = SlipRegressor(max_iter=3).fit(X, y)
    assert np.all(model.predict(X)[:, 2] == pytest.approx(np.median(y[:30, 2])))
    y[:, 2] = np.nan
    with pytest.warns(DataWarning, match=r"0 turning training window\(s\).*constant chi 1 "):
        SlipRegressor(max_iter=3).fit(X, y)
    y[:40, 2] = 1.5 + X[:40, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        SlipRegressor(max_iter=3).fit(X, y)


def _named_table(n=300, seed=0):
    rng = np.random.default_rng(seed)
    X = pd.DataFrame(rng.normal(size=(n, 3)), columns=["cur_l__mean", "cur_r__mean", "pitch"])
    y = np.column_stack([0.1 * X["cur_l__mean"], 0.1 * X["cur_r__mean"], np.ones(n),
                         0.02 * X["pitch"]])
    return X, y


@pytest.mark.slow
def test_slip_model_refuses_a_table_whose_columns_differ_from_those_it_was_fitted_on():
    # the model kept no column names: the same table with cur_l__mean and cur_r__mean
    # swapped predicted slip_1 0.0093 -> -0.0116 and slip_2 -0.0114 -> 0.0131 on its first
    # window (up to 0.057 apart on three windows) without a word
    from terrain.errors import MissingColumnError
    X, y = _named_table()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        model = SlipRegressor(max_iter=20).fit(X, y, groups=np.repeat(np.arange(6), 50))
    assert list(model.feature_names_in_) == list(X.columns)
    swapped = X[["cur_r__mean", "cur_l__mean", "pitch"]]
    for method in (model.predict, model.predict_std, model.predict_reference):
        with pytest.raises(MissingColumnError, match="cur_r__mean.*cur_l__mean"):
            method(swapped)
    with pytest.raises(MissingColumnError, match=r"missing \['pitch'\].*extra \['roll'\]"):
        model.predict(X.rename(columns={"pitch": "roll"}))
    # a table of another width is the same defect: named columns, not a shape (it raised
    # ShapeError "X must have shape (n_windows, 3), got (300, 2): ... missing ['pitch']"
    # while the same table renamed raised MissingColumnError)
    for method in (model.predict, model.predict_std, model.predict_reference):
        with pytest.raises(MissingColumnError, match=r"missing \['pitch'\]"):
            method(X[["cur_l__mean", "cur_r__mean"]])
        with pytest.raises(MissingColumnError, match=r"extra \['roll'\]"):
            method(X.assign(roll=0.0))
    # a bare array of the right width is taken as in the fitted order, as before
    np.testing.assert_array_equal(model.predict(X.to_numpy()), model.predict(X))
    np.testing.assert_array_equal(model.predict_std(X.to_numpy()), model.predict_std(X))
    with pytest.raises(ShapeError):
        model.predict(X.to_numpy()[:, :2])
    # the names change nothing else: bit-identical to a model fitted on the bare array
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        bare = SlipRegressor(max_iter=20).fit(X.to_numpy(), y,
                                              groups=np.repeat(np.arange(6), 50))
    assert not hasattr(bare, "feature_names_in_")
    np.testing.assert_array_equal(model.predict(X), bare.predict(X))
    np.testing.assert_array_equal(model.predict(X), model.predict_reference(X))
    np.testing.assert_array_equal(model.predict_std(X), bare.predict_std(X))
    # the names add no type the stored model's serialiser must trust (terrain slip-fit)
    import skops.io as sio

    from pipelines.slip_fit import TRUSTED
    data = sio.dumps(model)
    assert set(sio.get_untrusted_types(data=data)) <= set(TRUSTED)
    with pytest.raises(MissingColumnError, match="another order"):
        sio.loads(data, trusted=list(TRUSTED)).predict(swapped)
    # refitted on a bare array, the names of the earlier fit are forgotten
    model.fit(X.to_numpy(), y)
    assert not hasattr(model, "feature_names_in_")


def test_slip_model_stored_before_the_feature_names_still_loads_and_predicts(tmp_path):
    import joblib
    X, y = _named_table()
    model = SlipRegressor(max_iter=20).fit(X, y)
    expected = model.predict(X)
    del model.feature_names_in_          # as a model fitted and stored before the names
    joblib.dump(model, tmp_path / "old.joblib")
    old = joblib.load(tmp_path / "old.joblib")
    np.testing.assert_array_equal(old.predict(X), expected)
    np.testing.assert_array_equal(old.predict(X.to_numpy()), expected)
    old.predict(X[["cur_r__mean", "cur_l__mean", "pitch"]])    # no names: no check, as before


def test_unfitted_slip_model_raises_not_fitted_error():
    # predict before fit raised "'SlipRegressor' object has no attribute 'n_features_in_'"
    from sklearn.exceptions import NotFittedError
    X, _ = _named_table(10)
    for method in ("predict", "predict_std", "predict_reference"):
        with pytest.raises(NotFittedError, match="SlipRegressor"):
            getattr(SlipRegressor(), method)(X)
    with pytest.raises(NotFittedError, match="SlipRegressor"):
        SlipRegressor().score(X, np.zeros((10, 4)))


def test_error_figure_draws_no_bar_for_a_median_error_not_computed():
    # a terrain not scored (not simulated, or a model undefined there) was filled with 0 and
    # drawn at 1e-5, the smallest error on the log axis: the best model where there is none
    from terrain.slip.figures import error_figure

    errors = pd.DataFrame({"split": ["held-out seeds"] * 4, "windows": ["steady_straight"] * 4,
                           "model": ["learned", "learned", "pitch-linear", "pitch-linear"],
                           "terrain": ["SNOW", "ICE", "SNOW", "ICE"],
                           "median_abs_err": [0.01, 0.002, 0.3, np.nan]})
    ax = error_figure(errors, ("SNOW", "ICE", "GRASS")).axes[0]
    heights = {c.get_label(): [p.get_height() for p in c] for c in ax.containers}
    np.testing.assert_allclose(heights["learned"][:2], [0.01, 0.002], rtol=1e-2)
    np.testing.assert_allclose(heights["pitch-linear"][0], 0.3, rtol=1e-3)
    assert np.isnan(heights["pitch-linear"][1])         # ICE: no score, no bar
    assert np.isnan(heights["learned"][2]) and np.isnan(heights["pitch-linear"][2])  # GRASS
    assert sum(t.get_text() == "n/a" for t in ax.texts) == 3


def test_dead_reckon_refuses_a_non_finite_speed_slip_or_yaw_rate_by_name():
    # one NaN slip sample made every later pose NaN without a word ([nan, nan, 0] at the end)
    from terrain.errors import NonFiniteInputError

    t = np.linspace(0.0, 1.0, 11)
    rim = np.full_like(t, 0.5)
    slip = np.full_like(t, 0.1)
    slip[3] = np.nan
    with pytest.raises(NonFiniteInputError, match=r"slip_left.*1 of 11.*sample 3"):
        dead_reckon(t, rim, rim, HUSKY.track_m, slip, np.full_like(t, 0.1))
    fast = rim.copy()
    fast[[4, 6]] = np.inf
    with pytest.raises(NonFiniteInputError, match=r"v_right_m_s.*2 of 11"):
        dead_reckon(t, rim, fast, HUSKY.track_m)
    with pytest.raises(NonFiniteInputError, match="yaw_rate_rad_s"):
        dead_reckon(t, rim, rim, HUSKY.track_m, yaw_rate_rad_s=np.where(t > 0.5, np.nan, 0.0))
    with pytest.raises(NonFiniteInputError, match="chi"):
        dead_reckon(t, rim, rim, HUSKY.track_m, chi=np.nan)


def test_slip_fit_summary_counts_the_runs_that_slid_off_and_keeps_their_scenario():
    """A run that slid off its slope is left out of the odometry medians; the summary did
    not say how many were (and a scenario whose every run slid off had no key at all)."""
    from pipelines.slip_fit import _summary
    from terrain.io.jsonfile import strict_json

    errors = pd.DataFrame(columns=["windows", "terrain", "split", "model", "median_abs_err"])
    odo = pd.DataFrame({
        "scenario": ["slope_turn", "slope_turn", "slope_turn", "ice_slope"],
        "slid_off": [True, False, False, True],
        "plain_err_pct": [900.0, 4.0, 6.0, 800.0],
        "compensated_err_pct": [950.0, 1.0, 3.0, 700.0],
        "compensated_gyro_err_pct": [960.0, 0.5, 1.5, 600.0],
        "gyro_heading_err_pct": [970.0, 2.0, 2.0, 500.0],
        "reduction_pct": [-5.6, 75.0, 50.0, 12.5]})
    summary = json.loads(strict_json(_summary(errors, odo)))
    assert summary["odometry.slope_turn.slid_off_runs"] == 1
    assert summary["odometry.slope_turn.plain_err_pct"] == pytest.approx(5.0)
    assert summary["odometry.slope_turn.compensated_err_pct"] == pytest.approx(2.0)
    assert summary["odometry.slope_turn.slipping_runs"] == 2
    assert summary["odometry.ice_slope.slid_off_runs"] == 1
    assert summary["odometry.ice_slope.plain_err_pct"] is None      # no run left to score


@pytest.mark.parametrize("extra", [1, -5])
def test_slip_feature_matrix_refuses_windows_of_another_channel_count_than_named(extra):
    """Channels are read by position from ``channels``: windows holding one more channel
    than named were read without a word, fewer failed on NumPy's IndexError."""
    from features.slip_features import SLIP_CHANNELS, slip_feature_matrix

    x = np.ones((2, len(SLIP_CHANNELS) + extra, 100))
    with pytest.raises(ConfigError, match=rf"windows must have shape \(n_windows, "
                                          rf"{len(SLIP_CHANNELS)}, n_samples\), got "
                                          rf"\(2, {len(SLIP_CHANNELS) + extra}, 100\)"):
        slip_feature_matrix(x, SLIP_CHANNELS, 50.0, HUSKY)


def test_observer_slip_refuses_a_non_finite_gyro_sample_by_name():
    # one NaN gyro sample at 1 s went into the heading's cumulative sum and turned the
    # observer slip of every later window of the run into NaN, left out of n_scored silently
    from terrain.errors import NonFiniteError
    from terrain.slip.evaluation import observer_window_slip
    run = _still_run(imu=True)
    meta = pd.DataFrame({"run_id": [run.run_id], "t_start_s": [6.0], "t_end_s": [8.0]})
    assert np.isfinite(observer_window_slip([run], meta, HUSKY.track_m)).all()
    run.streams["imu"].loc[10, "wz"] = np.nan
    with pytest.raises(NonFiniteError, match="sim/ASPHALT/a/0.*imu column 'wz'.*row 10"):
        observer_window_slip([run], meta, HUSKY.track_m)
    run = _still_run(imu=True)
    run.streams["wheels"].loc[3, "vel_r"] = np.inf
    with pytest.raises(NonFiniteError, match="wheels column 'vel_r'"):
        observer_window_slip([run], meta, HUSKY.track_m)


def test_odometry_errors_refuse_a_non_finite_sample_by_name():
    # one NaN wheel speed or gyro sample made the dead-reckoned errors of the whole run NaN,
    # a row of NaN percentages without a word
    from terrain.errors import NonFiniteError
    run = _still_run(imu=True)
    meta = pd.DataFrame({"run_id": [run.run_id], "t_start_s": [0.0], "t_end_s": [2.0]})
    pred = np.array([[0.0, 0.0, 1.0, 0.0]])
    ok = odometry_errors([run], meta, pred, HUSKY.track_m, [run.run_id])
    assert np.isfinite(ok[["plain_err_pct", "gyro_heading_err_pct"]].to_numpy()).all()
    for stream, col in (("wheels", "vel_l"), ("imu", "wz"), ("truth", "y")):
        bad = _still_run(imu=True)
        bad.streams[stream].loc[40, col] = np.nan
        with pytest.raises(NonFiniteError, match=f"{stream} column '{col}', first at row 40"):
            odometry_errors([bad], meta, pred, HUSKY.track_m, [bad.run_id])


def test_dead_reckon_counts_only_slips_beyond_its_bounds():
    """A slip exactly at BRAKING_SLIP_FLOOR or at 1 is within the bounds, not held: no
    warning, and the ground speed is its exact inverse; also reversing, where the floor is
    in the rim's direction (hand mutants: ``q <= BRAKING_SLIP_FLOOR`` survived every test)."""
    t = np.linspace(0.0, 1.0, 11)
    for sign in (1.0, -1.0):
        rim = np.full_like(t, 0.5 * sign)
        left = np.full_like(t, sign * BRAKING_SLIP_FLOOR)
        right = np.full_like(t, sign * 1.0)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            pose = dead_reckon(t, rim, rim, HUSKY.track_m, left, right)
        ground = 0.5 * (ground_speed_from_slip(rim, left) + ground_speed_from_slip(rim, right))
        assert pose[-1, 0] == pytest.approx(np.trapezoid(ground, t))
        assert pose[-1, 0] == pytest.approx(sign * 0.5 * 0.5 / 0.05)   # 1 / (1 + s) rim, 0
