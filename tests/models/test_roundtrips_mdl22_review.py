"""Review tests (mdl22): round trips and consistency between the compiled and the plain
scikit-learn inference paths, pickling, cloning, and the ensemble's soft vote."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from sklearn.base import clone
from sklearn.calibration import CalibratedClassifierCV
from sklearn.ensemble import ExtraTreesClassifier, RandomForestClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.forest import ForestPipeline
from terrain.models.svm import SVMPipeline


def _data(seed, n=60, d=4, k=3):
    rng = np.random.default_rng(seed)
    y = np.arange(n) % k
    X = rng.normal(size=(n, d)) + y[:, None] * 0.7
    return X, y


def _svm(seed=0):
    X, y = _data(seed)
    svc = CalibratedClassifierCV(SVC(C=3.0, class_weight="balanced", random_state=0),
                                 method="sigmoid", ensemble=False)
    return SVMPipeline([("scale", StandardScaler()), ("svc", svc)]).fit(X, y), X, y


def _forest(seed=0, cls=ExtraTreesClassifier):
    X, y = _data(seed)
    model = ForestPipeline([("scale", StandardScaler()),
                            ("forest", cls(n_estimators=15, random_state=0))])
    return model.fit(X, y), X, y


def _plain(model, X):
    """scikit-learn's own Pipeline path on the same fitted steps."""
    return Pipeline.predict_proba(model, X)


@pytest.mark.parametrize("build", [_svm, _forest,
                                   lambda: _forest(cls=RandomForestClassifier)])
def test_compiled_equals_plain_for_batch_one_window_and_another_order(build):
    model, X, _ = build()
    assert model._compiled() is not None
    Xq = np.random.default_rng(5).normal(size=(17, X.shape[1])) * 2
    plain = _plain(model, Xq)
    np.testing.assert_allclose(model.predict_proba(Xq), plain, rtol=0, atol=1e-9)
    for i in range(len(Xq)):
        np.testing.assert_allclose(model.predict_proba(Xq[i:i + 1]), plain[i:i + 1],
                                   rtol=0, atol=1e-9)
    order = np.random.default_rng(1).permutation(len(Xq))
    np.testing.assert_allclose(model.predict_proba(Xq[order]), plain[order], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(model.predict(Xq),
                                  model.classes_[model.predict_proba(Xq).argmax(axis=1)])
    np.testing.assert_allclose(model.predict_proba(Xq.astype(np.float32)),
                               _plain(model, Xq.astype(np.float32)), rtol=0, atol=1e-6)


@pytest.mark.parametrize("build", [_svm, _forest])
def test_pickle_and_clone_round_trips(build):
    model, X, y = build()
    back = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(back.predict_proba(X), model.predict_proba(X))
    assert back._compiled() is not None
    twin = clone(model)
    assert type(twin) is type(model)
    assert twin.get_params().keys() == model.get_params().keys()
    np.testing.assert_array_equal(twin.fit(X, y).predict_proba(X), model.predict_proba(X))


@pytest.mark.parametrize("build", [_svm, _forest])
def test_replacing_the_final_step_is_seen_by_the_fast_path(build):
    model, X, y = build()
    other = LogisticRegression().fit(model[:-1].transform(X), (y + 1) % 3)
    model.steps[-1] = (model.steps[-1][0], other)
    np.testing.assert_allclose(model.predict_proba(X), _plain(model, X), atol=1e-12)
    model.set_params(**{model.steps[-1][0]: clone(other)})
    model.fit(X, y)
    np.testing.assert_allclose(model.predict_proba(X), _plain(model, X), atol=1e-12)


@pytest.mark.slow
@settings(max_examples=15, deadline=None)
@given(w=st.lists(st.floats(0.0, 5.0), min_size=2, max_size=2).filter(lambda v: sum(v) > 0.1),
       seed=st.integers(0, 50))
def test_soft_vote_is_the_hand_weighted_mean(w, seed):
    X, y = _data(seed, n=30)
    members = [("lr", LogisticRegression(max_iter=200)),
               ("et", ExtraTreesClassifier(n_estimators=5, random_state=0))]
    ens = SoftVotingEnsemble(members, weights=w).fit(X, y)
    fitted = [clone(m).fit(X, y) for _, m in members]
    wn = np.asarray(w) / sum(w)
    hand = sum(wi * m.predict_proba(X) for wi, m in zip(wn, fitted))
    np.testing.assert_allclose(ens.predict_proba(X), hand, atol=1e-12)
    np.testing.assert_array_equal(ens.predict(X), ens.classes_[hand.argmax(axis=1)])
    back = pickle.loads(pickle.dumps(ens))
    np.testing.assert_array_equal(back.predict_proba(X), ens.predict_proba(X))


def _windows(seed, n=24, c=2, s=64):
    rng = np.random.default_rng(seed)
    y = np.arange(n) % 3
    t = np.arange(s) / 50.0
    X = rng.normal(size=(n, c, s)) * 0.5 + np.sin(2 * np.pi * (2 + 3 * y)[:, None, None] * t)
    return X.astype(np.float32), y


def _cnns():
    from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
    return [RawCNNClassifier(max_epochs=2, width=4, batch_size=8, device="cpu", n_threads=1),
            SpectrogramCNNClassifier(rate_hz=50.0, segment_s=0.4, hop_s=0.2, max_epochs=2,
                                     width=4, batch_size=8, device="cpu", n_threads=1,
                                     band_limits_hz=(20.0, 10.0), augment_noise_std=0.1)]


@pytest.mark.parametrize("index", [0, 1])
def test_cnn_round_trips(index):
    X, y = _windows(0)
    model = _cnns()[index].fit(X, y)
    mean, scale = model.mean_.copy(), model.scale_.copy()
    Xq = _windows(3, n=9)[0] * 3 + 1
    proba = model.predict_proba(Xq)
    # normalisation statistics of the training windows only: other windows leave them
    np.testing.assert_array_equal(model.mean_, mean)
    np.testing.assert_array_equal(model.scale_, scale)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-6)
    for i in range(len(Xq)):
        np.testing.assert_allclose(model.predict_proba(Xq[i:i + 1]), proba[i:i + 1], atol=1e-6)
    np.testing.assert_allclose(model.predict_proba(Xq[::-1]), proba[::-1], atol=1e-6)
    np.testing.assert_array_equal(model.predict(Xq), model.classes_[proba.argmax(axis=1)])
    # same seed, same model (deterministic CPU training); clone and pickle round trips
    twin = clone(model)
    assert twin.get_params() == model.get_params()
    np.testing.assert_array_equal(twin.fit(X, y).predict_proba(Xq), proba)
    back = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(back.predict_proba(Xq), proba)
    # class order of predict_proba is classes_ for text labels too
    names = np.array(["sand", "grass", "asphalt"])[y]
    text = clone(model).fit(X, names)
    assert text.classes_.tolist() == ["asphalt", "grass", "sand"]
    np.testing.assert_array_equal(text.predict(Xq),
                                  text.classes_[text.predict_proba(Xq).argmax(axis=1)])


@pytest.mark.slow
@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 100), random_state=st.integers(0, 5))
def test_chosen_weights_are_the_first_best_on_held_out_training_runs(seed, random_state):
    from sklearn.metrics import log_loss

    from terrain.models.cv import class_keeping_split
    from terrain.models.ensemble import simplex_grid

    X, y = _data(seed, n=48)
    groups = y * 100 + (np.arange(48) // 9)    # runs of one class each
    names = np.array(["sand", "grass", "asphalt"])[y]
    members = [("lr", LogisticRegression(max_iter=200)),
               ("et", ExtraTreesClassifier(n_estimators=5, random_state=0)),
               ("lr2", LogisticRegression(C=0.01, max_iter=200))]
    ens = SoftVotingEnsemble(members, weight_step=0.5, inner_splits=3,
                             random_state=random_state).fit(X, names, groups)
    tr, va = class_keeping_split(names, groups, 3, random_state, "w", "inner_splits", "fixed")
    assert not set(groups[tr]) & set(groups[va])
    np.testing.assert_array_equal(ens.validation_groups_, np.unique(groups[va]))
    classes = np.unique(names)
    probas = []
    for _, m in members:
        fitted = clone(m).fit(X[tr], names[tr])
        assert fitted.classes_.tolist() == classes.tolist()
        probas.append(fitted.predict_proba(X[va]))
    best, best_w = np.inf, None
    for w in simplex_grid(3, 0.5):
        p = np.clip(sum(wi * pi for wi, pi in zip(w, probas)), 1e-12, 1.0)
        score = log_loss(names[va], p / p.sum(axis=1, keepdims=True), labels=classes)
        if score < best - 1e-12:
            best, best_w = score, w
    np.testing.assert_array_equal(ens.weights_, best_w)
    np.testing.assert_allclose(min(ens.weight_scores_.values()), best, rtol=1e-12)
    fitted = [clone(m).fit(X, names) for _, m in members]
    hand = sum(wi * m.predict_proba(X) for wi, m in zip(best_w, fitted))
    np.testing.assert_allclose(ens.predict_proba(X), hand, atol=1e-12)


def _member(p_a, runs=("r1", "r2", "r3"), model="m"):
    import pandas as pd
    return pd.DataFrame({"seed": 0, "fold": 0, "run": list(runs), "t_start_s": 0.0,
                         "group": list(runs), "model": model, "true": "a",
                         "proba_a": p_a, "proba_b": 1 - np.asarray(p_a, dtype=float)})


@settings(max_examples=20, deadline=None)
@given(order=st.permutations(range(3)), w=st.floats(0.1, 10.0))
def test_soft_vote_does_not_depend_on_the_members_row_order(order, w):
    from terrain.models.compare import soft_vote

    one, two = _member([0.9, 0.2, 0.6]), _member([0.3, 0.4, 0.8])
    ref = soft_vote([one, two], ["a", "b"], weights=(w, 1.0))
    out = soft_vote([one, two.iloc[list(order)]], ["a", "b"], weights=(w, 1.0))
    np.testing.assert_allclose(out["proba_a"], ref["proba_a"], atol=1e-15)
    hand = (w * np.array([0.9, 0.2, 0.6]) + np.array([0.3, 0.4, 0.8])) / (w + 1)
    np.testing.assert_allclose(ref["proba_a"], hand, atol=1e-12)


def test_soft_vote_refuses_a_window_given_twice():
    """Rows of two cells or folders concatenated repeat a window (seed, fold, run, start):
    each member's rows were then paired by their order in its frame, so the probabilities
    of one cell's window were averaged with those of another cell's in the other member."""
    import pandas as pd

    from terrain.errors import ConfigError
    from terrain.models.compare import soft_vote

    one = pd.concat([_member([0.9, 0.2, 0.6]), _member([0.1, 0.7, 0.5])])
    two = pd.concat([_member([0.3, 0.4, 0.8]), _member([0.5, 0.5, 0.5])])
    with pytest.raises(ConfigError, match="more than once"):
        soft_vote([one, two.iloc[::-1]], ["a", "b"])
    with pytest.raises(ConfigError, match="more than once"):
        soft_vote([one, two], ["a", "b"])
    text = one.assign(t_start_s="0.0")          # read as text: the refusal still names it
    with pytest.raises(ConfigError, match="r1 at 0.0 s"):
        soft_vote([text, text], ["a", "b"])


def test_cnn_scaling_comes_from_the_training_runs_without_the_early_stopping_runs():
    from terrain.models.cnn import RawCNNClassifier
    from terrain.models.cv import class_keeping_split

    X, y = _windows(0, n=36)
    X[np.arange(36) % 4 == 1] *= 5.0          # one run of each class on another scale
    groups = y * 10 + np.arange(36) % 4
    model = RawCNNClassifier(max_epochs=2, width=4, batch_size=8, device="cpu", n_threads=1,
                             early_stopping=True, validation_splits=4, patience=1)
    model.fit(X, y, groups)
    tr, va = class_keeping_split(y, groups, 4, 0, "early stopping", "validation_splits", "-")
    np.testing.assert_array_equal(model.validation_groups_, np.unique(groups[va]))
    np.testing.assert_allclose(model.mean_[:, 0], X[tr].mean(axis=(0, 2)), atol=1e-6)
    np.testing.assert_allclose(model.scale_[:, 0], X[tr].std(axis=(0, 2)), rtol=1e-6)


def test_a_start_read_as_text_is_named_in_the_refusal_of_a_nan_probability():
    """A NaN probability beside a start read as text ('0.0', e.g. from an object column)
    raised a bare ValueError "Unknown format code 'g'" while the refusal was being written."""
    from terrain.errors import NonFiniteInputError
    from terrain.models.compare import history_predictions, soft_vote

    one = _member([0.9, np.nan, 0.6]).assign(t_start_s="0.0")
    with pytest.raises(NonFiniteInputError, match="r2 at 0.0 s"):
        soft_vote([one], ["a", "b"])
    with pytest.raises(NonFiniteInputError, match="r2 at 0.0 s"):
        history_predictions(one, ["a", "b"], 2)
    with pytest.raises(NonFiniteInputError, match="r2 at 2 s"):
        history_predictions(one.assign(t_start_s=2.0), ["a", "b"], 2)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_tie_of_held_out_log_loss_goes_to_the_first_weight_vector(seed):
    """Two identical members tie every vector with its mirror (0.5 p + 0.5 p is p exactly):
    the weights are the first of the tied vectors in simplex_grid's order."""
    from terrain.models.ensemble import simplex_grid

    X, y = _data(seed, n=48)
    groups = y * 100 + (np.arange(48) // 9)
    members = [("lr", LogisticRegression(max_iter=200)),
               ("et", ExtraTreesClassifier(n_estimators=5, random_state=0)),
               ("lr2", LogisticRegression(max_iter=200))]
    ens = SoftVotingEnsemble(members, weight_step=0.5, inner_splits=3).fit(X, y, groups)
    grid = [tuple(w) for w in simplex_grid(3, 0.5)]
    best = min(ens.weight_scores_.values())
    tied = [w for w in grid if ens.weight_scores_[w] <= best + 1e-12]
    assert len(tied) >= 2
    assert tuple(ens.weights_) == tied[0]


def test_a_member_name_given_twice_is_refused():
    """A hand-built SoftVotingEnsemble took two members of one name (mdl22's left-alone):
    fit_pipeline's logged weight_<name> entries collapsed into one; the fit now refuses it
    (ConfigError naming it) and leaves the ensemble unfitted."""
    from terrain.errors import ConfigError
    X, y = _data(0, n=30)
    ens = SoftVotingEnsemble([("m", LogisticRegression(max_iter=200)),
                              ("m", ExtraTreesClassifier(n_estimators=5, random_state=0))],
                             weights=(1, 1))
    with pytest.raises(ConfigError, match=r"member name\(s\) \['m'\] given twice"):
        ens.fit(X, y)
    assert not hasattr(ens, "weights_")
