"""Review slp22: numerical robustness (valid inputs near the edges of a formula's domain,
long runs, epoch clocks, tiny residuals) and determinism of the slip area."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

FAST = settings(max_examples=60, deadline=None)


def _fused_std_reference(vp: float, vl: float, rho: float) -> float:
    """The std of the inverse-variance weighted mean, in exact rational arithmetic."""
    vp, vl, rho = Fraction(vp), Fraction(vl), Fraction(rho)
    wp, wl = 1 / vp ** 2, 1 / vl ** 2
    a, b = wp / (wp + wl) * vp, wl / (wp + wl) * vl
    return float(a * a + b * b + 2 * rho * a * b) ** 0.5


@FAST
@given(st.floats(1e-4, 0.5), st.floats(-1e-6, 1e-6), st.floats(-1.0, -0.999))
def test_fused_std_with_a_negative_correlation_is_never_nan(vp, rel, rho):
    """rho = -1 (allowed) with two nearly equal stds: the variance a^2 + b^2 - 2 a b of the
    weighted mean is ~0 and rounding made it negative, the std NaN (the pseudo-measurement
    then silently skipped); it is the exact std, floored."""
    from terrain.slip.estimate import FusionSettings, pseudo_measurement

    vl = vp * (1.0 + rel)
    t = np.arange(1.0)
    out = {"physics": (t, np.zeros((1, 2)), np.full((1, 2), vp)),
           "learned": (t, np.zeros((1, 2)), np.full((1, 2), vl))}
    floor = 1e-9
    fs = FusionSettings(min_std=floor, error_correlation=rho)
    _, _, std = pseudo_measurement(out, "fused", fs)
    assert np.all(np.isfinite(std))
    ref = max(_fused_std_reference(vp, vl, rho), floor)
    np.testing.assert_allclose(std, ref, rtol=1e-6)


def test_fused_std_at_minus_one_correlation_in_bulk():
    """Many window-sides: none NaN (10 % were, with stds within 1e-9 of each other)."""
    from terrain.slip.estimate import FusionSettings, pseudo_measurement

    rng = np.random.default_rng(0)
    vp = rng.uniform(1e-3, 0.1, (5000, 2))
    vl = vp * (1 + rng.uniform(-1e-9, 1e-9, vp.shape))
    t = np.arange(5000.0)
    out = {"physics": (t, np.zeros_like(vp), vp), "learned": (t, np.zeros_like(vl), vl)}
    fs = FusionSettings(min_std=1e-5, error_correlation=-1.0)
    _, _, std = pseudo_measurement(out, "fused", fs)
    assert not np.isnan(std).any()
    np.testing.assert_array_equal(std, 1e-5)


def _westward_run(yaw_of_truth):
    """A Husky driving 10 m straight due west (heading pi) at 1 m/s, wheels and truth exact;
    the wheels start between two truth samples (truth at 10 Hz from t = -0.05 s)."""
    import pandas as pd

    from terrain.run import Run

    t = np.arange(0.0, 10.0 + 1e-9, 0.01)
    wheels = pd.DataFrame({"t_s": t, "vel_l": 1.0, "vel_r": 1.0})
    tt = np.arange(-0.05, 10.2, 0.1)
    # the heading wobbles around pi by 1e-3 rad, as a measured heading does
    yaw = np.pi + 1e-3 * np.where(np.arange(tt.size) % 2, 1.0, -1.0)
    truth = pd.DataFrame({"t_s": tt, "x": -tt, "y": 0.0, "yaw": yaw_of_truth(yaw)})
    return Run("sim/ASPHALT/west/0", "sim", "ASPHALT", {"wheels": wheels, "truth": truth})


def test_odometry_errors_read_a_wrapped_truth_heading_as_an_angle():
    """A truth yaw wrapped to [-pi, pi) (as a logged heading is) straddling +-pi where dead
    reckoning starts was interpolated as a number (pi - 1e-3 and -pi + 1e-3 gave ~0 rad),
    the truth turned by pi into the start frame: exact odometry scored 200 % off. It is
    read as an angle: the wrapped and the unwrapped heading give the same figures."""
    import pandas as pd

    from terrain.slip.evaluation import odometry_errors
    from terrain.vehicles.skid_steer import HUSKY

    meta = pd.DataFrame({"run_id": "sim/ASPHALT/west/0", "t_start_s": [0.0, 5.0],
                         "t_end_s": [5.0, 10.0]})
    pred = np.zeros((2, 4)) + [0, 0, 1, 0]
    rows = [odometry_errors([_westward_run(f)], meta, pred, HUSKY.track_m,
                            ["sim/ASPHALT/west/0"])
            for f in (lambda y: y, lambda y: (y + np.pi) % (2 * np.pi) - np.pi)]
    for out in rows:
        assert out.loc[0, "plain_err_pct"] < 0.5
    cols = ["plain_err_pct", "compensated_err_pct", "distance_m"]
    np.testing.assert_allclose(rows[1][cols].to_numpy(float), rows[0][cols].to_numpy(float),
                               rtol=1e-9, atol=1e-9)


def _hour_at_100_hz():
    k = np.arange(360_001)
    vl = 1.0 + 0.3 * np.sin(2 * np.pi * k / 6000.0)
    vr = 1.0 + 0.3 * np.cos(2 * np.pi * k / 4500.0)
    s1 = 0.05 + 0.02 * np.sin(k / 700.0)
    s2 = -0.04 + 0.02 * np.cos(k / 900.0)
    return k * 0.01, vl, vr, s1, s2


def _dead_reckon_long_double(t, vl, vr, track, s1, s2, chi, lateral):
    """The module's scheme (trapezoidal speeds, midpoint heading) in long double."""
    from terrain.terramechanics.slip import ground_speed_from_slip

    L = np.longdouble
    v = (ground_speed_from_slip(vl, s1).astype(L) + ground_speed_from_slip(vr, s2).astype(L)) / 2
    w = (vr.astype(L) - vl.astype(L)) / (L(chi) * L(track))
    dt = np.diff(t.astype(L))
    wm, vm = (w[:-1] + w[1:]) / 2, (v[:-1] + v[1:]) / 2
    yaw = np.concatenate([[L(0)], np.cumsum(wm * dt)])
    mid = yaw[:-1] + dt * wm / 2
    x = np.cumsum((vm * np.cos(mid) - L(lateral) * np.sin(mid)) * dt)
    y = np.cumsum((vm * np.sin(mid) + L(lateral) * np.cos(mid)) * dt)
    return np.column_stack([np.concatenate([[L(0)], x]), np.concatenate([[L(0)], y]), yaw])


def test_dead_reckon_over_an_hour_at_100_hz_matches_long_double_and_an_epoch_clock():
    """360 000 steps: the float64 pose stays within 1e-9 m (rad) of the same scheme in long
    double (no accumulation beyond rounding), and on an epoch clock (t + 1.7e9 s, whose
    steps are off by up to 2.4e-7 s each) within 1e-5 m of the pose on a clock from 0:
    the steps telescope, the duration is not lost."""
    from terrain.slip.odometry import dead_reckon

    t, vl, vr, s1, s2 = _hour_at_100_hz()
    pose = dead_reckon(t, vl, vr, 0.555, s1, s2, 1.7, 0.01)
    ref = _dead_reckon_long_double(t, vl, vr, 0.555, s1, s2, 1.7, 0.01).astype(float)
    np.testing.assert_allclose(pose, ref, rtol=0, atol=1e-9)
    assert np.abs(pose[:, :2]).max() > 10      # tens of metres, turning: a real check
    epoch = dead_reckon(t + 1.7e9, vl, vr, 0.555, s1, s2, 1.7, 0.01)
    np.testing.assert_allclose(epoch, pose, rtol=0, atol=1e-5)
