"""Architecture checks: one-way data flow and documented public API."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_import_layers_contract_is_kept():
    """The import-linter `layers` contract in pyproject.toml holds (DESIGN.md data flow)."""
    exe = shutil.which("lint-imports")
    assert exe, "import-linter is a dev dependency: pip install -e '.[dev]'"
    done = subprocess.run([exe, "--no-cache"], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "0 broken" in done.stdout


def _public_members():
    for pkg_name in ("terrain", "features"):
        pkg = importlib.import_module(pkg_name)
        for info in pkgutil.walk_packages(pkg.__path__, prefix=pkg_name + "."):
            module = importlib.import_module(info.name)
            for name, obj in vars(module).items():
                if name.startswith("_") or getattr(obj, "__module__", None) != info.name:
                    continue
                if inspect.isfunction(obj) or inspect.isclass(obj):
                    yield f"{info.name}.{name}", obj


@pytest.mark.parametrize("qualname,obj", list(_public_members()),
                         ids=lambda v: v if isinstance(v, str) else "")
def test_public_functions_and_classes_have_docstrings(qualname, obj):
    assert inspect.getdoc(obj), f"{qualname} has no docstring"
