"""Review tests (svc21) of the streaming service core: the model's training steps read
back, the ring buffer's usual step, the forward filter and the service's pushes."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.serving import CataloguePeakTargets
from terrain.serving.model import model_channel_steps_s
from terrain.serving.targets import check_provider


def test_a_channel_step_beyond_the_float_range_is_a_config_error_not_an_overflow():
    with pytest.raises(ConfigError, match="channel_steps_s"):
        model_channel_steps_s({"channel_steps_s": {"vel_l": 10 ** 400}})


def test_a_numpy_channel_step_is_read_as_the_number_it_is():
    steps = model_channel_steps_s({"channel_steps_s": {"vel_l": np.float32(0.125),
                                                       "ax": np.int64(1)}})
    assert steps == {"vel_l": 0.125, "ax": 1.0}
    with pytest.raises(ConfigError, match="channel_steps_s"):
        model_channel_steps_s({"channel_steps_s": {"vel_l": np.bool_(True)}})


def test_catalogue_targets_answer_a_class_in_any_case_as_the_provider_check_accepts_it():
    # check_provider compares the classes in upper case (as the tables look them up):
    # a provider built from 'snow' passed for a model deciding 'SNOW', which then got the
    # fallback (the slipperiest terrain's slip) on every trusted decision, unflagged
    targets = CataloguePeakTargets(["ice", "snow"])
    check_provider(targets, ("ICE", "SNOW"), 0.5)
    snow = targets.target_for("snow", 0.9, False)
    assert snow != targets.fallback
    assert targets.target_for("SNOW", 0.9, False) == snow
    assert targets.target_for("Snow", 0.9, True) == targets.fallback   # stale: fallback
