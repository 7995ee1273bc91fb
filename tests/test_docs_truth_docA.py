"""The values the docs give for named constants and settings are the code's.

A constant the docs quote with its value, ``LONG_REQUEST_S`` = 100 s (the served model's
long lane) or ``StreamConfig.max_backlog_s`` (60 s), must hold that value in the code: the
other docs tests check that such a name exists, not what it is worth, so a changed
threshold left the old figure in the prose (mutant: ``LONG_REQUEST_S = 1000.0``, no test
failed).
"""

from __future__ import annotations

import ast
import re
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
NUMBER = r"(\d[\d,]*(?:\.\d+)?)"
#: "`LONG_REQUEST_ROWS` = 10,000 rows", "`StreamConfig.max_backlog_s` (60 s)"
STATED = re.compile(rf"`([A-Z][A-Z0-9_]+|[A-Z]\w*\.[a-z_]\w*)`\s*(?:=\s*|\()\s*{NUMBER}")


@cache
def _code_values() -> dict[str, float]:
    """Module-level numeric constants (``NAME = 100.0``) and class attribute defaults
    (``Class.field``) of the packages, by name; a name given two values maps to None."""
    values: dict[str, float | None] = {}

    def put(name, node):
        try:
            value = ast.literal_eval(node)
        except (ValueError, TypeError, SyntaxError, MemoryError, RecursionError):
            return
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return
        values[name] = float(value) if values.get(name, value) == value else None

    for folder in ("terrain", "features", "pipelines"):
        for path in (ROOT / folder).rglob("*.py"):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for node in tree.body:
                if isinstance(node, ast.Assign) and len(node.targets) == 1 \
                        and isinstance(node.targets[0], ast.Name):
                    put(node.targets[0].id, node.value)
                elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) \
                        and node.value is not None:
                    put(node.target.id, node.value)
                elif isinstance(node, ast.ClassDef):
                    for item in node.body:
                        if isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name) \
                                and item.value is not None:
                            put(f"{node.name}.{item.target.id}", item.value)
    return values


@pytest.mark.slow
def test_the_constant_pattern_reads_the_docs_examples():
    text = "`LONG_REQUEST_ROWS` = 10,000 rows and `StreamConfig.max_backlog_s` (60 s)"
    assert STATED.findall(text) == [("LONG_REQUEST_ROWS", "10,000"),
                                    ("StreamConfig.max_backlog_s", "60")]
    assert _code_values()["LONG_REQUEST_ROWS"] == 10_000
    assert _code_values()["StreamConfig.max_backlog_s"] == 60.0


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_named_constant_quoted_with_its_value_holds_that_value(doc):
    text = " ".join(doc.read_text(encoding="utf-8").split())
    code = _code_values()
    wrong = [f"{name}: stated {stated}, code {code[name]}"
             for name, stated in STATED.findall(text)
             if name in code and code[name] != float(stated.replace(",", ""))]
    assert not wrong, wrong
