"""Code style checks: the tree keeps 100 columns, PEP 8 layout and no unused or undefined names.

The checks are the well-kept libraries' own (pycodestyle, pyflakes; pinned dev dependencies),
run on every Python file of the packages, tests and benchmarks:

* pycodestyle with its default checks at 100 columns; ``E731`` (a lambda bound to a name) is
  allowed, as the tests use it for short callbacks;
* pyflakes: unused imports and variables, undefined names, redefinitions. An import kept on
  purpose carries ``# noqa`` (pyflakes honours none, so such lines are skipped here).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pycodestyle
from pyflakes import api as pyflakes_api
from pyflakes import reporter as pyflakes_reporter

ROOT = Path(__file__).resolve().parents[1]
CHECKED = ("terrain", "features", "pipelines", "tests", "benchmarks")
MAX_LINE_LENGTH = 100
#: pycodestyle's default ignore list plus E731
IGNORED = [*pycodestyle.DEFAULT_IGNORE.split(","), "E731"]
#: the command line that lists what the pycodestyle test finds
LIST_COMMAND = (f"python -m pycodestyle --max-line-length={MAX_LINE_LENGTH} "
                f"--ignore={','.join(IGNORED)} {' '.join(CHECKED)}")


def _python_files() -> list[Path]:
    files = sorted(p for d in CHECKED for p in (ROOT / d).rglob("*.py"))
    assert files, f"no Python files under {CHECKED} in {ROOT}"
    return files


def test_pycodestyle_finds_nothing():
    """Default pycodestyle checks at 100 columns (lambdas bound to names allowed)."""
    style = pycodestyle.StyleGuide(max_line_length=MAX_LINE_LENGTH, quiet=True, ignore=IGNORED)
    report = style.init_report(pycodestyle.StandardReport)
    for path in _python_files():
        style.input_file(str(path))
    found = [f"{code}: {report.counters[code]}" for code in sorted(report.messages)]
    assert report.total_errors == 0, (
        f"{report.total_errors} style problems ({', '.join(found)}); list them with "
        f"`{LIST_COMMAND}`")


def test_the_listing_command_runs_and_finds_what_the_test_finds(tmp_path):
    # the command the failure message gives is one this pycodestyle accepts (2.15 has no
    # --extend-ignore: the message named it before), with the test's own settings
    bad = tmp_path / "bad.py"
    bad.write_text("f = lambda x: x\nx = 1 +  2\n")
    command = LIST_COMMAND.split()[1:-len(CHECKED)] + [str(bad)]
    done = subprocess.run([sys.executable, *command], capture_output=True, text=True)
    assert done.returncode == 1 and "E222" in done.stdout, done.stdout + done.stderr
    assert "E731" not in done.stdout


class _Collect(pyflakes_reporter.Reporter):
    """A pyflakes reporter that keeps the messages instead of printing them."""

    def __init__(self) -> None:
        self.found: list[str] = []

    def unexpectedError(self, filename, msg) -> None:
        self.found.append(f"{filename}: {msg}")

    def syntaxError(self, filename, msg, lineno, offset, text) -> None:
        self.found.append(f"{filename}:{lineno}: {msg}")

    def flake(self, message) -> None:
        line = Path(message.filename).read_text().splitlines()[message.lineno - 1]
        if "# noqa" not in line:
            self.found.append(str(message))


def test_pyflakes_finds_nothing():
    """No unused import or variable, undefined name or redefinition (``# noqa`` lines kept)."""
    collect = _Collect()
    for path in _python_files():
        pyflakes_api.checkPath(str(path), collect)
    assert not collect.found, "\n".join(collect.found[:40])


def test_the_checks_catch_what_they_are_for(tmp_path):
    """Both checks flag a planted unused import, an undefined name and a 101-column line."""
    bad = tmp_path / "bad.py"
    bad.write_text("import os\n\n\ndef f():\n    return undefined_name\n\n\nx = '"
                   + "a" * (MAX_LINE_LENGTH - 5) + "'\n")
    collect = _Collect()
    pyflakes_api.checkPath(str(bad), collect)
    assert len(collect.found) == 2
    assert any("'os' imported but unused" in f for f in collect.found)
    assert any("undefined name 'undefined_name'" in f for f in collect.found)
    style = pycodestyle.StyleGuide(max_line_length=MAX_LINE_LENGTH, quiet=True)
    assert style.input_file(str(bad)) == 1
