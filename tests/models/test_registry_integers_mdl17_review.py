"""ModelConfig's counts follow the one integer rule (review mdl17)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.models.registry import ModelConfig, make_model


def test_numpy_integers_are_counts_for_every_setting():
    # max_epochs took np.int64(3) (config_integer) while cnn_seeds and n_threads refused it
    # with "must be an integer in 1-10, got np.int64(3)" (isinstance(int) only)
    config = ModelConfig(kind="cnn", max_epochs=np.int64(3), cnn_seeds=np.int64(3),
                         n_threads=np.int32(2))
    bag = make_model(config, ("ax", "ay"), 100.0, "borealtc", random_state=5)
    assert [name for name, _ in bag.estimators] == ["cnn-seed5", "cnn-seed6", "cnn-seed7"]


@pytest.mark.parametrize("field, value", [("cnn_seeds", True), ("cnn_seeds", 2.0),
                                          ("cnn_seeds", np.int64(11)), ("n_threads", False),
                                          ("n_threads", np.float64(2.0)),
                                          ("n_threads", np.int64(0))])
def test_booleans_floats_and_out_of_range_counts_are_still_refused(field, value):
    with pytest.raises(ConfigError, match=f"{field} must be an integer"):
        ModelConfig(kind="cnn", **{field: value})


@pytest.mark.parametrize("members", ["svm", "cnn-spectrogram"])
def test_ensemble_members_given_as_one_name_are_refused_naming_it(members):
    # one name where a tuple is meant was read letter by letter: the message listed
    # ['s', 'v', 'm'] as the members given
    with pytest.raises(ConfigError, match=f"ensemble_members must be a tuple of member "
                                          f"names, e.g. \\('svm', 'cnn-spectrogram'\\), got "
                                          f"'{members}'"):
        ModelConfig(kind="ensemble", ensemble_members=members)
