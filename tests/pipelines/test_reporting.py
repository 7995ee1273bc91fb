"""Commands seen by a new user: one-line errors with exit status 2, what was repaired, dropped
or skipped, pooled recall, the logged model, the registered model from another folder."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from terrain.cli import main

PRO = {"t_s": "time", "vel_l": "velL", "vel_r": "velR", "cur_l": "curL", "cur_r": "curR"}


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """Run commands in an empty folder with the embedded MLflow store."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    monkeypatch.delenv("MLFLOW_REGISTRY_URI", raising=False)
    return tmp_path


def _write(run, root, terrain=None):
    _, t, index = run.run_id.split("/")
    folder = root / (terrain or t)
    folder.mkdir(parents=True, exist_ok=True)
    run.streams["wheels"].rename(columns=PRO).to_csv(folder / f"pro_{index}.csv", index=False)
    imu = folder / f"imu_{index}.csv"
    run.streams["imu"].rename(columns={"t_s": "time"}).to_csv(imu, index=False)
    return imu


class _Captured:
    """Already captured output, readable like ``capsys``."""

    def __init__(self, captured):
        self._captured = captured

    def readouterr(self):
        return self._captured


def _assert_one_line_error(capsys, command):
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith(f"terrain {command}: error:")]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


#: one missing-input case per subcommand (test_the_parametrised_list_covers_every_subcommand)
MISSING_INPUT_CASES = [
    ["cv", "--dataset", "vulpi", "--no-progress"],
    ["train", "--dataset", "vulpi", "--no-progress"],
    ["predict", "--model", "nowhere", "missing_runs", "--out", "p.csv"],
    ["convert", "missing_src", "--dataset", "vulpi", "--data-dir", "d"],
    ["benchmark", "--repeats", "1"],
    ["simulate", "--vehicle", "mars", "--terrain", "ASPHALT", "--out", "sim"],
    ["audit", "missing_runs", "--json", "a.json", "--no-mlflow"],
    ["estimate", "missing_runs", "--out", "e.csv"],
    ["slip-table", "--data-dir", "missing_data"],
    # reaches the (missing) shipped data only after ~45 s of simulation: slow
    pytest.param(["validate", "estimation", "--quick"], marks=pytest.mark.slow),
    ["slip-fit", "--measured", "vulpi"],   # (an unknown terrain is a usage error)
    ["control-sim", "--vehicle", "husky", "--terrain", "MUD", "--scenario", "orchard",
     "--controller", "off", "--json", "c.json"],
    pytest.param(["control-grid", "--terrains", "MUD", "--out", "g"], marks=pytest.mark.slow),
    ["stream", "--model", "nowhere", "missing_runs", "--out", "s.csv"],
    ["stream-eval", "--part", "streams"],
    ["compare", "--quick", "--n-jobs", "1", "--out", "cmp"],
    ["serve", "--model", "nowhere", "--port", "1"],
]


_NO_MANIFEST = "manifest not found; regenerate data/ with `terrain convert` (file "
_SHIPPED = None      # the manifest of TERRAIN_DATA_DIR (the test's no_data_here), by path
#: what each case's one line must say: the missing input, by name
MISSING_INPUT_WORDS = {
    "cv": _SHIPPED, "train": _SHIPPED, "benchmark": _SHIPPED, "validate": _SHIPPED,
    "stream-eval": _SHIPPED, "compare": _SHIPPED,
    "slip-table": _NO_MANIFEST + str(Path("missing_data") / "manifest.json") + ")",
    "predict": "cannot load model 'nowhere': model directory nowhere does not exist",
    "stream": "model directory nowhere does not exist",
    "serve": "model directory nowhere does not exist",
    "convert": "runs folder does not exist (file missing_src)",
    "audit": "runs folder does not exist (file missing_runs)",
    "estimate": "runs folder does not exist (file missing_runs)",
    "simulate": "unknown vehicle 'mars'",
    "slip-fit": _SHIPPED,
    "control-sim": "unknown terrain 'MUD'",
    "control-grid": "unknown terrain 'MUD'",
}


@pytest.mark.slow
@pytest.mark.parametrize("argv", MISSING_INPUT_CASES)
def test_every_subcommand_answers_a_missing_input_in_one_line_with_status_2(
        workdir, capsys, monkeypatch, argv):
    monkeypatch.setenv("TERRAIN_DATA_DIR", str(workdir / "no_data_here"))
    from terrain.cli import SUBCOMMANDS
    if argv[0] not in SUBCOMMANDS:
        pytest.skip(f"{argv[0]} not in this installation")
    assert main(argv) == 2
    line = _assert_one_line_error(capsys, argv[0])
    # the missing input by name: any of "not found", "unknown", ... passed a line naming
    # none (or the wrong one)
    words = MISSING_INPUT_WORDS[argv[0]] or (
        f"{_NO_MANIFEST}{workdir / 'no_data_here' / 'manifest.json'})")
    assert words in line, line


def test_stream_eval_needs_two_folds(workdir, capsys):
    assert main(["stream-eval", "--part", "streams", "--folds", "1"]) == 2
    assert "--folds must be at least 2" in _assert_one_line_error(capsys, "stream-eval")


def test_the_parametrised_list_covers_every_subcommand():
    from terrain.cli import SUBCOMMANDS
    covered = {(case.values[0] if hasattr(case, "values") else case)[0]   # pytest.param or list
               for case in MISSING_INPUT_CASES}
    assert set(SUBCOMMANDS) <= covered, (
        f"add a missing-input case for {sorted(set(SUBCOMMANDS) - covered)} to "
        "test_every_subcommand_answers_a_missing_input_in_one_line_with_status_2")


def test_debug_shows_the_traceback(workdir):
    from terrain.errors import DataFormatError
    with pytest.raises(DataFormatError):
        main(["--debug", "estimate", "missing_runs", "--out", "e.csv"])
    with pytest.raises(DataFormatError):
        main(["estimate", "missing_runs", "--out", "e.csv", "--debug"])


def test_bad_input_file_is_one_line_naming_file_and_line(workdir, capsys, vulpi_runs):
    imu = _write(vulpi_runs[0], workdir / "runs")
    text = imu.read_text().split("\n")
    text[40] += ","
    imu.write_text("\n".join(text))
    assert main(["estimate", str(workdir / "runs"), "--out", "e.csv"]) == 2
    line = _assert_one_line_error(capsys, "estimate")
    assert str(imu) in line and "line 41" in line


@pytest.mark.slow
def test_cv_prints_and_logs_pooled_recall_matching_the_confusion(workdir, capsys):
    out = workdir / "cv.json"
    assert main(["cv", "--dataset", "vulpi", "--seeds", "0", "1", "--json", str(out),
                 "--no-progress"]) == 0
    report = json.loads(out.read_text())
    counts = np.asarray(report["confusion"]["counts"], dtype=float)
    expected = dict(zip(report["confusion"]["labels"], np.diag(counts) / counts.sum(axis=1)))
    assert report["pooled_recall"] == pytest.approx(expected)
    printed = capsys.readouterr().out
    assert "pooled per-class recall (confusion matrix, counts summed over 2 seed(s))" in printed
    assert "input: 15 run(s), 15 used" in printed
    from mlflow import MlflowClient
    client = MlflowClient(tracking_uri=f"sqlite:///{workdir / 'mlflow.db'}")
    run = client.get_run(report["mlflow_run_id"])
    for c, v in expected.items():
        assert run.data.metrics[f"recall_{c}_pooled"] == pytest.approx(v)
    assert run.data.metrics["input_runs_used"] == 15
    arts = {a.path for a in client.list_artifacts(run.info.run_id)}
    assert "input_report.csv" in arts


@pytest.mark.slow
def test_train_logs_what_it_trained_and_the_model_resolves_from_another_folder(
        workdir, capsys, monkeypatch, vulpi_runs, recwarn):
    assert main(["train", "--dataset", "vulpi", "--model", "svm", "--model-out", "model",
                 "--no-progress"]) == 0
    printed = capsys.readouterr()
    assert "CloudPickle" not in printed.err + printed.out
    assert not [w for w in recwarn if "input_example" in str(w.message)]
    mlmodel = (workdir / "model" / "MLmodel").read_text()
    assert "saved_input_example_info" in mlmodel
    from mlflow import MlflowClient
    store = f"sqlite:///{workdir / 'mlflow.db'}"
    client = MlflowClient(tracking_uri=store)
    (run,) = client.search_runs([client.get_experiment_by_name("terrain-train").experiment_id])
    params = run.data.params
    assert "svm_probability" not in params and "protocol" not in params
    assert "CalibratedClassifierCV(SVC)" in params["model.steps"]
    assert params["model.svc__method"] == "sigmoid"
    # a terrain folder with a dead gyro axis, predicted from another folder via the registry
    other = workdir / "elsewhere"
    other.mkdir()
    imu = _write(vulpi_runs[0], workdir / "new_runs", "SOMEWHERE")
    frame = pd.read_csv(imu)
    frame["wz"] = 0.0
    frame.to_csv(imu, index=False)
    monkeypatch.chdir(other)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", store)
    assert main(["predict", "--model", "models:/terrain-vulpi/latest",
                 str(workdir / "new_runs" / "SOMEWHERE"), "--out", "p.csv",
                 "--no-progress"]) == 0
    printed = capsys.readouterr()
    assert "imu.wz stuck" in printed.err
    assert "window(s) holding one flagged" in printed.out
    pred = pd.read_csv(other / "p.csv")
    assert len(pred) > 5 and (pred["flags"] == "stuck:imu.wz").all()
    (prun,) = client.search_runs(
        [client.get_experiment_by_name("terrain-predict").experiment_id])
    assert prun.data.metrics["n_runs_used"] == 1
    assert prun.data.metrics["n_windows_flagged"] == len(pred)


@pytest.fixture(scope="module")
def saved_model(tmp_path_factory):
    """A model trained on the shipped Vulpi runs, saved as an MLflow model directory."""
    folder = tmp_path_factory.mktemp("model")
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(folder)
        mp.delenv("MLFLOW_TRACKING_URI", raising=False)
        # the reporting does not depend on the model kind: the SVM trains in seconds
        assert main(["train", "--dataset", "vulpi", "--model", "svm", "--model-out", "model",
                     "--no-register", "--no-progress"]) == 0
    return folder / "model"


@pytest.mark.slow
def test_predict_says_why_a_run_gives_no_window(workdir, capsys, vulpi_runs, saved_model):
    imu = _write(vulpi_runs[0], workdir / "runs")
    for path in (imu, imu.with_name(imu.name.replace("imu", "pro"))):
        frame = pd.read_csv(path)
        frame[frame["time"] < 1.5].to_csv(path, index=False)
    assert main(["predict", "--model", str(saved_model), str(workdir / "runs"),
                 "--out", "p.csv", "--no-progress"]) == 2
    captured = capsys.readouterr()
    assert "1 run(s) too short (shorter than one 2 s window): runs/" in captured.out
    assert "no window to predict in 1 run(s)" in _assert_one_line_error(_Captured(captured),
                                                                        "predict")


@pytest.mark.slow
def test_predict_counts_windows_dropped_for_a_gap(workdir, capsys, vulpi_runs, saved_model):
    imu = _write(vulpi_runs[0], workdir / "runs")
    frame = pd.read_csv(imu)
    frame[(frame["time"] < 10) | (frame["time"] > 13)].to_csv(imu, index=False)
    assert main(["predict", "--model", str(saved_model), str(workdir / "runs"),
                 "--out", "p.csv", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "1 timestamp gap(s) (3.0 s) in runs/" in out
    assert "dropped windows: 2 spanning a gap" in out


@pytest.mark.slow
def test_predict_counts_and_names_a_run_skipped_for_a_missing_stream(
        workdir, capsys, vulpi_runs, saved_model):
    # a run without the IMU file the model needs is skipped: counted and named, not dropped
    # silently, and no prediction row comes from it
    _write(vulpi_runs[0], workdir / "runs")
    imu = _write(vulpi_runs[1], workdir / "runs", terrain="OTHER")
    imu.unlink()
    assert main(["predict", "--model", str(saved_model), str(workdir / "runs"),
                 "--out", "p.csv", "--no-progress"]) == 0
    out = capsys.readouterr().out
    skipped = "runs/OTHER/" + vulpi_runs[1].run_id.split("/")[2]
    assert f"1 run(s) skipped (no imu stream): {skipped}" in out
    assert "from 1 of 2 runs" in out
    assert not pd.read_csv(workdir / "p.csv")["run"].str.startswith("runs/OTHER").any()


def test_predict_with_a_bad_model_path_is_one_line(workdir, capsys, vulpi_runs):
    _write(vulpi_runs[0], workdir / "runs")
    assert main(["predict", "--model", str(workdir / "no_model"), str(workdir / "runs"),
                 "--out", "p.csv", "--no-progress"]) == 2
    line = _assert_one_line_error(capsys, "predict")
    assert "cannot load model" in line and len(line) < 700


def test_help_shows_defaults_and_choices(capsys):
    for argv, needles in ((["cv", "--help"], ["(default: 2.0)", "{borealtc,vulpi,combined}",
                                              "(default: borealtc)"]),
                          (["simulate", "--help"], ["ASPHALT", "husky", "straight_accel"])):
        with pytest.raises(SystemExit):
            main(argv)
        out = " ".join(capsys.readouterr().out.split())
        for needle in needles:
            assert needle in out, needle


def test_served_model_refuses_a_huge_finite_value(saved_model, vulpi_runs):
    from terrain.errors import ImplausibleValueError
    from terrain.serving.pyfunc import load_model, runs_to_model_input

    model, meta = load_model(saved_model)
    samples, _ = runs_to_model_input(vulpi_runs[:1], meta["channels"], float(meta["rate_hz"]))
    assert len(model.predict(samples)) > 5
    samples.loc[300, "ax"] = 1e300
    with pytest.raises(ImplausibleValueError) as info:
        model.predict(samples)
    assert info.value.column == "ax" and info.value.row == 300
    assert "row 300" in str(info.value)


@pytest.mark.slow
def test_audit_of_a_run_with_a_dead_gyro_reports_instead_of_crashing(workdir, capsys,
                                                                     borealtc_runs):
    run = next(r for r in borealtc_runs if r.run_id == "borealtc/ASPHALT/00")
    imu = _write(run, workdir / "runs")
    frame = pd.read_csv(imu)
    frame["wz"] = 0.0
    frame.to_csv(imu, index=False)
    assert main(["audit", str(workdir / "runs"), "--json", "a.json", "--no-mlflow",
                 "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert "imu.wz stuck" in captured.err
    assert "stuck or dead sensor channel(s): runs/ASPHALT/00 (imu.wz)" in captured.out
    assert "audited 1 runs" in captured.out


@pytest.mark.slow
def test_a_registered_model_on_s3_without_credentials_is_a_one_line_error(workdir, capsys,
                                                                          monkeypatch):
    # a registry entry whose artifacts live on S3, read with no AWS credentials: botocore's
    # NoCredentialsError used to reach the user as a traceback
    pytest.importorskip("botocore")
    from mlflow import MlflowClient

    for var in ("AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY", "AWS_SESSION_TOKEN",
                "AWS_PROFILE"):
        monkeypatch.delenv(var, raising=False)
    for var in ("AWS_SHARED_CREDENTIALS_FILE", "AWS_CONFIG_FILE"):
        monkeypatch.setenv(var, str(workdir / "none"))
    monkeypatch.setenv("AWS_EC2_METADATA_DISABLED", "true")
    store = f"sqlite:///{workdir / 'mlflow.db'}"
    client = MlflowClient(tracking_uri=store, registry_uri=store)   # not a process-wide one
    client.create_registered_model("cloudy")
    client.create_model_version("cloudy", "s3://no-such-bucket-terrain/model")
    assert main(["predict", "--model", "models:/cloudy/1", "runs", "--out", "p.csv"]) == 2
    line = _assert_one_line_error(capsys, "predict")
    assert "models:/cloudy/1" in line and "credentials" in line, line


@pytest.mark.slow
def test_stream_eval_prints_and_logs_per_seed_accuracy_and_a_readable_table(workdir, capsys,
                                                                            monkeypatch):
    """The held-out stream replay itself is replaced by two fixed score rows per seed: the
    command pools them, prints and logs every seed's accuracy, and logs a score table that
    reads back to the same pooled figures."""
    import mlflow

    import pipelines.stream_eval
    from terrain.serving.evaluation import StreamScore, pool_scores, read_stream_scores

    def fake(runs, recipe, seed, smoothings, **kwargs):
        scores = [StreamScore(0.9 + 0.01 * seed, (1.0 + seed, np.inf), 100, 0.95, 80,
                              {"SNOW": {"SNOW": 90 + seed, "ICE": 10 - seed}}),
                  StreamScore(0.8, (0.5,), 300, 0.85, 200, {"ICE": {"ICE": 240}})]
        return pd.DataFrame([{"fold": f, "smoothing": name, **s.as_row()}
                             for name in smoothings for f, s in enumerate(scores)])

    monkeypatch.setattr(pipelines.stream_eval, "held_out_streams", fake)
    assert main(["stream-eval", "--part", "streams", "--kinds", "all-dense",
                 "--seeds", "0", "2"]) == 0
    out = capsys.readouterr().out
    # seed 0: (0.90 * 100 + 0.8 * 300) / 400, seed 2: (0.92 * 100 + 0.8 * 300) / 400
    assert "per seed 0.825 / 0.830" in out
    mlflow.set_tracking_uri(f"sqlite:///{workdir / 'mlflow.db'}")
    (run,) = mlflow.search_runs(experiment_names=["terrain-stream-eval"],
                                output_format="list")
    name = "all-dense_dwell10_power0.5"
    assert run.data.metrics[f"{name}_accuracy_seed2"] == pytest.approx(0.83)
    path = mlflow.artifacts.download_artifacts(
        run_id=run.info.run_id, artifact_path="held_out_streams_all-dense.csv",
        dst_path=str(workdir / "dl"))
    table = read_stream_scores(path)
    pooled = pool_scores(table[table["smoothing"] == "dwell10_power0.5"])
    assert pooled["accuracy"] == pytest.approx(run.data.metrics[f"{name}_accuracy"])
    assert pooled["n_switches"] == 6 and np.isinf(max(table["delays_s"].sum()))


@pytest.mark.slow
def test_audit_says_which_checks_a_run_without_imu_misses(workdir, capsys, borealtc_runs):
    # a wheel-only run was "audited 1 runs, skipped 0" without a word that only its
    # currents were compared
    run = next(r for r in borealtc_runs if r.run_id == "borealtc/FLOORING/04")
    assert not run.has_imu
    folder = workdir / "runs" / "FLOORING"
    folder.mkdir(parents=True)
    run.streams["wheels"].iloc[:200].rename(columns=PRO).to_csv(folder / "pro_04.csv",
                                                                index=False)
    assert main(["audit", "runs", "--json", "a.json", "--no-mlflow", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "1 of 1 audited run(s) have no IMU stream (runs/FLOORING/04)" in out
    assert "only their motor currents are compared" in out
    signals = {s["signal"] for s in json.loads((workdir / "a.json").read_text())["signals"]}
    assert signals == {"cur_l", "cur_r"}


@pytest.mark.slow
def test_a_reader_that_closes_stdout_early_is_not_an_error(tmp_path):
    # `terrain slip-table | head -1`: the reader went away after its first line; the command
    # printed "terrain slip-table: error: [Errno 32] Broken pipe" and exited 2 (or Python's
    # "Exception ignored ... BrokenPipeError" and 120 when the write failed only at exit)
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    read, write = os.pipe()
    os.close(read)                     # the reader is gone before the command writes
    try:
        proc = subprocess.run(
            [sys.executable, "-c", "import sys; from terrain.cli import main; "
             "sys.exit(main(['slip-table']))"],
            stdout=write, stderr=subprocess.PIPE, text=True, cwd=tmp_path, timeout=120,
            env={**os.environ, "PYTHONPATH": str(root)})
    finally:
        os.close(write)
    assert proc.stderr == ""
    assert proc.returncode == 141      # as a shell reports a writer stopped by SIGPIPE
