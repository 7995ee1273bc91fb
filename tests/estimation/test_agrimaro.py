"""AgriMaRo 12-state EKF on simulated ground truth: Coriolis convention, NEES, NIS, RMSE."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.errors import EstimationError
from terrain.estimation import ema_filter, wrap_angle
from terrain.estimation.agrimaro import STATE_NAMES, AgriMaRoEKFSettings, estimate_agrimaro
from terrain.estimation.consistency import mean_chi2_bounds
from terrain.estimation.slip_state import SlipStateModel
from pipelines.validation.harness import (THESIS_TERRAINS, agrimaro_consistency,
                                          coriolis_filter_rmse, coriolis_prediction_error,
                                          simulate_agrimaro, truth_on_grid)


@pytest.fixture(scope="module")
def turning_run():
    """Omnidirectional random driving with turns (where the Coriolis terms matter)."""
    return simulate_agrimaro("GRASS", seed=1, duration_s=20.0, scenario="random")


@pytest.mark.slow
def test_coriolis_signs_of_eqs_4_33_4_34_match_simulated_truth(turning_run):
    err = coriolis_prediction_error(turning_run)
    # fed with true v, yaw rate and accelerometer acceleration, the body-frame signs
    # reproduce the next velocity to round-off; the signs printed in eq. 6.2 do not
    assert err["body"] < 1e-9
    assert err["eq6.2"] > 1e-3
    rmse = coriolis_filter_rmse(turning_run)
    assert rmse["body"]["v_by"] < 0.8 * rmse["eq6.2"]["v_by"]


@pytest.mark.slow
def test_mean_nees_against_the_bounds_of_a_time_average_on_grass():
    """The ANEES is a time average of the run-averaged NEES: its bounds are those of
    ``M n_eff`` chi-square(12) values, not one step's ``chi2(12 M) / M``, which the check
    used before (4 runs: [7.69, 17.26], about 4x wider here)."""
    row = agrimaro_consistency("GRASS", seeds=range(4), duration_s=12.0)
    lo, hi = mean_chi2_bounds(12, 4)
    assert row.nees_step_bounds == pytest.approx((lo, hi))
    assert 5 < row.nees_n_eff < 100                        # 14 of 1201 steps
    assert row.nees_bounds == pytest.approx(mean_chi2_bounds(12, 4 * row.nees_n_eff))
    assert row.nees_bounds[1] - row.nees_bounds[0] < 0.5 * (hi - lo)
    # 12 s runs: the start-up transient lifted the mean to 12.59, inside [10.76, 13.31];
    # the 20 s runs of the slow test below are conservative (ANEES 9.4-10.1, below n = 12).
    # The ANEES's bounds are checked in the strict xfail below (11.02 since 2026-11-30)
    assert row.anees < row.nees_bounds[1], row.as_dict()
    assert row.rmse["v_bx"] < 0.03 and row.rmse["yaw_rate"] < 0.01
    # NIS is reported but conservative on nearly every row (docs/estimation_validation.md:
    # the predicted covariance dominates S, and R sits above the simulated noise on some rows)
    assert 0 < row.nis_mean < row.nis_dof


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "reported, not loosened (2026-11-30): since the AgriMaRo's steering offsets come from a "
    "generator of their own, every later draw of these four 12 s GRASS runs (seeds 0-3) "
    "changed and their ANEES moved from 12.59 to 11.018 (11.015 once the implicit step "
    "iterates), 0.02 under the lower bound 11.036 of [11.04, 13.00]: the filter is slightly "
    "conservative on these draws, as it is on the 20 s runs (ANEES 9.2-9.5)"))
def test_mean_nees_of_four_12_s_grass_runs_lies_inside_its_bounds():
    row = agrimaro_consistency("GRASS", seeds=range(4), duration_s=12.0)
    assert row.nees_bounds[0] <= row.anees <= row.nees_bounds[1], row.as_dict()


@pytest.mark.slow
@pytest.mark.parametrize("terrain", THESIS_TERRAINS)
def test_mean_nees_is_conservative_on_thesis_terrains_ten_runs(terrain):
    """10 runs of 20 s: the ANEES (TILES 10.09, GRASS 9.49, GRAVEL 9.37) lies below n = 12
    and below the lower bound of the time average (TILES [11.67, 12.34], GRASS [11.89,
    12.11], GRAVEL [11.93, 12.07]): the filter is conservative, the consistency target is
    not met. (Against one step's bounds [9.16, 15.22] it read as inside, "target met".)"""
    row = agrimaro_consistency(terrain, seeds=range(10), duration_s=20.0)
    assert row.nees_step_bounds[0] <= row.anees <= row.nees_step_bounds[1]
    assert row.anees < row.nees_bounds[0] < 12.0 < row.nees_bounds[1], row.as_dict()


@pytest.mark.slow
def test_thesis_tuning_runs_and_tracks_velocity(turning_run):
    run = turning_run.run
    res = estimate_agrimaro(run, AgriMaRoEKFSettings())
    tr = truth_on_grid(turning_run, res.t_s)
    assert np.isfinite(res.x).all()
    assert np.sqrt(np.mean((res.state("v_by") - tr["v_by"]) ** 2)) < 0.1
    assert res.meta["settings"] == "thesis"
    eig = np.linalg.eigvalsh(np.diag(res.P_diag[-1]))
    assert (eig > 0).all()


@pytest.mark.slow
def test_slip_state_design_of_chapter_4_3_is_badly_behaved():
    """The 14-state design (slip in the state, no camera) cannot tell velocity from slip."""
    result = simulate_agrimaro("GRASS", seed=3, duration_s=15.0)
    run = result.run
    res = estimate_agrimaro(run, model=SlipStateModel(), store_covariance=False)
    tr = truth_on_grid(result, res.t_s)
    steady = res.t_s > 5.0
    slip_err = np.abs(res.state("slip_1")[steady] - tr["slip_1"][steady]).mean()
    # the true steady slip on grass is ~0.13; the ch. 4.3 filter stays near its zero start
    assert tr["slip_1"][steady].mean() > 0.1
    assert slip_err > 0.05
    # with the T265 camera rows the same state vector becomes observable
    cam = estimate_agrimaro(run, model=SlipStateModel(accel="direct", camera=True))
    cam_err = np.abs(cam.state("slip_1")[steady] - tr["slip_1"][steady]).mean()
    assert cam_err < slip_err


def _with_camera_yaw(run, yaw_c):
    cam = run.streams["cam"].copy()
    cam["yaw_c"] = yaw_c
    return replace(run, streams={**run.streams, "cam": cam})


@pytest.mark.parametrize("settings", [AgriMaRoEKFSettings(),
                                      AgriMaRoEKFSettings(ema_alpha=(("cam", 0.2),))],
                         ids=["thesis", "camera-ema"])
def test_camera_heading_wrapped_at_pi_gives_the_same_estimate(turning_run, settings):
    # a T265 reports its yaw in [-pi, pi): the EMA of eq. 6.12 / 7.8 must not average across
    # the 2 pi jump (it invented headings in between: innovations of 1.26 rad, NIS x20)
    run = turning_run.run
    yaw = run.streams["cam"]["yaw_c"].to_numpy()
    crossing = yaw + (np.pi - yaw[len(yaw) // 2])          # crosses +pi half-way
    wrapped = wrap_angle(crossing)
    assert np.ptp(wrapped) > 6.0                           # the jump is in the data
    base = estimate_agrimaro(_with_camera_yaw(run, crossing), settings)
    other = estimate_agrimaro(_with_camera_yaw(run, wrapped), settings)
    assert np.isfinite(other.x).all()
    yaw_col = STATE_NAMES.index("yaw")
    rest = [j for j in range(len(STATE_NAMES)) if j != yaw_col]
    np.testing.assert_allclose(other.x[:, rest], base.x[:, rest], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(other.x[:, yaw_col] - base.x[:, yaw_col]), 0.0,
                               atol=1e-9)
    np.testing.assert_allclose(other.nis, base.nis, rtol=1e-7, atol=1e-9)


def test_ema_filter_averages_angles_along_their_unwrapped_sequence():
    t = np.linspace(0.0, 1.0, 101)
    heading = 3.0 + 0.5 * t                                # passes pi at t = 0.28
    smooth = ema_filter(wrap_angle(heading)[:, None], 0.5, angle_columns=[0])[:, 0]
    plain = ema_filter(heading, 0.5)
    np.testing.assert_allclose(wrap_angle(smooth - plain), 0.0, atol=1e-12)
    # a non-angle column, or no angle column given, is averaged as before
    both = ema_filter(np.column_stack([heading, heading]), 0.5, angle_columns=[1])
    np.testing.assert_array_equal(both[:, 0], plain)
    with pytest.raises(EstimationError, match="angle columns"):
        ema_filter(heading, 0.5, angle_columns=[1])


def test_ema_filter_holds_the_previous_input_over_a_non_finite_sample():
    """The docstring said a non-finite sample repeats the previous *output*; the recursion
    holds the previous finite *input* (0, 5, nan, 8.75; repeating the output would end at
    7.5). Docstring-only fix: this pins the behaviour and runs the docstring's example."""
    import doctest

    import terrain.estimation.prefilter as prefilter
    out = ema_filter(np.array([0.0, 10.0, np.nan, 10.0]), 0.5)
    np.testing.assert_allclose(out, [0.0, 5.0, np.nan, 8.75])
    lead = ema_filter(np.array([np.nan, 4.0, 8.0]), 0.5)     # leading: the first finite one
    np.testing.assert_allclose(lead, [np.nan, 4.0, 6.0])
    finder = doctest.DocTestFinder()
    (test,) = [t for t in finder.find(prefilter) if t.name.endswith(".ema_filter")]
    assert test.examples                                    # the example is in the docstring
    result = doctest.DocTestRunner().run(test, out=lambda _: None)
    assert result.failed == 0 and result.attempted >= 1


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_imu_yaw_integral_leaves_non_finite_gyro_samples_out(bad):
    """``yaw_imu`` is the integral of ``wz``: a non-finite gyro sample was read as 0 rad/s
    (``nan_to_num``), so a 1 s NaN gap while turning at 0.5 rad/s left the yaw 0.5 rad
    short for the rest of the run (used as a measurement), and one inf made every later
    yaw 9e305 rad (a frozen heading, wrapped to an arbitrary angle). Left out, the
    integral spans the gap; the sample's own yaw_imu is non-finite like its wz."""
    import pandas as pd

    from terrain.estimation.agrimaro import agrimaro_samples
    from terrain.run import Run

    t = np.round(np.arange(501) * 0.01, 10)
    wz = np.full(t.size, 0.5)
    gap = (t > 2.0) & (t < 3.0) if np.isnan(bad) else t == 2.5
    wz[gap] = bad
    imu = pd.DataFrame({"t_s": t, "ax": 0.0, "ay": 0.0, "wz": wz})
    run = Run("sim/TEST/00", "sim", "TEST", {"imu": imu}, vehicle="agrimaro")
    yaw = agrimaro_samples(run, AgriMaRoEKFSettings(ema_alpha=()))["imu"].values[:, 3]
    assert np.isnan(yaw[gap]).all()
    np.testing.assert_allclose(yaw[~gap], 0.5 * t[~gap], atol=1e-9)


def _tiny_agrimaro_run(n=101):
    import pandas as pd

    from terrain.run import Run

    t = np.round(np.arange(n) * 0.01, 10)
    imu = pd.DataFrame({"t_s": t, "ax": 0.0, "ay": 0.0, "wz": 0.1})
    cam = pd.DataFrame({"t_s": t[::3], "v_cx": 0.0, "v_cy": 0.0, "yaw_rate_c": 0.1,
                        "yaw_c": 0.1 * t[::3]})
    return Run("sim/TEST/07", "sim", "TEST", {"imu": imu, "cam": cam}, vehicle="agrimaro",
               source="test.csv")


def test_agrimaro_run_errors_name_the_run_and_the_stream():
    """An imu stream without wz raised a bare KeyError 'wz' (only the other streams' columns
    were checked); a repeated timestamp TimeStepError 'sensor timestamps must be finite and
    strictly increasing' without run or stream; an empty imu stream numpy's IndexError
    'index 0 is out of bounds', one IMU sample TimeStepError 'rate must be > 0 Hz, got nan'."""
    from dataclasses import replace as dc_replace

    from terrain.errors import DataFormatError, MissingColumnError, TimeStepError
    run = _tiny_agrimaro_run()
    assert estimate_agrimaro(run).counts["imu"]["used"] == 101          # the run itself is fine
    no_wz = dc_replace(run, streams={**run.streams, "imu": run.streams["imu"].drop(
        columns=["wz"])})
    with pytest.raises(MissingColumnError, match=r"run sim/TEST/07: stream 'imu' lacks "
                                                 r"columns \['wz'\]"):
        estimate_agrimaro(no_wz)
    cam = run.streams["cam"].copy()
    cam.loc[5, "t_s"] = cam.loc[4, "t_s"]
    with pytest.raises(TimeStepError, match=r"run sim/TEST/07: stream 'cam': .*sample 5 "
                                            r"at 0.12 s after 0.12 s"):
        estimate_agrimaro(dc_replace(run, streams={**run.streams, "cam": cam}))
    for n in (0, 1):
        short = dc_replace(run, streams={**run.streams, "imu": run.streams["imu"].iloc[:n]})
        with pytest.raises(DataFormatError, match=rf"run sim/TEST/07: stream 'imu' has {n} "
                                                  r"samples?; the filter's clock needs 2"):
            estimate_agrimaro(short)


def test_an_unknown_sensor_or_latency_key_is_refused():
    """sensors=('imu', 'camera') ran without the camera ('cam') and time_offsets_s={'wheels':
    0.05} applied no latency (the sensor is 'omega'), both without a word; both are now a
    ConfigError naming the unknown names and the sensors there are."""
    from terrain.errors import ConfigError
    run = _tiny_agrimaro_run()
    with pytest.raises(ConfigError, match=r"sensors names \['camera'\], not a sensor of the "
                                          r"filter \(sensors: \['omega', 'imu', 'steer', "
                                          r"'cam'\]\)"):
        estimate_agrimaro(run, sensors=("imu", "camera"))
    with pytest.raises(ConfigError, match=r"time_offsets_s names \['wheels'\]"):
        estimate_agrimaro(run, time_offsets_s={"wheels": 0.05})
    assert estimate_agrimaro(run, sensors=("imu",)).counts.keys() == {"imu"}


def test_a_sensor_latency_is_subtracted_from_its_timestamps_only(turning_run):
    """``time_offsets_s`` is a latency: a camera that reports 30 ms late has its samples
    moved 30 ms earlier; the other sensors stay where they were."""
    from terrain.estimation.agrimaro import agrimaro_samples
    base = agrimaro_samples(turning_run.run)
    late = agrimaro_samples(turning_run.run, time_offsets_s={"cam": 0.03})
    np.testing.assert_allclose(late["cam"].t_s, base["cam"].t_s - 0.03, atol=1e-12)
    np.testing.assert_array_equal(late["cam"].values, base["cam"].values)
    np.testing.assert_array_equal(late["imu"].t_s, base["imu"].t_s)


def test_wheel_speeds_stand_in_for_the_wheel_rates_in_rad_per_s():
    """A run without an ``omega`` stream feeds wheels 1 and 2 from the ``wheels`` stream:
    ``vel_l``, ``vel_r`` (m/s) divided by the wheel radius give the encoder rates (rad/s) of
    the wheel rows; wheel 3 has no sample, and the latency of ``omega`` moves them."""
    import pandas as pd

    from terrain.estimation.agrimaro import agrimaro_samples
    from terrain.run import Run
    from terrain.vehicles.swerve import AGRIMARO

    t = np.round(np.arange(11) * 0.1, 10)
    imu = pd.DataFrame({"t_s": t, "ax": 0.0, "ay": 0.0, "wz": 0.0})
    wheels = pd.DataFrame({"t_s": t, "vel_l": 0.5, "vel_r": 0.8})
    run = Run("sim/TEST/01", "sim", "TEST", {"imu": imu, "wheels": wheels}, vehicle="agrimaro")
    omega = agrimaro_samples(run, AgriMaRoEKFSettings(ema_alpha=()),
                             time_offsets_s={"omega": 0.05})["omega"]
    r = AGRIMARO.wheel_radius_m
    np.testing.assert_allclose(omega.values[:, :2], np.tile([0.5 / r, 0.8 / r], (11, 1)))
    assert np.isnan(omega.values[:, 2]).all()
    np.testing.assert_allclose(omega.t_s, t - 0.05)


@pytest.mark.parametrize("offset", [True, None, np.array([0.01, 0.02])])
def test_a_sensor_latency_that_is_not_one_number_is_refused_naming_the_sensor(offset):
    """time_offsets_s={'cam': True} moved the camera 1 s earlier without a word, None was
    Python's bare TypeError in float(None) and an array of two latencies NumPy's; each is a
    ConfigError naming time_offsets_s.cam."""
    from terrain.errors import ConfigError
    from terrain.estimation.agrimaro import agrimaro_samples
    with pytest.raises(ConfigError, match=r"time_offsets_s\.cam must be a real number"):
        agrimaro_samples(_tiny_agrimaro_run(), time_offsets_s={"cam": offset})
