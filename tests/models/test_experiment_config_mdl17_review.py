"""ExperimentConfig's switches and seeds refused by name (review mdl17)."""

from __future__ import annotations

import pytest

from terrain.errors import ConfigError
from terrain.models.experiment import ExperimentConfig


@pytest.mark.parametrize("value", ["no", "false", 0, 1, None])
def test_search_must_be_true_or_false(value):
    # a text such as "no" from a config file was truthy: the nested grid search ran (and with
    # another model the error said "--search tunes the SVM" of a search never asked for)
    with pytest.raises(ConfigError, match="search must be True or False"):
        ExperimentConfig(search=value)


def test_search_true_and_false_are_kept():
    assert ExperimentConfig(search=True).search is True
    assert ExperimentConfig(model="cnn", search=False).search is False


@pytest.mark.parametrize("seeds", [3, 2.5, None])
def test_seeds_not_a_sequence_are_a_config_error(seeds):
    # a single seed given bare reached Python's "TypeError: 'int' object is not iterable"
    with pytest.raises(ConfigError, match="seeds"):
        ExperimentConfig(seeds=seeds)


@pytest.mark.parametrize("signals", [("imu", "imu"), ("wx", "wheels", "wx")])
def test_a_signal_named_twice_is_refused(signals):
    # the channels were de-duplicated, but the MLflow param read 'imu,imu' and the run
    # name '...-imu+imu': one selection logged under several names
    with pytest.raises(ConfigError, match=r"signals \['(imu|wx)'\] given twice"):
        ExperimentConfig(signals=signals)


def test_a_channel_inside_a_set_is_no_repeat():
    # a set and one of its channels name the selection differently: kept, as documented
    # (resolve_signals removes the overlap)
    assert ExperimentConfig(signals=("imu", "wx")).signals == ("imu", "wx")
