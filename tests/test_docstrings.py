"""Docstring meta-test, in the spirit of python-control's ``tests/docstrings_test.py``.

Every public function, class and public method of the packages ``terrain``, ``features`` and
``pipelines`` documents, in numpydoc form,

* every parameter of its signature under ``Parameters`` (a class documents its constructor's
  parameters, a dataclass its fields, under ``Parameters`` or ``Attributes``),
* what it returns under ``Returns`` (or ``Yields``) when its return annotation is not ``None``,
* the exceptions it raises itself under ``Raises`` when its body holds a ``raise`` statement.

The parameter parser reads numpydoc section headers (a title line underlined by dashes) and
the ``name : type`` lines of a section, including ``a, b : float`` and ``*args``.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import pkgutil
import re
import textwrap
from typing import Callable, Iterator

import pytest

PACKAGES = ("terrain", "features", "pipelines")
PARAM_SECTIONS = ("Parameters", "Other Parameters", "Attributes", "Keyword Arguments")
RETURN_SECTIONS = ("Returns", "Yields")
#: methods whose parameters are fixed by a protocol documented elsewhere (sklearn, mlflow,
#: argparse entry points): the protocol's own documentation is the reference
PROTOCOL_METHODS = frozenset({"get_feature_names_out", "__sklearn_tags__", "load_context",
                              "__call__", "__post_init__", "__init_subclass__"})


def _sections(doc: str) -> dict[str, list[str]]:
    """Split a numpydoc docstring into ``{section title: lines}``."""
    lines = textwrap.dedent(doc).splitlines()
    sections: dict[str, list[str]] = {"": []}
    current = ""
    i = 0
    while i < len(lines):
        line = lines[i]
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() and re.fullmatch(r"\s*-{3,}\s*", nxt) and len(nxt.strip()) >= 3:
            current = line.strip()
            sections.setdefault(current, [])
            i += 2
            continue
        sections[current].append(line)
        i += 1
    return sections


def _documented_names(doc: str) -> set[str]:
    names: set[str] = set()
    secs = _sections(doc)
    for title in PARAM_SECTIONS:
        body = secs.get(title, [])
        if not body:
            continue
        indent = min((len(b) - len(b.lstrip()) for b in body if b.strip()), default=0)
        for line in body:
            if not line.strip() or len(line) - len(line.lstrip()) != indent:
                continue
            head = line.strip().split(" : ")[0].rstrip(":")
            for name in head.split(","):
                names.add(name.strip().lstrip("*"))
    return names


def _own_raise(func: Callable) -> bool:
    """True when the function's own body (not nested defs) holds a ``raise`` statement."""
    try:
        src = textwrap.dedent(inspect.getsource(func))
    except (OSError, TypeError):
        return False
    tree = ast.parse(src)
    fn = tree.body[0]
    if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
        return False
    stack = list(fn.body)
    while stack:
        node = stack.pop()
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if not (isinstance(exc, ast.Name) and exc.id == "NotImplementedError"):
                return True  # an interface's NotImplementedError is not a documented error
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)):
            continue
        stack.extend(ast.iter_child_nodes(node))
    return False


def _signature_names(func: Callable) -> list[str]:
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):
        return []
    return [p.name for p in sig.parameters.values() if p.name not in ("self", "cls")]


def _returns_something(func: Callable) -> bool:
    try:
        ann = inspect.signature(func).return_annotation
    except (TypeError, ValueError):
        return False
    if ann is inspect.Signature.empty:
        return False
    return ann not in (None, "None", type(None), "NoReturn")


def _unwrap(obj):
    """The Python function under a numba dispatcher (``py_func``) or a ``functools`` wrapper
    (``__wrapped__``, e.g. ``lru_cache``); ``obj`` itself otherwise."""
    return getattr(obj, "py_func", None) or getattr(obj, "__wrapped__", obj)


def _public_callables() -> Iterator[tuple[str, Callable, str]]:
    """Yield ``(qualified name, object, kind)`` with kind ``function``, ``class``, ``method``.

    Functions wrapped by ``functools.lru_cache`` or ``numba.njit`` / ``vectorize`` are
    yielded unwrapped (:func:`_unwrap`), so they are checked like the others.
    """
    for pkg_name in PACKAGES:
        pkg = importlib.import_module(pkg_name)
        modules = [pkg_name] + [i.name for i in pkgutil.walk_packages(pkg.__path__,
                                                                      prefix=pkg_name + ".")]
        for mod_name in modules:
            module = importlib.import_module(mod_name)
            for name, obj in sorted(vars(module).items()):
                if name.startswith("_") or getattr(obj, "__module__", None) != mod_name:
                    continue
                obj = _unwrap(obj)
                if inspect.isfunction(obj):
                    yield f"{mod_name}.{name}", obj, "function"
                elif inspect.isclass(obj):
                    yield f"{mod_name}.{name}", obj, "class"
                    for meth_name, meth in sorted(vars(obj).items()):
                        if isinstance(meth, (staticmethod, classmethod)):
                            meth = meth.__func__
                        meth = _unwrap(meth)
                        if (not inspect.isfunction(meth) or meth_name.startswith("_")
                                or meth_name in PROTOCOL_METHODS):
                            continue
                        yield f"{mod_name}.{name}.{meth_name}", meth, "method"


def _problems(obj: Callable, kind: str) -> list[str]:
    doc = inspect.getdoc(obj) or ""
    if not doc:
        return ["no docstring"]
    out = []
    if kind == "class":
        if dataclasses.is_dataclass(obj):
            wanted = [f.name for f in dataclasses.fields(obj) if f.init]
        elif ("__init__" in vars(obj)
              and getattr(obj.__init__, "__qualname__", "").startswith(obj.__qualname__ + ".")):
            wanted = _signature_names(obj.__init__)
            init_doc = inspect.getdoc(obj.__init__) or ""
            doc = doc + "\n\n" + init_doc
        else:
            wanted = []
        documented = _documented_names(doc)
        missing = [w for w in wanted if w not in documented]
        if missing:
            out.append(f"undocumented parameters {missing}")
        return out
    documented = _documented_names(doc)
    missing = [w for w in _signature_names(obj) if w not in documented]
    if missing:
        out.append(f"undocumented parameters {missing}")
    secs = _sections(doc)
    if _returns_something(obj) and not any(secs.get(t) for t in RETURN_SECTIONS):
        out.append("no Returns section")
    if _own_raise(obj) and not secs.get("Raises"):
        out.append("raises but has no Raises section")
    return out


CASES = list(_public_callables())


@pytest.mark.parametrize("qualname,obj,kind", CASES, ids=[c[0] for c in CASES])
def test_public_callable_documents_parameters_returns_and_raises(qualname, obj, kind):
    problems = _problems(obj, kind)
    assert not problems, f"{qualname}: " + "; ".join(problems)


#: public functions behind a wrapper: numba.njit, numba.vectorize, functools.lru_cache
WRAPPED = ("terrain.terramechanics.slip.rim_speed_from_slip",
           "terrain.vehicles.swerve.wheel_rim_speed", "terrain.io.align.interpolated_mean_count",
           "terrain.estimation.equations.agrimaro.slip_state_observation_into")


def test_wrapped_functions_are_checked():
    """The checker itself: a wrapper is looked through, not skipped as a non-function."""
    checked = {c[0] for c in CASES}
    assert [q for q in WRAPPED if q not in checked] == []


def test_parser_reads_numpydoc_forms():
    """The checker itself: grouped names, star arguments, section titles."""
    def sample(a, b, *args, c=1, **kwargs):
        """Do.

        Parameters
        ----------
        a, b : float
            Two values, m.
        *args : float
            More.
        c : int
            Count.
        **kwargs
            Options.

        Returns
        -------
        float
        """
        return a

    assert _documented_names(inspect.getdoc(sample)) == {"a", "b", "args", "c", "kwargs"}
    assert _problems(sample, "function") == []

    def bad(x, y) -> float:
        """Do.

        Parameters
        ----------
        x : float
        """
        raise ValueError(x + y)

    probs = _problems(bad, "function")
    assert any("['y']" in p for p in probs)
    assert "no Returns section" in probs
    assert "raises but has no Raises section" in probs
