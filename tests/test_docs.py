"""The README and docs/ agree with the command line they describe.

* every ``terrain`` command they quote in full (a code line, or an inline span with an
  option and its value) parses with :func:`terrain.cli.build_parser`, placeholders
  (``NAME``, ``...``, ``<dir>``) aside;
* the stated range of ``terrain estimate --rate-hz`` is the one the code checks;
* every dotted name they quote (``terrain.x.y``, ``features.``, ``pipelines.``) exists;
* every option they name after ``terrain <subcommand>`` on one line, prose spans with a
  single option and synopses with placeholders included, is an option of that subcommand;
* every ``python benchmarks/<script>.py`` they quote names a script that defines each option
  given to it;
* every ``(default X)`` they state for a ``terrain`` option, and the smoothing default
  (dwell, evidence power), is the parser's and :class:`terrain.serving.SmoothingConfig`'s;
* every repository path and ``tests/...py::test`` node they quote exists.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import re
import shlex
from pathlib import Path

import pytest

from terrain.cli import SUBCOMMANDS, build_parser
from terrain.estimation.runner import MAX_RATE_HZ, MIN_RATE_HZ
from terrain.serving import SmoothingConfig
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


def _subcommand_options() -> dict[str, dict[str, object]]:
    """``{subcommand: {option string: default}}`` of :func:`terrain.cli.build_parser`."""
    action, = (a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return {name: {o: b.default for b in sub._actions for o in b.option_strings}
            for name, sub in action.choices.items()}


def _one_line(text: str) -> str:
    """A Markdown text with shell continuations joined and code fences' backticks kept."""
    return re.sub(r"\\\n\s*", " ", text)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_option_named_after_a_subcommand_is_one_of_its_options(doc):
    # the parse test above skips prose spans (`terrain simulate --duration-s`) and synopses
    # with placeholders (`terrain cv|train ... --window-ekf`): their options are checked here
    options = _subcommand_options()
    subs = "|".join(sorted(SUBCOMMANDS, key=len, reverse=True))
    wrong = []
    for line in _one_line(doc.read_text(encoding="utf-8")).splitlines():
        for m in re.finditer(rf"terrain ((?:{subs})(?:\|(?:{subs}))*)\b((?:[ \t]+[^\s`#]+)*)",
                             line):
            for option in re.findall(r"(?<![^\s\[])(--[a-z][\w-]*)", m.group(2)):
                wrong += [f"terrain {sub} {option}" for sub in m.group(1).split("|")
                          if option not in options[sub]]
    assert not wrong, wrong


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_benchmark_command_names_a_script_and_its_options(doc):
    text = re.sub(r"`\s*\n\s*", "` ", _one_line(doc.read_text(encoding="utf-8")))
    wrong = []
    for m in re.finditer(r"python (?:-m )?(benchmarks/\w+\.py)([^`\n]*)", text):
        script = ROOT / m.group(1)
        if not script.exists():
            wrong.append(f"{m.group(1)}: no such script")
            continue
        source = script.read_text(encoding="utf-8")
        args = re.split(r"\s#", m.group(2))[0]
        wrong += [f"{m.group(1)} {option}" for option in re.findall(r"(?<!\S)(--[a-z][\w-]*)", args)
                  if f'"{option}"' not in source and f"'{option}'" not in source]
    assert not wrong, wrong


def _value(text: str):
    """A stated default as a number where it reads as one (``2,000`` -> 2000), else text."""
    try:
        return float(text.replace(",", ""))
    except ValueError:
        return text


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_stated_option_default_is_the_parsers(doc):
    # "`--max-decisions` decisions (default 2,000, ...)", "`--physics` (default v1)"
    options = _subcommand_options()
    text = " ".join(doc.read_text(encoding="utf-8").split())
    wrong = []
    for m in re.finditer(r"`(--[\w-]+)`[^`()]{0,40}?\(default (\d{1,3}(?:,\d{3})+|[^,;)\s]+)",
                         text):
        option, stated = m.group(1), _value(m.group(2))
        defaults = [o[option] for o in options.values() if option in o]
        if not defaults or any(_value(str(d)) != stated for d in defaults):
            wrong.append(f"{option}: stated {m.group(2)}, parser {defaults}")
    assert not wrong, wrong


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_the_stated_smoothing_default_is_the_codes(doc):
    # "the streams' default, dwell 10 s, power 0.5" (README), the smoothing table's
    # "(default)" row (docs/streaming.md): SmoothingConfig and --dwell-s of stream and serve
    options = _subcommand_options()
    config = SmoothingConfig()
    code = {(config.dwell_s, config.evidence_power)}
    code |= {(options[sub]["--dwell-s"], config.evidence_power) for sub in ("stream", "serve")}
    text = " ".join(doc.read_text(encoding="utf-8").split())
    stated = {(float(m[0] or m[2]), float(m[1] or m[3])) for m in re.findall(
        r"default[^.;]{0,30}?dwell ([\d.]+) s, power ([\d.]+)"
        r"|dwell ([\d.]+) s, power ([\d.]+)\**\s*\(default", text)}
    assert all(s in code and len(code) == 1 for s in stated), (stated, code)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_repository_path_and_test_node_quoted_in_the_docs_exists(doc):
    text = doc.read_text(encoding="utf-8")
    paths = set(re.findall(r"`((?:terrain|features|pipelines|benchmarks|tests|docs|data)/"
                           r"[\w/.-]*\w)(?:::[\w*]+)?`", text))
    missing = sorted(p for p in paths if not (ROOT / p).exists())
    for path, name in set(re.findall(r"(tests/[\w/]+\.py)::([\w*]+)", text)):
        stem = re.escape(name.rstrip("*")) + (r"\w*" if name.endswith("*") else r"\b")
        pattern = rf"^\s*(?:def|class) {stem}"
        if not (ROOT / path).exists() or not re.search(
                pattern, (ROOT / path).read_text(encoding="utf-8"), re.M):
            missing.append(f"{path}::{name}")
    assert not missing, missing
