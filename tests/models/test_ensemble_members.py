"""The member probe of benchmarks/ensemble_members.py: its votes and its drive-physics member."""

from __future__ import annotations

import runpy
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "ensemble_members.py"
CLASSES = ["A", "B"]


@pytest.fixture(scope="module")
def script():
    return runpy.run_path(str(SCRIPT))


def _frame(p_a: list[float]) -> pd.DataFrame:
    p_a = np.asarray(p_a, dtype=float)
    return pd.DataFrame({"seed": 0, "fold": [0, 0, 1], "run": ["r0", "r0", "r1"],
                         "group": ["r0", "r0", "r1"], "t_start_s": [0.0, 2.0, 0.0],
                         "t_end_s": [2.0, 4.0, 2.0], "true": ["A", "A", "B"],
                         "predicted": np.where(p_a >= 0.5, "A", "B"),
                         "proba_A": p_a, "proba_B": 1.0 - p_a})


def test_votes_average_initialisations_then_members(script):
    members = {"svm": [_frame([0.9, 0.2, 0.4])],
               "wheel-trees": [_frame([0.6, 0.6, 0.6])],
               "cnn": [_frame([0.1, 0.3, 0.0]), _frame([0.5, 0.9, 0.2])],
               "cnn-spectrogram": [_frame([0.2, 0.8, 0.9]), _frame([0.4, 0.4, 0.1])]}
    votes = script["member_votes"](members, CLASSES)
    p = {name: v.sort_values(["fold", "t_start_s"])["proba_A"].to_numpy()
         for name, v in votes.items()}
    np.testing.assert_allclose(p["cnn"], [0.1, 0.3, 0.0])                 # first init alone
    np.testing.assert_allclose(p["cnn x2"], [0.3, 0.6, 0.1])               # mean of inits
    np.testing.assert_allclose(p["ensemble"], [0.55, 0.5, 0.65])           # svm + spec
    np.testing.assert_allclose(p["ensemble3"], [0.4, 0.43333333, 0.43333333])
    # a seed-averaged CNN is one member: (svm + mean(cnn) + mean(spec)) / 3
    np.testing.assert_allclose(p["ensemble3, CNNs x2"],
                               [(0.9 + 0.3 + 0.3) / 3, (0.2 + 0.6 + 0.6) / 3,
                                (0.4 + 0.1 + 0.5) / 3])
    np.testing.assert_allclose(p["ensemble3, CNNs x2 + wheel-trees"],
                               [(0.9 + 0.3 + 0.3 + 0.6) / 4, (0.2 + 0.6 + 0.6 + 0.6) / 4,
                                (0.4 + 0.1 + 0.5 + 0.6) / 4])
    # first initialisations plus wheel-trees: (svm + spec + wheel-trees) / 3
    np.testing.assert_allclose(p["ensemble + wheel-trees"],
                               [(0.9 + 0.2 + 0.6) / 3, (0.2 + 0.8 + 0.6) / 3,
                                (0.4 + 0.9 + 0.6) / 3])
    assert (votes["ensemble3"].set_index(["fold", "t_start_s"]).sort_index()["predicted"]
            .tolist() == ["B", "B", "B"])


def test_wheel_trees_find_a_planted_current_per_speed(script):
    """Two terrains that differ only in the drive current needed per unit speed (rolling
    resistance) are told apart from the wheel channels alone, across runs."""
    rng = np.random.default_rng(0)
    channels = ("vel_l", "vel_r", "cur_l", "cur_r", "wz")
    n, m = 240, 40
    runs = np.repeat(np.arange(12), n // 12)
    y = np.where(runs % 2 == 0, "soft", "hard")
    v = rng.uniform(0.2, 1.0, (n, 1)) * np.ones((1, m)) + 0.01 * rng.standard_normal((n, m))
    amps_per_m_s = np.where(y == "soft", 12.0, 6.0)[:, None]
    cur = 2.0 + amps_per_m_s * v + rng.standard_normal((n, m))
    X = np.stack([v, v, cur, cur + 0.3 * rng.standard_normal((n, m)),
                  rng.standard_normal((n, m))], axis=1)
    train = runs < 8
    model = script["RunBalancedWheelTrees"](channels, rate_hz=10.0, n_trees=50,
                                            random_state=0)
    model.fit(X[train], y[train], groups=runs[train])
    assert list(model.classes_) == ["hard", "soft"]
    proba = model.predict_proba(X[~train])
    assert proba.shape == (int((~train).sum()), 2)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    assert (model.predict(X[~train]) == y[~train]).mean() > 0.95


def test_fixed_weights_must_be_one_per_member():
    # two weights for three members dropped the third member silently (zip), in the
    # ensemble and in the out-of-fold soft vote alike
    from sklearn.dummy import DummyClassifier
    from sklearn.linear_model import LogisticRegression

    from terrain.errors import ConfigError
    from terrain.models.compare import soft_vote
    from terrain.models.ensemble import SoftVotingEnsemble

    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 3))
    y = np.where(X[:, 0] > 0, "A", "B")
    members = [("d1", DummyClassifier()), ("d2", DummyClassifier()),
               ("lr", LogisticRegression())]
    with pytest.raises(ConfigError, match="2 weight"):
        SoftVotingEnsemble(members, weights=(1, 1)).fit(X, y)
    with pytest.raises(ConfigError, match=">= 0"):
        SoftVotingEnsemble(members, weights=(1, -1, 1)).fit(X, y)
    ens = SoftVotingEnsemble(members, weights=(0, 0, 2)).fit(X, y)
    np.testing.assert_allclose(ens.weights_, [0, 0, 1])
    frame = pd.DataFrame({"seed": 0, "fold": 0, "run": "r", "t_start_s": np.arange(3.0),
                          "proba_A": [0.2, 0.5, 0.9], "proba_B": [0.8, 0.5, 0.1]})
    sure = frame.assign(proba_A=1.0, proba_B=0.0)
    with pytest.raises(ConfigError, match="1 weight"):
        soft_vote([frame, sure], ["A", "B"], weights=(1,))
    np.testing.assert_allclose(soft_vote([frame, sure], ["A", "B"], weights=(1, 1))["proba_A"],
                               [0.6, 0.75, 0.95])


def test_weights_to_choose_refuse_too_few_runs_and_an_off_grid_step():
    from sklearn.linear_model import LogisticRegression

    from terrain.errors import ConfigError
    from terrain.models.ensemble import SoftVotingEnsemble, simplex_grid

    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 3))
    y = np.where(X[:, 0] > 0, "A", "B")
    members = [("a", LogisticRegression()), ("b", LogisticRegression(C=0.01))]
    three_runs = np.repeat(["r0", "r1", "r2"], [14, 13, 13])
    # 4 inner folds over 3 runs: scikit-learn's bare ValueError ('Cannot have number of
    # splits n_splits=4 greater than the number of groups: 3')
    with pytest.raises(ConfigError, match=r"into 4 inner folds \(inner_splits\): it got 3 runs "
                                          r"\(runs r0, r1, r2\)"):
        SoftVotingEnsemble(members).fit(X, y, groups=three_runs)
    ten_runs = np.repeat([f"r{i}" for i in range(10)], 4)
    with pytest.raises(ConfigError, match="weight_step"):      # was a ZeroDivisionError
        SoftVotingEnsemble(members, weight_step=0).fit(X, y, groups=ten_runs)
    with pytest.raises(ConfigError, match="weight_step"):      # was searched as thirds
        simplex_grid(2, 0.3)
    assert len(simplex_grid(2, 0.1)) == 11 and len(simplex_grid(3, 0.25)) == 15
    ens = SoftVotingEnsemble(members, weight_step=0.5).fit(X, y, groups=ten_runs)
    assert len(ens.weight_scores_) == 3 and np.isclose(ens.weights_.sum(), 1.0)


def test_predict_before_fit_is_not_fitted_error():
    # predict read classes_ before predict_proba's check: Python's AttributeError
    # "'SoftVotingEnsemble' object has no attribute 'classes_'" instead of NotFittedError
    from sklearn.exceptions import NotFittedError
    from sklearn.linear_model import LogisticRegression

    from terrain.models.ensemble import SoftVotingEnsemble

    ens = SoftVotingEnsemble([("lr", LogisticRegression())], weights=(1,))
    X = np.zeros((2, 3))
    for method in (ens.predict, ens.predict_proba):
        with pytest.raises(NotFittedError, match="not fitted"):
            method(X)


def test_weights_are_never_chosen_on_every_run_of_a_class():
    # A, B with 4 runs each and C with one: StratifiedGroupKFold(4, seed 0)'s first split
    # held out C's only run, so the members that scored the weights never saw C (log loss
    # 9.28 at best, C's column 0) and the weights were chosen on that, without a word
    from sklearn.linear_model import LogisticRegression
    from sklearn.model_selection import StratifiedGroupKFold

    from terrain.errors import ConfigError
    from terrain.models.ensemble import SoftVotingEnsemble

    rng = np.random.default_rng(0)
    runs = [("A", f"a{i}") for i in range(4)] + [("B", f"b{i}") for i in range(4)] + [("C", "c0")]
    X = np.concatenate([rng.normal(size=(10, 3)) + 3 * "ABC".index(lab) for lab, _ in runs])
    y = np.repeat([lab for lab, _ in runs], 10)
    groups = np.repeat([run for _, run in runs], 10)
    _, first_val = next(StratifiedGroupKFold(4, shuffle=True, random_state=0)
                        .split(X, y, groups))
    assert "c0" in set(groups[first_val])          # the split the fit used to take
    members = [("a", LogisticRegression()), ("b", LogisticRegression(C=0.01))]
    ens = SoftVotingEnsemble(members).fit(X, y, groups=groups)
    held = set(ens.validation_groups_)
    assert held and "c0" not in held
    assert set(y[~np.isin(groups, list(held))]) == {"A", "B", "C"}
    assert min(ens.weight_scores_.values()) < 1.0
    # one run per class: every split holds out some class's only run; refused, named
    one_each = np.isin(groups, ["a0", "a1", "b0", "c0"])
    with pytest.raises(ConfigError, match=r"choosing the ensemble weights .*class\(es\) "
                                          r"\['.*'C'\]"):
        SoftVotingEnsemble(members, inner_splits=2).fit(X[one_each], y[one_each],
                                                        groups=groups[one_each])


def test_fit_without_labels_is_a_clear_error_and_the_input_width_is_kept():
    # fit(X, None) gave scikit-learn's generic "y should be a 1d array, got an array of
    # shape () instead.", and no n_features_in_ was set
    from sklearn.linear_model import LogisticRegression

    from terrain.models.ensemble import SoftVotingEnsemble

    X = np.random.default_rng(0).normal(size=(30, 3))
    y = np.repeat(["A", "B", "A"], 10)
    groups = np.repeat(["r0", "r1", "r2"], 10)
    for weights, kwargs in (((1,), {}), (None, {"groups": groups})):
        ens = SoftVotingEnsemble([("lr", LogisticRegression())], weights=weights,
                                 inner_splits=2)
        with pytest.raises(ValueError, match="requires y to be passed, but the target y is "
                                             "None"):
            ens.fit(X, None, **kwargs)
        assert ens.fit(X, y, **kwargs).n_features_in_ == 3


@pytest.mark.parametrize("weights, match", [
    ((0, 0, 0), "not all 0"),                  # was 0 / 0: NaN weights, NaN probabilities
    ((1, np.inf, 1), "finite"),                # was inf / inf: a NaN weight
    ((1, np.nan, 1), "finite"),
    ((1, 1, 1, 1), "4 weight"),                # a fourth weight would be renormalised away
])
def test_fixed_weights_are_refused_unless_finite_non_negative_one_per_member(weights, match):
    from terrain.errors import ConfigError
    from terrain.models.ensemble import normalised_weights

    with pytest.raises(ConfigError, match=match):
        normalised_weights(weights, 3)
    np.testing.assert_allclose(normalised_weights((0, 1, 3), 3), [0.0, 0.25, 0.75])
