"""Every benchmark script imports and parses its arguments.

The benchmarks are run by hand (their figures are in docs/), so a renamed library function
would break one unseen until somebody needed it. Each script is imported as a module (its
``main`` is not run) and asked for ``--help``, which builds its argument parser.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

SCRIPTS = sorted((Path(__file__).resolve().parents[1] / "benchmarks").glob("*.py"))


def test_there_are_benchmarks():
    assert len(SCRIPTS) > 20


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_benchmark_imports_and_answers_help(path, monkeypatch, capsys):
    spec = importlib.util.spec_from_file_location(f"benchmark_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.__doc__ and callable(module.main)
    monkeypatch.setattr(sys, "argv", [path.name, "--help"])
    with pytest.raises(SystemExit) as stop:
        module.main()
    assert stop.value.code == 0
    assert "usage:" in capsys.readouterr().out


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_benchmark_refuses_a_prefix_of_an_option(path, capsys):
    # as `terrain` does (allow_abbrev=False): `--seed 1` must not run a benchmark as
    # `--seeds 1`, a prefix is a usage error (exit 2), not the option it abbreviates
    import copy

    from test_docs_truth_doc4 import _benchmark_parser

    parser = copy.deepcopy(_benchmark_parser(path))     # the cached one stays untouched
    options = [s for a in parser._actions for s in a.option_strings
               if s.startswith("--") and s != "--help" and len(s) > 4]
    if not options:
        pytest.skip("no long option to abbreviate")
    prefix = options[0][:-1]
    if any(s != options[0] and s.startswith(prefix) for s in options):
        pytest.skip(f"{options[0]} has no unique prefix")
    for action in parser._actions:            # a missing required option would end the
        if action.option_strings:             # parse before the prefix is looked at
            action.required = False
    with pytest.raises(SystemExit) as stop:
        parser.parse_args([prefix, "1"])
    assert stop.value.code == 2
    assert "unrecognized arguments" in capsys.readouterr().err


def _parser(path):
    import copy

    from test_docs_truth_doc4 import _benchmark_parser

    return copy.deepcopy(_benchmark_parser(path))     # the cached one stays untouched


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_every_number_option_has_a_range_check(path):
    # `bench_control.py --chunk 0` ended in "ValueError: range() arg 3 must not be zero",
    # `--repeats 0` in "KeyError: 'agrimaro'", `bench_served_load.py --behind-long -1` sent
    # every long body but one: a bare int / float type accepts any count, NaN and inf
    bare = [a.option_strings[0] if a.option_strings else a.dest
            for a in _parser(path)._actions if a.type in (int, float)]
    assert not bare, f"{path.name}: options without a range check: {bare}"


def test_every_seed_list_refuses_a_repeated_seed(capsys):
    # `--seeds 0 0` ran seed 0 twice and pooled it as two seeds
    checked = []
    for path in SCRIPTS:
        parser = _parser(path)
        seeds = [a for a in parser._actions if "--seeds" in a.option_strings]
        if not seeds or seeds[0].nargs != "+":   # no list of seeds
            continue
        _optional(parser)
        with pytest.raises(SystemExit) as stop:
            parser.parse_args(["--seeds", "1", "1"])
        assert stop.value.code == 2, path.name
        assert "given twice" in capsys.readouterr().err, path.name
        checked.append(path.stem)
    assert len(checked) >= 10, checked      # 14 scripts take a list of seeds


#: a valid value of the list options whose choices or default give none
LIST_VALUES = {"--decided": "husky=ICE", "dirs": "a", "--merge": "a", "--bounds": "0.3",
               "--side-force-factors": "2", "--friction-factors": "2",
               "--measured-terrains": "ICE"}


def _optional(parser):
    for action in parser._actions:            # a missing required option or positional
        if action.option_strings:             # would end the parse first
            action.required = False
        else:
            action.nargs = "?"


def test_every_list_option_refuses_a_repeated_value(capsys):
    # `bench_models.py --models svm svm` timed the SVM twice and logged the second fit's
    # figures over the first's under one key; `--terrains ICE ICE` ran every ICE cell twice
    checked = []
    for path in SCRIPTS:
        for action in _parser(path)._actions:
            if action.nargs not in ("+", "*") or action.dest == "vote":
                continue                     # --vote: each use one group (action append)
            name = action.option_strings[0] if action.option_strings else action.dest
            value = (LIST_VALUES[name] if LIST_VALUES.get(name)
                     else action.choices[0] if action.choices is not None
                     else action.default[0])
            parser = _parser(path)
            _optional(parser)
            for other in parser._actions:     # the positional tested keeps its list
                if other.dest == action.dest:
                    other.nargs = action.nargs
            argv = [str(value), str(value)]
            with pytest.raises(SystemExit) as stop:
                parser.parse_args(([name] if action.option_strings else []) + argv)
            assert stop.value.code == 2, (path.name, name)
            assert "given twice" in capsys.readouterr().err, (path.name, name)
            checked.append(f"{path.stem} {name}")
    assert len(checked) >= 35, checked      # 39 list options in 19 scripts


BAD_VALUES = [("bench_control", "--chunk", "0"), ("bench_control", "--repeats", "0"),
              ("bench_control", "--steps", "-5"), ("bench_ekf", "--steps", "0"),
              ("bench_ekf", "--minutes", "-1"), ("bench_ekf", "--minutes", "nan"),
              ("bench_serving", "--minutes", "inf"), ("bench_serving", "--minutes", "-1"),
              ("bench_serving", "--warmup", "-1"), ("bench_served_load", "--behind-long", "-1"),
              ("bench_served_load", "--requests", "0"), ("bench_served_load", "--reference", "-1"),
              ("bench_served_load", "--concurrency", "0"), ("bench_slip", "--repeats", "0"),
              ("bench_slip", "--singles", "-3"), ("bench_models", "--repeats", "0"),
              ("bench_models", "--threads", "0"), ("cnn_device", "--seeds", "-1"),
              ("learning_curve_runs", "--splits", "1"), ("stream_reset_nested",
                                                         "--inner-folds", "1"),
              ("stream_figure", "--fold", "5"), ("stream_transient_bound", "--target", "1.5"),
              ("stream_transient_bound", "--hop-s", "0"), ("parked_creep", "--seconds", "0"),
              ("parked_creep", "--slope-deg", "nan"), ("parked_creep", "--terrains", "FOO"),
              ("parked_creep", "--terrains", "ICE,"), ("ensemble_weights", "--n-jobs", "0"),
              ("merge_compare", "--history", "0"), ("unseen_runs", "--seed", "-1"),
              ("errors_by_manoeuvre", "--turning-rad-s", "-0.1"),
              *((script, "--dataset", "foo") for script in (
                  "ensemble_members", "ensemble_weights", "errors_by_manoeuvre",
                  "learning_curve_runs", "unseen_runs")),
              ("learning_curve_runs", "--models", "foo"), ("cnn_device", "--models", "svm"),
              ("cnn_device", "--devices", "tpu"), ("speed_bound", "--terrains", "FOO"),
              ("speed_bound", "--scenarios", "nope"), ("control_imu_views", "--terrains", "FOO"),
              ("control_imu_views", "--scenarios", "nope"),
              ("feedback_contribution", "--vehicles", "tracked"),
              ("feedback_contribution", "--scenarios", "nope")]


@pytest.mark.parametrize("script, option, value", BAD_VALUES,
                         ids=[f"{s}{o}={v}" for s, o, v in BAD_VALUES])
def test_an_option_out_of_its_range_is_a_usage_error(script, option, value, capsys):
    parser = _parser(SCRIPTS[[p.stem for p in SCRIPTS].index(script)])
    _optional(parser)
    with pytest.raises(SystemExit) as stop:
        parser.parse_args([option, value])
    assert stop.value.code == 2
    assert option in capsys.readouterr().err


def test_bench_control_refuses_a_chunk_longer_than_the_steps(monkeypatch, capsys):
    # `--steps 10` (chunk 50) timed no chunk: every figure inf, every ratio NaN, printed
    # as "inf us/wheel ... MISSED"
    path = SCRIPTS[[p.stem for p in SCRIPTS].index("bench_control")]
    spec = importlib.util.spec_from_file_location("benchmark_bench_control_chunk", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(sys, "argv", [path.name, "--steps", "10", "--no-mlflow"])
    with pytest.raises(SystemExit) as stop:
        module.main()
    assert stop.value.code == 2
    assert "--chunk" in capsys.readouterr().err


@pytest.mark.parametrize("script", ["speed_bound", "control_imu_views"])
def test_terrains_are_catalogue_names_in_any_case(script):
    # as terrain simulate reads them: "ice" is ICE
    parser = _parser(SCRIPTS[[p.stem for p in SCRIPTS].index(script)])
    assert parser.parse_args(["--terrains", "ice", "Snow"]).terrains == ["ICE", "SNOW"]


def test_cnn_device_takes_auto_and_torch_device_strings():
    parser = _parser(SCRIPTS[[p.stem for p in SCRIPTS].index("cnn_device")])
    assert parser.parse_args(["--devices", "auto", "cpu", "cuda:1"]).devices == [
        "auto", "cpu", "cuda:1"]


@pytest.mark.slow
@pytest.mark.parametrize("terrain, named", [("GRASS", "with an IMU on GRASS (they are on"),
                                            ("FOO", "unknown terrain 'FOO'")])
def test_speed_bound_refuses_a_measured_terrain_without_runs(terrain, named, monkeypatch,
                                                             capsys):
    # `--online --measured-terrains GRASS` selected no run and ended in pandas' "KeyError:
    # ... 'setting'"; FOO the same
    path = SCRIPTS[[p.stem for p in SCRIPTS].index("speed_bound")]
    spec = importlib.util.spec_from_file_location("benchmark_speed_bound_measured", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "online", lambda args: pytest.fail("ran"))
    monkeypatch.setattr(sys, "argv", [path.name, "--online", "--measured-terrains", "snow",
                                      terrain])
    with pytest.raises(SystemExit) as stop:
        module.main()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "argument --measured-terrains" in err and named in err


@pytest.mark.slow
def test_speed_bound_takes_a_measured_terrain_in_any_case(monkeypatch):
    path = SCRIPTS[[p.stem for p in SCRIPTS].index("speed_bound")]
    spec = importlib.util.spec_from_file_location("benchmark_speed_bound_case", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    seen = []
    monkeypatch.setattr(module, "online", lambda args: seen.append(args.measured_terrains))
    monkeypatch.setattr(sys, "argv", [path.name, "--online", "--measured-terrains", "snow"])
    module.main()
    assert seen == [["SNOW"]]


OUTPUT_OPTIONS = ("--out", "--figure", "--heldout-table")


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_every_output_option_is_checked_before_any_work(path, tmp_path, capsys):
    # `unseen_runs.py --out FILE/x` cross-validated every fold and then ended in
    # mkdir's FileExistsError / NotADirectoryError traceback; a plain Path type takes
    # anything, pipelines.arguments' output_file / output_dir refuse it while parsing
    from pipelines.arguments import output_dir, output_file

    parser = _parser(path)
    outputs = [a for a in parser._actions if set(a.option_strings) & set(OUTPUT_OPTIONS)]
    assert all(a.type in (output_file, output_dir) for a in outputs), \
        [(a.option_strings[0], a.type) for a in outputs]
    (tmp_path / "file").write_text("x")
    for action in parser._actions:
        if action.option_strings:
            action.required = False
        else:
            action.nargs = "?"
    for action in outputs:
        with pytest.raises(SystemExit) as stop:
            parser.parse_args([action.option_strings[0], str(tmp_path / "file" / "out.csv")])
        assert stop.value.code == 2
        assert action.option_strings[0] in capsys.readouterr().err
