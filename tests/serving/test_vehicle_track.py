"""The derived wheel yaw rate ``(vel_r - vel_l) / B`` uses the vehicle's own track width B:
each run's in its windows, the training vehicle's in a saved model and in the live service.

Before, every window took the Husky's 0.5708 m: a tracked vehicle (B = 0.393 m) turning at
0.5 rad/s on its wheels got ``yaw_rate_wheels`` 0.34 rad/s."""

from __future__ import annotations

from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pandas as pd
import pytest

from features.windows import (HUSKY_TRACK_M, WindowConfig, add_derived_channels,
                              derived_track_m, make_windows, window_frame)
from terrain.errors import ConfigError
from terrain.io.align import align_streams
from terrain.run import TIME, WHEEL_CHANNELS, Run
from terrain.serving import CataloguePeakTargets, SmoothingConfig, StreamConfig, StreamService
from terrain.serving.model import model_track_m, read_model_metadata
from terrain.serving.pyfunc import predict_windows, save_model
from terrain.vehicles import HUSKY, TRACKED, get_vehicle


def _turning_run(vehicle: str, run_id: str = "r1") -> Run:
    """20 s of a wheel stream at 10 Hz turning on the spot: vel_r - vel_l = 0.2 m/s."""
    t = np.arange(200) / 10.0
    wheels = pd.DataFrame({TIME: t, "cur_l": 5.0, "cur_r": 6.0, "vel_l": -0.1 + 0 * t,
                           "vel_r": 0.1 + 0.05 * np.sin(t)})
    return Run(run_id, "sim", "GRASS", {"wheels": wheels}, vehicle=vehicle)


def test_track_width_of_each_vehicle():
    assert derived_track_m("husky") == HUSKY.track_m == HUSKY_TRACK_M
    assert derived_track_m("Tracked") == TRACKED.track_m == 0.393
    # the AgriMaRo has no left and right side; unknown: the Husky's, as before
    assert derived_track_m("agrimaro") == derived_track_m(None) == HUSKY_TRACK_M
    with pytest.raises(ConfigError, match="unknown vehicle 'bike'"):
        derived_track_m("bike")


@pytest.mark.parametrize("vehicle, track_m", [("husky", 0.5708), ("tracked", 0.393),
                                              ("agrimaro", 0.5708)])
def test_windows_derive_the_wheel_yaw_rate_with_the_runs_own_track(vehicle, track_m):
    ws = make_windows([_turning_run(vehicle)], ["vel_diff", "yaw_rate_wheels"],
                      WindowConfig(window_s=2.0, rate_hz=10.0))
    assert len(ws) == 10
    np.testing.assert_allclose(ws.X[:, 1], ws.X[:, 0] / track_m, rtol=1e-12)


def test_windows_of_two_vehicles_each_keep_their_own_track():
    ws = make_windows([_turning_run("husky", "h"), _turning_run("tracked", "t")],
                      ["vel_diff", "yaw_rate_wheels"], WindowConfig(window_s=2.0, rate_hz=10.0))
    for run_id, vehicle in (("h", HUSKY), ("t", TRACKED)):
        X = ws.X[ws.run_ids == run_id]
        np.testing.assert_allclose(X[:, 1], X[:, 0] / vehicle.track_m, rtol=1e-12)


def test_ekf_channels_of_a_tracked_run_use_its_track():
    # the EKF's wheel slip channels read (v_R - v_L) against its yaw rate with the track
    # width: with the Husky's on a tracked run the slips of a pure spin came out wrong
    from features.ekf_signals import add_ekf_channels
    from terrain.estimation.skid_steer import SkidSteerSettings

    t = np.arange(600) / 50.0
    w = 0.6 * np.ones_like(t)
    imu = pd.DataFrame({TIME: t, "wx": 0.0, "wy": 0.0, "wz": w, "ax": 0.0, "ay": 0.0,
                        "az": 9.81})
    half = 0.5 * TRACKED.track_m * w * 1.4                 # chi 1.4: the sides slip
    wheels = pd.DataFrame({TIME: t, "cur_l": 5.0, "cur_r": 5.0, "vel_l": -half, "vel_r": half})
    run = Run("spin", "sim", "GRASS", {"imu": imu, "wheels": wheels}, vehicle="tracked")
    ws = make_windows([run], ["ekf_slip_l", "ekf_slip_r"], WindowConfig(window_s=2.0,
                                                                        rate_hz=50.0))
    frame = add_derived_channels(align_streams(run, ("imu", "wheels"), 50.0), TRACKED.track_m)
    own = add_ekf_channels(frame, wheel_rate_hz=50.0,
                           settings=SkidSteerSettings(track_m=TRACKED.track_m))
    husky = add_ekf_channels(frame, wheel_rate_hz=50.0)
    X_own, *_ = window_frame(own, ["ekf_slip_l", "ekf_slip_r"], WindowConfig(2.0, rate_hz=50.0))
    X_husky, *_ = window_frame(husky, ["ekf_slip_l", "ekf_slip_r"],
                               WindowConfig(2.0, rate_hz=50.0))
    np.testing.assert_allclose(ws.X, X_own, rtol=1e-12)
    assert np.abs(ws.X - X_husky).max() > 0.05


def _mean_model():
    """A fitted classifier on the per-channel window means (picklable, sklearn only)."""
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import FunctionTransformer

    X = np.zeros((4, 2, 20))
    X[2:, 1] = 1.0                                   # yaw_rate_wheels means 0 and 1 rad/s
    return make_pipeline(FunctionTransformer(np.mean, kw_args={"axis": 2}),
                         LogisticRegression()).fit(X, ["A", "A", "B", "B"])


@pytest.mark.filterwarnings("ignore:.*An input example was not provided")
def test_a_saved_model_derives_its_channels_with_the_training_vehicles_track(tmp_path):
    import mlflow.pyfunc

    config = WindowConfig(window_s=2.0, rate_hz=10.0)
    samples = align_streams(_turning_run("tracked"), ("wheels",), 10.0)
    samples.insert(0, "run", "r1")
    channels = ["vel_diff", "yaw_rate_wheels"]
    out = {}
    for vehicle in ("tracked", "husky"):
        path = tmp_path / vehicle
        save_model(path, _mean_model(), channels, config, ["A", "B"], {"vehicle": vehicle},
                   progress=False)
        meta = read_model_metadata(path)
        assert model_track_m(meta) == derived_track_m(vehicle)
        out[vehicle] = mlflow.pyfunc.load_model(str(path)).predict(samples)
        expected = predict_windows(_mean_model(), samples, channels, config, ["A", "B"],
                                   derived_track_m(vehicle))
        pd.testing.assert_frame_equal(out[vehicle], expected)
    assert np.abs(out["tracked"]["proba_B"] - out["husky"]["proba_B"]).min() > 0.01


def test_model_track_of_a_model_saved_before_the_key_is_the_huskys():
    assert model_track_m({"vehicle": "tracked"}) == HUSKY_TRACK_M   # its windows used it
    assert model_track_m({"track_m": 0.393}) == 0.393


def test_the_service_derives_the_live_channels_with_the_models_track(wheel_model, train_runs):
    # a wheel model whose metadata names the tracked vehicle's track: every streamed window
    # is the batch window derived with that track, not the Husky's
    run = train_runs[0]
    model = replace(wheel_model, metadata=MappingProxyType({"track_m": TRACKED.track_m}))
    frame = align_streams(run, ("wheels",), model.window.rate_hz).iloc[:400]
    svc = StreamService(model, CataloguePeakTargets(model.classes),
                        StreamConfig(smoothing=SmoothingConfig(dwell_s=None),
                                     hop_s=model.window.window_s))
    decisions = []
    for row in frame.itertuples(index=False):
        decisions += svc.push("wheels", row.t_s, {c: getattr(row, c) for c in WHEEL_CHANNELS})
    order = [list(model.pipeline.classes_).index(c) for c in model.classes]
    got = np.array([d.proba for d in decisions])
    expected = {}
    for track in (TRACKED.track_m, HUSKY_TRACK_M):
        X, *_ = window_frame(add_derived_channels(frame, track), model.channels, model.window)
        expected[track] = model.pipeline.predict_proba(X[:len(got)])[:, order]
    assert len(got) >= 8
    np.testing.assert_allclose(got, expected[TRACKED.track_m], atol=1e-6)
    assert np.abs(got - expected[HUSKY_TRACK_M]).max() > 1e-3


def _labelled(vehicle: str, run_id: str, terrain: str, turn_m_s: float) -> Run:
    t = np.arange(300) / 10.0
    wheels = pd.DataFrame({TIME: t, "cur_l": 5.0 + turn_m_s + 0.1 * np.sin(3 * t),
                           "cur_r": 6.0 - turn_m_s + 0.1 * np.cos(2 * t),
                           "vel_l": 0.4 - turn_m_s + 0.05 * np.sin(t),
                           "vel_r": 0.4 + turn_m_s + 0.05 * np.cos(t)})
    return Run(run_id, "sim", terrain, {"wheels": wheels}, vehicle=vehicle)


def test_a_stream_model_fitted_on_tracked_runs_serves_with_their_track():
    # fit_stream_model's StreamModel had no metadata, so the service derived the live
    # yaw_rate_wheels with the Husky's track while its training windows used 0.393 m
    from terrain.serving.recipes import ModelRecipe, fit_stream_model

    recipe = ModelRecipe(signals="wheels", window_s=2.0, rate_hz=10.0, train_hop_s=1.0)
    runs = [_labelled("tracked", f"r{i}", terrain, turn)
            for i, (terrain, turn) in enumerate([("GRASS", 0.05), ("GRASS", 0.06),
                                                 ("ICE", 0.15), ("ICE", 0.16)])]
    model = fit_stream_model(recipe, runs)
    assert model_track_m(model.metadata) == TRACKED.track_m
    mixed = fit_stream_model(recipe, runs[:3] + [replace(runs[3], vehicle="husky")])
    assert model_track_m(mixed.metadata) == HUSKY_TRACK_M
    run = _labelled("tracked", "new", "ICE", 0.1)
    svc = StreamService(model, CataloguePeakTargets(model.classes),
                        StreamConfig(smoothing=SmoothingConfig(dwell_s=None), hop_s=2.0))
    frame = run.streams["wheels"]
    decisions = []
    for row in frame.itertuples(index=False):
        decisions += svc.push("wheels", row.t_s, {c: getattr(row, c) for c in WHEEL_CHANNELS})
    ws = make_windows([run], model.channels, WindowConfig(window_s=2.0, rate_hz=10.0))
    order = [list(model.pipeline.classes_).index(c) for c in model.classes]
    expected = model.pipeline.predict_proba(ws.X[:len(decisions)])[:, order]
    assert len(decisions) >= 10
    np.testing.assert_allclose([d.proba for d in decisions], expected, atol=1e-6)


@pytest.mark.filterwarnings("ignore:.*An input example was not provided")
def test_saving_keeps_a_track_the_metadata_gives(tmp_path):
    path = save_model(tmp_path / "m", _mean_model(), ["vel_diff", "yaw_rate_wheels"],
                      WindowConfig(window_s=2.0, rate_hz=10.0), ["A", "B"],
                      {"dataset": "borealtc", "track_m": TRACKED.track_m}, progress=False)
    assert model_track_m(read_model_metadata(path)) == TRACKED.track_m


@pytest.mark.parametrize("vehicle", ["tracked", "husky"])
def test_the_wheel_physics_features_of_a_stream_model_use_the_runs_track(vehicle):
    from features.wheel_physics import WheelPhysicsFeatures
    from terrain.serving.recipes import ModelRecipe, fit_stream_model

    recipe = ModelRecipe(signals="wheels", window_s=2.0, rate_hz=10.0, train_hop_s=1.0,
                         features="stats+physics")
    runs = [_labelled(vehicle, f"r{i}", terrain, turn)
            for i, (terrain, turn) in enumerate([("GRASS", 0.05), ("ICE", 0.15)])]
    pipe = fit_stream_model(recipe, runs).pipeline
    physics = [t for _, t in pipe.steps[0][1].transformer_list
               if isinstance(t, WheelPhysicsFeatures)]
    assert [p.track_m for p in physics] == [derived_track_m(vehicle)]


def _spin_run(run_id: str, terrain: str, chi: float, vehicle: str = "tracked") -> Run:
    """A 12 s spin at 0.6 rad/s with the sides' speeds chi times the kinematic ones."""
    t = np.arange(600) / 50.0
    w = 0.6 + 0.05 * np.sin(t)
    imu = pd.DataFrame({TIME: t, "wx": 0.0, "wy": 0.0, "wz": w, "ax": 0.01 * np.sin(5 * t),
                        "ay": 0.01 * np.cos(3 * t), "az": 9.81})
    half = 0.5 * get_vehicle(vehicle).track_m * w * chi
    wheels = pd.DataFrame({TIME: t, "cur_l": 5.0 * chi, "cur_r": 5.0 * chi, "vel_l": -half,
                           "vel_r": half})
    return Run(run_id, "sim", terrain, {"imu": imu, "wheels": wheels}, vehicle=vehicle)


def test_the_window_ekf_of_a_model_uses_the_training_runs_track():
    # WindowEKFClassifier ran the skid-steer filter of every window with the Husky's track
    from features.ekf_signals import window_ekf_channels
    from terrain.estimation.skid_steer import SkidSteerSettings
    from terrain.models.registry import ModelConfig
    from terrain.serving.recipes import ModelRecipe, fit_stream_model

    recipe = ModelRecipe(signals="all", window_s=2.0, rate_hz=50.0, train_hop_s=1.0,
                         window_ekf=True)
    runs = [_spin_run("a", "GRASS", 1.3), _spin_run("b", "ICE", 2.0)]
    model = fit_stream_model(recipe, runs).pipeline
    assert model.track_m == TRACKED.track_m
    ws = make_windows(runs, model.channels, WindowConfig(window_s=2.0, rate_hz=50.0))
    own = window_ekf_channels(ws.X, ws.channels, 50.0, wheel_rate_hz=model.wheel_rate_hz,
                              settings=SkidSteerSettings(track_m=TRACKED.track_m))
    np.testing.assert_allclose(model.augment(ws.X)[:, len(ws.channels):], own)
    husky = window_ekf_channels(ws.X, ws.channels, 50.0, wheel_rate_hz=model.wheel_rate_hz)
    assert np.abs(own - husky).max() > 0.05
    with pytest.raises(ConfigError, match="ModelConfig.track_m must be a finite value > 0"):
        ModelConfig(track_m=0.0)
