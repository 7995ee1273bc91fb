"""Review tests (mdl11) of how the soft-voting ensemble chooses its weights: on members
fitted on the training runs only, ties to the first vector of the grid."""

from __future__ import annotations

import numpy as np
from sklearn.dummy import DummyClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.neighbors import KNeighborsClassifier

from terrain.models.ensemble import SoftVotingEnsemble, simplex_grid


def _noise(n_runs=12, per_run=10, seed=0):
    """Windows of pure noise: features carry nothing of the label of their run."""
    rng = np.random.default_rng(seed)
    groups = np.repeat([f"r{i}" for i in range(n_runs)], per_run)
    y = np.repeat(np.where(np.arange(n_runs) % 2 == 0, "A", "B"), per_run)
    return rng.normal(size=(len(y), 3)), y, groups


def test_a_memorising_member_is_weighed_on_runs_it_never_saw():
    # a 1-nearest-neighbour member reproduces every window it was fitted on: fitted on the
    # held-out runs too, it looked perfect on them (log loss 0) and took all the weight;
    # fitted on the training runs only it is a coin on noise with 0/1 probabilities, far
    # worse than the class prior
    X, y, groups = _noise()
    ens = SoftVotingEnsemble([("knn", KNeighborsClassifier(n_neighbors=1)),
                              ("prior", DummyClassifier(strategy="prior"))],
                             weight_step=0.25, inner_splits=4).fit(X, y, groups)
    assert ens.weights_[0] < 0.5, ens.weight_scores_
    # the score of the knn alone is that of a memoriser seen on unseen runs, not 0
    assert ens.weight_scores_[(1.0, 0.0)] > 1.0


def test_a_tie_between_weight_vectors_goes_to_the_first_of_the_grid():
    # two copies of one deterministic member: every weight vector gives the same mixture
    X, y, groups = _noise(seed=1)
    X[:, 0] += (y == "A")                       # something to learn, not needed for the tie
    same = LogisticRegression()
    ens = SoftVotingEnsemble([("a", same), ("b", same)], weight_step=0.25,
                             inner_splits=4).fit(X, y, groups)
    scores = np.array(list(ens.weight_scores_.values()))
    assert np.ptp(scores) < 1e-12
    np.testing.assert_array_equal(ens.weights_, simplex_grid(2, 0.25)[0])
