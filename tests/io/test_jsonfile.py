"""Strict JSON output: what could not be computed is null, never a bare NaN token."""

from __future__ import annotations

import json

import numpy as np
import pytest

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
