"""Review tests of the thin pipelines (pipelines/validation, live_terrain, slip_model...)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pipelines.validation.sim_tables import regression_chi
from terrain.run import TIME, Run
from terrain.vehicles import HUSKY


def test_regression_chi_fits_only_the_turning_samples_and_gives_command_over_gyro():
    # chi = (v_R - v_L) / B over the measured yaw rate, fitted where |(v_R - v_L) / B| >
    # 0.2 rad/s: a straight-line sample (gyro noise, no commanded turn) must not enter
    t = np.arange(0.0, 10.0, 0.1)
    x = np.linspace(-1.0, 1.0, len(t))               # commanded turn rate, rad/s
    wheels = pd.DataFrame({TIME: t, "vel_l": -x * HUSKY.track_m / 2,
                           "vel_r": x * HUSKY.track_m / 2})
    wz = np.where(np.abs(x) > 0.2, x / 1.6, 0.3)     # chi 1.6; a gyro offset near x = 0
    imu = pd.DataFrame({TIME: t, "wz": wz})
    run = Run("r", "sim", "ICE", {"wheels": wheels, "imu": imu})
    assert regression_chi(run) == pytest.approx(1.6, rel=1e-9)
    # with gyro noise: the least-squares slope of wz on x (through 0) is 1 / chi, not the
    # slope of x on wz
    noisy = wz + 0.05 * np.cos(7.0 * t)
    run = Run("r", "sim", "ICE", {"wheels": wheels, "imu": imu.assign(wz=noisy)})
    turning = np.abs(x) > 0.2
    slope = np.linalg.lstsq(x[turning, None], noisy[turning], rcond=None)[0][0]
    assert regression_chi(run) == pytest.approx(1.0 / slope, rel=1e-9)
    assert abs(regression_chi(run) - 1.6) > 1e-3       # the noise does move it


class _Stop(Exception):
    """Raised by a stand-in once the arguments it was called with are recorded."""


def test_control_grid_tunes_with_the_estimator_feed_forward_and_grids_asked_for(
        tmp_path, monkeypatch):
    # the tuning runs must be those of the grid: the Husky's --husky-estimator, without
    # feed-forward under --no-feed-forward, over the gain grids given (tuned with the
    # default estimator and the feed-forward on, the gains would fit another controller)
    from cli_helpers import RecordingRun

    import pipelines.control_grid as control_grid
    from terrain.cli import main

    calls = []

    def capture(vehicle, terrains, kp_grid, ki_grid, **kwargs):
        calls.append((vehicle, terrains, kp_grid, ki_grid, kwargs))
        raise _Stop()

    monkeypatch.chdir(tmp_path)
    # (at the command's module: patched in terrain.tracking, the stand-in was bound for good
    # by every command module main() imported for the first time meanwhile)
    monkeypatch.setattr(control_grid, "tracked_run", RecordingRun())
    monkeypatch.setattr(control_grid, "tune_gains", capture)
    assert main(["control-grid", "--vehicles", "husky", "--terrains", "ICE",
                 "--husky-estimator", "observer", "--no-feed-forward", "--kp-grid", "3", "4",
                 "--ki-grid", "1", "--seeds", "3", "--duration-s", "1.5", "--out", "g"]) == 1
    (vehicle, terrains, kp_grid, ki_grid, kwargs), = calls
    assert (vehicle, terrains, kp_grid, ki_grid) == ("husky", ["ICE"], [3.0, 4.0], [1.0])
    assert kwargs["estimator"] == "observer" and kwargs["feed_forward"] is False


@pytest.mark.parametrize("argv, code", [
    (["--repeats", "100"], 1),              # MAX_REPEATS itself is taken (stand-in stops it)
    (["--repeats", "101"], 2),
    (["--repeats", "0"], 2),
    (["--reference-windows", "1"], 1),
    (["--reference-windows", "0"], 2),
])
def test_benchmark_takes_repeats_up_to_the_maximum_and_one_reference_window(
        argv, code, monkeypatch, capsys):
    # refused (status 2, one line) before the shipped data are read and a run is opened
    import pipelines.benchmark as benchmark
    from cli_helpers import exit_code

    def stop(*args, **kwargs):
        raise _Stop()

    monkeypatch.setattr(benchmark, "tracked_run", stop)
    assert exit_code(["benchmark", *argv]) == code
    if code == 2:
        assert capsys.readouterr().err.strip().splitlines()[-1] == (
            "terrain benchmark: error: --repeats must be in 1-100 and --reference-windows "
            f">= 1, got {argv[1] if argv[0] == '--repeats' else 3} and "
            f"{argv[1] if argv[0] == '--reference-windows' else 300}")


def test_consistency_row_says_inside_against_the_bounds_of_the_time_average():
    # the report's "inside" column: the ANEES against the bounds of a time average of
    # M n_eff chi-square(12) values, not one step's much wider bounds
    from pipelines.validation.harness import ConsistencyRow

    row = ConsistencyRow(terrain="GRASS", n_runs=10, anees=10.0, nees_bounds=(11.9, 12.1),
                         nees_fraction_in_bounds=0.9, nis_mean=8.0, nis_dof=8.2,
                         nis_bounds=(7.5, 8.9), rmse={"v_bx": 0.01, "yaw_rate": 0.02},
                         nees_step_bounds=(9.16, 15.22), nees_n_eff=400.0)
    d = row.as_dict()
    assert d["NEES_inside"] is False                       # 10 is inside one step's bounds
    assert (d["NEES_lo"], d["NEES_hi"]) == (11.9, 12.1)
    assert (d["NEES_step_lo"], d["NEES_step_hi"]) == (9.16, 15.22)
    assert (d["terrain"], d["runs"], d["ANEES"], d["NEES_n_eff"]) == ("GRASS", 10, 10.0, 400.0)
    assert (d["NIS"], d["NIS_dof"], d["NIS_lo"], d["NIS_hi"]) == (8.0, 8.2, 7.5, 8.9)
    assert (d["rmse_v_bx"], d["rmse_yaw_rate"]) == (0.01, 0.02)
    assert ConsistencyRow(**{**row.__dict__, "anees": 12.0}).as_dict()["NEES_inside"] is True


@pytest.mark.slow
def test_simulate_notes_the_steps_each_wheel_command_was_clipped_on(tmp_path, capsys):
    # AgriMaRo, random, seed 0, 10 s: the outer wheel's command passes the speed limit; the
    # note counts each wheel's clipped steps out of the run's 1001 time steps (10 s at
    # 100 Hz, both ends), as the run's metadata holds them
    import json

    from terrain.cli import main
    from terrain.vehicles import get_vehicle

    assert main(["simulate", "--vehicle", "agrimaro", "--terrain", "ICE", "--scenario",
                 "random", "--duration-s", "10", "--seed", "0", "--out", str(tmp_path)]) == 0
    counts = json.loads((tmp_path / "ICE" / "meta_00.json").read_text())[
        "speed_limit_clipped_steps"]
    assert len(counts) == 3 and any(counts)
    limit = get_vehicle("agrimaro").motor.max_wheel_speed_rad_s
    per_wheel = ", ".join(f"wheel {i + 1} {c}" for i, c in enumerate(counts))
    assert capsys.readouterr().out.splitlines()[-1] == (
        f"note: the random scenario asked for more than the wheel speed limit "
        f"({limit:.3g} rad/s): each wheel's command clipped to it on {per_wheel} of 1001 "
        f"physics steps (the run does not follow the command there)")


@pytest.mark.parametrize("source", [["--classifier-uncontrolled-only"],
                                    ["--terrain-source", "label"]])
def test_control_sim_refuses_another_vehicles_estimator_before_training_a_classifier(
        source, tmp_path, monkeypatch, capsys):
    # `--vehicle husky --estimator ekf-vo --classifier-uncontrolled-only` trained the
    # live-sim classifier (minutes of simulated runs and an SVM fit) and only then did the
    # closed loop refuse the AgriMaRo's estimator
    import pipelines.control_classifier as control_classifier
    from cli_helpers import exit_code

    trained = []

    def train(*args, **kwargs):
        trained.append(args)
        raise _Stop()

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(control_classifier, "sim_classifier", train)
    assert exit_code(["control-sim", "--vehicle", "husky", "--terrain", "ICE", "--scenario",
                      "straight_accel", "--controller", "traction", "--estimator", "ekf-vo",
                      "--duration-s", "0.5", "--json", "c.json", *source]) == 2
    assert not trained and not any(tmp_path.iterdir())
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "terrain control-sim: error: --estimator 'ekf-vo' is not available for husky; "
        "valid: fused, observer, fused-full-imu, fused-clean-imu")


def test_stream_eval_part_none_without_model_out_is_refused_before_any_run(
        tmp_path, monkeypatch, capsys):
    # --part none only saves the --model-out models: without it the command read BorealTC,
    # opened an MLflow run, logged an empty stream_eval.json and said nothing was done
    import pipelines.stream_eval as stream_eval
    from cli_helpers import RecordingRun, exit_code

    read = []
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(stream_eval, "load_dataset", lambda name: read.append(name) or [])
    recorder = RecordingRun()
    monkeypatch.setattr(stream_eval, "tracked_run", recorder)
    assert exit_code(["stream-eval", "--part", "none"]) == 2
    assert not read and not recorder.starts and not any(tmp_path.iterdir())
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "terrain stream-eval: error: --part none evaluates nothing and only saves the "
        "--model-out models: give --model-out DIR, or another --part")


def test_slip_errors_of_the_estimation_report_split_steady_and_transient_on_the_filter_clock():
    # docs/estimation_validation.md's slip columns: steady_err_i the signed mean error of
    # wheel i after 5 s, steady_truth the mean true slip there, transient_rmse over the first
    # 3 s and rmse over the run, both over the finite errors (a slip NaN in its dead band)
    from types import SimpleNamespace

    from pipelines.validation.estimation_tables import _slip_errors

    t_ph = np.arange(0.0, 10.0 + 1e-9, 0.01)
    slip = np.column_stack([0.1 + 0.01 * t_ph, 0.2 * np.ones_like(t_ph), 0.05 * t_ph])
    n = len(t_ph)
    physics = SimpleNamespace(t_s=t_ph, pose=np.zeros((n, 3)), twist=np.zeros((n, 3)),
                              accel_body=np.zeros((n, 2)), delta=np.zeros((n, 0)),
                              slip_motor=slip, omega=np.zeros((n, 3)))
    t = np.arange(0.0, 10.0 + 1e-9, 0.5)            # the filter's clock, 21 steps
    truth = np.column_stack([0.1 + 0.01 * t, 0.2 * np.ones_like(t), 0.05 * t])
    offset = np.zeros_like(truth)
    offset[:, 0] = 0.1                               # wheel 1: +0.1 throughout
    offset[:, 1] = np.where(t > 5.0, -0.05, np.where(t < 3.0, 0.2, 0.0))
    estimate = truth + offset
    estimate[t == 9.5, 2] = np.nan                   # wheel 3: one NaN (dead band)
    est = SimpleNamespace(slip=estimate, ekf=SimpleNamespace(t_s=t))
    out = _slip_errors(SimpleNamespace(physics=physics), est)
    steady, first = t > 5.0, t < 3.0
    assert out["steady_err_1"] == pytest.approx(0.1)
    assert out["steady_err_2"] == pytest.approx(-0.05)            # signed, not absolute
    assert out["steady_err_3"] == pytest.approx(0.0, abs=1e-12)   # the NaN left out
    assert out["steady_truth"] == pytest.approx(truth[steady].mean())
    assert out["transient_rmse"] == pytest.approx(
        np.sqrt(np.mean(offset[first] ** 2)))                    # 6 steps, 3 wheels
    finite = np.isfinite(estimate)
    assert out["rmse"] == pytest.approx(np.sqrt(np.mean(offset[finite] ** 2)))


def test_live_decision_is_the_latest_emitted_by_t_and_an_unclassified_window_is_none():
    # the loop's decision at t: the latest window decided by t with the loop time it was
    # emitted at; a window the service did not classify (terrain None) gives no decision,
    # not the older one before it (its age would hide that the classifier stopped)
    from collections import deque

    from pipelines.live_terrain import MAX_DECISIONS, LiveClassifier

    live = object.__new__(LiveClassifier)
    live._decisions = deque([(2.0, "ICE", 0.9), (2.5, "SNOW", 0.6), (3.0, None, 0.0)],
                            maxlen=MAX_DECISIONS)
    assert live(1.9) == (None, 0.0)                       # before the first decision
    assert live(2.0) == ("ICE", 0.9, 2.0)
    assert live(2.0 - 1e-10) == ("ICE", 0.9, 2.0)         # the loop clock's rounding
    assert live(2.7) == ("SNOW", 0.6, 2.5)
    assert live(3.2) == (None, 0.0)


def test_thesis_straight_line_table_takes_steady_after_4_s_and_peak_after_0_2_s(monkeypatch):
    # docs/sim_validation.md: steady slip = mean of the three wheels' average after 4 s; peak
    # = its maximum after 0.2 s (the start-up instant left out); one row per thesis terrain
    import pipelines.validation.sim_tables as sim_tables

    t = np.round(np.arange(0.0, 8.0 + 1e-9, 0.01), 2)
    average = np.where(t > 4.0, 0.1, 0.3)
    average[t == 0.1] = 0.9                            # start-up spike: not the peak
    average[t == 1.0] = 0.5                            # the peak
    configs = []

    def simulate(config):
        configs.append(config)
        truth = pd.DataFrame({TIME: t, "slip_1": average - 0.02, "slip_2": average,
                              "slip_3": average + 0.02})
        return Run("r", "sim", config.terrains[0], {"truth": truth}, vehicle="agrimaro")

    monkeypatch.setattr(sim_tables, "simulate", simulate)
    table = sim_tables.thesis_straight_line_table(duration_s=8.0, seed=3)
    assert list(table["terrain"]) == ["TILES", "GRASS", "GRAVEL"]
    assert np.allclose(table["steady_slip"], 0.1) and np.allclose(table["peak_slip"], 0.5)
    assert {(c.vehicle, c.scenario, c.duration_s, c.seed) for c in configs} == {
        ("agrimaro", "straight_accel", 8.0, 3)}
