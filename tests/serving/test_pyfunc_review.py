"""Review tests of the aligned-samples pyfunc (:func:`terrain.serving.pyfunc.predict_windows`):
its clock checks at their bounds and the order of its probability columns."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig
from terrain.errors import DataFormatError, TimestampError
from terrain.serving.pyfunc import predict_windows


class _Classifier:
    """Classes in another order than the model's (``B`` first), one probability each."""
    classes_ = np.array(["B", "A"])

    def predict_proba(self, X):
        return np.tile([0.8, 0.2], (len(X), 1))


def _predict(samples):
    return predict_windows(_Classifier(), samples, ["vel_l", "vel_r"],
                           WindowConfig(window_s=2.0, rate_hz=20.0), ["A", "B"])


def _samples(n=200, step=0.05):
    """``n`` aligned wheel samples of one run, ``step`` s apart (20 Hz by default)."""
    return pd.DataFrame({"run": "r1", "t_s": np.arange(n) * step, "vel_l": 0.5,
                         "vel_r": 0.5})


def test_probabilities_are_named_by_the_classifiers_own_class_order():
    out = _predict(_samples())
    assert (out["predicted"] == "B").all()
    assert out["proba_A"].to_numpy() == pytest.approx(0.2)
    assert out["proba_B"].to_numpy() == pytest.approx(0.8)


def test_a_duplicated_timestamp_is_refused_naming_its_row():
    samples = _samples()
    samples.loc[8, "t_s"] = samples.loc[7, "t_s"]
    with pytest.raises(TimestampError) as info:
        _predict(samples)
    assert info.value.row == 8 and "increase strictly" in str(info.value)


def test_the_clock_rate_is_checked_to_one_percent():
    """5 % off the model's 20 Hz (21 Hz) is refused; within 1 % (20.1 Hz) is taken."""
    assert len(_predict(_samples(step=1 / 20.1))) == 5
    with pytest.raises(DataFormatError, match="samples at 21.000 Hz; the model expects 20.0 Hz"):
        _predict(_samples(step=1 / 21.0))


def test_a_run_of_exactly_one_window_is_not_short_even_when_its_window_is_dropped():
    """40 samples at 20 Hz fill the 2 s window: one window, or, holding a NaN, one dropped
    window; never a run "shorter than one window"."""
    out = _predict(_samples(40))
    assert len(out) == 1 and out.attrs["short_runs"] == []
    samples = _samples(40)
    samples.loc[10, "vel_l"] = np.nan
    out = _predict(samples)
    assert len(out) == 0 and out.attrs["dropped_windows"] == 1
    assert out.attrs["short_runs"] == []


def test_one_missing_row_is_a_hole_refused_naming_the_row_after_it():
    """A step of two periods (one row left out) would put both sides of it in one window."""
    samples = _samples().drop(index=50).reset_index(drop=True)
    with pytest.raises(TimestampError) as info:
        _predict(samples)
    assert info.value.row == 50
    assert "a step of 0.1 s, 1 step(s) longer than 1.5 sample periods" in str(info.value)


def test_samples_without_a_run_are_refused_not_left_out():
    samples = _samples().astype({"run": object})
    samples.loc[[30, 31], "run"] = None
    with pytest.raises(DataFormatError) as info:
        _predict(samples)
    assert info.value.row == 30 and "2 sample(s) without a run" in str(info.value)


def test_a_class_the_classifier_does_not_know_gets_probability_zero():
    # the model's classes A, B, C; the classifier was fitted on B and A only (no window of
    # C in its training folds): proba_C is 0 ("0 for a class the pipeline does not know"),
    # so every row's probabilities still sum to 1 (NaN would make the sum NaN)
    out = predict_windows(_Classifier(), _samples(), ["vel_l", "vel_r"],
                          WindowConfig(window_s=2.0, rate_hz=20.0), ["A", "B", "C"])
    assert len(out) == 5
    assert (out["proba_C"] == 0.0).all()
    np.testing.assert_allclose(out[["proba_A", "proba_B", "proba_C"]].sum(axis=1), 1.0)


def test_two_runs_whose_names_read_alike_are_refused_not_merged():
    # run 1 (a number) and run "1" (text) are two runs to groupby, but the answer names
    # each str(run): before, both runs' windows came back under one name "1", same times
    a = _samples(40).assign(run=1)
    both = pd.concat([a, a.assign(run="1")], ignore_index=True).astype({"run": object})
    with pytest.raises(DataFormatError, match=r"runs \['1'\] .* the same name"):
        _predict(both)
