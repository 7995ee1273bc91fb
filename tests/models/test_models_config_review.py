"""Review of the classifiers' configuration: settings that are nonsense are refused with a
:class:`~terrain.errors.ConfigError` naming the field when the configuration is built, before
any data is read, instead of a bare scikit-learn error after it or a silently different run."""

from __future__ import annotations

import math

import pytest

from terrain.errors import ConfigError
from terrain.models.experiment import ExperimentConfig
from terrain.models.svm import SVMConfig


@pytest.mark.parametrize("field, value", [
    ("C", 0.0), ("C", -1.0), ("C", math.nan), ("C", math.inf),
    ("gamma", 0.0), ("gamma", -0.01), ("gamma", "bogus"), ("gamma", math.nan),
    ("inner_splits", 1), ("inner_splits", 2.5), ("inner_splits", True),
    ("search_C", ()), ("search_C", (1.0, -3.0)), ("search_gamma", ()),
    ("search_gamma", ("scale", 0.0))])
def test_svm_settings_are_checked_when_the_config_is_built(field, value):
    # C <= 0 and gamma "bogus" reached SVC's InvalidParameterError at the first fit;
    # gamma 0 fitted a constant kernel; inner_splits 1 and an empty grid raised scikit-learn's
    # bare ValueError inside the CV, after the data was windowed
    with pytest.raises(ConfigError, match=f"SVMConfig.{field}"):
        SVMConfig(**{field: value})


def test_svm_settings_take_the_kernel_width_names_and_positive_numbers():
    for gamma in ("scale", "auto", 0.003):
        assert SVMConfig(gamma=gamma).gamma == gamma
    config = SVMConfig(C=0.5, search_C=(0.1,), search_gamma=("auto", 1.0), inner_splits=2)
    assert (config.C, config.search_C, config.search_gamma, config.inner_splits) == (
        0.5, (0.1,), ("auto", 1.0), 2)


def test_a_zero_rate_is_refused_not_replaced_by_the_dataset_rate():
    # rate_hz=0.0 was taken as "unset" (``rate_hz or IMU rate``): the experiment ran at
    # BorealTC's 100 Hz and logged rate_hz 100 for a rate of 0 asked
    with pytest.raises(ConfigError, match="rate_hz"):
        ExperimentConfig(rate_hz=0.0)
    # None is the documented "dataset's IMU rate"; a rate given is kept
    assert ExperimentConfig(rate_hz=None).window_config().rate_hz == 100.0
    assert ExperimentConfig(dataset="vulpi", rate_hz=25.0).window_config().rate_hz == 25.0


@pytest.mark.parametrize("n_splits", [2.5, 1, 0, True, "5"])
def test_outer_folds_must_be_an_integer_of_two_at_least(n_splits):
    # 2.5 reached scikit-learn's bare "number of folds must be of Integral type" after the
    # dataset was loaded and windowed; 1 and 0 were refused only then
    with pytest.raises(ConfigError, match="n_splits"):
        ExperimentConfig(n_splits=n_splits)


def test_outer_folds_take_every_integer_of_two_and_more():
    assert ExperimentConfig(n_splits=2).n_splits == 2
    assert ExperimentConfig(n_splits=10, protocol="loro").n_splits == 10
