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
