"""Argument validation of ``terrain estimate`` and of the estimator settings behind it
(fuzzing findings): the gate probability, the filter rate, an explicit learned-model folder."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from terrain.cli import main
from terrain.errors import ConfigError, TerrainError, TimeStepError
from terrain.estimation import Gate, make_grid
from terrain.estimation.runner import (MAX_GRID_STEPS, MAX_RATE_HZ, MIN_RATE_HZ,
                                       check_rate_hz)
from terrain.io.writer import write_run
from terrain.sim import SimConfig, simulate


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    write_run(simulate(SimConfig(vehicle="husky", terrains=("SNOW",),
                                 scenario="straight_accel", duration_s=3.0, seed=1)), root)
    return root


def _error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("terrain estimate: error:")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize("p", [0.0, 1.0, 1.5, -1.0, float("nan"), "x"])
def test_gate_probability_outside_the_open_unit_interval_is_a_config_error(p):
    with pytest.raises(ConfigError, match=r"gate probability must be in \(0, 1\)"):
        Gate(p)


def test_gate_config_error_is_still_a_value_error_and_max_dof_is_checked():
    assert issubclass(ConfigError, ValueError) and issubclass(ConfigError, TerrainError)
    with pytest.raises(ConfigError, match="max_dof"):
        Gate(0.99, max_dof=0)
    assert Gate(0.999).threshold(1) == pytest.approx(10.828, abs=1e-3)


@pytest.mark.parametrize("gate", ["0", "1", "1.5", "-1"])
def test_estimate_bad_gate_is_one_line_before_reading_runs(gate, tmp_path, capsys):
    # the folder does not even exist: the argument is refused first
    assert main(["estimate", str(tmp_path / "absent"), "--out", str(tmp_path / "s.csv"),
                 "--gate", gate]) == 2
    # named as the option (it was Gate's "gate probability must be in (0, 1) ...")
    assert f"--gate must be a probability in (0, 1) exclusive (e.g. 0.999), got {float(gate):g}" \
        in _error_line(capsys)


@pytest.mark.parametrize("rate", ["1e9", "0", "-5", "inf", "nan", "20000", "1e-9",
                                  "0.05"])
def test_estimate_bad_rate_is_one_line(rate, tmp_path, capsys):
    assert main(["estimate", str(tmp_path / "absent"), "--out", str(tmp_path / "s.csv"),
                 "--rate-hz", rate]) == 2
    line = _error_line(capsys)
    assert "--rate-hz must be in [1, 10000] Hz" in line


def test_estimate_help_states_the_rate_range_the_check_enforces(capsys):
    with pytest.raises(SystemExit):
        main(["estimate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"in [{MIN_RATE_HZ:g}, {MAX_RATE_HZ:g}]" in text


def test_check_rate_hz():
    assert check_rate_hz(None) is None
    assert check_rate_hz(200) == 200.0
    assert check_rate_hz(MAX_RATE_HZ) == MAX_RATE_HZ
    assert check_rate_hz(MIN_RATE_HZ) == MIN_RATE_HZ
    for bad in (0, 0.0, -1, 0.99 * MIN_RATE_HZ, MAX_RATE_HZ * 1.01, float("inf"),
                float("nan"), "fast"):
        with pytest.raises(ConfigError, match="rate_hz"):
            check_rate_hz(bad)


def test_make_grid_refuses_a_grid_too_large_before_allocating_it():
    with pytest.raises(ConfigError, match="above the 10000 Hz"):
        make_grid(0.0, 10.0, 1e9)
    # within the rate bound, but too many steps (a clock in ms: 1e6 s of "seconds")
    with pytest.raises(ConfigError, match="more than the 5,000,000 allowed"):
        make_grid(0.0, 1e6, 100.0)
    with pytest.raises(TimeStepError):
        make_grid(0.0, 10.0, 0.0)
    # a span shorter than one step gives one step: no filter runs on it
    with pytest.raises(TimeStepError, match="has 1 step: a filter needs at least 2"):
        make_grid(0.0, 0.005, 100.0)
    assert make_grid(0.0, 0.01, 100.0).size == 2
    grid = make_grid(0.0, (MAX_GRID_STEPS - 1) / 1e4, 1e4)
    assert grid.size == MAX_GRID_STEPS and np.all(np.diff(grid) > 0)


def test_estimate_rate_within_bounds_still_works(run_dir, tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert main(["estimate", str(run_dir), "--out", str(out), "--slip-model", "physics",
                 "--rate-hz", "50", "--gate", "0.999"]) == 0
    printed = capsys.readouterr().out
    assert "at 50.0 Hz" in printed and out.exists()
    # the 100 Hz IMU on a 50 Hz filter: every other sample unused (latest wins), counted;
    # at 1 Hz 94 % of them went unused without a word before
    unused = re.search(r"samples unused \(a later one in the same filter step wins\) "
                       r"\{'gyro': '(\d+) of (\d+)'", printed)
    assert unused and abs(int(unused[1]) / int(unused[2]) - 0.5) < 0.02
    assert main(["estimate", str(run_dir), "--out", str(out), "--slip-model", "physics"]) == 0
    assert "samples unused" not in capsys.readouterr().out      # the IMU rate: none


def test_explicit_slip_model_dir_that_does_not_exist_is_an_error(run_dir, tmp_path, capsys):
    missing = tmp_path / "no_model"
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv"),
                 "--slip-model-dir", str(missing)]) == 2
    line = _error_line(capsys)
    assert f"--slip-model-dir {missing}: no such folder" in line
    assert not (tmp_path / "s.csv").exists()       # no silent fall-back to physics


def test_explicit_slip_model_dir_without_mlmodel_is_an_error(run_dir, tmp_path, capsys):
    folder = tmp_path / "model"
    folder.mkdir()
    (folder / "model.pkl").write_bytes(b"\x80")
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv"),
                 "--slip-model", "learned", "--slip-model-dir", str(folder)]) == 2
    line = _error_line(capsys)
    assert "no MLmodel file" in line and "model.pkl" in line


def test_explicit_slip_model_dir_that_is_a_file_is_an_error(run_dir, tmp_path, capsys):
    path = tmp_path / "model.pkl"
    path.write_bytes(b"\x80")
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv"),
                 "--slip-model-dir", str(path)]) == 2
    assert "not a folder" in _error_line(capsys)


def test_corrupt_slip_model_dir_is_an_error_saying_why(run_dir, tmp_path, capsys):
    folder = tmp_path / "model"
    folder.mkdir()
    (folder / "MLmodel").write_text("flavors:\n  sklearn:\n    pickled_model: model.pkl\n"
                                    "    serialization_format: cloudpickle\n")
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv"),
                 "--slip-model-dir", str(folder)]) == 2
    line = _error_line(capsys)
    assert "the model cannot be loaded" in line and "model.pkl" in line


def test_slip_model_dir_whose_mlmodel_is_not_yaml_says_so(run_dir, tmp_path, capsys):
    # an MLmodel holding the word "junk" leaked "AttributeError: 'str' object has no
    # attribute 'copy'" from MLflow's loader
    folder = tmp_path / "model"
    folder.mkdir()
    (folder / "MLmodel").write_text("junk\n")
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv"),
                 "--slip-model-dir", str(folder)]) == 2
    line = _error_line(capsys)
    assert str(folder / "MLmodel") in line and "AttributeError" not in line


@pytest.mark.slow
def test_an_option_of_the_other_vehicle_kind_is_said_not_silently_ignored(run_dir, tmp_path,
                                                                          capsys):
    # --tuning tunes the AgriMaRo EKF, --slip-model the skid-steer one's slip source
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv"),
                 "--tuning", "thesis"]) == 0
    assert ("note: --tuning thesis not used: it tunes the AgriMaRo EKF"
            in capsys.readouterr().out)
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv"),
                 "--lag", "ema"]) == 0
    assert "note: --lag ema filters the AgriMaRo camera" in capsys.readouterr().out
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv")]) == 0
    out = capsys.readouterr().out
    # defaults say nothing about options (the input report's "not used: ... s of imu
    # outside the other stream's span" is about data, not options)
    assert "note: --" not in out and "--lag" not in out
    agri = tmp_path / "agri"
    write_run(simulate(SimConfig(vehicle="agrimaro", terrains=("SNOW",),
                                 scenario="straight_accel", duration_s=3.0, seed=1)), agri)
    assert main(["estimate", str(agri), "--out", str(tmp_path / "a.csv"),
                 "--slip-model", "physics", "--tuning", "thesis"]) == 0
    out = capsys.readouterr().out
    assert "note: --slip-model physics not used: no skid-steer run" in out
    assert "--tuning" not in out


def test_slip_model_dir_not_used_is_said(run_dir, tmp_path, capsys):
    assert main(["estimate", str(run_dir), "--out", str(tmp_path / "s.csv"),
                 "--slip-model", "physics", "--slip-model-dir", str(tmp_path / "nope")]) == 0
    out = capsys.readouterr().out
    assert "--slip-model-dir" in out and "not used" in out
    # the reason: the slip source chosen uses no model, or no run is a skid-steer one
    assert (f"note: --slip-model-dir {tmp_path / 'nope'} not used: --slip-model physics uses "
            "no learned model") in out
    agri = tmp_path / "agri"
    write_run(simulate(SimConfig(vehicle="agrimaro", terrains=("SNOW",),
                                 scenario="straight_accel", duration_s=1.0, seed=1)), agri)
    assert main(["estimate", str(agri), "--out", str(tmp_path / "a.csv"),
                 "--slip-model-dir", str(tmp_path / "nope")]) == 0
    assert (f"note: --slip-model-dir {tmp_path / 'nope'} not used: no skid-steer run (the "
            "AgriMaRo EKF observes its slip)") in capsys.readouterr().out


def test_the_states_table_keeps_nine_significant_digits(run_dir, tmp_path):
    # the states go to 9 significant digits (pipelines/estimate.py): a gyro bias of 1e-4
    # rad/s printed to 4 digits would lose what a 1e-8 rad/s change of it tells
    import pandas as pd

    from terrain.io.measured import read_runs_path
    from terrain.slip.estimate import estimate_skid_steer_slip_run

    out = tmp_path / "s.csv"
    assert main(["estimate", str(run_dir), "--out", str(out), "--slip-model", "ekf"]) == 0
    written = pd.read_csv(out)
    (run,) = read_runs_path(run_dir)
    frame = estimate_skid_steer_slip_run(run, "ekf").to_frame()
    assert list(written.columns) == list(frame.columns)
    for column in ("v_bx", "yaw_rate", "gyro_bias", "std_v_bx", "nis"):
        expected = frame[column].to_numpy(float)
        assert np.allclose(written[column].to_numpy(float), expected, rtol=1e-8, atol=0.0,
                           equal_nan=True), column


def test_a_run_shorter_than_a_slip_window_names_that_reason(tmp_path, capsys):
    # 1.5 s of a run with currents, IMU and a catalogue terrain: the physics slip has no 2 s
    # window; the note said "needs motor currents, an IMU and a catalogue terrain" before
    root = tmp_path / "short"
    write_run(simulate(SimConfig(vehicle="husky", terrains=("SNOW",),
                                 scenario="straight_accel", duration_s=1.5, seed=1)), root)
    assert main(["estimate", str(root), "--out", str(tmp_path / "s.csv"),
                 "--slip-model", "physics"]) == 0
    out = capsys.readouterr().out
    (note,) = [line for line in out.splitlines() if "slip model not used" in line]
    assert "no complete 2 s window" in note and "SNOW/00" in note
    assert "catalogue" not in note and "no slip model is used (none could be used)" in out


@pytest.mark.slow
def test_without_a_slip_model_the_common_slip_is_not_claimed(tmp_path, capsys):
    # a 120 s run on a terrain outside the catalogue (no physics slip): the slip-augmented
    # EKF, left with the accelerometer alone, drifted to slip 0.77 (std 0.003, NIS 7.95 on
    # 3.1 dof) against a true 0 to 0.17, under a note saying the slip stayed at its prior 0
    import pandas as pd
    root = tmp_path / "runs"
    run = simulate(SimConfig(vehicle="husky", terrains=("ICE", "SNOW", "ASPHALT"),
                             scenario="random", duration_s=120.0, seed=0))
    write_run(run, root)
    (root / "MIXED").rename(root / "MUD")
    assert main(["estimate", str(root), "--out", str(tmp_path / "s.csv"),
                 "--slip-model", "physics"]) == 0
    out = capsys.readouterr().out
    assert "no slip model is used (none could be used)" in out
    assert "terrain 'MUD' not in the terrain catalogue" in out
    frame = pd.read_csv(tmp_path / "s.csv")
    assert frame["std_slip_1"].isna().all() and frame["std_slip_2"].isna().all()
    truth = run.streams["truth"][["slip_1", "slip_2"]].abs().median()
    assert truth.max() < 0.15 and frame[["slip_1", "slip_2"]].abs().median().max() < 0.1


def test_missing_slip_inputs_names_the_first_input_the_slip_models_lack():
    from features.slip_outputs import missing_slip_inputs, slip_model_outputs
    run = simulate(SimConfig(vehicle="husky", terrains=("SNOW",),
                             scenario="straight_accel", duration_s=3.0, seed=1))
    assert missing_slip_inputs(run) is None and slip_model_outputs(run) is not None
    wheels = run.streams["wheels"]
    cases = {"no IMU stream": {"wheels": wheels},
             "no motor currents": {**run.streams,
                                   "wheels": wheels.drop(columns=["cur_l", "cur_r"])}}
    for reason, streams in cases.items():
        other = replace(run, streams=streams)
        assert reason in missing_slip_inputs(other) and slip_model_outputs(other) is None
    # one side's current missing is named too (not the generic "no complete window")
    right_less = replace(run, streams={**run.streams, "wheels": wheels.drop(columns=["cur_r"])})
    assert "no motor currents" in missing_slip_inputs(right_less)
    mud = replace(run, terrain="MUD")
    assert "'MUD' not in the terrain catalogue" in missing_slip_inputs(mud)


@pytest.mark.parametrize("rate_hz", [0, 0.0, -5.0, float("nan"), 1e9])
def test_library_estimators_refuse_a_rate_outside_the_bound(rate_hz):
    """``rate_hz=0`` is not "the default" in the library either (None is)."""
    from terrain.estimation.agrimaro import estimate_agrimaro
    from terrain.estimation.skid_steer import estimate_skid_steer
    from terrain.slip.estimate import estimate_skid_steer_slip_run
    for vehicle, estimate in (("husky", estimate_skid_steer), ("agrimaro", estimate_agrimaro),
                              ("husky", estimate_skid_steer_slip_run)):
        run = simulate(SimConfig(vehicle=vehicle, terrains=("SNOW",),
                                 scenario="straight_accel", duration_s=1.0, seed=1))
        with pytest.raises(ConfigError, match="rate_hz"):
            estimate(run, rate_hz=rate_hz)


def test_estimate_keeps_every_digit_of_an_epoch_clock(run_dir, tmp_path, capsys):
    # the readers accept a clock in epoch seconds (both files shifted alike); the output
    # keeps its 10 digits before the point, so no two filter steps share a time
    import pandas as pd
    epoch = tmp_path / "epoch"
    for src in run_dir.rglob("*.*"):
        dst = epoch / src.relative_to(run_dir)
        dst.parent.mkdir(parents=True, exist_ok=True)
        if src.suffix == ".csv":
            frame = pd.read_csv(src)
            frame["time"] = frame["time"] + 1.7e9
            frame.to_csv(dst, index=False, float_format="%.17g")
        else:
            dst.write_bytes(src.read_bytes())
    out = tmp_path / "s.csv"
    assert main(["estimate", str(epoch), "--out", str(out),
                 "--slip-model", "physics"]) == 0
    t = pd.read_csv(out)["t_s"].to_numpy()
    assert t.size > 100 and t[0] >= 1.7e9
    assert np.all(np.diff(t) > 0)
    np.testing.assert_allclose(np.diff(t), np.median(np.diff(t)), rtol=1e-3)


def test_an_agrimaro_run_without_wheel_3_says_so_and_warns_nothing(run_dir, tmp_path, capsys):
    # a run labelled agrimaro whose only wheel stream is vel_l / vel_r: wheels 1 and 2 come
    # from it, wheel 3 has no encoder; said in a note, not in numpy's All-NaN warning
    import json
    import shutil
    import warnings
    copy = tmp_path / "agri"
    shutil.copytree(run_dir, copy)
    (meta,) = copy.rglob("meta_*.json")
    meta.write_text(json.dumps({**json.loads(meta.read_text()), "vehicle": "agrimaro"}))
    out = tmp_path / "s.csv"
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert main(["estimate", str(copy), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "wheel 3 has no encoder, so slip_3 is not estimated" in printed
    assert "slip_3 none (no finite estimate)" in printed and "(agrimaro)" in printed


@pytest.mark.slow
def test_an_agrimaro_run_without_camera_or_steering_encoders_says_what_rests_on_the_model(
        tmp_path, capsys):
    # without the camera the speed over ground is measured by nothing: the slip of a 20 s
    # orchard run came out +0.05 (std 0.19) against a true +0.17, and nothing said why
    root = tmp_path / "agri"
    write_run(simulate(SimConfig(vehicle="agrimaro", terrains=("SNOW",), scenario="orchard",
                                 duration_s=8.0, seed=0)), root)
    assert main(["estimate", str(root), "--out", str(tmp_path / "all.csv")]) == 0
    # every sensor there: no note but the lag's (an 8 s SNOW run's camera / rim speed peak,
    # 0.14, is not a clear one: no lag applied, terrain.slip.alignment.gated_lag) and the
    # count of the slips the dead band sets to 0 (the run starts from rest)
    notes = [ln for ln in capsys.readouterr().out.splitlines() if "note:" in ln]
    dead_band = [ln for ln in notes if "m/s dead band" in ln]
    assert len(dead_band) == 1 and dead_band[0].startswith("note: run agri/SNOW/00: ")
    notes = [ln for ln in notes if ln not in dead_band]
    # the lag's note is there (all(...) over the notes also passed with none printed)
    assert len(notes) == 2 and notes[0].startswith(
        "note: encoder lag of run agri/SNOW/00 not applied (no lag): the cross-correlation "
        "peak at ")
    assert notes[1] == ("note: encoder lag applied on 0 of 1 runs, not applied on 1 (no clear "
                        "cross-correlation peak), not estimated on 0")
    (cam,) = root.rglob("cam_*.csv")
    (steer,) = root.rglob("steer_*.csv")
    cam.unlink()
    steer.unlink()
    assert main(["estimate", str(root), "--out", str(tmp_path / "s.csv")]) == 0
    out = capsys.readouterr().out
    assert "has no cam stream (the T265 visual odometry" in out
    assert "the encoder lag is not estimated" in out and "encoder lag not estimated" in out
    assert "has no steer stream: the steering angles delta_1..3" in out
