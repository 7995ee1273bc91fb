"""Strict JSON output: what could not be computed is null, never a bare NaN token."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.io.jsonfile import json_ready, strict_json


def _strict(token):
    raise ValueError(f"not JSON: {token}")


def test_non_finite_floats_are_null_and_numpy_scalars_python_ones():
    obj = {"a": np.float64("nan"), "b": [float("inf"), -np.inf, np.int64(3)],
           "c": (np.float32(0.5), True, None), 4: {"d": 0.123456789}}
    loaded = json.loads(strict_json(obj), parse_constant=_strict)
    assert loaded == {"a": None, "b": [None, None, 3], "c": [0.5, True, None],
                      "4": {"d": 0.123456789}}          # every float kept in full


def test_json_ready_rounds_only_when_asked():
    assert json_ready(0.123456789) == 0.12346
    assert json_ready(0.123456789, None) == 0.123456789
    assert json_ready(np.bool_(False)) is False


def test_a_value_json_cannot_hold_is_a_type_error():
    with pytest.raises(TypeError):
        strict_json({"x": np.zeros(2)})


def test_booleans_stay_json_booleans_not_numbers():
    # True == 1 in Python, so a comparison of loaded values cannot tell them apart: the text
    text = strict_json({"ok": True, "flags": [False, np.bool_(True)]}, indent=None)
    assert text == '{"ok": true, "flags": [false, true]}\n'
    assert json_ready([True, (np.bool_(False),)]) == [True, [False]]
    assert type(json_ready([True])[0]) is bool


def test_rounding_reaches_floats_nested_in_lists_and_tuples():
    assert json_ready([0.123456789, (1.0000049, {"x": [2.9999951]})], 3) == \
        [0.123, [1.0, {"x": [3.0]}]]


def test_strict_json_text_is_indented_as_asked_and_ends_with_a_newline():
    text = strict_json({"a": [1, 2]}, indent=2)
    assert text == '{\n  "a": [\n    1,\n    2\n  ]\n}\n'
    assert strict_json([1]).endswith("]\n")


_leaf = (st.none() | st.booleans() | st.integers(-2**63, 2**63 - 1) | st.text(max_size=5)
         | st.floats(allow_nan=True, allow_infinity=True)
         | st.floats(width=32).map(np.float32) | st.integers(-9, 9).map(np.int64))
_values = st.recursive(_leaf, lambda inner: st.lists(inner, max_size=3)
                       | st.tuples(inner, inner)
                       | st.dictionaries(st.text(max_size=3), inner, max_size=3), max_leaves=8)


def _same(loaded, original):
    """``loaded`` (from JSON) is ``original`` with every finite float exact, every non-finite
    one None, tuples as lists and numpy scalars as Python ones."""
    if isinstance(original, (bool, np.bool_)) or original is None:
        return loaded is (None if original is None else bool(original))
    if isinstance(original, (float, np.floating)):
        return loaded is None if not np.isfinite(original) else (
            type(loaded) is float and loaded == float(original))
    if isinstance(original, (int, np.integer)):
        return type(loaded) is int and loaded == int(original)
    if isinstance(original, dict):
        return loaded.keys() == original.keys() and all(_same(loaded[k], v)
                                                        for k, v in original.items())
    if isinstance(original, (list, tuple)):
        return (isinstance(loaded, list) and len(loaded) == len(original)
                and all(_same(a, b) for a, b in zip(loaded, original)))
    return loaded == original


@given(_values)
@settings(max_examples=50, deadline=None)
def test_strict_json_reads_back_every_finite_float_exactly(value):
    loaded = json.loads(strict_json(value), parse_constant=_strict)
    assert _same(loaded, value)


def _read_fifo_in_background(fifo):
    import threading

    got = {}

    def read():
        with open(fifo) as f:
            got["text"] = f.read()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    return reader, got


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize("through_link", [False, True])
def test_whole_file_writes_a_pipe_or_device_through_and_never_replaces_it(tmp_path,
                                                                          through_link):
    # `--out /dev/stdout` (a link to a pipe or terminal) or a named pipe: the text went to a
    # temporary regular file that os.replace then renamed over the pipe (as root, over
    # /dev/full or /dev/null themselves), so the reader got nothing and the node was gone
    import stat

    from terrain.io.jsonfile import whole_file

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    target = fifo
    if through_link:
        target = tmp_path / "stdout"
        target.symlink_to(fifo)
    reader, got = _read_fifo_in_background(fifo)
    with whole_file(target) as tmp:
        tmp.write_text("t_s,terrain\n1.0,SNOW\n")
    reader.join(timeout=5)
    assert got.get("text") == "t_s,terrain\n1.0,SNOW\n"
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["pipe"] + (["stdout"] if through_link else []))
