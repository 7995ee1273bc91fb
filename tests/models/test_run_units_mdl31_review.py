"""Run-grouped protocols refuse split units finer than a run (mdl31 review).

``cross_validate(protocol="grouped" | "loro")`` reports how a model does on unseen runs,
but it split whatever ``groups`` it was given: windows, or 5 s partitions, as groups made
folds holding windows of one run on both sides, and the report's "grouped" figures then
measured the run's fingerprint instead of its terrain. A run may span several split units
only where its class has that one run (the time blocks of
:func:`~terrain.models.cv.split_single_run_classes`).
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.neighbors import KNeighborsClassifier

from terrain.errors import ConfigError
from terrain.models.cv import cross_validate, split_single_run_classes


def _fingerprints(n_runs: int = 16, per_run: int = 12):
    """Windows whose features identify their run (a run-specific offset) but not its
    terrain: every classifier is at chance on unseen runs."""
    rng = np.random.default_rng(31)
    run = np.repeat(np.arange(n_runs), per_run)
    y = rng.permutation(np.repeat(["A", "B"], n_runs // 2))[run]
    X = 5.0 * rng.standard_normal((n_runs, 2))[run] + 0.1 * rng.standard_normal((run.size, 2))
    runs = np.array([f"r{r:02d}" for r in run], dtype=object)
    t0 = np.tile(np.arange(per_run) * 1.0, n_runs)
    return X, y, runs, t0


def _factory(seed):
    return KNeighborsClassifier(1)


@pytest.mark.parametrize("protocol", ["grouped", "loro"])
def test_windows_as_groups_are_refused_naming_the_run(protocol):
    X, y, runs, t0 = _fingerprints()
    windows = np.array([f"{r}#{k}" for k, r in enumerate(runs)], dtype=object)
    with pytest.raises(ConfigError, match=r"groups.*r00"):
        cross_validate(_factory, X, y, windows, runs, t0, t0 + 1.0, protocol, (0,), 4)


def test_partitions_as_grouped_units_are_refused():
    # 3 partitions per run: on main the "grouped" CV scored the fingerprints (accuracy 1.0)
    X, y, runs, t0 = _fingerprints()
    partitions = np.array([f"{r}#{int(t) // 4}" for r, t in zip(runs, t0)], dtype=object)
    with pytest.raises(ConfigError, match="groups"):
        cross_validate(_factory, X, y, partitions, runs, t0, t0 + 1.0, "grouped", (0,), 4)


def test_runs_as_groups_score_the_fingerprints_at_chance():
    X, y, runs, t0 = _fingerprints()
    report = cross_validate(_factory, X, y, runs, runs, t0, t0 + 1.0, "grouped", (0, 1), 4)
    assert report.pooled["accuracy"].max() < 0.75


def test_the_papers_protocol_still_splits_partitions_of_a_run():
    # the published protocol is leaky by design and reported as such, never the headline
    X, y, runs, t0 = _fingerprints()
    partitions = np.array([f"{r}#{int(t) // 4}" for r, t in zip(runs, t0)], dtype=object)
    report = cross_validate(_factory, X, y, partitions, runs, t0, t0 + 1.0, "paper", (0,), 5)
    assert report.pooled["accuracy"].iloc[0] > 0.9


def test_time_blocks_of_a_single_run_class_are_accepted():
    X, y, runs, t0 = _fingerprints()
    y = y.copy()
    y[runs == "r00"] = "C"                       # a class of one run, cut into time blocks
    units, split = split_single_run_classes(y, runs, t0, 3)
    assert split == ["C"] and len(set(units[runs == "r00"])) == 3
    report = cross_validate(_factory, X, y, units, runs, t0, t0 + 1.0, "grouped", (0,), 3)
    assert len(report.predictions) == len(y)


def test_a_run_of_two_classes_may_hold_a_block_of_its_single_run_class():
    # per-sample labels: run r01 holds windows of B (a class of many runs, one unit: the
    # run) and of C (its only run, cut into blocks)
    X, y, runs, t0 = _fingerprints()
    y = np.where(runs == "r01", np.where(t0 < 6, "B", "C"), y)
    units, split = split_single_run_classes(y, runs, t0, 2)
    assert split == ["C"]
    report = cross_validate(_factory, X, y, units, runs, t0, t0 + 1.0, "grouped", (0,), 3)
    assert len(report.predictions) == len(y)
