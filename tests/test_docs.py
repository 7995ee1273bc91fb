"""The README and docs/ agree with the command line they describe.

* every ``terrain`` command they quote in full (a code line, or an inline span with an
  option and its value) parses with :func:`terrain.cli.build_parser`, placeholders
  (``NAME``, ``...``, ``<dir>``) aside;
* the stated range of ``terrain estimate --rate-hz`` is the one the code checks;
* every dotted name they quote (``terrain.x.y``, ``features.``, ``pipelines.``) exists.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import re
import shlex
from pathlib import Path

import pytest

from terrain.cli import SUBCOMMANDS, build_parser
from terrain.estimation.runner import MAX_RATE_HZ, MIN_RATE_HZ
from terrain.terramechanics.catalogue import TERRAIN_NAMES

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
COMMAND = rf"terrain (?:{'|'.join(sorted(SUBCOMMANDS, key=len, reverse=True))})"
#: a word in capitals that is no terrain name (NAME, DIR, HZ...), an ellipsis, <...>,
#: [...], {...} or a pipe
PLACEHOLDER = re.compile(rf"\b(?!(?:{'|'.join(TERRAIN_NAMES)})\b)[A-Z][A-Z_]+\b"
                         r"|\.\.\.|[<>\[\]{}|]")


def _quoted_commands(text: str) -> list[str]:
    """``terrain <subcommand> ...`` commands of a Markdown text, continuations joined."""
    text = re.sub(r"\\\n\s*", " ", text)
    found = [m.group(1) for m in re.finditer(rf"`({COMMAND}\s[^`]*--[^`]*)`", text)]
    for line in text.splitlines():
        line = re.sub(r"^\s*(\$ )?(cd \S+ && |\w+=\S+ )*", "", line)
        if re.match(rf"{COMMAND}\b", line):
            found.append(line)
    commands = []
    for command in found:
        command = re.split(r"\s+#", command)[0].strip().removesuffix("&").strip()
        args = command.split()[2:]
        if PLACEHOLDER.search(command) or not any(a.startswith("-") for a in args):
            continue
        # an inline span naming one option (`terrain simulate --duration-s`) is prose
        if len(args) == 1 and "\n" not in command:
            continue
        commands.append(" ".join(command.split()))
    return commands


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_command_quoted_in_the_docs_parses(doc):
    # docs/physics_v2.md quoted `terrain audit --dataset vulpi --physics v2` without the
    # --json the audit needs, README a control-grid without its --out: copied, they failed
    parser = build_parser()
    failed = []
    for command in _quoted_commands(doc.read_text(encoding="utf-8")):
        err = io.StringIO()
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                parser.parse_args(shlex.split(command)[1:])
        except SystemExit as exc:
            if exc.code:
                failed.append(f"{command!r}: {err.getvalue().strip().splitlines()[-1]}")
    assert not failed, "\n".join(failed)


def test_readme_states_the_rate_range_the_code_checks():
    # README said (0, 10000] Hz; check_rate_hz refuses below MIN_RATE_HZ = 1 Hz
    text = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    (low, high), = re.findall(r"`--rate-hz` a rate in \[([\d.]+), ([\d.]+)\] Hz", text)
    assert (float(low), float(high)) == (MIN_RATE_HZ, MAX_RATE_HZ)


def _resolves(dotted: str) -> bool:
    """Whether ``package.module.attr...`` names an importable module or one of its attributes."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_dotted_name_quoted_in_the_docs_exists(doc):
    # docs/model_comparison.md cited `terrain.models.compare._windows`, renamed cell_windows
    names = set(re.findall(r"`((?:terrain|features|pipelines)\.[\w.]+)`",
                           doc.read_text(encoding="utf-8")))
    missing = sorted(n for n in names if not _resolves(n.rstrip(".")))
    assert not missing, missing
