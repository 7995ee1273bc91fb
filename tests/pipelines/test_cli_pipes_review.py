"""Third review of the command-line layer (arguments, dispatch, estimate, serve, the closed
loop's classifier options): odd inputs and hand mutants no earlier test held."""

from __future__ import annotations

import argparse

import pytest
from cli_helpers import exit_code

from pipelines.arguments import output_dir, output_file


@pytest.mark.parametrize("name", ["loop", "loop/out.csv"])
def test_an_output_path_through_a_symlink_loop_is_refused_in_one_line(
        name, tmp_path, monkeypatch, capsys):
    # `--out loop` (a link to itself) passed the output check, then Path.resolve raised
    # RuntimeError('Symlink loop') while the options were read: a traceback
    monkeypatch.chdir(tmp_path)
    (tmp_path / "loop").symlink_to("loop")
    with pytest.raises(argparse.ArgumentTypeError, match="symbolic links"):
        output_file(name)
    with pytest.raises(argparse.ArgumentTypeError, match="symbolic links"):
        output_dir(name)
    assert exit_code(["estimate", "runs", "--out", name]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "RuntimeError" not in err
    assert f"argument --out: cannot write {name!r}: " in err.splitlines()[-1]


def test_ctrl_c_while_the_commands_are_loaded_is_one_line_with_status_130(monkeypatch,
                                                                          capsys):
    # loading the pipelines takes seconds; a Ctrl-C then was a traceback of import frames
    import terrain.cli as cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    try:
        code = cli.main(["slip-table"])
    except KeyboardInterrupt:
        pytest.fail("the Ctrl-C escaped main")
    assert code == 130
    assert capsys.readouterr().err == "terrain: interrupted\n"


def test_the_entry_points_module_leaves_the_slow_imports_to_main():
    # the console script imports terrain.cli before main can catch a Ctrl-C: that import
    # must not load the pipelines, MLflow or scikit-learn (seconds of imports)
    import subprocess
    import sys

    code = ("import sys, terrain.cli; print(sorted(m for m in ('pipelines.arguments', "
            "'terrain.tracking', 'mlflow', 'sklearn') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def _parsed(argv):
    """The sub-command parser and parsed options of ``terrain ARGV``."""
    from terrain.cli import _command_parser, build_parser

    parser = build_parser()
    args = parser.parse_args(argv)
    return _command_parser(parser, args), args


def test_an_output_file_inside_an_input_model_directory_is_refused(
        tmp_path, monkeypatch, capsys):
    # a folder holding MLmodel is a model: a file written in it (at any depth) would change
    # the model the command reads; a plain input folder's other files are taken
    from pipelines.arguments import check_output_files

    monkeypatch.chdir(tmp_path)
    (tmp_path / "model" / "artifacts").mkdir(parents=True)
    (tmp_path / "model" / "MLmodel").write_text("flavors: {}\n")
    (tmp_path / "runs").mkdir()
    for out in ("model/p.csv", "model/artifacts/p.csv"):
        with pytest.raises(SystemExit) as stop:
            check_output_files(*_parsed(["predict", "--model", "model", "runs", "--out", out]))
        assert stop.value.code == 2
        assert capsys.readouterr().err.splitlines()[-1] == (
            f"terrain predict: error: argument --out: cannot write {out!r}: it lies in the "
            "input model directory 'model'")
    (tmp_path / "model" / "MLmodel").unlink()     # a plain folder: its files are outputs
    check_output_files(*_parsed(["predict", "--model", "model", "runs", "--out",
                                 "model/p.csv"]))
    check_output_files(*_parsed(["predict", "--model", "model", "runs", "--out",
                                 "runs/p.csv"]))


@pytest.mark.parametrize("argv, text", [
    (["--terrain-source", "model"], "--terrain-source model needs --model DIR"),
    (["--terrain-source", "label", "--classifier-seeds", "7", "--classifier-uncontrolled-only"],
     "--classifier-seeds and --classifier-uncontrolled-only train the live-sim classifier; "
     "--terrain-source label uses none: leave them out"),
])
def test_control_sim_refuses_a_terrain_source_without_what_it_needs_or_uses(
        argv, text, tmp_path, monkeypatch, capsys):
    import pipelines.control_sim as control_sim

    def no_training(*args, **kwargs):
        raise AssertionError("no terrain source may be built for refused options")

    monkeypatch.setattr(control_sim, "decision_source", no_training)
    monkeypatch.chdir(tmp_path)
    assert exit_code(["control-sim", "--vehicle", "husky", "--terrain", "SNOW", "--scenario",
                      "straight_accel", "--controller", "traction", *argv,
                      "--json", "m.json"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == f"terrain control-sim: error: {text}"
    assert not any(tmp_path.iterdir())


def _served_dir(tmp_path):
    """A folder whose MLmodel says it is an already wrapped streaming model."""
    served = tmp_path / "served"
    served.mkdir()
    (served / "MLmodel").write_text(
        "metadata:\n  kind: terrain-stream\n  source_model: trained\n  hop_s: 0.5\n"
        "  max_decisions: 100\n")
    return served


def test_serve_refuses_a_kept_copy_of_an_already_wrapped_model(tmp_path):
    # --served-out alone (every wrapping option at its default) would be silently ignored
    from pipelines.serve import check_no_wrap_options, is_served_model
    from terrain.errors import ConfigError

    served = _served_dir(tmp_path)
    assert is_served_model(served) and not is_served_model(tmp_path)
    _, args = _parsed(["serve", "--model", str(served)])
    check_no_wrap_options(served, args)     # the defaults: nothing to refuse
    _, args = _parsed(["serve", "--model", str(served), "--served-out", str(tmp_path / "k")])
    with pytest.raises(ConfigError, match=r"^--served-out .*k: .*served is an already wrapped "
                                          r"model.*terrain serve --model trained with"):
        check_no_wrap_options(served, args)
    _, args = _parsed(["serve", "--model", str(served), "--max-decisions", "7"])
    with pytest.raises(ConfigError, match=r"^--max-decisions 7: .*own settings "
                                          r"\(max_decisions 100\)"):
        check_no_wrap_options(served, args)


def test_the_filters_reset_is_refused_where_no_filter_runs():
    # --dwell-s 0 turns the forward filter off: a reset of it would be silently ignored
    from pipelines.arguments import smoothing_from_args
    from terrain.errors import ConfigError

    off = argparse.Namespace(dwell_s=0.0, reset_confidence=None, reset_windows=None)
    assert smoothing_from_args(off).dwell_s is None
    with pytest.raises(ConfigError, match=r"^--reset-confidence resets the forward filter, "
                                          r"which --dwell-s 0 turns off$"):
        smoothing_from_args(argparse.Namespace(dwell_s=0.0, reset_confidence=0.9,
                                               reset_windows=None))
    # a count without the confidence: the reset stays off, the count changes nothing
    with pytest.raises(ConfigError, match=r"^--reset-windows 3 needs --reset-confidence"):
        smoothing_from_args(argparse.Namespace(dwell_s=10.0, reset_confidence=None,
                                               reset_windows=3))


@pytest.mark.parametrize("value", ["inf", "nan", "0", "-1"])
def test_serve_refuses_a_header_timeout_that_is_not_a_finite_positive_time(
        value, tmp_path, monkeypatch, capsys):
    # an infinite timeout would never close a client stalled in its headers
    monkeypatch.chdir(tmp_path)
    assert exit_code(["serve", "--model", "nowhere", "--header-timeout-s", value]) == 2
    assert capsys.readouterr().err == (
        f"terrain serve: error: --header-timeout-s must be a finite number of seconds > 0, "
        f"got {float(value):g}\n")


def test_the_loops_classifier_never_trains_on_the_gain_tuning_seeds(tmp_path):
    # the gains were tuned on TUNING_SEEDS: a classifier trained there would have seen the
    # runs its gains were chosen on (refused before any simulation)
    from pipelines.control_classifier import sim_classifier
    from terrain.control.grid import TUNING_SEEDS
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match=rf"classifier seeds \[{TUNING_SEEDS[0]}\] are "
                                          "evaluation or tuning seeds"):
        sim_classifier("husky", ["ICE"], seeds=(TUNING_SEEDS[0], 2000), cache_dir=tmp_path)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("host", ["localhost", "::1", "127.0.0.2"])
def test_serve_takes_every_loopback_host_named_in_its_messages(
        host, tmp_path, monkeypatch, capsys):
    # the host passes; the next check (the model) is the one that answers
    monkeypatch.chdir(tmp_path)
    assert exit_code(["serve", "--model", "nowhere", "--host", host]) == 2
    assert capsys.readouterr().err == ("terrain serve: error: model directory nowhere does "
                                       "not exist\n")


def test_estimate_run_selects_terrain_and_index_and_lists_the_runs_otherwise(monkeypatch):
    from types import SimpleNamespace

    import pipelines.estimate as estimate
    from terrain.errors import ConfigError

    runs = [SimpleNamespace(run_id=f"r/{t}/{i}") for t, i in (("ICE", "00"), ("SNOW", "00"),
                                                              ("ICE", "01"))]
    monkeypatch.setattr(estimate, "read_runs_path", lambda run_dir: runs)
    assert estimate._load("r", None) == runs
    assert estimate._load("r", "SNOW/00") == [runs[1]]
    assert estimate._load("r", "ICE/01") == [runs[2]]
    for select in ("00", "r/ICE/00", "ice/00"):
        with pytest.raises(ConfigError, match=rf"^no run '{select}' in r; runs: ICE/00, "
                                              "SNOW/00, ICE/01$"):
            estimate._load("r", select)


def test_estimate_writes_one_run_to_out_itself_and_says_a_missing_model_once(
        tmp_path, monkeypatch, capsys):
    # one run: its table is --out (no <stem>_<TERRAIN>_<XX> file); the physics fallback of
    # a missing learned model is said once, where the model was looked for, not per run
    from types import SimpleNamespace

    import pandas as pd

    import pipelines.estimate as estimate
    from terrain.slip.estimate import LEARNED_FALLBACK_NOTE

    run = SimpleNamespace(run_id="r/ICE/00", vehicle="husky")
    est = SimpleNamespace(notes=[LEARNED_FALLBACK_NOTE, "note: something else"], lag=None,
                          summary=lambda: "r/ICE/00",
                          to_frame=lambda: pd.DataFrame({"t_s": [0.5], "v_bx": [0.25]}))
    monkeypatch.setattr(estimate, "_load", lambda run_dir, select: [run])
    monkeypatch.setattr(estimate, "input_report", lambda runs: SimpleNamespace(text=str))
    monkeypatch.setattr(estimate, "estimate_skid_steer_slip_run", lambda *a, **k: est)
    monkeypatch.setattr(estimate, "slip_model_outputs", lambda run, learned: None)
    monkeypatch.setattr(estimate, "missing_slip_inputs", lambda run: [])
    monkeypatch.setattr(estimate, "resolve_slip_model", lambda model_dir: (None, "no store"))
    out = tmp_path / "e.csv"
    assert exit_code(["estimate", str(tmp_path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.csv"]
    assert pd.read_csv(out).to_dict("list") == {"t_s": [0.5], "v_bx": [0.25]}
    assert text.count("note: no learned slip model (no store); physics supplies the slip") == 1
    assert LEARNED_FALLBACK_NOTE not in text and "note: something else" in text
    assert f"r/ICE/00 -> {out}" in text


def test_estimate_says_the_skid_steer_options_an_agrimaro_run_does_not_use(
        tmp_path, monkeypatch, capsys):
    # an option for the other vehicle kind is said, not silently ignored; no learned model
    # is looked for (a --slip-model-dir that cannot be loaded is then no error)
    from types import SimpleNamespace

    import pandas as pd

    import pipelines.estimate as estimate

    def no_lookup(model_dir):
        raise AssertionError("no skid-steer run: the learned model must not be looked for")

    run = SimpleNamespace(run_id="r/GRASS/00", vehicle="agrimaro")
    est = SimpleNamespace(notes=[], lag=None, summary=lambda: "r/GRASS/00",
                          to_frame=lambda: pd.DataFrame({"t_s": [0.5]}))
    monkeypatch.setattr(estimate, "_load", lambda run_dir, select: [run])
    monkeypatch.setattr(estimate, "input_report", lambda runs: SimpleNamespace(text=str))
    monkeypatch.setattr(estimate, "estimate_run", lambda *a, **k: est)
    monkeypatch.setattr(estimate, "resolve_slip_model", no_lookup)
    monkeypatch.chdir(tmp_path)
    assert exit_code(["estimate", "r", "--out", "e.csv", "--slip-model", "fused",
                      "--slip-model-dir", "nowhere"]) == 0
    text = capsys.readouterr().out
    assert ("note: --slip-model fused not used: no skid-steer run (the AgriMaRo EKF observes "
            "its slip with the camera)") in text
    assert ("note: --slip-model-dir nowhere not used: no skid-steer run (the AgriMaRo EKF "
            "observes its slip)") in text


def test_an_output_file_given_with_a_trailing_slash_is_refused_as_a_folder(tmp_path):
    # Path('results/') is Path('results'): a missing 'results/' became a file 'results'
    with pytest.raises(argparse.ArgumentTypeError,
                       match=r"^cannot write '.*results/': it names a folder \(give a file "
                             r"name\)$"):
        output_file(str(tmp_path / "results") + "/")
    assert not (tmp_path / "results").exists()
    assert output_file(str(tmp_path / "results")) == tmp_path / "results"


@pytest.mark.parametrize("message, shown", [
    ("bad value\n  in column 'x'\n\tline 4", "bad value in column 'x' line 4"),
    ("v" * 2000, "v" * 497 + "..."),
])
def test_a_multi_line_or_long_error_reaches_the_user_as_one_short_line(
        message, shown, monkeypatch, capsys):
    """A project error's message with line breaks is joined into one line, and one longer
    than 500 characters is cut to 500 (a message holding a table dumped the table)."""
    import pipelines.slip_table as slip_table
    import terrain.cli as cli
    from terrain.errors import ConfigError

    def fail(args):
        raise ConfigError(message)

    monkeypatch.setattr(slip_table, "main", fail)
    assert cli.main(["slip-table"]) == 2
    assert capsys.readouterr().err == f"terrain slip-table: error: {shown}\n"


def test_slip_fit_takes_catalogue_terrains_in_any_case_each_once(capsys):
    """``slip-fit --terrains ice`` was refused ("unknown terrains/scenarios ['ice']") where
    ``simulate`` and the benchmarks take any case (est19's left-alone); a name given twice
    in two cases ran the same cell twice."""
    _, args = _parsed(["slip-fit", "--terrains", "ice", "Sandy_Loam"])
    assert args.terrains == ["ICE", "SANDY_LOAM"]
    for argv in (["--terrains", "ice", "ICE"], ["--terrains", "MUD"]):
        with pytest.raises(SystemExit) as exc:
            _parsed(["slip-fit", *argv])
        assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "ICE given twice" in err and "unknown terrain 'MUD'" in err
