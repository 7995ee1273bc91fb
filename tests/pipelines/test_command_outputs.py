"""What the commands print, log and write says what the run held: the counts, the notes and
the names (pipelines/control_sim.py, predict.py, train.py, slip_model.py,
estimate.py and terrain/cli.py), on known values; stand-ins keep the runs short."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from cli_helpers import RecordingRun, control_sim_json

import pipelines.control_sim as control_sim
from terrain.cli import main
from terrain.errors import ConfigError


def _closed_loop_stand_in(monkeypatch, speed_limit, correction, energy=12.34):
    """``run_closed_loop`` replaced by one returning these clipped-step counts per motor."""
    def run(vehicle, terrain, scenario, traction, seed, duration_s, gains, table, **kwargs):
        return None, None, {"peak_slip": 0.25, "energy_j_per_m": energy,
                            "speed_limit_clipped_steps": list(speed_limit),
                            "correction_clipped_steps": list(correction)}
    monkeypatch.setattr(control_sim, "run_closed_loop", run)


def _control_sim(tmp_path, capsys):
    result = control_sim_json(tmp_path, "--terrain-source", "label", "--controller",
                              "traction", "--duration-s", "2")
    return result, capsys.readouterr().out


def test_control_sim_notes_clipped_commands_when_any_motor_step_was_clipped(
        tmp_path, capsys, monkeypatch):
    # one motor clipped on 3 steps, no correction clipped: the note names the speed limit's
    # counts only (it was printed only when every motor was clipped, or both kinds were)
    _closed_loop_stand_in(monkeypatch, [0, 3, 0, 0], [0, 0, 0, 0])
    result, out = _control_sim(tmp_path, capsys)
    assert ("note: wheel commands clipped at the speed limit, physics steps per motor: "
            "{'speed_limit_clipped_steps': [0, 3, 0, 0]} (the run does not follow the "
            "command there)") in out
    assert "wrote " + str(tmp_path / "c.json") + ": peak_slip 0.250, energy 12.3 J/m" in out
    assert result["speed_limit_clipped_steps"] == [0, 3, 0, 0]
    assert result["duration_s"] == 2.0 and result["terrain"] == "ICE"
    _closed_loop_stand_in(monkeypatch, [0, 0, 0, 0], [0, 0, 0, 0], energy=None)
    _, out = _control_sim(tmp_path, capsys)
    assert "note:" not in out and "energy n/a (the run did not move)" in out


class _WindowModel:
    """A stand-in classifier: one ``ICE`` window per full 2 s of samples at 100 Hz."""

    def predict(self, samples):
        n = len(samples) // 200
        return pd.DataFrame({"t_start_s": 2.0 * np.arange(n), "t_end_s": 2.0 * np.arange(n) + 2,
                             "predicted": ["ICE"] * n})


def test_predict_counts_the_runs_used_skipped_and_noted_apart(
        tmp_path, capsys, monkeypatch, write_run, synth_imu, synth_pro):
    """Six runs for a model trained on an AgriMaRo at 100 Hz: two full (one with a 50 Hz IMU),
    one of 1.5 s (too short for a 2 s window), one of exactly one window (200 samples) and
    two without their IMU (skipped). Every Husky run draws the other-vehicle note, the
    50 Hz one the slower-IMU note, and each count reaches the printout and the logged
    metrics."""
    import pipelines.predict as predict

    meta = {"window_s": 2.0, "rate_hz": 100.0, "vehicle": "agrimaro",
            "channels": ["vel_l", "vel_r", "cur_l", "cur_r", "wx", "wy", "wz", "ax", "ay", "az"]}
    monkeypatch.setattr(predict, "_load", lambda uri, progress: (_WindowModel(), meta))
    run = RecordingRun()
    monkeypatch.setattr(predict, "tracked_run", run)
    runs = tmp_path / "runs"
    write_run(runs, "ICE", "00", synth_imu(10.0), synth_pro(10.0))
    write_run(runs, "ICE", "01", synth_imu(10.0, rate_hz=50.0), synth_pro(10.0))
    write_run(runs, "SNOW", "00", synth_imu(1.5), synth_pro(1.5))
    write_run(runs, "SNOW", "01", None, synth_pro(10.0))
    write_run(runs, "SNOW", "03", None, synth_pro(10.0))
    write_run(runs, "SNOW", "02", synth_imu(1.99), synth_pro(1.99))    # 200 samples: 2 s
    out = tmp_path / "p.csv"
    assert main(["predict", "--model", str(tmp_path), str(runs), "--out", str(out),
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    # the 1.5 s run gave no window: not used (it was counted as used, "from 4 of 6 runs",
    # while the input report above said "6 run(s), 3 used")
    assert "input: 6 run(s), 3 used" in text
    assert "11 windows from 3 of 6 runs -> " + str(out) in text
    assert "predicted windows per class: {'ICE': 11}" in text
    assert text.count("IMU is sampled at 50 Hz") == 1
    m = run.metrics
    assert (m["n_windows"], m["n_runs"], m["n_runs_used"], m["n_runs_skipped"]) == (11, 6, 3, 2)
    assert m["input_runs_used"] == m["n_runs_used"]
    assert (m["n_runs_other_vehicle"], m["n_runs_slower_imu"]) == (6, 1)
    assert m["input_runs_too_short"] == 1     # the 1.5 s run; 200 samples fill one window
    assert m["n_windows_flagged"] == 0
    assert len(pd.read_csv(out)) == 11


def test_predict_names_the_first_line_of_a_model_load_failure(tmp_path, capsys, monkeypatch):
    import pipelines.predict as predict

    def fail(uri, progress):
        raise OSError("MLmodel unreadable\n  in the second line: detail")
    monkeypatch.setattr(predict, "load_model", fail)
    assert main(["predict", "--model", str(tmp_path), str(tmp_path), "--out",
                 str(tmp_path / "p.csv")]) == 2
    assert capsys.readouterr().err == (f"terrain predict: error: cannot load model "
                                       f"'{tmp_path}': MLmodel unreadable\n")


class _Windows(SimpleNamespace):
    """A stand-in of the training windows: their arrays, counted by length."""

    def __len__(self):
        return len(self.X)


def test_train_logs_the_runs_hop_vehicle_and_classes_it_trained_on(
        tmp_path, capsys, monkeypatch):
    """Three runs loaded, two windowed (a Husky's and an AgriMaRo's): two runs trained, no
    single vehicle; the 0.5 s training hop given is the one logged; a one-seed CNN budget
    leaves the run's name alone; a lower-case catalogued class is no stranger; a member's
    ``n_jobs`` is not a model parameter."""
    from sklearn.neighbors import KNeighborsClassifier
    from sklearn.pipeline import Pipeline

    import pipelines.train as train

    runs = [SimpleNamespace(run_id=f"vulpi/{t}/{i}", vehicle=v, streams={})
            for t, i, v in (("ICE", 0, "husky"), ("MY_YARD", 1, "agrimaro"),
                            ("ICE", 2, "husky"))]
    labels = np.array(["ice", "ice", "MY_YARD", "MY_YARD"])
    X = np.array([[0.0], [0.1], [1.0], [1.1]])
    pipe = Pipeline([("clf", KNeighborsClassifier(n_neighbors=1, n_jobs=1))]).fit(X, labels)
    ws = _Windows(X=X, labels=labels, run_ids=np.array(["vulpi/ICE/0"] * 2
                                                       + ["vulpi/MY_YARD/1"] * 2),
                  counts={}, channels=["vel_l"])
    report = SimpleNamespace(metrics=dict, table=pd.DataFrame(), text=lambda: "report")
    logged = {}
    monkeypatch.setattr(train, "load_dataset", lambda name: runs)
    monkeypatch.setattr(train, "fit_pipeline", lambda config, runs, progress: (pipe, ws, {}))
    monkeypatch.setattr(train, "input_report", lambda *a: report)
    monkeypatch.setattr(train, "runs_to_model_input", lambda *a: (pd.DataFrame(), []))
    monkeypatch.setattr(train, "log_model", lambda pipe, ch, w, classes, meta, *a, **k:
                        logged.update(meta=meta, classes=classes) or "runs:/x/model")
    run = RecordingRun()

    def tracked(experiment, run_name, params):
        logged.update(name=run_name, params=params)
        return run
    monkeypatch.setattr(train, "tracked_run", tracked)
    assert main(["train", "--dataset", "vulpi", "--model", "svm", "--train-hop-s", "0.5",
                 "--no-progress", "--no-register"]) == 0
    out = capsys.readouterr().out
    assert logged["name"] == "svm-vulpi-all"
    assert logged["params"]["train_hop_s"] == 0.5 and logged["params"]["window_s"] == 2.0
    assert logged["meta"]["vehicle"] is None and logged["meta"]["trained_on_runs"] == 2
    assert logged["meta"]["channel_steps_s"] == {}    # (runs without streams here)
    assert run.metrics["n_runs"] == 2 and run.metrics["n_windows"] == 4
    assert "trained on 4 windows of 2 runs, classes ['MY_YARD', 'ice']" in out
    assert "note: class(es) ['MY_YARD'] not in the terrain catalogue" in out
    assert "registered as" not in out
    assert run.params["model.clf__n_neighbors"] == 1
    assert not [k for k in run.params if k.endswith("n_jobs")]


def test_estimate_names_each_runs_file_counts_its_lags_and_keeps_the_epoch_time(
        tmp_path, capsys, monkeypatch):
    """Four runs (an AgriMaRo's, three Husky's) whose lag was not applied, applied twice and
    not estimated: one file per run named by terrain and index, each count in the closing
    note, the learned model looked for (a skid-steer run among them), an epoch clock
    written to the digit."""
    import pipelines.estimate as estimate

    runs = [SimpleNamespace(run_id=f"r/{t}/{i}", vehicle=v)
            for t, i, v in (("GRASS", "00", "agrimaro"), ("ASPHALT", "00", "husky"),
                            ("ASPHALT", "01", "husky"), ("SNOW", "00", "husky"))]
    from terrain.slip.alignment import LagEstimate, lag_not_estimated

    lags = {"r/GRASS/00": LagEstimate(0.2, 0.1, 500, applied=False, reason="low"),
            "r/ASPHALT/00": LagEstimate(0.1, 0.8, 500),
            "r/ASPHALT/01": LagEstimate(0.1, 0.8, 500),
            "r/SNOW/00": lag_not_estimated("fewer than 20 finite samples")}

    def est(run, *args, **kwargs):
        return SimpleNamespace(notes=[], lag=lags[run.run_id], summary=lambda: run.run_id,
                               to_frame=lambda: pd.DataFrame({"t_s": [1700000000.123456],
                                                              "v_bx": [0.5]}))
    monkeypatch.setattr(estimate, "_load", lambda run_dir, select: runs)
    monkeypatch.setattr(estimate, "input_report", lambda runs: SimpleNamespace(text=str))
    monkeypatch.setattr(estimate, "estimate_run", est)
    monkeypatch.setattr(estimate, "estimate_skid_steer_slip_run", est)
    monkeypatch.setattr(estimate, "slip_model_outputs", lambda run, learned: None)
    monkeypatch.setattr(estimate, "missing_slip_inputs", lambda run: [])
    monkeypatch.setattr(estimate, "resolve_slip_model",
                        lambda model_dir: (None, "no tracking store at here"))
    out = tmp_path / "s.csv"
    assert main(["estimate", str(tmp_path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "note: no learned slip model (no tracking store at here)" in text
    assert ("note: encoder lag applied on 2 of 4 runs, not applied on 1 (no clear "
            "cross-correlation peak), not estimated on 1") in text
    written = sorted(p.name for p in tmp_path.glob("s_*.csv"))
    assert written == ["s_ASPHALT_00.csv", "s_ASPHALT_01.csv", "s_GRASS_00.csv",
                       "s_SNOW_00.csv"]
    assert f"r/SNOW/00 -> {tmp_path / 's_SNOW_00.csv'}" in text
    frame = pd.read_csv(tmp_path / "s_GRASS_00.csv", dtype={"t_s": str})
    assert frame["t_s"].tolist() == ["1700000000.123456"]


def test_a_write_error_naming_no_file_names_the_output_options_given(
        tmp_path, capsys, monkeypatch):
    # a file over the size limit (EFBIG) names no file, as a full disk does: the line names
    # the one output given, or each of several; a long message is cut at 500 characters
    import errno

    def fail(args):
        raise failure
    monkeypatch.setattr(control_sim, "main", fail)
    argv = ["control-sim", "--vehicle", "husky", "--terrain", "ice", "--scenario",
            "straight_accel", "--controller", "off", "--json", str(tmp_path / "c.json")]
    failure = OSError(errno.EFBIG, "File too large")
    assert main(argv) == 2
    assert capsys.readouterr().err == (f"terrain control-sim: error: [Errno {errno.EFBIG}] "
                                       f"File too large while writing --json "
                                       f"{tmp_path / 'c.json'}\n")
    assert main([*argv, "--csv", str(tmp_path / "t.csv")]) == 2
    assert capsys.readouterr().err.endswith(
        f" while writing one of --json {tmp_path / 'c.json'}, --csv {tmp_path / 't.csv'}\n")
    failure = ConfigError("x" * 600)
    assert main(argv) == 2
    assert capsys.readouterr().err == "terrain control-sim: error: " + "x" * 497 + "...\n"
    # a write error that names its file is that file's, not the options' (it may be a
    # temporary file or a cache): no 'while writing' is added
    failure = OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "tmp.bin"))
    assert main(argv) == 2
    assert capsys.readouterr().err == ("terrain control-sim: error: No space left on device: "
                                       f"{tmp_path / 'tmp.bin'}\n")


def test_slip_model_dir_errors_list_what_the_folder_holds_and_the_loaders_reason(
        tmp_path, monkeypatch):
    import mlflow.sklearn

    from pipelines.slip_model import load_slip_model_dir

    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ConfigError, match=r"not an MLflow model folder \(found: nothing\)"):
        load_slip_model_dir(empty)
    full = tmp_path / "full"
    full.mkdir()
    for name in "abcdefghij":
        (full / name).write_text("")
    with pytest.raises(ConfigError, match=r"\(found: a, b, c, d, e, f, g, h\); give"):
        load_slip_model_dir(full)
    # a reason of exactly 200 characters is kept whole; a longer one is cut to 200
    (full / "MLmodel").write_text("flavors: {}\n")
    for reason, shown in (("y" * 200, "y" * 200), ("z" * 201, "z" * 197 + "...")):
        def fail(uri, reason=reason):
            raise ValueError(reason)
        monkeypatch.setattr(mlflow.sklearn, "load_model", fail)
        with pytest.raises(ConfigError) as info:
            load_slip_model_dir(full)
        assert str(info.value) == (f"--slip-model-dir {full}: the model cannot be loaded "
                                   f"(ValueError: {shown})")


def test_the_registered_slip_model_is_its_highest_version_by_number(monkeypatch):
    # versions 9 and 10: the latest is 10 (9 as text)
    import mlflow
    import mlflow.artifacts
    import mlflow.sklearn

    import terrain.tracking
    from pipelines.slip_model import REGISTERED_SLIP_MODEL, resolve_slip_model

    class Client:
        def __init__(self, **kwargs):
            pass

        def search_model_versions(self, query):
            return [SimpleNamespace(version=v) for v in ("9", "10", "2")]

        def get_model_version_download_uri(self, name, version):
            return f"store/{name}/{version}"

    monkeypatch.setattr(terrain.tracking, "tracking_uri", lambda: "http://stand-in:5000")
    monkeypatch.setattr(terrain.tracking, "check_store", lambda store: None)
    monkeypatch.setattr(mlflow, "MlflowClient", Client)
    monkeypatch.setattr(mlflow.artifacts, "download_artifacts",
                        lambda artifact_uri, tracking_uri: "local:" + artifact_uri)
    monkeypatch.setattr(mlflow.sklearn, "load_model", lambda path: path)
    assert resolve_slip_model(None) == (f"local:store/{REGISTERED_SLIP_MODEL}/10",
                                        f"models:/{REGISTERED_SLIP_MODEL}/latest")

    def unreachable(store):
        raise ConfigError("cannot reach http://stand-in:5000; start it first")
    monkeypatch.setattr(terrain.tracking, "check_store", unreachable)
    assert resolve_slip_model(None) == (None, "tracking store not usable: cannot reach "
                                              "http://stand-in:5000")
