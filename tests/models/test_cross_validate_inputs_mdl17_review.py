"""cross_validate's inputs refused by name (review mdl17)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression

from terrain.errors import ConfigError, NonFiniteInputError, ShapeError
from terrain.models.cv import cross_validate

N = 40


def _case():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(N, 3))
    y = np.array(["a", "b"] * (N // 2), dtype=object)
    groups = np.array([f"r{i % 10}" for i in range(N)])
    t0 = np.arange(N, dtype=float)
    return X, y, groups, groups.copy(), t0, t0 + 1.0


def _cv(X, y, groups, run_ids, t0, t1, **kw):
    return cross_validate(lambda seed: LogisticRegression(), X, y, groups, run_ids, t0, t1,
                          **{"seeds": (0,), **kw})


@pytest.mark.parametrize("missing", [np.nan, None])
def test_a_missing_label_is_refused_not_made_a_class(missing):
    # astype(str) made NaN the class "nan" (None: "None"): trained, tested and scored as a
    # terrain, with its own recall column
    X, y, groups, run_ids, t0, t1 = _case()
    y[[4, 9]] = missing
    with pytest.raises(NonFiniteInputError, match="y holds 2 missing.*index 4"):
        _cv(X, y, groups, run_ids, t0, t1)


@pytest.mark.parametrize("field", ["X", "groups", "run_ids", "t_start_s", "t_end_s"])
def test_a_per_window_input_of_another_length_is_a_shape_error_naming_it(field):
    # IndexError "index 30 is out of bounds for axis 0 with size 30" in the middle of the CV
    args = dict(zip(["X", "y", "groups", "run_ids", "t0", "t1"], _case()))
    key = {"t_start_s": "t0", "t_end_s": "t1"}.get(field, field)
    args[key] = args[key][:30]
    with pytest.raises(ShapeError, match=field):
        _cv(*args.values())


@pytest.mark.parametrize("seeds", [(), (0, 0), (-1,), (1.5,), (True,)])
def test_seeds_that_are_not_distinct_integers_are_refused(seeds):
    # () reached pandas' "No objects to concatenate"; (0, 0) counted one split twice
    with pytest.raises(ConfigError, match="seeds"):
        _cv(*_case(), seeds=seeds)


@pytest.mark.parametrize("n", [-1, 2.5, True])
def test_time_inference_not_a_count_is_refused(n):
    # -1 gave a column of NaN (the median of no timing), 2.5 a bare TypeError, True timed 1
    with pytest.raises(ConfigError, match="time_inference"):
        _cv(*_case(), time_inference=n)


def test_valid_inputs_still_run():
    report = _cv(*_case(), seeds=(0, np.int64(1)), time_inference=2)
    assert len(report.folds) == 10 and "infer_ms_per_window" in report.folds
