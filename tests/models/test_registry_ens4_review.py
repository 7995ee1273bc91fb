"""Review tests (ens4) of the model registry's refusals."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.models.registry import MODELS, ModelConfig


@pytest.mark.parametrize("flag", ["tune_weights", "early_stopping", "window_ekf",
                                  "run_balanced"])
@pytest.mark.parametrize("value", ["no", "false", 0, 1, None])
def test_a_switch_is_true_or_false_not_anything_truthy(flag, value):
    # run_balanced="no" (a config file's text) was truthy and trained run-balanced
    with pytest.raises(ConfigError, match=rf"ModelConfig.{flag} must be True or False"):
        ModelConfig(kind="ensemble", **{flag: value})


@pytest.mark.parametrize("flag", ["tune_weights", "early_stopping", "window_ekf",
                                  "run_balanced"])
def test_a_numpy_bool_is_a_switch_too(flag):
    assert getattr(ModelConfig(kind="ensemble", **{flag: np.bool_(True)}), flag)


def test_an_unknown_model_lists_every_valid_name():
    with pytest.raises(ConfigError) as err:
        ModelConfig(kind="SVM")
    assert "unknown model 'SVM'" in str(err.value)
    assert all(repr(m) in str(err.value) for m in MODELS)


def test_an_ensemble_member_named_twice_is_refused():
    # ("svm", "svm") built two identically seeded SVMs whose vote is the one SVM's, served
    # and reported as an ensemble at twice the cost
    with pytest.raises(ConfigError, match=r"more than once.*'svm'"):
        ModelConfig(kind="ensemble", ensemble_members=("svm", "cnn", "svm"))
    assert ModelConfig(kind="ensemble", ensemble_members=("svm", "cnn")).ensemble_members
