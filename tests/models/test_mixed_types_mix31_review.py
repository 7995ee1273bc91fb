"""Labels and runs of types that do not sort together (text beside numbers, bytes beside
text) are refused by the one shared rule :func:`terrain.errors.refuse_mixed_types` at every
entry point that sorts them (review mix31): NumPy's ``unique`` and ``sorted`` failed with
the bare "'<' not supported between instances of 'str' and 'int'", naming no argument, and
``cross_validate``'s ``astype(str)`` made ``1`` and ``"1"`` one class without a word.

Valid labels and runs (all integers, all text, Python's and NumPy's integers together) give
the same results as before: the rule only judges object arrays mixing type families.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.linear_model import LogisticRegression

from terrain.errors import (MixedTypesError, TerrainError, refuse_mixed_types)
from terrain.models import cv, ensemble, experiment, metrics, weighting
from terrain.models.cnn import RawCNNClassifier
from terrain.models.svm import SVMConfig, svm_window_pipeline
from terrain.serving import evaluation as serving_evaluation
from terrain.serving.smoothing import SmoothingConfig
from terrain.slip import evaluation as slip_evaluation
from terrain.slip.baselines import fit_pitch_slip
from terrain.slip.learned import SlipRegressor, calibration_folds

N = 12
LABELS = np.array(["a", "b"] * 6, dtype=object)
RUNS = np.array(["r1", "r2", "r3", "r4", "r5", "r6"] * 2, dtype=object)
MIXED_RUNS = np.array([1, "r2", 3, "r4", 5, "r6"] * 2, dtype=object)
MIXED_LABELS = np.array([1, "b"] * 6, dtype=object)
X = np.random.default_rng(0).normal(size=(N, 3))
T0 = np.arange(N, dtype=float)


def _refused(call, name, first="int", second="str", index=1):
    """``call()`` raises the shared MixedTypesError naming ``name`` and both types."""
    with pytest.raises(MixedTypesError) as info:
        call()
    message = str(info.value)
    assert f"{name} mixes values of type {first} and {second}" in message, message
    assert f"index {index}" in message, message
    assert isinstance(info.value, (TerrainError, TypeError, ValueError))


def _logistic(_seed=0):
    return LogisticRegression()


# --- the rule ----------------------------------------------------------------------------

def test_rule_names_owner_argument_types_and_first_index():
    values = np.array(["a", "b", 3, "c", 4.5], dtype=object)
    with pytest.raises(MixedTypesError, match=r"^f: groups mixes values of type str and int "
                                              r"\(the first int at index 2\)"):
        refuse_mixed_types("f", "groups", values)


@pytest.mark.parametrize("values", [
    np.array([1, np.int64(2), 3.0, np.float32(4.5)], dtype=object),  # numbers
    np.array([True, np.bool_(False)], dtype=object),                 # booleans
    np.array(["a", np.str_("b")], dtype=object),                           # text
    np.array([b"a", np.bytes_(b"b")], dtype=object),                       # bytes
    [1, "r2"],                           # NumPy reads it as text: as it read before
    np.array([1, 2]), np.array(["a", "b"]), np.array([], dtype=object),
    pd.Series(["a", "b"], dtype=object),
])
def test_rule_accepts_one_type_family(values):
    refuse_mixed_types("f", "groups", values)


@pytest.mark.parametrize("values, first, second", [
    (np.array([1.5, "a"], dtype=object), "float", "str"),
    (np.array(["a", b"a"], dtype=object), "str", "bytes"),
    (np.array([np.int64(1), "a"], dtype=object), "int64", "str"),
    (pd.Series([1, "a"]), "int", "str"),
    (np.array([True, 1, 0, False], dtype=object), "bool", "int"),
    (np.array([2.0, np.bool_(True)], dtype=object), "float", "bool"),
])
def test_rule_refuses_two_families(values, first, second):
    _refused(lambda: refuse_mixed_types("f", "y", values), "y", first, second)


@settings(max_examples=60, deadline=None)
@given(numbers=st.lists(st.one_of(st.integers(-5, 5), st.floats(-5, 5)), min_size=1,
                        max_size=8),
       texts=st.lists(st.text(min_size=1, max_size=3), min_size=1, max_size=8),
       data=st.data())
def test_rule_refuses_every_interleaving_at_the_first_other_type(numbers, texts, data):
    values = data.draw(st.permutations(numbers + texts))
    arr = np.empty(len(values), dtype=object)
    arr[:] = values
    kind = lambda v: isinstance(v, str)   # noqa: E731
    index = next(i for i, v in enumerate(values) if kind(v) != kind(values[0]))
    with pytest.raises(MixedTypesError, match=rf"at index {index}\)"):
        refuse_mixed_types("f", "labels", arr)


# --- every entry point -------------------------------------------------------------------

@pytest.mark.parametrize("protocol", ["grouped", "loro", "paper"])
def test_iter_splits(protocol):
    _refused(lambda: list(cv.iter_splits(protocol, LABELS, MIXED_RUNS, 0, 2)), "groups")
    _refused(lambda: list(cv.iter_splits(protocol, MIXED_LABELS, RUNS, 0, 2)), "labels")


def test_require_runs_and_class_keeping_split():
    _refused(lambda: cv.require_runs(RUNS, 2, "p", "s", labels=MIXED_LABELS), "labels")
    _refused(lambda: cv.require_runs(MIXED_RUNS, 2, "p", "s"), "groups")
    _refused(lambda: cv.class_keeping_split(MIXED_LABELS, RUNS, 2, 0, "p", "s", "x"),
             "labels")
    _refused(lambda: cv.class_keeping_split(LABELS, MIXED_RUNS, 2, 0, "p", "s", "x"),
             "groups")


def test_cross_validate():
    def run(y, groups, run_ids):
        return cv.cross_validate(_logistic, X, y, groups, run_ids, T0, T0 + 1, seeds=(0,),
                                 n_splits=2)
    _refused(lambda: run(LABELS, MIXED_RUNS, RUNS), "groups")
    _refused(lambda: run(LABELS, RUNS, MIXED_RUNS), "run_ids")
    # (astype(str) made the class 1 and the class "1" one)
    _refused(lambda: run(np.array([1, "1"] * 6, dtype=object), RUNS, RUNS), "y")


def test_run_weights():
    for call in (weighting.run_shares, weighting.within_class_run_weights):
        _refused(lambda: call(MIXED_LABELS, RUNS), "labels")
        _refused(lambda: call(LABELS, MIXED_RUNS), "groups")
    _refused(lambda: weighting.run_balanced(LogisticRegression()).fit(X, MIXED_LABELS, RUNS),
             "labels")


def test_metrics():
    _refused(lambda: metrics.window_metrics(MIXED_LABELS, LABELS, ["a", "b"]), "y_true")
    _refused(lambda: metrics.confusion(LABELS, MIXED_LABELS, ["a", "b"]), "y_pred")
    _refused(lambda: metrics.majority_vote(LABELS, MIXED_RUNS), "groups")
    _refused(lambda: metrics.run_majority_accuracy(LABELS, LABELS, MIXED_RUNS), "groups")


def test_classifiers():
    members = [("a", LogisticRegression()), ("b", LogisticRegression())]
    _refused(lambda: ensemble.SoftVotingEnsemble(members, weights=[1, 1]).fit(X, MIXED_LABELS),
             "y")
    _refused(lambda: ensemble.SoftVotingEnsemble(members, inner_splits=2).fit(
        X, LABELS, MIXED_RUNS), "groups")
    windows = np.random.default_rng(1).normal(size=(N, 2, 64))
    _refused(lambda: RawCNNClassifier(max_epochs=1).fit(windows, MIXED_LABELS), "y")
    pipe = svm_window_pipeline(["a", "b"], 50.0, SVMConfig(probability=False))
    _refused(lambda: pipe.fit(windows, MIXED_LABELS), "y")
    _refused(lambda: experiment.check_two_classes(MIXED_LABELS, "d", RUNS), "labels")


def test_refused_fit_keeps_the_previous_fit():
    members = [("a", LogisticRegression())]
    model = ensemble.SoftVotingEnsemble(members, weights=[1]).fit(X, LABELS)
    before = model.predict_proba(X)
    with pytest.raises(MixedTypesError):
        model.fit(X, MIXED_LABELS)
    np.testing.assert_array_equal(model.predict_proba(X), before)


def test_serving_evaluation():
    _refused(lambda: serving_evaluation.grouped_oof_proba(_logistic, X, MIXED_LABELS, RUNS, 0,
                                                          2), "labels")
    _refused(lambda: serving_evaluation.grouped_oof_proba(_logistic, X, LABELS, MIXED_RUNS, 0,
                                                          2), "groups")
    proba = np.full((N, 2), 0.5)
    _refused(lambda: serving_evaluation.smooth_runs(proba, MIXED_RUNS, T0, 1.0,
                                                    SmoothingConfig()), "run_ids")


def test_slip():
    frame = pd.DataFrame(X, columns=["f0", "f1", "f2"])
    targets = np.random.default_rng(2).normal(size=(N, 4)) * 0.1
    train = np.arange(N) % 2 == 0
    _refused(lambda: slip_evaluation.leave_one_out(SlipRegressor, frame, targets, MIXED_RUNS,
                                                   train, ~train), "groups")
    _refused(lambda: SlipRegressor().fit(frame, targets, groups=MIXED_RUNS), "groups")


# --- valid inputs: the same results as before -------------------------------------------

RUN_NAMES = {
    "text": np.array(["r1", "r2", "r3", "r4", "r5", "r6"] * 2, dtype=object),
    "int": np.array([1, 2, 3, 4, 5, 6] * 2),
    "int objects": np.array([1, np.int64(2), 3, np.int32(4), 5, np.int64(6)] * 2,
                            dtype=object),
}


@pytest.mark.parametrize("kind", list(RUN_NAMES))
def test_valid_runs_split_and_weigh_as_text_runs(kind):
    """Runs named by integers (Python's and NumPy's mixed included) give the folds and the
    weights that the same runs named by text give (one name per run, in the same order)."""
    groups = RUN_NAMES[kind]
    text = RUN_NAMES["text"]
    for protocol in ("grouped", "loro", "paper"):
        got = list(cv.iter_splits(protocol, LABELS, groups, 0, 2))
        want = list(cv.iter_splits(protocol, LABELS, text, 0, 2))
        assert len(got) == len(want)
        for (a, b), (c, d) in zip(got, want):
            np.testing.assert_array_equal(a, c)
            np.testing.assert_array_equal(b, d)
    np.testing.assert_array_equal(weighting.within_class_run_weights(LABELS, groups),
                                  weighting.within_class_run_weights(LABELS, text))
    assert (cv.class_keeping_split(LABELS, groups, 2, 0, "p", "s", "x")[0].tolist()
            == cv.class_keeping_split(LABELS, text, 2, 0, "p", "s", "x")[0].tolist())
    assert metrics.run_majority_accuracy(LABELS, LABELS, groups) == 1.0


@settings(max_examples=40, deadline=None)
@given(labels=st.lists(st.sampled_from([0, 1, 2]), min_size=6, max_size=30),
       data=st.data())
def test_int_labels_mixed_with_numpy_ints_split_and_weigh_as_plain_ints(labels, data):
    """Python's and NumPy's integers in one object array are one family: the folds and the
    weights are those of the plain integer array."""
    n = len(labels)
    groups = np.array(data.draw(st.lists(st.integers(0, 3), min_size=n, max_size=n)))
    wrap = data.draw(st.lists(st.booleans(), min_size=n, max_size=n))
    plain = np.array(labels)
    mixed = np.empty(n, dtype=object)
    mixed[:] = [np.int64(v) if w else int(v) for v, w in zip(labels, wrap)]
    np.testing.assert_array_equal(weighting.run_shares(mixed, groups),
                                  weighting.run_shares(plain, groups))
    np.testing.assert_array_equal(weighting.within_class_run_weights(mixed, groups),
                                  weighting.within_class_run_weights(plain, groups))
    if len(set(groups.tolist())) < 2:
        return
    got = list(cv.iter_splits("loro", mixed, groups, 0))
    want = list(cv.iter_splits("loro", plain, groups, 0))
    assert [(a.tolist(), b.tolist()) for a, b in got] == [(a.tolist(), b.tolist())
                                                          for a, b in want]


def test_slip_fits_by_terrain_and_run():
    pitch = np.linspace(0.0, 0.1, N)
    _refused(lambda: fit_pitch_slip(pitch, pitch, MIXED_LABELS), "terrains")
    # (1 and "1" were one terrain in the returned mapping, had NumPy sorted them)
    _refused(lambda: fit_pitch_slip(pitch, pitch, np.array([1, "1"] * 6, dtype=object)),
             "terrains")
    _refused(lambda: calibration_folds(X, np.zeros((N, 4)), MIXED_RUNS, 2), "groups")
    frame = pd.DataFrame({c: np.zeros(N) for c in (
        "wz__mean", "vel_diff__mean", "cur_l__mean", "cur_r__mean", "phys_slip_l",
        "phys_slip_r")})
    pred = np.ones((N, 4))
    _refused(lambda: slip_evaluation.measured_checks(frame, pred, RUNS, MIXED_LABELS, 0.5),
             "terrains")
    _refused(lambda: slip_evaluation.measured_checks(frame, pred, MIXED_RUNS, LABELS, 0.5),
             "run_ids")


def test_valid_terrains_fit_as_before():
    pitch = np.linspace(0.0, 0.1, N)
    slip = 0.02 + 0.5 * pitch
    fitted = fit_pitch_slip(pitch, slip, LABELS.astype(str))
    assert fitted == fit_pitch_slip(pitch, slip, LABELS)
    assert set(fitted) == {"a", "b"}
    folds = calibration_folds(X, np.zeros((N, 4)), RUN_NAMES["int objects"], 3)
    want = calibration_folds(X, np.zeros((N, 4)), RUN_NAMES["int"], 3)
    assert [(a.tolist(), b.tolist()) for a, b in folds] == [(a.tolist(), b.tolist())
                                                            for a, b in want]


def test_booleans_beside_numbers_are_refused_as_one_label_in_disguise():
    # True == 1: the run shares of [True, 1, 0, False] were computed for two runs, not four
    # values of two kinds, without a word
    from terrain.models.weighting import run_shares
    with pytest.raises(MixedTypesError, match=r"True equals 1 and False 0, so two labels "
                                              r"would be one"):
        run_shares(np.array([True, 1, 0, False], dtype=object), np.array(["a", "b", "c", "d"]))


def test_integer_labels_in_an_object_array_are_scored_as_integers():
    # pandas' object column of integers: scikit-learn's metrics refused it as targets of
    # type 'unknown' (a bare ValueError); the same labels as integers or text score the same
    from terrain.models.metrics import confusion, window_metrics
    y = [1, 2, 1, 2, 3, 3]
    p = [1, 2, 2, 2, 3, 1]
    as_object = window_metrics(np.array(y, dtype=object), np.array(p, dtype=object), [1, 2, 3])
    assert as_object == window_metrics(np.array(y), np.array(p), [1, 2, 3])
    text = window_metrics(np.array(y).astype(str), np.array(p).astype(str), ["1", "2", "3"])
    assert [as_object[k] for k in ("accuracy", "balanced_accuracy", "macro_f1")] == \
        [text[k] for k in ("accuracy", "balanced_accuracy", "macro_f1")]
    cm = confusion(pd.Series(y, dtype=object), pd.Series(p, dtype=object), [1, 2, 3])
    assert cm.to_numpy().tolist() == [[1, 1, 0], [0, 2, 0], [1, 0, 1]]
