"""Split settings and inputs refused by name (review mdl17)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError, ShapeError
from terrain.models.cv import grouped_units, iter_splits, split_single_run_classes

LABELS = np.array(["A", "B"] * 10)
GROUPS = np.array([f"{lab}/{i % 5}" for i, lab in enumerate(LABELS)])


@pytest.mark.parametrize("protocol", ["grouped", "paper"])
@pytest.mark.parametrize("seed", [-1, 2 ** 32, 1.5, True, np.nan])
def test_a_seed_outside_numpys_range_is_a_config_error_naming_it(protocol, seed):
    # grouped: NumPy's bare "Seed must be between 0 and 2**32 - 1" (or "1.5 cannot be used to
    # seed"); paper: -1 was taken silently as (21 - 1) mod 2**32, and 2**32 as seed 0, the
    # published split
    with pytest.raises(ConfigError, match="seed"):
        list(iter_splits(protocol, LABELS, GROUPS, seed, 2))


@pytest.mark.parametrize("protocol", ["grouped", "paper"])
@pytest.mark.parametrize("n_splits", [2.5, 3.0])
def test_folds_not_an_integer_are_a_config_error_naming_them(protocol, n_splits):
    # scikit-learn's bare "The number of folds must be of Integral type"
    with pytest.raises(ConfigError, match="n_splits"):
        list(iter_splits(protocol, LABELS, GROUPS, 0, n_splits))


@pytest.mark.parametrize("protocol", ["grouped", "loro", "paper"])
def test_labels_and_groups_of_other_lengths_are_a_shape_error(protocol):
    # scikit-learn's "Found input variables with inconsistent numbers of samples"
    with pytest.raises(ShapeError, match="labels"):
        list(iter_splits(protocol, LABELS, GROUPS[:-1], 0, 2))


def test_the_published_split_and_the_top_seed_are_kept():
    first = [t.tolist() for _, t in iter_splits("paper", LABELS, GROUPS, 0, 2)]
    assert len(first) == 2
    assert len(list(iter_splits("paper", LABELS, GROUPS, 2 ** 32 - 1, 2))) == 2
    assert len(list(iter_splits("grouped", LABELS, GROUPS, np.uint32(7), 2))) == 2


@pytest.mark.parametrize("n_blocks", [0, 1, True, 2.0, -3])
def test_blocks_of_a_single_run_class_not_an_integer_from_2_are_refused(n_blocks):
    # 0 reached NumPy's bare "number sections must be larger than 0"; True and 1 cut the run
    # into one block, never trained on when it is tested, with no word
    labels = np.array(["A"] * 6 + ["B"] * 6)
    runs = np.array(["A/0"] * 6 + ["B/0"] * 3 + ["B/1"] * 3)
    with pytest.raises(ConfigError, match="n_blocks"):
        split_single_run_classes(labels, runs, np.arange(12.0), n_blocks)


def test_grouped_units_refuses_the_blocks_too():
    class _Windows:
        labels = np.array(["A"] * 4)
        groups = np.array(["A/0"] * 4)
        run_ids = groups
        t_start_s = np.arange(4.0)
        t_end_s = t_start_s + 1.0
    with pytest.raises(ConfigError, match="n_blocks"):
        grouped_units(_Windows(), 0)


@pytest.mark.parametrize("missing", [np.nan, None])
def test_an_inner_split_refuses_missing_runs_by_name(missing):
    # every NaN run is a new object, so a set of them counted one run per window: 12 "runs"
    # passed the run count and reached scikit-learn's bare "Cannot have number of splits
    # n_splits=2 greater than the number of groups: 1" (None: "'<' not supported")
    from terrain.errors import NonFiniteInputError
    from terrain.models.cv import class_keeping_split

    labels = np.array(["A", "B"] * 6)
    groups = np.array([f"r{i}" for i in range(12)], dtype=object)
    groups[[3, 7]] = missing
    with pytest.raises(NonFiniteInputError, match="groups.*index 3"):
        class_keeping_split(labels, groups, 2, 0, "early stopping", "validation_splits",
                            "early_stopping=False")
    with pytest.raises(NonFiniteInputError, match="groups"):
        class_keeping_split(labels, np.full(12, np.nan), 2, 0, "early stopping",
                            "validation_splits", "early_stopping=False")


@pytest.mark.parametrize("seed", [-1, 2 ** 32, 0.5, True])
def test_an_inner_split_refuses_a_seed_numpy_refuses_by_name(seed):
    # the ensemble's random_state reached NumPy's bare "Seed must be between 0 and 2**32 - 1"
    from terrain.models.cv import class_keeping_split

    labels = np.array(["A", "B"] * 6)
    groups = np.array([f"r{i}" for i in range(12)])
    with pytest.raises(ConfigError, match="random_state"):
        class_keeping_split(labels, groups, 2, seed, "choosing the ensemble weights",
                            "inner_splits", "fixed weights")


@pytest.mark.parametrize("protocol", ["grouped", "loro", "paper"])
@pytest.mark.parametrize("missing", [np.nan, None])
def test_a_missing_run_is_refused_by_every_protocol(protocol, missing):
    # grouped merged every window of a NaN run into one split unit without a word (NumPy's
    # unique counts NaN once); loro: "Input groups contains NaN", paper: KeyError nan; a None
    # run: TypeError "'<' not supported between instances of 'str' and 'NoneType'"
    from terrain.errors import NonFiniteInputError

    groups = np.array([f"r{i % 5}" for i in range(20)], dtype=object)
    if missing is not None:
        groups = np.array([float(i % 5) for i in range(20)])
    groups[[2, 3, 7]] = missing
    with pytest.raises(NonFiniteInputError, match="groups holds 3 missing.*index 2"):
        list(iter_splits(protocol, LABELS, groups, 0, 2))
