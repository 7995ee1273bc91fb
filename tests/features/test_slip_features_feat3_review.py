"""Slip features and targets review (feat3): known values of the slope, the inverse ICR
expansion and the chi target; a window without a truth sample has NaN targets."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.slip_features import (INV_CHI_FLOOR_RAD_S, SLIP_CHANNELS, slip_feature_matrix,
                                    slip_targets)
from features.windows import WindowSet
from terrain.errors import ConfigError
from terrain.run import TIME, Run
from terrain.vehicles import HUSKY, get_vehicle

RATE = 50.0


def _windows(vel_l, vel_r, wz):
    """``(n_windows, len(SLIP_CHANNELS), n)`` windows with the given speeds and yaw rate."""
    n_w, n = vel_l.shape
    values = {c: np.zeros((n_w, n)) for c in SLIP_CHANNELS}
    values.update(vel_l=vel_l, vel_r=vel_r, vel_diff=vel_r - vel_l, wz=wz,
                  cur_l=np.full((n_w, n), 5.0), cur_r=np.full((n_w, n), 6.0),
                  az=np.full((n_w, n), 9.81))
    return np.stack([values[c] for c in SLIP_CHANNELS], axis=1)


def test_the_slope_of_a_speed_ramp_is_its_acceleration_in_m_per_s2():
    t = np.arange(100) / RATE
    v = np.stack([0.5 + 0.2 * t, 1.0 - 0.3 * t])
    names, f = slip_feature_matrix(_windows(v, v, np.zeros_like(v)), SLIP_CHANNELS, RATE,
                                   HUSKY)
    np.testing.assert_allclose(f[:, names.index("vel_mean__slope")], [0.2, -0.3], rtol=1e-12)


def test_inv_chi_divides_by_the_track_of_the_vehicle_given():
    # gyro yaw rate (v_R - v_L) / (chi B) on the tracked test bed (B = 0.393 m): the gain of
    # wz on (v_R - v_L) / B is the ridge-floored 1 / chi of that vehicle's own track
    tracked = get_vehicle("tracked")
    t = np.arange(100) / RATE
    dv = 0.3 + 0.1 * np.sin(2 * np.pi * 0.5 * t)[None]
    vel_l, vel_r = 0.5 - dv / 2, 0.5 + dv / 2
    chi = 1.6
    wz = dv / (chi * tracked.track_m)
    names, f = slip_feature_matrix(_windows(vel_l, vel_r, wz), SLIP_CHANNELS, RATE, tracked)
    x = dv[0] / tracked.track_m
    want = np.dot(x, wz[0]) / (np.dot(x, x) + x.size * INV_CHI_FLOOR_RAD_S ** 2)
    np.testing.assert_allclose(f[0, names.index("inv_chi")], want, rtol=1e-12)
    assert abs(want - 1 / chi) < 0.01


def _truth_run(yaw_rate, dv, gap=None):
    tt = np.arange(0, 10.0, 0.01)
    truth = pd.DataFrame({TIME: tt, "slip_1": 0.1, "slip_2": 0.2, "yaw_rate": yaw_rate,
                          "v_by": 0.01, "terrain": "SNOW"})
    if gap is not None:
        truth = truth[(tt < gap[0]) | (tt >= gap[1])]
    return Run("sim1", "sim", "SNOW", {"truth": truth})


def _window_set(dv, t0):
    n = 100
    vel_l = np.full((len(t0), n), 0.5)
    X = _windows(vel_l, vel_l + dv, np.zeros_like(vel_l))
    t0 = np.asarray(t0, dtype=float)
    return WindowSet(X, SLIP_CHANNELS, np.array(["sim1"] * len(t0), dtype=object),
                     np.array(["sim1"] * len(t0), dtype=object),
                     np.array(["SNOW"] * len(t0), dtype=object), t0, t0 + 2.0, RATE)


def test_chi_target_is_the_wheel_speed_difference_over_track_times_yaw_rate():
    # chi = mean(v_R - v_L) / (B mean(yaw rate)): 0.3 m/s over 0.5708 m at 0.35 rad/s
    ws = _window_set(0.3, [0.0, 2.0])
    Y = slip_targets([_truth_run(0.35, 0.3)], ws, HUSKY.track_m)
    np.testing.assert_allclose(Y["chi"], 0.3 / (HUSKY.track_m * 0.35), rtol=1e-12)
    np.testing.assert_allclose(Y[["slip_1", "slip_2", "v_by"]], [[0.1, 0.2, 0.01]] * 2)
    # below MIN_TURN_RATE_RAD_S the chi target is undefined
    assert np.isnan(slip_targets([_truth_run(0.05, 0.3)], ws, HUSKY.track_m)["chi"]).all()


def test_a_window_without_a_truth_sample_has_nan_targets_not_zeros():
    ws = _window_set(0.3, [0.0, 4.0])
    Y = slip_targets([_truth_run(0.35, 0.3, gap=(3.9, 6.1))], ws, HUSKY.track_m)
    assert np.isfinite(Y.loc[0, ["slip_1", "slip_2", "yaw_rate", "v_by", "chi"]]).all()
    assert Y.loc[1, ["slip_1", "slip_2", "yaw_rate", "v_by", "chi"]].isna().all()


@pytest.mark.parametrize("rate", [0.0, -50.0, float("nan"), float("inf"), True])
def test_a_rate_that_is_not_a_positive_number_is_refused_naming_it(rate):
    # a negative rate flipped the sign of the slope (and of the pitch correction) without a
    # word: -50 Hz gave vel_mean__slope -0.2 m/s^2 for a ramp of +0.2; 0 Hz gave NaN
    t = np.arange(100) / RATE
    v = (0.5 + 0.2 * t)[None]
    with pytest.raises(ConfigError, match="slip_feature_matrix.rate_hz"):
        slip_feature_matrix(_windows(v, v, np.zeros_like(v)), SLIP_CHANNELS, rate, HUSKY)


def test_a_window_of_one_sample_is_refused_not_given_a_nan_slope():
    # one sample has no slope: 0/0 gave vel_mean__slope and pitch NaN with a RuntimeWarning
    v = np.full((1, 1), 0.5)
    with pytest.raises(ConfigError, match="n_samples >= 2"):
        slip_feature_matrix(_windows(v, v, np.zeros_like(v)), SLIP_CHANNELS, RATE, HUSKY)
