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
    """The import-linter `layers` contract in pyproject.toml holds (one-way data flow)."""
    exe = shutil.which("lint-imports")
    assert exe, "import-linter is a dev dependency: pip install -e '.[dev]'"
    done = subprocess.run([exe, "--no-cache"], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "0 broken" in done.stdout


def _import_cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (or a self-import) of the
    directed import graph ``edges`` (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in edges:
                    continue
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        component.append(w)
                        if w == v:
                            break
                    if len(component) > 1 or v in edges[v]:
                        cycles.append(sorted(component))
    return cycles


def test_cycle_finder_finds_a_planted_cycle():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"e"}}
    assert sorted(_import_cycles(edges)) == [["a", "b", "c"], ["e"]]
    assert _import_cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_between_modules():
    """No module of terrain, features or pipelines imports itself back through others
    (any import statement counts, also those inside functions or TYPE_CHECKING blocks)."""
    import grimp                                # installed with import-linter (dev extra)

    graph = grimp.build_graph("terrain", "features", "pipelines", cache_dir=None)
    edges = {m: set(graph.find_modules_directly_imported_by(m)) for m in graph.modules}
    assert _import_cycles(edges) == []


def _public_members():
    for pkg_name in ("terrain", "features"):
        pkg = importlib.import_module(pkg_name)
        for info in pkgutil.walk_packages(pkg.__path__, prefix=pkg_name + "."):
            module = importlib.import_module(info.name)
            for name, obj in vars(module).items():
                if name.startswith("_") or getattr(obj, "__module__", None) != info.name:
                    continue
                # the Python function under numba.njit / vectorize or functools.lru_cache
                obj = getattr(obj, "py_func", None) or getattr(obj, "__wrapped__", obj)
                if inspect.isfunction(obj) or inspect.isclass(obj):
                    yield f"{info.name}.{name}", obj


@pytest.mark.parametrize("qualname,obj", list(_public_members()),
                         ids=lambda v: v if isinstance(v, str) else "")
def test_public_functions_and_classes_have_docstrings(qualname, obj):
    assert inspect.getdoc(obj), f"{qualname} has no docstring"


def test_wrapped_functions_are_among_the_public_members():
    # numba.njit, numba.vectorize, functools.lru_cache
    members = {q for q, _ in _public_members()}
    wrapped = {"terrain.terramechanics.slip.rim_speed_from_slip",
               "terrain.vehicles.swerve.wheel_rim_speed",
               "terrain.io.align.interpolated_mean_count"}
    assert wrapped - members == set()
