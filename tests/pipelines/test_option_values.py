"""Numeric options out of range are refused in one line before any work, and whatever
still goes wrong inside a command reaches the user as one line, never a traceback.

The values below are those a fuzz of every numeric option of the CLI found answered
with a Python traceback (``OverflowError``, NumPy's seed ``ValueError``, a
``MemoryError``) or accepted where they would run for ever (``--cnn-seeds 10**12``).
"""

from __future__ import annotations

import argparse
import re

import pytest
from cli_helpers import exit_code

from features.windows import MAX_WINDOW_SAMPLES, WindowConfig
from pipelines.arguments import EMPTY_PATH, seed_value
from terrain.audit.physics import PhysicsComparisonSettings
from terrain.audit.selection import MAX_BOOTSTRAP, SelectionSettings
from terrain.cli import main
from terrain.control.traction import TractionControlConfig
from terrain.errors import ConfigError
from terrain.models.compare import CompareConfig
from terrain.models.experiment import MAX_SEED, ExperimentConfig
from terrain.models.registry import MAX_CNN_SEEDS, MAX_TORCH_THREADS, ModelConfig


def test_seed_type_takes_numpys_range_only():
    assert seed_value("0") == 0 and seed_value(str(MAX_SEED)) == MAX_SEED
    for bad in ("-1", str(MAX_SEED + 1), "1.5", "x"):
        with pytest.raises(argparse.ArgumentTypeError, match="seed"):
            seed_value(bad)


_NOT_FINITE = "window_s and rate_hz must be finite numbers > 0"


@pytest.mark.parametrize("kwargs, words", [
    # an infinite window or rate was also refused as a window of too many samples ("holds
    # inf samples"): each is refused as not finite
    (dict(window_s=float("inf")), _NOT_FINITE), (dict(window_s=float("nan")), _NOT_FINITE),
    (dict(hop_s=float("inf")), "hop_s must be a finite number > 0 s"),
    (dict(rate_hz=float("inf")), _NOT_FINITE),
    (dict(window_s=2.0, partition_s=float("inf")), "partition_s must be finite"),
    (dict(window_s=MAX_WINDOW_SAMPLES / 100 + 1, rate_hz=100.0),
     f"at most {MAX_WINDOW_SAMPLES:,} (a shorter window or a lower rate)")])
def test_window_config_refuses_infinite_or_huge_windows(kwargs, words):
    with pytest.raises(ConfigError, match=re.escape(words)):
        WindowConfig(**kwargs)


def test_window_config_keeps_the_largest_window_it_allows():
    assert WindowConfig(window_s=MAX_WINDOW_SAMPLES / 100, rate_hz=100.0).n_samples == \
        MAX_WINDOW_SAMPLES


@pytest.mark.parametrize("kwargs, match", [
    (dict(seeds=(-1,)), "seeds"), (dict(seeds=(MAX_SEED + 1,)), "seeds"),
    (dict(seeds=()), "seeds"), (dict(seeds=(1, 2, 1)), "seeds must be distinct"),
    (dict(train_hop_s=float("inf")), "train_hop_s"),
    (dict(window_s=float("inf")), "window_s"), (dict(hop_s=float("inf")), "hop_s"),
])
def test_experiment_config_checks_seeds_and_windows_before_any_data(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        ExperimentConfig(**kwargs)


def _usage_error(argv, capsys, tmp_path, monkeypatch) -> str:
    """Run ``terrain argv`` in ``tmp_path``: it must stop with a usage error (exit 2), show
    no traceback and write nothing; returns its stderr."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert not any(tmp_path.iterdir())
    return err


@pytest.mark.parametrize("argv", [
    ["cv", "--dataset", "vulpi", "--seeds", "0", "1", "0"],
    ["compare", "--quick", "--seeds", "2", "2"],
    ["stream-eval", "--seeds", "0", "0"],
    ["control-grid", "--seeds", "3", "3", "--out", "x"],
    ["slip-fit", "--train-seeds", "0", "0"],
    ["control-sim", "--vehicle", "husky", "--terrain", "SNOW", "--scenario", "orchard",
     "--controller", "off", "--json", "x.json", "--classifier-seeds", "5", "5"],
])
def test_a_seed_given_twice_is_a_usage_error(argv, capsys, tmp_path, monkeypatch):
    # it would run one split (or simulation) twice and count it as two seeds
    assert "given twice" in _usage_error(argv, capsys, tmp_path, monkeypatch)


@pytest.mark.parametrize("argv, message", [
    (["compare", "--models", "svm", "svm"], "models must be distinct: ['svm']"),
    (["compare", "--windows-s", "2", "2.0"], "windows_s must be distinct: [2.0]"),
    (["compare", "--history", "1", "5", "1"], "history must be distinct: [1]"),
    (["stream-eval", "--kinds", "wheels", "wheels"], "--kinds: ['wheels'] given more"),
    # the wheel CV alone uses no recipe: the list was ignored (and not logged) unsaid
    (["stream-eval", "--part", "wheel-cv", "--kinds", "all"],
     "--kinds chooses the recipes of the held-out streams and of --model-out; --part wheel-cv"),
    (["control-grid", "--terrains", "ICE", "ice", "--out", "g"], "terrains: ['ICE'] given"),
    (["control-grid", "--vehicles", "husky", "husky", "--out", "g"], "vehicles: ['husky']"),
    (["control-grid", "--ki-grid", "0", "0", "--out", "g"], "--ki-grid: [0.0] given"),
    (["slip-fit", "--scenarios", "orchard", "orchard", "--out", "s"], "scenarios: ['orchard']"),
    # one selection logged as the param 'imu,imu' and a run named 'svm-borealtc-imu+imu'
    (["cv", "--signals", "imu", "imu"], "signals ['imu'] given twice"),
    (["train", "--signals", "wheels", "imu", "wheels"], "signals ['wheels'] given twice"),
])
def test_a_value_repeated_on_a_grid_axis_is_refused_before_any_work(argv, message, capsys,
                                                                    tmp_path, monkeypatch):
    # each would fit or simulate its cells twice and count them twice in the tables
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("argv, message", [
    (["control-sim", "--vehicle", "husky", "--terrain", "SNOW", "--scenario", "orchard",
      "--controller", "traction", "--json", "c.json", "--terrain-source", "label",
      "--classifier-seeds", "5", "6"],
     "--classifier-seeds trains the live-sim classifier; --terrain-source label uses none"),
    (["control-grid", "--out", "g", "--classifier-uncontrolled-only"],
     "--classifier-uncontrolled-only trains the live-sim classifier"),
    (["control-grid", "--out", "g", "--model", "m"],
     "--model is used only with --terrain-source model, not 'label'"),
    # ran and ignored --kp without a word (CLI fuzz)
    (["control-sim", "--vehicle", "husky", "--terrain", "SNOW", "--scenario", "orchard",
      "--controller", "off", "--json", "c.json", "--terrain-source", "label", "--kp", "5"],
     "--kp acts on the traction controller, which --controller off does not run"),
    (["control-sim", "--vehicle", "husky", "--terrain", "SNOW", "--scenario", "orchard",
      "--controller", "off", "--json", "c.json", "--classifier-uncontrolled-only", "--ki",
      "1", "--no-feed-forward"],
     "--ki, --no-feed-forward act on the traction controller, which --controller off does "
     "not run (terrain source 'live-sim', uncontrolled classifier runs)"),
])
def test_a_terrain_source_option_the_source_ignores_is_refused(argv, message, capsys,
                                                               tmp_path, monkeypatch):
    # with the label as terrain source these ran and changed nothing (control-grid also
    # took --model without a word)
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("argv, message", [
    (["control-grid", "--out", "g", "--no-tune", "--kp-grid", "2", "--ki-grid", "7"],
     "--kp-grid and --ki-grid are tuning grids; --no-tune uses the default gains"),
    (["control-grid", "--out", "g", "--ki-grid", "3", "--no-tune"],
     "--ki-grid is a tuning grid; --no-tune uses the default gains: leave it or --no-tune"),
    (["control-grid", "--out", "g", "--vehicles", "agrimaro", "--husky-estimator",
      "observer"], "--husky-estimator is the Husky's slip estimator; --vehicles agrimaro has "
                   "no husky: leave it out"),
    (["control-grid", "--out", "g", "--vehicles", "husky", "--agrimaro-estimator",
      "ekf-vo"], "--agrimaro-estimator is the AgriMaRo's slip estimator; --vehicles "
                 "husky has no agrimaro: leave it out"),
])
def test_a_control_grid_option_the_grid_ignores_is_refused(argv, message, capsys, tmp_path,
                                                           monkeypatch):
    # the grid ran, ignored them and logged them to MLflow as parameters of the run
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())


def test_slip_fit_refuses_an_unknown_measured_dataset_before_simulating(capsys, tmp_path):
    # it simulated and fitted for minutes and then failed on the dataset name
    with pytest.raises(SystemExit) as exc:
        main(["slip-fit", "--measured", "mars", "--out", str(tmp_path / "o"), "--cache-dir",
              str(tmp_path / "c")])
    assert exc.value.code == 2 and "invalid choice: 'mars'" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


def test_slip_fit_refuses_a_seed_in_training_and_held_out(capsys, tmp_path):
    # the held-out mask would take seed 1 and leave it out of training without a word
    assert main(["slip-fit", "--train-seeds", "0", "1", "--test-seeds", "1", "--out",
                 str(tmp_path / "o"), "--cache-dir", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert "seed(s) [1] in both --train-seeds and --test-seeds" in err
    assert not (tmp_path / "c").exists()


def test_limits_of_costly_repeats():
    ModelConfig(kind="cnn", cnn_seeds=MAX_CNN_SEEDS)
    with pytest.raises(ConfigError, match="cnn_seeds"):
        ModelConfig(kind="cnn", cnn_seeds=MAX_CNN_SEEDS + 1)
    # torch accepts a million threads and crashes at exit (segmentation fault)
    ModelConfig(kind="cnn", n_threads=MAX_TORCH_THREADS)
    for bad in (0, MAX_TORCH_THREADS + 1, 10 ** 6, True):
        with pytest.raises(ConfigError, match="n_threads"):
            ModelConfig(kind="cnn", n_threads=bad)
    SelectionSettings(n_bootstrap=MAX_BOOTSTRAP)
    with pytest.raises(ConfigError, match="n_bootstrap"):
        SelectionSettings(n_bootstrap=MAX_BOOTSTRAP + 1)
    with pytest.raises(ConfigError, match="n_param_bootstrap"):
        SelectionSettings(n_param_bootstrap=10 ** 12)
    with pytest.raises(ConfigError, match="n_bootstrap"):
        PhysicsComparisonSettings(n_bootstrap=5)


@pytest.mark.parametrize("kwargs, match", [
    (dict(windows_s=(2.0, float("nan"))), "window_s"), (dict(signals=("bogus",)), "bogus"),
    (dict(datasets=("x",)), "dataset"), (dict(max_epochs=0), "max_epochs"),
    (dict(n_threads=0), "n_threads"), (dict(n_threads=10 ** 6), "n_threads"),
    (dict(train_hop_s=float("inf")), "train_hop_s"),
])
def test_compare_config_checks_every_axis_value(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        CompareConfig(**kwargs)


def test_traction_config_names_the_non_finite_setting():
    with pytest.raises(ConfigError, match=r"got kp=nan$"):
        TractionControlConfig(kp=float("nan"))


#: (argv, text the one-line message holds), each refused before any run is read
_REFUSED = [
    # refused by the option's own type, named as the option (it said "window_s and rate_hz")
    (["cv", "--window-s", "inf"], "argument --window-s: must be a finite number > 0"),
    (["cv", "--window-s", "0"], "argument --window-s: must be a finite number > 0"),
    (["cv", "--hop-s", "inf"], "argument --hop-s: must be a finite number > 0"),
    (["cv", "--train-hop-s", "inf"], "argument --train-hop-s: must be a finite number > 0"),
    (["cv", "--seeds", "-1"], "argument --seeds: a seed"),
    (["cv", "--seeds", "1000000000000"], "argument --seeds: a seed"),
    (["train", "--window-s", "1e12"], "at most 1,000,000"),
    (["train", "--train-hop-s", "inf"], "argument --train-hop-s: must be a finite"),
    (["train", "--cnn-seeds", "0"], "argument --cnn-seeds: must be an integer >= 1"),
    (["train", "--cnn-seeds", "1000000000000"],
     "argument --cnn-seeds: must be an integer in 1-10, got 1000000000000"),
    (["compare", "--quick", "--signals", "imu"], "would ignore ['--signals']"),
    (["compare", "--quick", "--early-stopping"], "would ignore ['--early-stopping']"),
    (["compare", "--n-jobs", "0"], "argument --n-jobs"),
    (["compare", "--windows-s", "nan"], "argument --windows-s: must be a finite number > 0"),
    (["compare", "--max-epochs", "0"], "argument --max-epochs: must be an integer >= 1"),
    (["compare", "--threads", "0"], "argument --threads: must be an integer >= 1, got 0"),
    (["audit", "--dataset", "vulpi", "--json", "a.json", "--replay-input-lowpass-hz", "0"],
     "argument --replay-input-lowpass-hz: must be a finite number > 0, got 0"),
    (["stream-eval", "--window-s", "-1"], "argument --window-s: must be a finite number"),
    # 3 samples at the wheel CV's 10 Hz (15 at the 50 Hz the check used): refused after the
    # dataset was read and an MLflow run opened
    (["stream-eval", "--window-s", "0.3"], "at least 4 samples"),
    (["compare", "--threads", "1000000"],
     "argument --threads: must be an integer in 1-1024, got 1000000"),
    (["benchmark", "--repeats", "1000000000000"], "--repeats"),
    # named as SelectionSettings' n_bootstrap, n_param_bootstrap and min_gain
    (["audit", "--dataset", "vulpi", "--json", "a.json", "--bootstrap", "1000000000000"],
     "argument --bootstrap: must be an integer in 10-100,000, got 1000000000000"),
    (["audit", "--dataset", "vulpi", "--json", "a.json", "--bootstrap", "0"],
     "argument --bootstrap: must be an integer in 10-100,000, got 0"),
    (["audit", "--dataset", "vulpi", "--json", "a.json", "--param-bootstrap",
      "1000000000000"],
     "argument --param-bootstrap: must be an integer in 0-10,000, got 1000000000000"),
    (["audit", "--dataset", "vulpi", "--json", "a.json", "--param-bootstrap", "-1"],
     "argument --param-bootstrap: must be an integer in 0-10,000, got -1"),
    (["audit", "--dataset", "vulpi", "--json", "a.json", "--min-gain", "nan"],
     "argument --min-gain: must be a fraction of the baseline RMSE in [0, 1), got nan"),
    (["audit", "--dataset", "vulpi", "--json", "a.json", "--min-gain", "1"],
     "argument --min-gain: must be a fraction of the baseline RMSE in [0, 1), got 1"),
    (["simulate", "--vehicle", "husky", "--terrain", "ICE", "--seed", "-1"], "seed"),
    # named as SimConfig's duration_s ("duration_s must be in (0, 7200] s, got -1.0")
    (["simulate", "--vehicle", "husky", "--terrain", "ICE", "--out", "s", "--duration-s",
      "-1"], "argument --duration-s: must be a finite number in (0, 7200] s, got -1"),
    (["simulate", "--vehicle", "husky", "--terrain", "ICE", "--out", "s", "--duration-s",
      "nan"], "argument --duration-s: must be a finite number in (0, 7200] s, got nan"),
    (["simulate", "--vehicle", "husky", "--terrain", "ICE", "--out", "s", "--duration-s",
      "0.01"], "error: a duration of 0.01 s is too short for the husky: the minimum is 0.16 s"),
    # "gate probability must be in (0, 1) exclusive", the option not named
    (["estimate", "r", "--out", "e.csv", "--gate", "nan"],
     "error: --gate must be a probability in (0, 1) exclusive (e.g. 0.999), got nan"),
    # named as SimConfig's segment_length_m; inf ran, its note saying 'changes every inf m'
    (["simulate", "--vehicle", "husky", "--terrain", "ICE,SNOW", "--out", "s",
      "--segment-m", "0"], "argument --segment-m: must be a finite number > 0, got 0"),
    (["simulate", "--vehicle", "husky", "--terrain", "ICE,SNOW", "--out", "s",
      "--segment-m", "inf"], "argument --segment-m: must be a finite number > 0, got inf"),
    (["control-grid", "--terrains", "BOGUS", "--out", "g"], "unknown terrain 'BOGUS'"),
    (["control-grid", "--seeds", "1000", "--out", "g"], "are tuning seeds"),
    (["control-grid", "--kp-grid", "2", "nan", "--out", "g"],
     "argument --kp-grid: must be a finite number >= 0, got nan"),
    (["control-grid", "--vehicles", "tracked", "--out", "g"], "supports vehicles"),
    (["slip-fit", "--orchard-duration-s", "nan"], "--orchard-duration-s"),
    # shorter than one 2 s slip window: scikit-learn's 0-sample error after the simulation
    (["slip-fit", "--duration-s", "1.9"], "at least one slip window (2 s)"),
    (["slip-fit", "--duration-s", "nan"], "at least one slip window (2 s)"),
    # refused after an MLflow run had been opened (and offered by train's --help)
    (["train", "--signals", "all+ekf"], "EKF-derived channels are for cross-validation"),
    # refused after the wheel-only CV had run (found by a CLI fuzz)
    (["stream-eval", "--folds", "1000"], "--folds 1000 over the"),
    # ignored by the streams part, yet logged to its MLflow run as if used
    (["stream-eval", "--part", "streams", "--hop-s", "1"],
     "--hop-s set the wheel-cv part's windows; --part streams does not run it"),
    (["control-sim", "--vehicle", "husky", "--terrain", "ICE", "--scenario",
      "straight_accel", "--controller", "traction", "--json", "c.json", "--kp", "nan"],
     "argument --kp: must be a finite number >= 0, got nan"),
    # an empty value was the option left out: the live-sim classifier, the default data/
    (["control-sim", "--vehicle", "husky", "--terrain", "ICE", "--scenario",
      "straight_accel", "--controller", "traction", "--json", "c.json", "--model", ""],
     f"argument --model: {EMPTY_PATH}"),
    (["control-grid", "--model", "", "--out", "g"], f"argument --model: {EMPTY_PATH}"),
    (["slip-table", "--data-dir", " "], f"argument --data-dir: {EMPTY_PATH}"),
    # a folder argument given as "" was Path(""), the working folder: predict and estimate
    # read the runs there, --slip-model-dir "" looked for a slip model in it
    (["predict", "--model", "m", "", "--out", "p.csv"], f"argument RUNS_DIR: {EMPTY_PATH}"),
    # --model "" loaded the working folder (". is not a terrain model directory", or its
    # model where the command ran in one)
    (["predict", "--model", "", "r", "--out", "p.csv"], f"argument --model: {EMPTY_PATH}"),
    (["estimate", "", "--out", "s.csv"], f"argument RUN_DIR: {EMPTY_PATH}"),
    (["estimate", "r", "--out", "s.csv", "--slip-model-dir", ""],
     f"argument --slip-model-dir: {EMPTY_PATH}"),
    (["stream", "--model", "", "r", "--out", "s.csv"], f"argument --model: {EMPTY_PATH}"),
    (["stream", "--model", "m", "", "--out", "s.csv"], f"argument RUN_DIR: {EMPTY_PATH}"),
    (["audit", "", "--json", "a.json"], f"argument RUNS_DIR: {EMPTY_PATH}"),
    (["serve", "--model", " "], f"argument --model: {EMPTY_PATH}"),
    (["convert", "", "--dataset", "vulpi", "--data-dir", "d"], f"argument CSV_DIR: {EMPTY_PATH}"),
]


@pytest.mark.slow
@pytest.mark.parametrize("argv, text", _REFUSED, ids=[" ".join(a) for a, _ in _REFUSED])
def test_cli_refuses_out_of_range_values_in_one_line(argv, text, tmp_path, monkeypatch,
                                                     capsys):
    monkeypatch.chdir(tmp_path)
    code = exit_code(argv)
    assert code == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert text in lines[-1] and lines[-1].startswith(f"terrain {argv[0]}: error:")
    assert "Traceback" not in err
    assert not (tmp_path / "mlflow.db").exists()  # no MLflow run was opened


@pytest.mark.parametrize("exc, code, text", [
    (RuntimeError("boom"), 1, "internal error: RuntimeError: boom"),
    (MemoryError("Unable to allocate 8 TiB"), 1, "not enough memory (Unable to allocate"),
    (KeyboardInterrupt(), 130, "interrupted"),
])
def test_unexpected_errors_reach_the_user_as_one_line(exc, code, text, monkeypatch, capsys):
    import pipelines.slip_table as slip_table

    def fail(args):
        raise exc

    monkeypatch.setattr(slip_table, "main", fail)
    assert main(["slip-table"]) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and text in err and "Traceback" not in err


def test_debug_shows_the_unexpected_error_itself(monkeypatch):
    import pipelines.slip_table as slip_table

    def fail(args):
        raise RuntimeError("boom")

    monkeypatch.setattr(slip_table, "main", fail)
    with pytest.raises(RuntimeError, match="boom"):
        main(["slip-table", "--debug"])


def test_more_folds_than_runs_is_a_config_error_not_sklearns_value_error():
    import numpy as np

    from terrain.models.cv import iter_splits

    groups = np.repeat([f"r{i}" for i in range(10)], 20)  # 10 runs of 20 windows
    labels = np.where(np.arange(200) // 20 % 2 == 0, "A", "B")
    assert len(list(iter_splits("grouped", labels, groups, 0, 10))) == 10
    for n_splits in (1, 11):
        with pytest.raises(ConfigError, match=f"{n_splits} folds over 10 split units"):
            list(iter_splits("grouped", labels, groups, 0, n_splits))


def test_stream_eval_refuses_a_full_model_folder_before_any_evaluation(
        tmp_path, monkeypatch, capsys):
    # the check came after the whole evaluation and the fit of the earlier recipes' models
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mo" / "wheels").mkdir(parents=True)
    (tmp_path / "mo" / "wheels" / "MLmodel").write_text("x")
    assert main(["stream-eval", "--part", "streams", "--kinds", "all", "wheels",
                 "--model-out", "mo"]) == 2
    err = capsys.readouterr().err
    assert "--model-out: model directory 'mo/wheels' exists and is not empty" in err
    assert "Traceback" not in err and not (tmp_path / "mlflow.db").exists()
    assert sorted(p.name for p in (tmp_path / "mo").iterdir()) == ["wheels"]


@pytest.mark.parametrize("command", ["cv", "train"])
def test_run_balanced_with_window_ekf_is_refused_in_the_flags_own_names(
        command, capsys, tmp_path, monkeypatch):
    # the refusal named the library's fields (run_balanced, window_ekf), not the flags
    monkeypatch.chdir(tmp_path)
    code = exit_code([command, "--dataset", "vulpi", "--run-balanced", "--window-ekf"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert "--run-balanced" in err and "--window-ekf" in err


@pytest.mark.parametrize("argv", [
    ["cv", "--seed", "1"],                      # --seeds
    ["cv", "--data", "borealtc"],               # --dataset
    ["compare", "--quick", "--model", "svm"],   # --models
    ["--deb", "cv"],                            # --debug
])
def test_a_prefix_of_an_option_is_a_usage_error_not_that_option(argv, capsys, tmp_path,
                                                                monkeypatch):
    # argparse's default took a prefix as the option it starts: `terrain cv --seed 1` ran
    # a whole cross-validation as --seeds 1 and wrote an MLflow store, unsaid
    assert "unrecognized arguments" in _usage_error(argv, capsys, tmp_path, monkeypatch)


@pytest.mark.parametrize("command", [["stream", "RUN", "--out", "d.csv"],
                                     ["serve", "--port", "5999"]])
@pytest.mark.parametrize("uri", ["models:/terrain-borealtc/latest", "runs:/abc/model",
                                 "http://host/m"])
def test_a_model_uri_where_a_model_directory_is_read_is_a_usage_error(command, uri, capsys,
                                                                      tmp_path, monkeypatch):
    # "model directory models:/terrain-borealtc/latest does not exist" (http://host/m named
    # as http:/host/m): stream and serve read a directory; predict reads the URIs
    err = _usage_error([command[0], "--model", uri, *command[1:]], capsys, tmp_path,
                       monkeypatch)
    assert f"{uri!r} is a URI" in err and "terrain predict reads" in err, err
