"""Slip-augmented skid-steer EKF (issue 10 item 4) and ``terrain estimate --slip-model``
(item 6) on short simulated Husky runs with truth."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.slip_outputs import slip_model_outputs
from terrain.cli import main
from terrain.estimation.consistency import chi2_test, nees
from terrain.estimation.equations import skid_steer as base
from terrain.estimation.equations import skid_steer_slip as eq
from terrain.estimation.model import finite_difference_jacobian
from terrain.io.measured import read_runs_dir
from terrain.io.writer import write_run
from terrain.sim import SimConfig, simulate
from terrain.slip.estimate import BATCH_FUSION, estimate_skid_steer_slip_run
from terrain.slip.physics import PhysicsSlipSettings

X = np.array([0.8, 0.3, 0.01, np.log(1.4), 0.12, 0.07, 0.2, 0.05])


def test_jacobians_match_finite_differences_and_wheel_rows_reduce_to_the_base_model():
    p = eq.SkidSteerSlipEquationParams()
    np.testing.assert_allclose(eq.H(X, p), finite_difference_jacobian(lambda x: eq.h(x, p), X),
                               atol=1e-7)
    np.testing.assert_allclose(eq.F(X, None, 0.01, p),
                               finite_difference_jacobian(lambda x: eq.f(x, None, 0.01, p), X),
                               atol=1e-9)
    x0 = X.copy()
    x0[4:6] = 0.0
    np.testing.assert_allclose(eq.h(x0, p)[:3], base.h(x0[:4]), rtol=1e-12)
    # rim speed = ground speed / (1 - s) (SAE driving slip)
    np.testing.assert_allclose(eq.h(X, p)[:2] * (1 - X[4:6]), base.h(X[:4])[:2], rtol=1e-12)
    # level ground at rest: the accelerometer reads (0, g)
    np.testing.assert_allclose(eq.h(np.r_[X[:6], 0.0, 0.0], p)[5:], [0.0, p.gravity_m_s2])


@pytest.fixture(scope="module")
def sandy(tmp_path_factory):
    # 40 s as the NEES protocol of docs/slip_learning.md (at 20 s the start-up transient
    # dominates: NEES 3.21 against an upper bound of 3.10 with BATCH_FUSION)
    root = tmp_path_factory.mktemp("fusion")
    write_run(simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",),
                                 scenario="straight_accel", duration_s=40.0, seed=3)), root)
    return root, read_runs_dir(root, dataset="fusion")[0]


def _truth(run, t, cols):
    tr = run.streams["truth"]
    return np.column_stack([np.interp(t, tr["t_s"], tr[c]) for c in cols])


@pytest.mark.slow
def test_fused_slip_is_near_truth_where_the_plain_ekf_reads_zero(sandy):
    _, run = sandy
    outputs = slip_model_outputs(run)
    plain = estimate_skid_steer_slip_run(run, "ekf")
    fused = estimate_skid_steer_slip_run(run, "fused", outputs=outputs)
    late = fused.ekf.t_s > 5.0
    truth = np.median(_truth(run, fused.ekf.t_s, ["slip_1", "slip_2"])[late], axis=0)
    assert truth.min() > 0.05                                      # soft ground slips
    assert np.abs(np.median(plain.slip[plain.ekf.t_s > 5.0], axis=0)).max() < 0.01
    np.testing.assert_allclose(np.median(fused.slip[late], axis=0), truth, atol=0.01)
    assert np.all(fused.slip_std > 0) and np.all(np.isfinite(fused.slip_std))
    assert "not observable" in fused.notes[0] and "physics" in fused.notes[0]


@pytest.mark.slow
def test_nees_inside_chi_square_bounds_with_the_simulation_noise_model(sandy):
    """In simulation the motor and terrain constants are exact: the physics slip's only
    error sources are the current noise and the window model, so its parameter
    uncertainties are 0 rather than the field defaults (per-window RMS z 0.9 on the tuning
    seeds, ``docs/slip_learning.md``)."""
    _, run = sandy
    outputs = slip_model_outputs(run, None, PhysicsSlipSettings(efficiency_rel_std=0.0,
                                                                hysteresis_rel_std=0.0))
    est = estimate_skid_steer_slip_run(run, "physics", outputs=outputs)
    f = est.ekf
    names = ("slip_1", "slip_2")
    idx = [f.state_names.index(n) for n in names]
    late = f.t_s > 3.0
    err = f.x[late][:, idx] - _truth(run, f.t_s[late], names)
    test = chi2_test(nees(err, f.P[late][:, idx][:, :, idx]), 2)
    assert test.inside, test


@pytest.mark.slow
def test_cli_writes_std_columns_and_prints_the_unobservability_note(sandy, tmp_path, capsys,
                                                                    monkeypatch):
    root, _ = sandy
    monkeypatch.chdir(tmp_path)           # no tracking store: the learned model is not found
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)   # exported by an earlier CLI call
    out = tmp_path / "states.csv"
    assert main(["estimate", str(root), "--out", str(out)]) == 0
    frame = pd.read_csv(out)
    cols = list(frame.columns)
    assert cols.index("std_slip_1") == cols.index("slip_1") + 1
    assert cols.index("std_slip_2") == cols.index("slip_2") + 1
    assert (frame[["std_slip_1", "std_slip_2"]] > 0).all().all()
    printed = capsys.readouterr().out
    assert "no learned slip model" in printed
    assert "is not observable from wheel speeds + IMU; supplied by the fused (physics only" \
        in printed
    assert main(["estimate", str(root), "--out", str(out), "--slip-model", "ekf"]) == 0
    assert "no slip model is used" in capsys.readouterr().out
    # --slip-model learned without a model: the fallback is said once (the run's own note
    # repeated the command's, which says where the model was looked for)
    assert main(["estimate", str(root), "--out", str(out), "--slip-model", "learned"]) == 0
    printed = capsys.readouterr().out
    assert printed.count("no learned slip model") == 1
    assert "physics supplies the slip" in printed


def test_pseudo_measurement_takes_the_calibrated_learned_std():
    from terrain.slip.estimate import FusionSettings, pseudo_measurement
    t = np.arange(3.0)
    phys = (t, np.full((3, 2), 0.10), np.full((3, 2), 0.004))
    learned = (t, np.full((3, 2), 0.12), np.array([[0.002] * 2, [np.nan] * 2, [1e-5] * 2]))
    s = FusionSettings(min_std=0.001)
    _, sl, vl = pseudo_measurement({"physics": phys, "learned": learned}, "learned", s)
    np.testing.assert_allclose(sl, 0.12)
    np.testing.assert_allclose(vl[0], 0.002)                        # calibrated std
    np.testing.assert_allclose(vl[1], np.hypot(s.learned_std_floor, 0.02))  # no calibration
    np.testing.assert_allclose(vl[2], s.min_std)                    # floor
    _, sf, vf = pseudo_measurement({"physics": phys, "learned": learned}, "fused", s)
    w = 0.004 ** -2 / (0.004 ** -2 + 0.002 ** -2)                   # inverse-variance weights
    np.testing.assert_allclose(sf[0], w * 0.10 + (1 - w) * 0.12)
    np.testing.assert_allclose(vf[0], 0.002)                        # the better one's std


@pytest.mark.slow
def test_scaled_slip_drift_makes_the_filter_std_proportional_to_the_pseudo_std(sandy):
    """``slip_psd_rel``: drift density ``slip_psd + slip_psd_rel std^2``. With no constant
    part the steady slip variance is proportional to the pseudo-measurement variance, so a
    100x smaller pseudo std gives a ~100x smaller filter std (the wheels and accelerometer
    add little on the slip states); with the constant drift it does not scale."""
    from dataclasses import replace

    from terrain.slip.estimate import FusionSettings
    _, run = sandy
    t, slip, _ = slip_model_outputs(run)["physics"]
    late = {}
    for name, fs in (("scaled", replace(BATCH_FUSION, filter=replace(
            BATCH_FUSION.filter, slip_psd=0.0))), ("constant", FusionSettings(min_std=1e-5))):
        for sd in (1e-2, 1e-4):
            outs = {"physics": (t, slip, np.full_like(slip, sd))}   # drift std = pseudo std
            est = estimate_skid_steer_slip_run(run, "physics", outputs=outs, settings=fs)
            late[name, sd] = np.median(est.slip_std[est.ekf.t_s > 10.0])
    assert 80 < late["scaled", 1e-2] / late["scaled", 1e-4] < 120
    assert late["constant", 1e-2] / late["constant", 1e-4] < 20


def test_segments_process_each_pseudo_measurement_once(sandy):
    """Window centres lie on the filter grid; a segment must not re-process the sample on the
    previous segment's last step (it did, with the next window's variance). With one std and
    one drift for every window the segmented filter is the plain whole-grid filter."""
    from dataclasses import replace

    from terrain.estimation.runner import SensorSamples, make_grid, run_filter
    from terrain.estimation.skid_steer_slip import (SPEED_BOUND_MOVABLE, SPEED_BOUND_NOISE_STDS,
                                                    SkidSteerSlipModel, run_with_pseudo_slip,
                                                    speed_bounds_m_s)
    _, run = sandy
    t, slip, _ = slip_model_outputs(run)["physics"]
    imu, w = run.streams["imu"], run.streams["wheels"]
    samples = {"wheels": SensorSamples(w["t_s"].to_numpy(float),
                                       w[["vel_l", "vel_r"]].to_numpy(float)),
               "gyro": SensorSamples(imu["t_s"].to_numpy(float), imu[["wz"]].to_numpy(float)),
               "accel": SensorSamples(imu["t_s"].to_numpy(float),
                                      imu[["ax", "az"]].to_numpy(float))}
    grid = make_grid(0.0, 20.0, 100.0)
    assert np.isin(np.round(t[t < 20] * 100), np.round(grid * 100)).all()   # on grid steps
    fs = replace(BATCH_FUSION.filter, slip_psd=1e-6, slip_psd_rel=0.0, slip_psd_transient=0.0)
    seg = run_with_pseudo_slip(grid, samples, fs, t, slip, np.full(len(t), 0.004))
    # the segments hand the speed bound on, step for step
    lo, up = speed_bounds_m_s(grid, samples["wheels"], fs.speed_bound_braking_slip,
                              SPEED_BOUND_NOISE_STDS * fs.wheel_std_m_s, fs.speed_bound_hold_s)
    lower, upper = np.full((grid.size, 8), -np.inf), np.full((grid.size, 8), np.inf)
    lower[:, 0], upper[:, 0] = lo, up
    whole = run_filter(SkidSteerSlipModel(replace(fs, slip_std=0.004)), grid,
                       {**samples, "slip_model": SensorSamples(t, slip)},
                       store_covariance=True, engine="numpy", step_bounds=(lower, upper),
                       step_bound_movable=SPEED_BOUND_MOVABLE)
    np.testing.assert_allclose(seg.x, whole.x, atol=1e-12)
    assert seg.meta["step_bounds_active"] == whole.meta["step_bounds_active"]
    np.testing.assert_allclose(seg.P_diag, whole.P_diag, atol=1e-15)
    assert seg.counts["slip_model"]["used"] == whole.counts["slip_model"]["used"] \
        == int(np.sum(t <= 20.0 + 1e-9))


def test_a_pseudo_measurement_with_no_finite_side_is_counted_as_non_finite():
    """A window with one non-finite side was counted in ``non_finite`` (and in the run
    summary's "non-finite samples skipped"); one with neither side finite was dropped before
    the filter saw it, so it vanished from ``samples`` and ``non_finite`` alike."""
    from terrain.estimation.runner import SensorSamples
    from terrain.estimation.skid_steer_slip import SkidSteerSlipSettings, run_with_pseudo_slip
    t = np.arange(401) / 100.0
    samples = {"wheels": SensorSamples(t, np.full((t.size, 2), 0.3))}
    tp = np.array([0.5, 1.5, 2.5, 3.5])
    slip = np.array([[0.1, 0.1], [np.nan, np.nan], [np.nan, 0.1], [0.1, 0.1]])
    res = run_with_pseudo_slip(t, samples, SkidSteerSlipSettings(), tp, slip,
                               np.full(4, 0.05))
    c = res.counts["slip_model"]
    assert (c["samples"], c["non_finite"], c["used"]) == (4, 2, 3)


def test_window_sides_whose_physics_std_is_unknown_are_skipped_and_counted(sandy):
    # a NaN current spread inside a window gave a steady window's std (0); it is now a NaN
    # physics std (terrain.slip.physics.within_window_current_std), which the filter skips:
    # the run says how many window-sides that was, beside the full-slip count
    _, run = sandy
    out = slip_model_outputs(run)
    t, slip, std = out["physics"]
    std = std.copy()
    std[[3, 7, 7], [0, 0, 1]] = np.nan
    out["physics"] = (t, slip, std)
    est = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="none")
    assert est.meta["pseudo_unknown_std"] == 3
    assert any(f"physics slip without a std on 3 of {std.size} window-sides" in n
               for n in est.notes)
    assert est.ekf.counts["slip_model"]["non_finite"] == 2      # windows 3 and 7


def test_a_spinning_start_gets_a_wide_physics_std_and_a_transient_drift():
    """A start on ice spins the wheels (true slip ~0.5 for ~2 s) at the curve's flat
    maximum traction: the window covering it must not claim the knee slip with a small std
    (it did: 0.0045 +- 0.0004), while steady windows keep the current-noise std."""
    run = simulate(SimConfig(vehicle="husky", terrains=("ICE",), scenario="straight_accel",
                             duration_s=12.0, seed=200))
    sim = PhysicsSlipSettings(efficiency_rel_std=0.0, hysteresis_rel_std=0.0)
    out = slip_model_outputs(run, None, sim)
    t, _, std = out["physics"]
    _, _, change = out["physics_transient"]
    _, _, noise = out["physics_current"]
    truth = _truth(run, t, ["slip_1", "slip_2"])
    start, steady = truth.max(axis=1) > 0.2, t > 5.0
    assert start.any() and np.all(std[start] > 0.05)                 # spin: wide
    assert np.all(change[start] > 0.05)                              # ... and a transient
    np.testing.assert_allclose(std[steady], noise[steady], rtol=1e-9)   # steady: noise only
    assert np.all(change[steady] == 0.0)
    err = np.abs(truth[steady] - out["physics"][1][steady])
    assert np.median(err / std[steady]) < 2.0


def test_fused_std_with_an_error_correlation():
    """``error_correlation``: the std of the inverse-variance weighted mean; 1 gives back the
    conservative bound (>= the better std), 0 the independent combination."""
    from terrain.errors import ConfigError
    from terrain.slip.estimate import FusionSettings, pseudo_measurement
    t = np.arange(2.0)
    outs = {"physics": (t, np.full((2, 2), 0.10), np.full((2, 2), 0.004)),
            "learned": (t, np.full((2, 2), 0.12), np.full((2, 2), 0.003))}
    _, _, v0 = pseudo_measurement(outs, "fused", FusionSettings(min_std=1e-6,
                                                                error_correlation=0.0))
    np.testing.assert_allclose(v0, (0.004 ** -2 + 0.003 ** -2) ** -0.5)
    _, _, v1 = pseudo_measurement(outs, "fused", FusionSettings(min_std=1e-6,
                                                                error_correlation=1.0))
    wp = 0.004 ** -2 / (0.004 ** -2 + 0.003 ** -2)
    np.testing.assert_allclose(v1, wp * 0.004 + (1 - wp) * 0.003)
    assert np.all(v1 >= 0.003) and np.all(v0 < 0.003)
    with pytest.raises(ConfigError):
        FusionSettings(error_correlation=1.5)


@pytest.mark.slow
def test_physics_slip_noise_averages_the_runs_own_wheel_rate(tmp_path):
    # a window mean of 15 Hz currents averages 30.5 samples, of 6.5 Hz ones 13.5
    # (terrain.io.align.interpolated_mean_count): the current-noise std of the physics slip
    # scales with 1 / sqrt(count), as on Vulpi's 15 Hz Husky against BorealTC's 6.5 Hz
    import dataclasses

    from features.slip_features import SLIP_WINDOW
    from terrain.io.align import interpolated_mean_count
    from terrain.sim.sensors import SensorSettings

    std = {}
    for rate in (6.5, 15.0):
        root = tmp_path / str(rate)
        sensors = dataclasses.replace(SensorSettings(), wheel_rate_hz=rate)
        write_run(simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",),
                                     scenario="straight_accel", duration_s=20.0, seed=3,
                                     sensors=sensors)), root)
        run = read_runs_dir(root, dataset="rates")[0]
        std[rate] = np.nanmedian(slip_model_outputs(run)["physics_current"][2], axis=0)
    n, rate = round(SLIP_WINDOW.window_s * SLIP_WINDOW.rate_hz), SLIP_WINDOW.rate_hz
    expected = np.sqrt(interpolated_mean_count(n, rate, 6.5)
                       / interpolated_mean_count(n, rate, 15.0))
    np.testing.assert_allclose(std[15.0] / std[6.5], expected, rtol=0.03)


@pytest.mark.slow
@pytest.mark.parametrize("key,n_full", [("SANDY_LOAM/07", 90), ("SNOW/05", 42)])
def test_full_slip_windows_of_measured_soft_ground_keep_the_slip_in_range(borealtc_runs, key,
                                                                          n_full):
    """On measured SANDY_LOAM and SNOW the current often asks for more traction than the
    terrain's curve (rising up to full slip) gives: the physics slip is +-1. It used to
    enter the EKF as +-1 with std 1e-5 where its interval collapsed, and the slip states,
    unbounded, went past +-1 (before: |slip| > 1 in 43 % of SANDY_LOAM/07's steps, max 1.05,
    and 70 % of SNOW/05's, max 1.45). Now such a window-side enters as the centre of its
    physics interval, and the states are clipped into [-1, 1] after every update."""
    run = next(r for r in borealtc_runs if r.run_id == f"borealtc/{key}")
    out = slip_model_outputs(run)
    _, slip, std = out["physics"]
    full = np.abs(slip) >= 1.0
    assert full.sum() == n_full                          # of 94 and 108 window-sides
    assert not np.any(full & (std < 1e-3))               # before: 9 and 2 with std ~0
    lo, up = out["physics_interval"][1:]
    assert np.all(up[full] - lo[full] > 0.01)
    est = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="none")
    assert np.abs(est.slip).max() <= 1.0      # before: 44 % / 70 % of the steps above 1
    assert est.meta["pseudo_full_slip"] == n_full
    assert est.meta["pseudo_full_slip_use"] == "interval centre"
    assert any("full slip" in n for n in est.notes)
    if key == "SNOW/05":
        # the speed stays near the rims (0.54 m/s): 0.56 m/s; skipping those window-sides
        # instead left the speed to the accelerometer, 2.27 m/s
        assert np.abs(est.ekf.state("v_bx")).max() < 1.0
    # without the interval the full-slip window-sides are skipped, and said so
    out.pop("physics_interval")
    skipped = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="none")
    assert skipped.meta["pseudo_full_slip_use"] == "skipped"
    assert np.abs(skipped.slip).max() <= 1.0


def test_slip_states_are_clipped_into_their_physical_range_after_each_update():
    """A slip pseudo-measurement beyond +-1 (or at +-1 with a tiny std, which the wheel rows
    push past) used to leave the states outside [-1, 1]; the model's ``state_bounds`` clip
    them after every update (the compiled loop does not apply bounds: refused)."""
    from terrain.errors import ConfigError
    from terrain.estimation.runner import SensorSamples, run_filter
    from terrain.estimation.skid_steer_slip import SkidSteerSlipModel, SkidSteerSlipSettings
    model = SkidSteerSlipModel(SkidSteerSlipSettings(slip_std=1e-5))
    lower, upper = model.state_bounds
    np.testing.assert_array_equal(lower[4:6], -1.0)
    np.testing.assert_array_equal(upper[4:6], 1.0)
    assert np.all(np.isinf(np.r_[lower[:4], lower[6:], upper[:4], upper[6:]]))
    t = np.arange(0.0, 2.0, 0.01)
    samples = {"wheels": SensorSamples(t, np.full((t.size, 2), 0.3)),
               "slip_model": SensorSamples(t[::50], np.tile([1.3, -1.2], (4, 1)))}
    res = run_filter(model, t, samples, engine="numpy")
    # before: slip_1 1.3, slip_2 -1.2 after the first update
    assert res.state("slip_1").max() == 1.0 and res.state("slip_2").min() == -1.0
    with pytest.raises(ConfigError, match="bounds"):
        run_filter(model, t, samples, engine="numba")


def test_pseudo_measurement_times_are_the_window_centres(sandy):
    """pseudo_measurement's docstring said its t_s were the window ends; they are the window
    centres of slip_model_outputs (1 s, 2 s, ... for 2 s windows hopped by 1 s), the time a
    window mean describes. Docstring-only fix: this pins the behaviour."""
    from features.slip_features import slip_windows
    from terrain.slip.estimate import pseudo_measurement
    _, run = sandy
    ws = slip_windows([run])
    t, slip, std = pseudo_measurement(slip_model_outputs(run), "physics", BATCH_FUSION)
    np.testing.assert_allclose(t, 0.5 * (ws.t_start_s + ws.t_end_s))
    assert np.all(t < ws.t_end_s) and slip.shape == std.shape == (t.size, 2)


def test_speed_bounds_are_the_ground_speeds_the_held_rim_speeds_allow():
    """Each side's contact moves with its rim (|q| < 1 in eqs. 7.1-7.2) and at most
    |omega r| / (1 + s_b) fast; the forward speed is the mean of the sides."""
    from terrain.errors import ConfigError
    from terrain.estimation.runner import SensorSamples
    from terrain.estimation.skid_steer_slip import speed_bounds_m_s
    t = np.arange(0.0, 1.0, 0.1)
    wheels = SensorSamples(np.array([0.2, 0.5, 0.7]),
                           np.array([[0.4, 0.2], [-0.4, 0.2], [np.nan, 1.0]]))
    lo, up = speed_bounds_m_s(t, wheels, -0.5, 0.0)
    # no wheel sample yet: unbounded; then held until the next (the NaN one is skipped)
    assert np.all(np.isinf(lo[:2])) and np.all(np.isinf(up[:2]))
    np.testing.assert_allclose(lo[2:5], 0.0)
    np.testing.assert_allclose(up[2:5], (0.8 + 0.4) / 2)
    np.testing.assert_allclose(lo[5:], -0.8 / 2)            # the left side reverses
    np.testing.assert_allclose(up[5:], 0.4 / 2)
    # the noise margin widens each rim before the slip's factor
    lo, up = speed_bounds_m_s(t, wheels, 0.0, 0.1)
    np.testing.assert_allclose(up[3], (0.5 + 0.3) / 2)
    np.testing.assert_allclose(lo[3], 0.0)
    np.testing.assert_allclose(lo[6], -(0.5 + 0.0) / 2)
    assert np.all(np.isinf(speed_bounds_m_s(t, None, -0.5, 0.1)[1]))
    with pytest.raises(ConfigError, match="braking_slip"):
        speed_bounds_m_s(t, wheels, -1.0, 0.1)


@pytest.mark.slow
def test_the_speed_no_longer_runs_off_on_a_measured_snow_reversal(borealtc_runs):
    """BorealTC SNOW/06: at its two reversals the speed and the slips ran off together along
    the direction the wheels cannot see (v (1 - s) = omega r), the slip reading the reverse
    drive as braking: 6.13 m/s where the rims never passed 0.56 m/s
    (docs/slip_learning.md). With the speed projected back into the range the rims allow at
    a braking slip down to -0.3, it stays within that range and a note counts the steps."""
    from dataclasses import replace
    run = next(r for r in borealtc_runs if r.run_id == "borealtc/SNOW/06")
    out = slip_model_outputs(run)
    rim = np.abs(run.streams["wheels"][["vel_l", "vel_r"]].to_numpy()).max()
    est = estimate_skid_steer_slip_run(run, "fused", outputs=out)
    v = np.abs(est.ekf.state("v_bx"))
    fs = BATCH_FUSION.filter
    assert fs.speed_bound_braking_slip == -0.3
    assert v.max() <= (rim + 3 * fs.wheel_std_m_s) / (1 + fs.speed_bound_braking_slip) + 1e-9
    assert v.max() < 0.9                                   # 0.80; before: 6.13
    held = est.meta["speed_bound_active_steps"]
    assert 0 < held < 0.05 * v.size
    assert any("projected back" in n and f"on {held} of" in n for n in est.notes)
    free = replace(BATCH_FUSION, filter=replace(BATCH_FUSION.filter,
                                                speed_bound_braking_slip=None))
    off = estimate_skid_steer_slip_run(run, "fused", outputs=out, settings=free)
    assert np.abs(off.ekf.state("v_bx")).max() > 5.0       # the run-off, without the bound
    assert off.meta["speed_bound_active_steps"] == 0
    assert not any("projected back" in n for n in off.notes)


@pytest.mark.slow
def test_learned_slip_outputs_refuse_a_model_fitted_on_the_features_in_another_order(tmp_path):
    # slip_model_outputs handed the model a bare array: a model whose feature columns were
    # in another order predicted from the wrong columns without a word
    import warnings

    from features.slip_features import one_hot_probabilities, slip_features, slip_windows
    from terrain.errors import DataWarning, MissingColumnError
    from terrain.slip.learned import SlipRegressor
    from terrain.terramechanics.catalogue import TERRAIN_NAMES
    from terrain.vehicles import HUSKY

    write_run(simulate(SimConfig(vehicle="husky", terrains=("SANDY_LOAM",),
                                 scenario="straight_accel", duration_s=8.0, seed=3)), tmp_path)
    run = read_runs_dir(tmp_path, dataset="order")[0]
    ws = slip_windows([run])
    X = slip_features(ws, HUSKY, one_hot_probabilities(["SANDY_LOAM"] * len(ws), TERRAIN_NAMES))
    rng = np.random.default_rng(0)
    y = np.column_stack([rng.normal(size=(len(X), 2)), np.ones(len(X)), np.zeros(len(X))])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        model = SlipRegressor(max_iter=5, min_samples_leaf=1).fit(X, y)
        reordered = SlipRegressor(max_iter=5, min_samples_leaf=1).fit(X[X.columns[::-1]], y)
    out = slip_model_outputs(run, model)
    np.testing.assert_array_equal(out["learned"][1], model.predict(X.to_numpy())[:, :2])
    with pytest.raises(MissingColumnError, match="another order"):
        slip_model_outputs(run, reordered)


@pytest.mark.parametrize("kwargs,match", [
    (dict(min_std=-0.01), r"FusionSettings.min_std must be a finite std > 0, got -0.01"),
    (dict(min_std=0.0), r"FusionSettings.min_std must be a finite std > 0, got 0.0"),
    (dict(min_std=float("nan")), r"FusionSettings.min_std must be a finite std > 0, got nan"),
    (dict(learned_std_floor=-1.0), r"learned_std_floor must be a finite std >= 0, got -1.0"),
    (dict(learned_std_floor=float("inf")), r"learned_std_floor must be a finite std >= 0"),
    (dict(error_correlation="0.1"), r"FusionSettings.error_correlation must be a real number"),
    (dict(min_std="0.003"), r"FusionSettings.min_std must be a real number"),
    (dict(learned_std_floor=None), r"FusionSettings.learned_std_floor must be a real number"),
    (dict(error_correlation=float("nan")), r"FusionSettings.error_correlation must be in "),
])
def test_fusion_settings_refuse_impossible_floors_and_text(kwargs, match):
    """FusionSettings checked only error_correlation, with np.isfinite: the text '0.1' raised
    numpy's bare TypeError, min_std -0.01 or NaN and learned_std_floor -1 were taken (a NaN
    floor makes every pseudo-measurement std NaN: every window then skipped as non-finite)."""
    from terrain.errors import ConfigError
    from terrain.slip.estimate import FusionSettings
    with pytest.raises(ConfigError, match=match):
        FusionSettings(**kwargs)
    FusionSettings(learned_std_floor=0, error_correlation=None)       # defaults still valid


def test_a_run_on_a_terrain_outside_the_catalogue_gets_no_slip_outputs_and_says_why(sandy):
    """The physics slip needs the terrain's catalogue curve: a run labelled with a terrain
    the catalogue lacks gets no outputs, and the reason names the terrain."""
    from dataclasses import replace

    from features.slip_outputs import missing_slip_inputs

    _, run = sandy
    assert missing_slip_inputs(run) is None
    odd = replace(run, terrain="MARS")
    assert missing_slip_inputs(odd) == "terrain 'MARS' not in the terrain catalogue"
    assert slip_model_outputs(odd) is None


def test_current_and_transient_stds_leave_the_model_uncertainties_out(sandy):
    """``physics_current`` is the current noise alone and ``physics_transient`` the slip
    change inside each window: the gearbox-efficiency and rolling-loss uncertainties of the
    settings widen the ``physics`` std only, not these two (the transient std computed with
    them grew with a wider efficiency prior)."""
    _, run = sandy
    usual = slip_model_outputs(run)
    wide = slip_model_outputs(run, None, PhysicsSlipSettings(efficiency_rel_std=0.3,
                                                             hysteresis_rel_std=0.4))
    for key in ("physics_current", "physics_transient"):
        np.testing.assert_allclose(wide[key][2], usual[key][2], rtol=1e-12, err_msg=key)
    assert (usual["physics_transient"][2] > 0).any()
    assert np.all(wide["physics"][2] > usual["physics"][2])


@pytest.mark.parametrize("drop, reason", [
    ("currents", "no motor currents (cur_l, cur_r)"), ("imu", "no IMU stream"),
    ("wheels", "no wheel stream")])
def test_a_run_lacking_a_slip_input_gets_no_outputs_and_the_reason_names_it(
        sandy, drop, reason):
    """Each missing input is named as itself, before any windowing (which would call a run
    without IMU one without a complete window)."""
    from dataclasses import replace

    from features.slip_outputs import missing_slip_inputs

    _, run = sandy
    streams = dict(run.streams)
    if drop == "currents":
        streams["wheels"] = streams["wheels"].drop(columns=["cur_l", "cur_r"])
    else:
        del streams[drop]
    lacking = replace(run, streams=streams)
    assert missing_slip_inputs(lacking) == reason
    assert slip_model_outputs(lacking) is None
