"""Feature transformers and windowing review (ftr10): settings and inputs refused where they
are given, and the lines a hand mutation left untested."""

from __future__ import annotations

import re

import numpy as np
import pytest

from features.transformers import WindowFeatures
from features.wheel_physics import WheelPhysicsFeatures
from features.windows import as_windows
from terrain.errors import ConfigError


@pytest.mark.parametrize("field, value, words", [
    ("track_m", -1.0, "a finite value > 0"), ("track_m", 0.0, "a finite value > 0"),
    ("track_m", float("nan"), "a finite value > 0"), ("ridge", 0.0, "a finite value > 0"),
    ("ridge", float("inf"), "a finite value > 0"), ("track_m", "0.57", "a real number"),
    ("ridge", True, "a real number")])
def test_wheel_physics_fit_refuses_a_track_or_ridge_that_transform_refuses(
        field, value, words):
    # fit took them and fixed its 50 names; only transform refused them, from inside
    # physics_features ("physics_features.track_m must be ..."), as rate_hz was before
    X = np.ones((2, 4, 40))
    with pytest.raises(ConfigError, match=f"WheelPhysicsFeatures.{field} must be {words}"):
        WheelPhysicsFeatures(**{field: value}).fit(X)


@pytest.mark.parametrize("values", [
    np.ones((2, 4, 40), dtype=bool),                       # a mask passed for the windows
    [[[True, False] * 20] * 4] * 2,                        # the same, as nested lists
    np.full((2, 4, 40), "1.5"),                            # text: was parsed to 1.5
    np.full((2, 4, 40), 1.5 + 2.0j),                       # complex: the imaginary part lost
])
@pytest.mark.parametrize("make", [
    lambda: WheelPhysicsFeatures(),
    lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l"))])
def test_windows_that_are_not_real_numbers_are_refused_naming_the_dtype(values, make):
    # as_windows converted them with np.asarray(X, dtype=float): booleans became samples of
    # 0 and 1 (50 and 36 features of a mask), text was parsed, complex values lost their
    # imaginary part with a ComplexWarning only
    with pytest.raises(ValueError, match="X must hold real numbers"):
        make().fit(values)
    fitted = make().fit(np.ones((2, 4, 40)))
    with pytest.raises(ValueError, match="X must hold real numbers"):
        fitted.transform(values)


def test_windows_of_integers_and_float32_are_read_as_float64():
    ints = np.arange(2 * 4 * 40).reshape(2, 4, 40) % 7
    fx = WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")).fit(ints)
    np.testing.assert_array_equal(fx.transform(ints), fx.transform(ints.astype(float)))
    np.testing.assert_array_equal(as_windows(ints.astype(np.float32), "abcd"),
                                  ints.astype(np.float32).astype(float))


def test_runs_of_several_vehicles_take_the_default_track_whatever_the_order(monkeypatch):
    """runs_track_m asks derived_track_m for no vehicle (the Husky's track) when the runs
    come from several; one vehicle in any case is that vehicle's. (Popping any vehicle of
    the set survived the tests: which one it pops depends on the string hash.)"""
    import pandas as pd

    from features import windows
    from terrain.run import TIME, Run

    asked = []
    real = windows.derived_track_m
    monkeypatch.setattr(windows, "derived_track_m", lambda v: asked.append(v) or real(v))

    def run(vehicle, rid):
        t = np.arange(10) / 10.0
        wheels = pd.DataFrame({TIME: t, "vel_l": 0.1, "vel_r": 0.1, "cur_l": 1.0,
                               "cur_r": 1.0})
        return Run(rid, "sim", "GRASS", {"wheels": wheels}, vehicle=vehicle)

    mixed = [run("tracked", "a"), run("husky", "b")]
    assert windows.runs_track_m(mixed) == windows.HUSKY_TRACK_M and asked == [None]
    asked.clear()
    assert windows.runs_track_m([run("Tracked", "a"), run("tracked", "b")]) == 0.393
    assert asked == ["tracked"]
    asked.clear()
    assert windows.runs_track_m([]) == windows.HUSKY_TRACK_M and asked == [None]


@pytest.mark.slow
def test_serial_feature_union_hands_parallel_settings_to_feature_union(monkeypatch):
    """n_jobs asking for parallel work goes through FeatureUnion.transform (joblib), as the
    docstring says; n_jobs None or 1 stays serial. (Dropping the n_jobs test survived: both
    paths give the same numbers.)"""
    from sklearn.pipeline import FeatureUnion

    from features.transformers import SerialFeatureUnion

    calls = []
    parent = FeatureUnion.transform
    monkeypatch.setattr(FeatureUnion, "transform",
                        lambda self, X, **kw: calls.append(self.n_jobs) or parent(self, X,
                                                                                  **kw))
    X = np.random.default_rng(1).standard_normal((3, 4, 40))
    for n_jobs in (None, 1, 2, -1):
        part = [("physics", WheelPhysicsFeatures(short_s=None))]
        union = SerialFeatureUnion(part, n_jobs=n_jobs).fit(X)
        calls.clear()
        out = union.transform(X)
        assert calls == ([] if n_jobs in (None, 1) else [n_jobs])
        np.testing.assert_array_equal(out, WheelPhysicsFeatures(short_s=None).fit_transform(X))


@pytest.mark.parametrize("make, change", [
    (lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")), {"stats": ("mean",)}),
    (lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")),
     {"stats": tuple(reversed(WindowFeatures().stats))}),
    (lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")),
     {"channels": ("ax", "wz", "cur_l", "vel_l")}),
    (lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")), {"band_width_hz": 5.0}),
    (lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")), {"rate_hz": 100.0}),
    (lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")),
     {"bands_hz": ((1.0, 2.0),)}),
    (lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")),
     {"min_speed_m_s": 0.2}),
    (lambda: WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")),
     {"turn_floor_rad_s": 0.1}),
    (lambda: WheelPhysicsFeatures(), {"short_s": 1.0}),
    (lambda: WheelPhysicsFeatures(), {"track_m": 0.393}),
    (lambda: WheelPhysicsFeatures(), {"ridge": 1e-2}),
    (lambda: WheelPhysicsFeatures(), {"channels": ("vel_r", "vel_l", "cur_l", "cur_r")}),
    (lambda: WheelPhysicsFeatures(), {"rate_hz": 20.0}),
])
def test_settings_changed_after_fit_are_refused_until_refit(make, change):
    """transform built its columns from the current settings while get_feature_names_out
    kept those fixed at fit: set_params(stats=('mean',)) after fit gave 22 columns under 36
    names, reversed statistics or swapped channels the same count under the wrong names,
    and WheelPhysicsFeatures' short_s 1 s its last 10 samples under '__last2s' names,
    without a word. A transform after any change of a setting (fit checked them all) is
    refused, naming the setting; a refit takes it."""
    from sklearn.exceptions import NotFittedError

    X = np.random.default_rng(2).standard_normal((3, 4, 40)) + 1.0
    fx = make().fit(X)
    fx.set_params(**change)
    with pytest.raises(NotFittedError, match=f"{next(iter(change))}.*fit again"):
        fx.transform(X)
    F = fx.fit(X).transform(X)
    assert F.shape == (3, len(fx.get_feature_names_out()))
    np.testing.assert_array_equal(F, make().set_params(**change).fit_transform(X))


def test_a_floor_fit_refuses_cannot_be_set_after_fit():
    # fit refuses a speed floor of 0 (infinite current per speed of a standing window);
    # set after fit it reached transform: cur_l__per_speed inf for a standing window
    from sklearn.exceptions import NotFittedError

    X = np.zeros((2, 4, 40))
    X[:, 2] = 5.0                                        # 5 A, standing
    fx = WindowFeatures(channels=("wz", "ax", "cur_l", "vel_l")).fit(X)
    fx.set_params(min_speed_m_s=0.0)
    with pytest.raises(NotFittedError, match=r"\['min_speed_m_s'\] changed since fit"):
        fx.transform(X)
    with pytest.raises(ConfigError, match="min_speed_m_s must be a finite value > 0"):
        fx.fit(X)


def test_settings_left_as_they_were_fitted_keep_transforming():
    X = np.random.default_rng(3).standard_normal((3, 4, 40))
    for fx in (WindowFeatures(channels=["wz", "ax", "cur_l", "vel_l"], stats=["mean", "std"],
                              bands_hz=[[1.0, 2.0], [2.0, 5.0]]),
               WheelPhysicsFeatures(channels=list(WheelPhysicsFeatures().channels))):
        F = fx.fit(X).transform(X)
        fx.set_params(**fx.get_params())           # the same values, new objects
        np.testing.assert_array_equal(fx.transform(X), F)


@pytest.mark.parametrize("value", ["no", "False", 1, 0, None, np.array([True])])
def test_a_steady_only_switch_that_is_not_a_boolean_is_refused(value):
    # read by truthiness, the text "no" (or "False") of a config file turned the
    # steady-motion filter on, and dropped every window under 0.1 m/s without a word
    from features.windows import WindowConfig

    with pytest.raises(ConfigError, match="WindowConfig.steady_only must be True or False"):
        WindowConfig(steady_only=value)
    assert WindowConfig(steady_only=np.bool_(True)).steady_only
    assert not WindowConfig(steady_only=False).steady_only


@pytest.mark.parametrize("n_rows", [3, 300])
def test_window_frame_refuses_steady_only_without_wheel_speeds_however_short(n_rows):
    # the documented refusal came after the return of a frame shorter than one window:
    # 3 rows of an IMU-only frame gave 0 windows, 300 rows the ConfigError
    import pandas as pd

    from features.windows import WindowConfig, window_frame
    from terrain.run import TIME

    frame = pd.DataFrame({TIME: np.arange(n_rows) / 50.0, "wz": 0.0})
    with pytest.raises(ConfigError, match=r"steady_only needs the wheel speeds.*vel_l"):
        window_frame(frame, ["wz"], WindowConfig(window_s=2.0, steady_only=True))
    X, *_ = window_frame(frame, ["wz"], WindowConfig(window_s=2.0))
    assert len(X) == (0 if n_rows < 100 else 3)


@pytest.mark.parametrize("field, value", [("channels", "ax"), ("channels", "wz"),
                                          ("stats", "mean")])
def test_window_features_refuse_one_text_for_a_list_of_names(field, value):
    # channels="ax" was read letter by letter: windows of 2 channels named 'a' and 'x'
    # (a__mean, x__mean, ..., no band of the IMU channel ax) without a word; stats="mean"
    # was refused as the unknown statistics ['m', 'e', 'a', 'n']
    X = np.ones((2, 2, 10))
    with pytest.raises(ConfigError, match=f"WindowFeatures.{field} must be a sequence of "
                                          f"names, got the text '{value}'"):
        WindowFeatures(**{field: value}).fit(X)
    fx = WindowFeatures(channels=("ax",), stats=("mean",)).fit(np.ones((2, 1, 10)))
    assert list(fx.get_feature_names_out())[:2] == ["ax__mean", "ax__band_0_2p5hz"]


def _window_set(n=6):
    from features.windows import WindowSet

    ids = np.array(["r1"] * 3 + ["r2"] * (n - 3), dtype=object)
    return WindowSet(np.zeros((n, 1, 4)), ("wz",), ids, ids.copy(), ids.copy(),
                     np.arange(n, dtype=float), np.arange(n) + 1.0, 50.0,
                     {"windows": n, "per_run": {"r1": {"windows": 3}, "r2": {"windows": n - 3}}})


@pytest.mark.parametrize("mask, words", [
    (np.ones(7, dtype=bool), "7 entries for 6 windows"),
    (np.ones(5, dtype=bool), "5 entries for 6 windows"),
    (np.array([0.0, 2.0]), "dtype float64"),
    (np.array([0, 6]), "index 6 outside 0..5"),
    (np.array([-7]), "index -7 outside 0..5"),
    (np.ones((6, 1), dtype=bool), "shape (6, 1)"),
])
def test_a_subset_mask_that_does_not_select_windows_is_a_shape_error(mask, words):
    # NumPy's bare IndexError ("boolean index did not match indexed array along axis 0",
    # "arrays used as indices must be of integer (or boolean) type", "index 6 is out of
    # bounds") named neither the mask nor the window set
    from terrain.errors import ShapeError

    with pytest.raises(ShapeError, match=re.escape(words)):
        _window_set().subset(mask)


def test_a_subset_by_mask_list_or_indices_selects_those_windows():
    ws = _window_set()
    for mask in (np.arange(6) % 2 == 0, [True, False] * 3, np.array([0, 2, 4]), [0, -4, 4]):
        sub = ws.subset(mask)
        np.testing.assert_array_equal(sub.t_start_s, [0.0, 2.0, 4.0])
        assert sub.counts["windows"] == 3 and sub.counts["not_selected"] == 3
    assert len(ws.subset(np.array([], dtype=int))) == 0
    assert len(ws.subset([])) == 0        # (np.asarray([]) is float64: no window, not refused)
