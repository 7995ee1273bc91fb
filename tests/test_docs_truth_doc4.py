"""The commands, extras and experiment names the README and docs/ quote are the code's.

:mod:`tests.test_docs` parses every complete ``terrain`` command and checks that the options
given to a ``python benchmarks/<script>.py`` appear in its source. This file checks what that
leaves out:

* every ``python benchmarks/<script>.py ...`` they quote with arguments parses with the
  script's own argument parser (an option's value, e.g. a ``--kind`` that is no choice of
  it, or a required option left out);
* synopses (``terrain cv|train ... --window-ekf``, ``--physics {v1,v2}``, ``[--json]``,
  ``--kind K``) parse too, each alternative in turn, a placeholder standing for a valid
  value of its option (a synopsis may leave out required options);
* every ``--option value`` quoted without its command (```--estimator observer```) names
  one of the option's choices, where it takes choices;
* every ``pip install`` extra they name is one of ``pyproject.toml``'s, and every pin they
  state (``torch==2.13.0``) is the one there;
* every MLflow experiment they name (```terrain-<name>```) is one the code logs to;
* every class (```...Error```, ```...Config```, ```...Settings``` ...) and constant
  (```DEFAULT_GAINS```) they name in backticks is defined or quoted by the code;
* every output file they name (```measured_checks.csv```, ```compare_cells.csv```) is a
  name the code writes or reads, unless the repository holds it or the doc's own command
  writes it;
* every Markdown link and image target (``![grid](model_comparison_grid.png)``) exists, and
  so does every repository file named in plain text (``docs/streaming.md``, not backticked);
* every loopback URL they quote (``http://127.0.0.1:5001/invocations``) is an endpoint of
  ``terrain serve``.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import re
import shlex
import sys
import tomllib
from functools import cache
from pathlib import Path

import pytest

from terrain.cli import SUBCOMMANDS, build_parser
from terrain.serving.http import ENDPOINTS
from terrain.terramechanics.catalogue import TERRAIN_NAMES

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
_TERRAINS = "|".join(TERRAIN_NAMES)
#: a placeholder token: a word in capitals that is no terrain name nor a comma list of
#: them (NAME, DIR, K), one with <...>, an ellipsis, a shell variable
PLACEHOLDER = re.compile(rf"^(?!(?:{_TERRAINS})(?:,(?:{_TERRAINS}))*$)[A-Z][A-Z_]*$"
                         r"|[<>]|^\.\.\.$|^\$\w+$")
SUBS = "|".join(sorted(SUBCOMMANDS, key=len, reverse=True))


def _snippets(text: str) -> list[tuple[str, bool]]:
    """``(code, in_block)``: the lines of the fenced blocks (continuations joined) and the
    inline code spans (line breaks inside a span read as spaces) of a Markdown text."""
    found = []
    for i, part in enumerate(re.split(r"^\s*```.*$", text, flags=re.M)):
        if i % 2:
            found += [(line, True) for line in re.sub(r"\\\n\s*", " ", part).splitlines()]
        else:
            found += [(" ".join(s.split()), False) for s in re.findall(r"`([^`]+)`", part)]
    return found


def _arguments(tail: str) -> list[str] | None:
    """The arguments of a command line before any comment, pipe, ``&&``, redirect or ``&``;
    ``None`` when its quotes do not close (a command quoted in part)."""
    tail = re.sub(r"<[^<>]*>", "<x>", tail)
    tail = re.split(r"\s#|\s\|\s|\s&&\s|\s>|\s&$", tail)[0]
    try:
        return shlex.split(tail)
    except ValueError:
        return None


def _variants(tokens: list[str]) -> list[list[str]]:
    """The commands a synopsis stands for: optional ``[...]`` included, alternatives
    ``a|b`` and ``{a,b}`` taken in step (the i-th variant takes each token's i-th)."""
    alternatives = []
    for token in tokens:
        if not token.startswith(("'", '"', "[{", "[[")):
            token = token.strip("[]")
        if not token:
            continue
        braces = re.fullmatch(r"\{([^{}]*,[^{}]*)\}", token)
        if braces:
            alternatives.append(braces.group(1).split(","))
        elif "|" in token:
            alternatives.append(token.split("|"))
        else:
            alternatives.append([token])
    n = max((len(a) for a in alternatives), default=1)
    return [[a[i % len(a)] for a in alternatives] for i in range(n)]


def _filled(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """``argv`` with each placeholder replaced by a value its option takes (its first
    choice, else ``1``, else ``x`` for a positional); an ellipsis after a value or a
    positional (a repetition mark) is dropped."""
    filled = []
    for i, token in enumerate(argv):
        if not PLACEHOLDER.search(token):
            filled.append(token)
            continue
        action = parser._option_string_actions.get(argv[i - 1]) if i else None
        if token == "..." and (action is None or action.nargs == 0):
            continue
        if action is None:
            filled.append("x")
        elif action.choices:
            filled.append(str(next(iter(action.choices))))
        else:
            filled.append("1")
    return filled


def _parse_error(parser: argparse.ArgumentParser, tokens: list[str]) -> str | None:
    """Why ``tokens`` (each of its variants) does not parse, or ``None``; a synopsis (one
    with placeholders) may leave required arguments out."""
    synopsis = any(PLACEHOLDER.search(t) for t in tokens)
    for variant in _variants(tokens):
        argv = _filled(parser, variant)
        err = io.StringIO()
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                parser.parse_args(argv)
        except SystemExit as exc:
            message = err.getvalue()
            if exc.code and not (synopsis and "arguments are required" in message):
                return f"{argv}: {message.strip().splitlines()[-1]}"
    return None


def _commands(doc: Path, program: str) -> list[tuple[str, list[str], bool]]:
    """``(name, arguments, in_block)`` of each command ``program`` (a regular expression
    whose first group is the subcommand or script) quoted at the start of a code line or
    span of ``doc``."""
    commands = []
    for code, in_block in _snippets(doc.read_text(encoding="utf-8")):
        code = re.sub(r"^\s*(\$ )?(cd \S+ && |\w+=\S+ )*", "", code)
        m = re.match(rf"{program}(?=\s|$)(.*)", code)
        if m:
            args = _arguments(m.group(2))
            if args is not None:
                commands.append((m.group(1), args, in_block))
    return commands


@cache
def _subparsers() -> dict[str, argparse.ArgumentParser]:
    """``{subcommand: its parser}`` of :func:`terrain.cli.build_parser`."""
    action, = (a for a in build_parser()._actions
               if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


@pytest.fixture(scope="module")
def subparsers() -> dict[str, argparse.ArgumentParser]:
    return _subparsers()


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_terrain_synopsis_parses(doc, subparsers):
    # `terrain cv|train ... --window-ekf`, `--physics {v1,v2}`, `--kind K`, `python -m
    # terrain.cli validate sim ...`: tests/test_docs skips commands with placeholders (and
    # the python -m form) and checks only their option names, not values
    wrong = []
    program = rf"(?:python -m terrain\.cli|terrain) ((?:{SUBS})(?:\|(?:{SUBS}))*)"
    for subs, args, in_block in _commands(doc, program):
        # an inline span naming one option (`terrain simulate --duration-s`) is prose
        if not in_block and len(args) < 2:
            continue
        for sub in subs.split("|"):
            error = _parse_error(subparsers[sub], args)
            if error:
                wrong.append(f"terrain {sub} {error}")
    assert not wrong, "\n".join(wrong)


class _Parsed(Exception):
    """Raised instead of running a benchmark once its arguments are parsed."""


@cache
def _benchmark_parser(script: Path) -> argparse.ArgumentParser:
    """The argument parser a benchmark script's ``main`` builds (its ``main`` not run)."""
    spec = importlib.util.spec_from_file_location(f"doc4_benchmark_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    built = []

    def stop(parser, args=None, namespace=None):
        built.append(parser)
        raise _Parsed

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(argparse.ArgumentParser, "parse_args", stop)
        patch.setattr(sys, "argv", [script.name])
        with pytest.raises(_Parsed):
            module.main()
    return built[0]


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_benchmark_command_parses_with_its_script_parser(doc):
    # docs/model_comparison.md quoted `benchmarks/ensemble_weights.py ... --threads 1`
    # without the --out the script requires; tests/test_docs only checks option names
    wrong = []
    for script, args, in_block in _commands(doc, r"python (?:-m )?(benchmarks/\w+\.py)"):
        if not args:
            continue  # the script named in prose ("with the arguments given")
        if not (ROOT / script).exists():
            wrong.append(f"{script}: no such script")
            continue
        error = _parse_error(_benchmark_parser(ROOT / script), args)
        if error:
            wrong.append(f"{script} {error}")
    assert not wrong, "\n".join(wrong)


def _pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def _pins() -> dict[str, str]:
    """``{distribution: version}`` of every ``name==version`` of pyproject.toml."""
    project = _pyproject()["project"]
    requirements = [*project["dependencies"],
                    *(r for extra in project["optional-dependencies"].values() for r in extra)]
    pins = {}
    for requirement in requirements:
        m = re.fullmatch(r"([\w.-]+)(?:\[[\w,]+\])?==([\w.+]+)", requirement)
        if m:
            pins[m.group(1).lower()] = m.group(2)
    # stated in pyproject's comment: aeon's own dependency installed with --no-deps
    comment = re.search(r"pip install --no-deps ([^`\n]*)`",
                        (ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    for m in re.finditer(r"([\w.-]+)==([\w.+]+)", comment.group(1) if comment else ""):
        pins.setdefault(m.group(1).lower(), m.group(2))
    return pins


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_pip_extra_and_stated_pin_is_pyprojects(doc):
    # README: "`torch==2.13.0` is the CPU build", "pip install 'terrain[ray]'"
    text = doc.read_text(encoding="utf-8")
    extras = set(_pyproject()["project"]["optional-dependencies"])
    pins = _pins()
    wrong = [f"extra [{e}]" for spec in re.findall(r"(?:\.|terrain)\[([\w,]+)\]", text)
             for e in spec.split(",") if e not in extras]
    for name, version in re.findall(r"`[^`]*?\b([A-Za-z][\w.-]*)==([\w.+]+)", text):
        if pins.get(name.lower()) != version:
            wrong.append(f"{name}=={version}: pyproject.toml pins {pins.get(name.lower())}")
    for line in re.findall(r"pip install[^`\n]*", text):
        for name, version in re.findall(r"([A-Za-z][\w.-]*)==([\w.+]+)", line):
            if pins.get(name.lower()) != version:
                wrong.append(f"{line}: pyproject.toml pins {name} {pins.get(name.lower())}")
    assert not wrong, sorted(set(wrong))


@cache
def _experiments() -> frozenset[str]:
    """Every ``"terrain-<name>"`` string literal of the code that logs runs."""
    names = set()
    for folder in ("terrain", "pipelines", "benchmarks"):
        for path in (ROOT / folder).rglob("*.py"):
            names |= set(re.findall(r"[\"'](terrain-[a-z0-9-]+)[\"']",
                                    path.read_text(encoding="utf-8")))
    return frozenset(names)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_mlflow_experiment_named_is_one_the_code_logs_to(doc):
    # README "MLflow": "one experiment per pipeline (`terrain-cv`, `terrain-train`, ...)"
    named = set(re.findall(r"`(terrain-[a-z0-9-]+)`", doc.read_text(encoding="utf-8")))
    assert named <= _experiments(), sorted(named - _experiments())


@cache
def _code_names() -> frozenset[str]:
    """Names the code defines (``class``, ``def``, a module-level or class-level assignment)
    or quotes as a string (an environment variable, an error code)."""
    names = set()
    for folder in ("terrain", "features", "pipelines", "benchmarks"):
        for path in (ROOT / folder).rglob("*.py"):
            source = path.read_text(encoding="utf-8")
            names |= set(re.findall(r"^\s*(?:class|def)\s+(\w+)", source, re.M))
            names |= set(re.findall(r"^\s*(\w+)\s*(?::[^=\n]+)?=", source, re.M))
            names |= set(re.findall(r"[\"'](\w+)[\"']", source))
    return frozenset(names)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_class_and_constant_named_is_the_codes(doc):
    # `ServiceBusyError`, `SmoothingConfig`, `DEFAULT_GAINS`, `BODY_TIMEOUT_S`: a class or
    # constant renamed in the code would leave its old name in the docs
    text = doc.read_text(encoding="utf-8")
    named = set(re.findall(r"`([A-Z]\w*(?:Error|Warning|Config|Settings|Pipeline|Model))`", text))
    named |= set(re.findall(r"`([A-Z][A-Z0-9]+_[A-Z0-9_]+)`", text))
    missing = sorted(n for n in named if n not in _code_names() and n not in TERRAIN_NAMES)
    assert not missing, missing


_EXTENSIONS = r"(?:csv|png|json|md|pkl|parquet)"


@cache
def _written_file_names() -> tuple[re.Pattern, ...]:
    """The file names the code writes or reads (string literals, names in its docstrings),
    one pattern each, in any case (an f-string's ``{...}`` and a docs placeholder's
    ``<...>`` stand for any name part; a name that is nearly all placeholder,
    ``f"{name}.csv"``, is left out)."""
    names = set()
    for folder in ("terrain", "features", "pipelines", "benchmarks"):
        for path in (ROOT / folder).rglob("*.py"):
            source = path.read_text(encoding="utf-8")
            names |= {Path(n).name for n in re.findall(
                rf"[\"']([\w{{}}<>.:!\- /\[\]]*?\.{_EXTENSIONS})[\"']", source)}
            names |= set(re.findall(rf"``([\w<>.-]+\.{_EXTENSIONS})``", source))
    patterns = []
    for name in names:
        parts = re.split(r"\{[^{}]*\}", name)
        if len(re.findall(r"[A-Za-z0-9]", re.sub(rf"\.{_EXTENSIONS}$", "", "".join(parts)))) < 3:
            continue  # f"{name}.csv" would match any name
        patterns.append(re.compile(r"[\w<>.-]+".join(map(re.escape, parts)), re.I))
    return tuple(patterns)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_output_file_named_is_one_the_code_writes(doc):
    # docs/slip_learning.md: "`slip_errors.csv`, `odometry.csv`, `measured_checks.csv`",
    # README: "`compare_table.md/.csv`, `compare_cells.csv`": a renamed output would
    # leave the old name; a file of the repository (docs/...) or one the doc's own
    # commands write (`--out x.csv`, `@request.csv`) is no output of the code
    text = doc.read_text(encoding="utf-8")
    own = set(re.findall(rf"(?:--\w[\w-]* |@|> )(?:\S*/)?([\w.-]+\.{_EXTENSIONS})\b", text))
    wrong = []
    for name in set(re.findall(rf"`([\w<>.-]+\.{_EXTENSIONS})`", text)):
        if (name in own or list(ROOT.glob(f"*/{name}")) or (ROOT / name).exists()
                or any(p.fullmatch(name) for p in _written_file_names())):
            continue
        wrong.append(name)
    assert not wrong, sorted(wrong)


@cache
def _option_choices() -> dict[str, list[list[str] | None]]:
    """``{option: [its choices in each parser that has it, None where it takes any value]}``
    over the ``terrain`` subcommands and the benchmark scripts."""
    parsers = [*_subparsers().values(),
               *(_benchmark_parser(s) for s in sorted((ROOT / "benchmarks").glob("*.py")))]
    choices: dict[str, list[list[str] | None]] = {}
    for parser in parsers:
        for a in parser._actions:
            for option in a.option_strings:
                choices.setdefault(option, []).append(
                    None if a.choices is None else [str(c) for c in a.choices])
    return choices


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_option_value_in_prose_is_one_of_its_choices(doc):
    # prose spans without their command, "(`--estimator observer`)", "`--kind all-dense`":
    # the value of an option that takes choices (in every parser that has it) is one of them
    wrong = []
    for code, _ in _snippets(doc.read_text(encoding="utf-8")):
        for option, value in re.findall(r"(?<![\w-])(--[a-z][\w-]*)[ =]([^\s`\[\]|{}]+)", code):
            known = _option_choices().get(option, [None])
            if (value.startswith("-") or PLACEHOLDER.search(value)
                    or any(c is None for c in known)):
                continue
            if not any(value in c for c in known):
                wrong.append(f"{option} {value}: choices {known}")
    assert not wrong, sorted(set(wrong))


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_link_and_image_target_exists(doc):
    # `![grid](model_comparison_grid.png)`, `[docs/...](docs/...)`: relative to the doc's
    # folder, as a Markdown viewer resolves them (tests/test_docs checks backticked paths)
    targets = re.findall(r"\]\(([^)\s]+)\)", doc.read_text(encoding="utf-8"))
    missing = [t for t in targets if not re.match(r"[a-z]+:|#", t)
               and not (doc.parent / t.split("#")[0]).exists()]
    assert not missing, missing


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_repository_file_named_in_prose_exists(doc):
    # "(docs/streaming.md, "Latency")", "benchmarks/stream_reset_nested.py": tests/test_docs
    # checks the backticked paths; a file named in plain text (with its extension) must
    # exist too, at the repository root or under docs/
    text = doc.read_text(encoding="utf-8")
    paths = set(re.findall(r"(?<![\w/.`-])((?:terrain|features|pipelines|benchmarks|tests|docs"
                           r"|data)/[\w/.-]*\w\.[a-z]{2,7})\b", text))
    missing = sorted(p for p in paths if not (ROOT / p).exists()
                     and not (ROOT / "docs" / p).exists())
    assert not missing, missing


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_served_url_is_an_endpoint_of_terrain_serve(doc):
    # README's curl example posts to http://127.0.0.1:5001/invocations
    paths = re.findall(r"https?://(?:127\.0\.0\.1|localhost|\[::1\])(?::\d+)?(/[\w/.-]*)",
                       doc.read_text(encoding="utf-8"))
    assert not [p for p in paths if p not in ENDPOINTS], (paths, ENDPOINTS)
