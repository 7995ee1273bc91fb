"""The commands README.md and docs/*.md give a user run as given: parsed by the real
``terrain`` parser and past each command's own checks of the parsed options (what the
command refuses before it reads a run), for every value a placeholder stands for."""

from __future__ import annotations

import argparse
import re
import shlex
from pathlib import Path

import pytest

from pipelines.compare import config_from_args
from terrain.cli import build_parser
from terrain.errors import TerrainError

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _block_commands(text: str, sub: str) -> list[list[str]]:
    """The ``terrain SUB ...`` lines of the fenced blocks of a Markdown text (continuations
    joined, comments cut), as argument lists after ``terrain SUB``."""
    found = []
    for i, part in enumerate(re.split(r"^\s*```.*$", text, flags=re.M)):
        if not i % 2:
            continue
        for line in re.sub(r"\\\n\s*", " ", part).splitlines():
            m = re.match(rf"\s*terrain {sub}\s(.*)", line)
            if m:
                found.append(shlex.split(re.split(r"\s#", m.group(1))[0]))
    return found


def _subparser(sub: str) -> argparse.ArgumentParser:
    action, = (a for a in build_parser()._actions
               if isinstance(a, argparse._SubParsersAction))
    return action.choices[sub]


def _documented_compare_commands():
    """``(doc, argv)`` of every full ``terrain compare`` command (no ``[...]`` synopsis) of
    the docs, each capitalised placeholder of ``--models`` filled with every model, any
    other (SEED, D) with a value its option takes."""
    parser = _subparser("compare")
    models = parser._option_string_actions["--models"].choices
    fill = {"--seeds": "0", "--datasets": "vulpi"}
    cases = []
    for doc in DOCS:
        for argv in _block_commands(doc.read_text(encoding="utf-8"), "compare"):
            if any(t.startswith("[") for t in argv):
                continue
            for model in models:
                filled, option = [], None
                for token in argv:
                    if token.startswith("--"):
                        option = token
                    elif re.fullmatch(r"[A-Z]+", token):
                        token = model if option == "--models" else fill[option]
                    filled.append(token)
                cases.append(pytest.param(filled, id=f"{doc.name}-{model}-{' '.join(argv)}"))
    return cases


@pytest.mark.parametrize("argv", _documented_compare_commands())
def test_every_documented_compare_command_passes_the_commands_own_checks(argv, tmp_path):
    # README's "terrain compare --models MODEL ... --n-jobs 1 --threads 1 --out
    # cmp/borealtc-MODEL-sSEED  # MODEL x SEED in 0 1 2" (and docs/model_comparison.md's
    # paper-protocol pair) parsed, but with MODEL = svm, one member of the vote merged
    # next, compare refused it: "--threads trains the CNNs and none of the models ['svm']
    # has one: leave it out"
    argv = [str(tmp_path / "out") if i and argv[i - 1] == "--out" else t
            for i, t in enumerate(argv)]
    args = _subparser("compare").parse_args(argv)
    try:
        config_from_args(args)
    except TerrainError as exc:
        pytest.fail(f"terrain compare {' '.join(argv)}: {exc}")


@pytest.fixture(scope="module")
def few_borealtc_runs(borealtc_runs):
    """Two runs of each of two BorealTC terrains (seconds to fit a recipe on)."""
    out = []
    for terrain in ("ICE", "SNOW"):
        out += [r for r in borealtc_runs if r.terrain == terrain and r.has_imu][:2]
    return out


@pytest.mark.slow
def test_stream_eval_saves_the_model_it_fitted_with_its_metadata(few_borealtc_runs, tmp_path,
                                                                 monkeypatch, capsys):
    # stream-eval --model-out saved the fitted streaming model with {"dataset", "recipe"}
    # only: the channel_steps_s and track_m that fit_stream_model gives it (as terrain
    # train's model has them) were dropped, so `terrain stream --model DIR/wheels` judged a
    # stream's first steps for gaps by their own instead of the training runs' steps
    import pipelines.stream_eval as stream_eval
    from cli_helpers import RecordingRun

    from terrain.cli import main
    from terrain.serving import load_stream_model
    from terrain.serving.recipes import RECIPES, fit_stream_model

    monkeypatch.setattr(stream_eval, "load_dataset", lambda name: few_borealtc_runs)
    monkeypatch.setattr(stream_eval, "tracked_run", RecordingRun())
    assert main(["stream-eval", "--part", "none", "--kinds", "wheels", "--model-out",
                 str(tmp_path / "m")]) == 0
    fitted = fit_stream_model(RECIPES["wheels"], few_borealtc_runs)
    saved = load_stream_model(tmp_path / "m" / "wheels")
    assert saved.channels == fitted.channels
    for key, value in fitted.metadata.items():
        assert saved.metadata.get(key) == pytest.approx(value), key
    # and the vehicle of its runs, as terrain train writes it
    assert saved.metadata.get("vehicle") == "husky"


def test_convert_writes_where_slip_table_reads_and_its_help_says_so(tmp_path, monkeypatch):
    # convert's --help said "(default: the project's data/)", but both convert (writing)
    # and slip-table / cv (reading) default to TERRAIN_DATA_DIR when it is set, which
    # slip-table's --help names
    import pipelines.convert as convert

    from terrain.cli import main
    from terrain.io.shipped import default_data_dir

    monkeypatch.setenv("TERRAIN_DATA_DIR", str(tmp_path / "d"))
    written = []
    monkeypatch.setattr(convert, "convert_dataset",
                        lambda src, dataset, data_dir: written.append(Path(data_dir)) or {})
    monkeypatch.setattr(convert, "read_shipped", lambda *a, **k: [])
    monkeypatch.setattr(convert, "input_report",
                        lambda runs: type("R", (), {"text": lambda self: ""})())
    (tmp_path / "csv").mkdir()
    main(["convert", str(tmp_path / "csv"), "--dataset", "borealtc"])
    assert written == [default_data_dir()] == [tmp_path / "d"]
    for sub in ("convert", "slip-table"):
        text = _subparser(sub)._option_string_actions["--data-dir"].help
        assert "TERRAIN_DATA_DIR" in text, (sub, text)


def test_the_live_sim_classifier_keeps_the_training_steps_a_train_model_keeps(tmp_path):
    from pipelines.control_classifier import sim_classifier
    from terrain.serving import load_stream_model

    folder, _ = sim_classifier("husky", ["ICE", "SNOW"], seeds=(2000,),
                               scenarios=("straight_accel",), duration_s=4.0,
                               cache_dir=tmp_path, controlled_runs=False)
    metadata = load_stream_model(folder).metadata
    assert metadata.get("channel_steps_s"), sorted(metadata)


def test_compare_help_names_every_file_compare_writes():
    # the description listed compare_table.md/.csv, compare_cells.csv, compare.png and the
    # grid's files, not predictions.csv, which README names and merge_compare.py reads
    from pipelines.compare import SUMMARY_FILES

    text = " ".join(_subparser("compare").description.split())
    named = set(re.findall(r"[\w.]+\.(?:csv|md|png)\b", text))
    named |= {f"compare_table.{e}" for e in ("md", "csv")} if "compare_table.md/.csv" in text \
        else set()
    assert set(SUMMARY_FILES) | {"compare_cells.csv"} <= named, text
