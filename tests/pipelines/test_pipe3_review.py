"""Review tests of the command-line layer (pass pipe3): outputs as documented, options
checked before the work, no traceback."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pandas as pd

from cli_helpers import RecordingRun, exit_code


def _cv_result(config):
    """A cross-validation outcome whose second class has no window (recall NaN)."""
    folds = pd.DataFrame({"seed": [0], "fold": [0], "accuracy": [0.75],
                          "balanced_accuracy": [0.75], "macro_f1": [0.7],
                          "run_majority_accuracy": [np.nan]})
    pooled = pd.DataFrame({"seed": [0], "accuracy": [0.75], "balanced_accuracy": [0.75],
                           "macro_f1": [0.7], "run_majority_accuracy": [np.nan]})
    confusion = pd.DataFrame([[3, 1], [0, 0]], index=["ICE", "SNOW"], columns=["ICE", "SNOW"])
    report = SimpleNamespace(classes=["ICE", "SNOW"], folds=folds, pooled=pooled,
                             confusion=confusion, notes=[], predictions=pd.DataFrame(),
                             summary=lambda: {c: {"mean": float(folds[c].mean()),
                                                  "std": 0.0, "min": float(folds[c].min()),
                                                  "max": float(folds[c].max()), "n_folds": 1}
                                              for c in folds.columns[2:]})
    return SimpleNamespace(config=config, report=report, n_windows=4, n_runs=2,
                           timings_s={"cv": 0.1}, counts={}, input_notes=[])


def test_cv_json_is_strict_json_with_null_for_an_undefined_figure(tmp_path, monkeypatch):
    # a class without a window has no recall (NaN) and a fold without a whole run no run
    # vote: json.dumps wrote the bare token NaN, which jq and JSON.parse refuse
    import pipelines.cv as cv

    monkeypatch.setattr(cv, "load_dataset", lambda name: [])
    monkeypatch.setattr(cv, "run_cv", lambda config, runs, progress: _cv_result(config))
    monkeypatch.setattr(cv, "input_report", lambda *a: SimpleNamespace(
        text=lambda: "", metrics=lambda: {}, table=pd.DataFrame()))
    monkeypatch.setattr(cv, "plot_confusion", lambda *a: None)
    monkeypatch.setattr(cv, "tracked_run", RecordingRun())
    out = tmp_path / "cv.json"
    assert exit_code(["cv", "--seeds", "0", "--json", str(out), "--no-progress"]) == 0
    text = out.read_text()
    report = json.loads(text, parse_constant=lambda token: pytest_fail(token))
    assert report["pooled_recall"] == {"ICE": 0.75, "SNOW": None}
    assert report["pooled"]["run_majority_accuracy"] == {"mean": None, "std": None}
    assert report["pooled"]["accuracy"]["mean"] == 0.75


def pytest_fail(token):
    raise AssertionError(f"not strict JSON: {token}")


def test_stream_refuses_its_smoothing_options_before_loading_the_model(
        tmp_path, monkeypatch, capsys):
    # --dwell-s -1 (or --reset-windows without --reset-confidence) was refused only after
    # the model was loaded (seconds for an ensemble) and the run read, as serve refuses it
    import pipelines.stream as stream

    loaded = []
    monkeypatch.setattr(stream, "load_stream_model", lambda path: loaded.append(path))
    monkeypatch.setattr(stream, "read_folder_run", lambda *a: loaded.append(a))
    for options in (["--dwell-s", "-1"], ["--reset-windows", "3"]):
        assert exit_code(["stream", "--model", str(tmp_path / "m"), str(tmp_path / "r"),
                          "--out", str(tmp_path / "d.csv"), *options]) == 2
        err = capsys.readouterr().err
        assert options[0] in err and "Traceback" not in err
    assert loaded == []


def test_audit_reproduce_line_gives_back_the_low_pass_it_ran_with(tmp_path, monkeypatch):
    # the report's reproduce line wrote the cut-off with :g, 6 significant digits:
    # 2.123456789 Hz came back as 2.12346 Hz, another replay than the one reported
    import shlex

    import pipelines.audit as audit
    from terrain.cli import build_parser

    calls = []
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(audit, "load_dataset", lambda name: [])
    monkeypatch.setattr(audit, "_audit", lambda args, *rest: calls.append(args))
    for hz in ("2.123456789", "2", "0.1"):
        assert exit_code(["audit", "--dataset", "vulpi", "--json", "a.json", "--no-mlflow",
                          "--replay-input-lowpass-hz", hz]) == 0
        line = audit._command(calls[-1])
        again = build_parser().parse_args(shlex.split(line)[1:])
        assert again.replay_input_lowpass_hz == float(hz)
    assert line.endswith("--replay-input-lowpass-hz 0.1")
    assert audit._command(calls[1]).endswith("--replay-input-lowpass-hz 2")


def test_compare_history_below_one_is_refused_as_the_option(capsys):
    # --history 0 was refused by the grid's field ('CompareConfig.history must be an integer
    # >= 1'), a name the command line does not have
    for value in ("0", "-1", "x"):
        assert exit_code(["compare", "--history", value]) == 2
        err = capsys.readouterr().err
        assert "argument --history:" in err and "CompareConfig" not in err


def test_slip_fit_reads_the_measured_dataset_before_simulating(tmp_path, monkeypatch, capsys):
    # --measured borealtc was read only after the runs were simulated and the model fitted
    # (hours): a dataset that cannot be read failed at the very end, nothing registered
    import pipelines.slip_fit as slip_fit
    from terrain.errors import DataFormatError

    def unreadable(name):
        raise DataFormatError(f"{name}: manifest not found", tmp_path / "manifest.json")

    simulated = []
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(slip_fit, "load_dataset", unreadable)
    monkeypatch.setattr(slip_fit, "simulated_runs", lambda *a: simulated.append(a))
    assert exit_code(["slip-fit", "--measured", "borealtc", "--terrains", "ICE",
                      "--scenarios", "orchard"]) == 2
    assert "manifest not found" in capsys.readouterr().err
    assert simulated == []


def test_control_grid_refuses_reserved_classifier_seeds_before_tuning(
        tmp_path, monkeypatch, capsys):
    # --terrain-source live-sim with a classifier seed that is an evaluation (--seeds) or
    # tuning seed was refused by the classifier's training, after every vehicle's gains
    # were tuned (minutes of closed-loop runs)
    import pipelines.control_grid as control_grid

    tuned = []
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(control_grid, "tune_gains", lambda *a, **k: tuned.append(a))
    for seeds in (["--classifier-seeds", "0", "--seeds", "0"],
                  ["--classifier-seeds", "1000", "2000"]):
        assert exit_code(["control-grid", "--vehicles", "husky", "--terrains", "ICE",
                          "--terrain-source", "live-sim", *seeds, "--out", "g"]) == 2
        err = capsys.readouterr().err
        assert "are evaluation or tuning seeds" in err
        assert ("[0]" if "0" in seeds[1:2] else "[1000]") in err
    assert tuned == []


def test_compare_refuses_cnn_training_options_for_a_grid_without_a_cnn(capsys):
    # --models svm minirocket with --early-stopping, --max-epochs or --threads ran the grid
    # with the option ignored (and logged to MLflow as if used), as --cnn-seeds is refused
    from pipelines.compare import config_from_args
    from terrain.cli import build_parser
    from terrain.errors import ConfigError

    import pytest

    for option in (["--early-stopping"], ["--max-epochs", "3"], ["--threads", "2"]):
        args = build_parser().parse_args(["compare", "--models", "svm", "minirocket",
                                          *option])
        with pytest.raises(ConfigError, match=f"{option[0]} .*none of the models"):
            config_from_args(args)
        # with a CNN in the grid, or an ensemble holding one, they are taken
        for models in (["svm", "cnn"], ["ensemble"]):
            args = build_parser().parse_args(["compare", "--models", *models, *option])
            config = config_from_args(args)
            assert config.early_stopping or config.max_epochs == 3 or config.n_threads == 2


def test_option_types_take_their_documented_bounds_and_refuse_just_beyond():
    # each argparse type's range as its help and message state it, both ends included where
    # the message says so (a bound moved by one would refuse a documented value)
    import argparse

    import pytest

    from pipelines.arguments import (integer_in, non_negative_number, positive_integer,
                                     positive_number, probability, seed_value, sim_duration_s)
    from terrain.models.experiment import MAX_SEED
    from terrain.sim.simulate import MAX_DURATION_S

    accepted = [(positive_number, "1e-9", 1e-9),
                (sim_duration_s, f"{MAX_DURATION_S:g}", MAX_DURATION_S),
                (non_negative_number, "0", 0.0), (positive_integer, "1", 1),
                (integer_in(10, 100), "10", 10), (integer_in(10, 100), "100", 100),
                (probability, "0", 0.0), (probability, "1", 1.0),
                (seed_value, "0", 0), (seed_value, str(MAX_SEED), MAX_SEED)]
    for parse, text, value in accepted:
        assert parse(text) == value
    refused = [(positive_number, "0"), (positive_number, "inf"), (positive_number, "nan"),
               (sim_duration_s, str(MAX_DURATION_S + 0.001)), (sim_duration_s, "0"),
               (non_negative_number, "-1e-9"), (positive_integer, "0"),
               (integer_in(10, 100), "9"), (integer_in(10, 100), "101"),
               (probability, "1.0000001"), (probability, "-0.0001"), (probability, "nan"),
               (seed_value, "-1"), (seed_value, str(MAX_SEED + 1))]
    for parse, text in refused:
        with pytest.raises(argparse.ArgumentTypeError):
            parse(text)


def test_serve_port_range_and_backlog_floor(monkeypatch):
    # port 65535 is a port, 65536 is not; the listen backlog never drops below 16 however
    # tight the open-file limit, and --max-connections must fit twice under it
    import argparse

    import pytest

    import pipelines.serve as serve
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match="outside 1-65535"):
        serve.bind_port("127.0.0.1", 65536)
    with pytest.raises(ConfigError, match="outside 1-65535"):
        serve.bind_port("127.0.0.1", -1)
    for port in (0, 65535):     # the system's free port; the last port (in use: its reason)
        sock = None
        try:
            sock = serve.bind_port("127.0.0.1", port)
        except ConfigError as exc:
            assert "outside" not in str(exc)
        finally:
            if sock is not None:
                sock.close()
    monkeypatch.setattr(serve, "_open_file_limit", lambda: 200)
    assert serve.accept_backlog(60) == 16            # (200 - 64 - 120) // 3 = 5 -> 16
    assert serve.accept_backlog(10) == (200 - 64 - 20) // 3
    args = argparse.Namespace(max_body_bytes=1, max_decisions=1, max_in_flight=1,
                              max_connections=68, header_timeout_s=1.0, hop_s=0.5,
                              dwell_s=10.0, reset_confidence=None, reset_windows=None)
    serve._check_args(args)                          # 2 x 68 = 136 <= 200 - 64
    with pytest.raises(ConfigError, match="--max-connections 69"):
        serve._check_args(argparse.Namespace(**{**vars(args), "max_connections": 69}))


def test_a_reset_confidence_of_zero_is_refused_with_its_reason():
    # at 0 every window would reset the forward filter: smoothing off, said the wrong way
    import argparse

    import pytest

    from pipelines.arguments import smoothing_from_args
    from terrain.errors import ConfigError

    args = argparse.Namespace(dwell_s=10.0, reset_confidence=0.0, reset_windows=None)
    with pytest.raises(ConfigError, match="--reset-confidence must be > 0"):
        smoothing_from_args(args)
    args.reset_confidence = 1e-6
    assert smoothing_from_args(args).reset_confidence == 1e-6


def test_no_help_line_shows_a_default_of_none():
    # an option without a default (None: computed, or off) shows no '(default: None)',
    # which would read as the value None being passed
    from terrain.cli import build_parser

    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices
    for name, command in commands.items():
        text = command.format_help()
        assert "(default: None)" not in text, name
    assert "(default: 0.5)" in commands["stream"].format_help()      # --hop-s


def test_stream_eval_refuses_a_single_fold_before_reading_the_data(monkeypatch, capsys):
    # one fold holds every run out and trains on none
    import pipelines.stream_eval as stream_eval

    read = []
    monkeypatch.setattr(stream_eval, "load_dataset", lambda name: read.append(name))
    assert exit_code(["stream-eval", "--folds", "1"]) == 2
    assert "--folds must be at least 2" in capsys.readouterr().err and read == []


def test_simulate_reads_the_vehicle_name_in_any_case(tmp_path, monkeypatch):
    # --vehicle HUSKY is the husky (as --terrain ice is ICE), not an unknown vehicle
    import pipelines.simulate as simulate

    configs = []

    def capture(config):
        configs.append(config)
        raise KeyboardInterrupt

    monkeypatch.setattr(simulate, "simulate", capture)
    assert exit_code(["simulate", "--vehicle", "HUSKY", "--terrain", "ice", "--duration-s",
                      "1", "--out", str(tmp_path / "s")]) == 130
    assert configs[0].vehicle == "husky" and configs[0].terrains == ("ICE",)
