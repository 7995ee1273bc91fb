"""Second review of the command-line layer: options refused in their own names, before any
work, where a hand mutant or a defect showed no test held them."""

from __future__ import annotations

import pytest
from cli_helpers import exit_code

from terrain.sim.simulate import MAX_DURATION_S


@pytest.mark.parametrize("value", ["inf", f"{MAX_DURATION_S + 1:g}"])
def test_slip_fit_names_a_duration_beyond_the_simulators_range_as_its_option(
        value, tmp_path, monkeypatch, capsys):
    # it said "duration_s must be in (0, 7200] s, got inf": the field, not the option
    monkeypatch.chdir(tmp_path)
    assert exit_code(["slip-fit", "--duration-s", value, "--cache-dir", "c", "--out", "o"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("terrain slip-fit: error: --duration-s: ") and err.count("\n") == 1
    assert f"(0, {MAX_DURATION_S:g}] s" in err
    assert not any(tmp_path.iterdir())      # nothing simulated, no MLflow run opened


def test_a_model_directory_that_cannot_be_listed_is_a_usage_error_not_a_traceback(
        tmp_path, monkeypatch, capsys):
    # a folder one may write into but not list (mode -wx, as an upload drop box): listing
    # it raised PermissionError while the options were read, outside the one-line handler
    from pathlib import Path

    target = tmp_path / "drop"
    target.mkdir()
    listing = Path.iterdir

    def refuse(path):
        if path == target:
            raise PermissionError(13, "Permission denied", str(path))
        return listing(path)

    monkeypatch.setattr(Path, "iterdir", refuse)
    assert exit_code(["train", "--model-out", str(target)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert (f"argument --model-out: cannot use {str(target)!r} as model directory: "
            "Permission denied") in err.splitlines()[-1]


def test_help_states_a_default_once_where_the_help_text_gives_it(capsys):
    # the formatter adds "(default: ...)" only to a help that does not already say it
    assert exit_code(["cv", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "classifier (default: svm; see README 'Model comparison')" in out
    assert out.count("default: svm") == 1
    assert "--protocol {grouped,loro,paper}" in out and "(default: grouped)" in out


class _Stop(Exception):
    """Raised by a stand-in: ends a command once what it was given is recorded."""


def test_estimate_refuses_a_rate_out_of_range_by_name_before_reading_the_runs(
        tmp_path, monkeypatch, capsys):
    # RUN_DIR 'r' does not exist: a refusal naming --rate-hz came before any run was read
    monkeypatch.chdir(tmp_path)
    for value in ("0.5", "nan", "20000"):
        assert exit_code(["estimate", "r", "--out", "e.csv", "--rate-hz", value]) == 2
        line = capsys.readouterr().err.strip().splitlines()[-1]
        assert line.startswith("terrain estimate: error: --rate-hz"), line
    assert not any(tmp_path.iterdir())


def test_stream_options_reach_the_service_and_the_slip_targets(tmp_path, monkeypatch):
    # --min-confidence sets both the service's threshold and the desired-slip fallback;
    # --hop-s the time between decisions
    from types import SimpleNamespace

    import pipelines.stream as stream

    seen = {}
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(stream, "load_stream_model",
                        lambda path: SimpleNamespace(classes=("ICE", "SNOW")))
    monkeypatch.setattr(stream, "read_folder_run", lambda run_dir, index: None)

    def targets(classes, config):
        seen["slip"] = config
        raise _Stop

    monkeypatch.setattr(stream, "TableTargets", targets)
    real = stream.StreamConfig
    monkeypatch.setattr(stream, "StreamConfig",
                        lambda **kwargs: seen.setdefault("stream", real(**kwargs)))
    with pytest.raises(_Stop):
        exit_code(["stream", "--model", "m", "r", "--out", "d.csv", "--hop-s", "0.25",
                   "--min-confidence", "0.7", "--debug"])
    assert seen["slip"].min_confidence == 0.7
    assert (seen["stream"].hop_s, seen["stream"].min_confidence) == (0.25, 0.7)


def test_simulate_options_reach_the_simulation(tmp_path, monkeypatch):
    import pipelines.simulate as simulate

    seen = []
    monkeypatch.chdir(tmp_path)

    def capture(config):
        seen.append(config)
        raise _Stop

    monkeypatch.setattr(simulate, "simulate", capture)
    with pytest.raises(_Stop):
        exit_code(["simulate", "--vehicle", "Husky", "--terrain", "ICE,SNOW", "--scenario",
                   "orchard", "--duration-s", "12", "--seed", "7", "--segment-m", "4.5",
                   "--physics", "v1", "--effect", "gyro_bias=0.1", "--out", "s", "--debug"])
    config = seen[0]
    assert (config.vehicle, config.terrains, config.scenario) == ("husky", ("ICE", "SNOW"),
                                                                  "orchard")
    assert (config.duration_s, config.seed, config.segment_length_m, config.physics) == (
        12.0, 7, 4.5, "v1")
    assert config.effects.gyro_bias == 0.1


@pytest.mark.parametrize("command", [
    ["audit", "runs", "--json", "a.json", "--no-mlflow"],
    ["predict", "--model", "m", "runs", "--out", "p.csv"]])
def test_no_progress_reaches_the_readers(command, tmp_path, monkeypatch):
    # --no-progress hides the bars of the run readers (and of predict's model loader)
    import pipelines.audit as audit
    import pipelines.predict as predict

    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs").mkdir()
    seen = []

    def record(*args, progress=True, **kwargs):
        seen.append(progress)
        raise _Stop

    monkeypatch.setattr(audit, "read_runs_dir", record)
    monkeypatch.setattr(predict, "load_model", record)
    for extra, shown in (([], True), (["--no-progress"], False)):
        with pytest.raises(_Stop):
            exit_code([*command, *extra, "--debug"])
        assert seen.pop() is shown


def test_compare_training_hop_reaches_the_grid():
    from pipelines.compare import config_from_args
    from terrain.cli import build_parser

    for extra in ([], ["--quick"]):
        args = build_parser().parse_args(["compare", "--train-hop-s", "0.5", *extra])
        assert config_from_args(args).train_hop_s == 0.5


def test_only_a_pipeline_module_left_out_of_the_install_drops_its_subcommand(monkeypatch):
    # a pipeline not installed is left out of the parser; one whose own import fails on a
    # missing dependency is an error, not a subcommand silently gone from the help
    import importlib
    from types import SimpleNamespace

    import terrain.cli as cli

    real = importlib.import_module

    def missing(name):
        def load(module_name):
            if module_name == "pipelines.cv":
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return real(module_name)
        return SimpleNamespace(import_module=load)

    monkeypatch.setattr(cli, "importlib", missing("pipelines.cv"))
    choices = cli.build_parser()._subparsers._group_actions[0].choices
    assert "cv" not in choices and "train" in choices
    monkeypatch.setattr(cli, "importlib", missing("not_installed_dependency"))
    with pytest.raises(ModuleNotFoundError, match="not_installed_dependency"):
        cli.build_parser()


def test_a_probability_option_takes_both_ends_of_0_1_and_refuses_beyond():
    import argparse

    from pipelines.arguments import probability

    assert probability("0") == 0.0 and probability("1") == 1.0
    for bad in ("1.0001", "-0.01", "nan"):
        with pytest.raises(argparse.ArgumentTypeError,
                           match=rf"must be a probability in \[0, 1\], got {bad}$"):
            probability(bad)


def test_cv_paper_protocol_refuses_a_hop_and_the_cnn_options_reach_the_config():
    from pipelines.cv import config_from_args
    from terrain.cli import build_parser
    from terrain.errors import ConfigError

    def cv(*argv):
        return config_from_args(build_parser().parse_args(["cv", *argv]))

    # the paper protocol fixes 1.7 s windows every 0.1 s: a hop of its own is refused
    with pytest.raises(ConfigError, match="drop --window-s / --hop-s"):
        cv("--protocol", "paper", "--hop-s", "0.5")
    assert cv("--protocol", "paper", "--hop-s", "0.1").hop_s == 0.1
    config = cv("--cnn-seeds", "3", "--window-ekf", "--model", "cnn")
    assert (config.cnn_seeds, config.window_ekf, config.model) == (3, True, "cnn")
    assert cv("--run-balanced").run_balanced and not cv().run_balanced


def test_audit_refuses_runs_dir_and_dataset_together(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs").mkdir()
    assert exit_code(["audit", "runs", "--dataset", "vulpi", "--json", "a.json",
                      "--no-mlflow"]) == 2
    assert capsys.readouterr().err == ("terrain audit: error: give exactly one of RUNS_DIR or "
                                       "--dataset\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs"]


def _stub_audit(monkeypatch):
    """``terrain audit`` with the shipped runs and the audit itself stood in for: the list
    of ``(settings, tracked)`` each call was given."""
    import pipelines.audit as audit

    calls = []
    monkeypatch.setattr(audit, "load_dataset", lambda name: [])
    monkeypatch.setattr(audit, "_audit", lambda args, runs, settings, source, name, tracked:
                        calls.append((settings, tracked)))
    return calls


def test_audit_no_mlflow_opens_no_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{tmp_path / 'store.db'}")
    calls = _stub_audit(monkeypatch)
    assert exit_code(["audit", "--dataset", "vulpi", "--json", "a.json", "--no-mlflow"]) == 0
    assert calls[0][1] is None and not (tmp_path / "store.db").exists()


def test_audit_refuses_an_md_whose_figures_folder_is_a_file_before_the_audit(
        tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    calls = _stub_audit(monkeypatch)
    (tmp_path / "r_figures").write_text("a file\n")
    assert exit_code(["audit", "--dataset", "vulpi", "--json", "a.json", "--md", "r.md",
                      "--no-mlflow"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("terrain audit: error: --md: cannot use 'r_figures' as output "
                          "folder") and err.count("\n") == 1
    assert calls == []


def test_stream_eval_refuses_a_recipe_given_twice_before_reading_any_run(
        tmp_path, monkeypatch, capsys):
    import pipelines.stream_eval as stream_eval

    monkeypatch.chdir(tmp_path)

    def no_data(name):
        raise AssertionError("the dataset was read")

    monkeypatch.setattr(stream_eval, "load_dataset", no_data)
    assert exit_code(["stream-eval", "--part", "streams", "--kinds", "wheels", "all",
                      "wheels"]) == 2
    assert capsys.readouterr().err == ("terrain stream-eval: error: --kinds: ['wheels'] given "
                                       "more than once\n")


@pytest.mark.parametrize("host", ["0.0.0.0", "10.1.2.3", "192.168.0.7", "::"])
def test_serve_refuses_a_private_or_wildcard_host(host, tmp_path, monkeypatch, capsys):
    # a private address is not a loopback one: the server would answer the whole network
    monkeypatch.chdir(tmp_path)
    assert exit_code(["serve", "--model", "m", "--host", host]) == 2
    assert capsys.readouterr().err == (f"terrain serve: error: --host {host} is not a "
                                       "loopback address (use 127.0.0.1)\n")


@pytest.mark.parametrize("command", [["slip-fit"], ["control-grid"]])
def test_run_parameters_hold_the_options_not_the_clis_own_function(command, tmp_path):
    # slip-fit logged every parsed name to MLflow, _main too: '<function main at 0x...>',
    # a parameter that changed from run to run
    from pipelines.arguments import option_params
    from terrain.cli import build_parser

    args = build_parser().parse_args(command + ["--out", str(tmp_path / "o")])
    assert callable(args._main)
    params = option_params(args, ("out",))
    assert params and not any(k.startswith("_") for k in params)
    assert "out" not in params and params["seeds" if "seeds" in params else "terrains"]
    assert {k: v for k, v in vars(args).items() if k in params} == params
