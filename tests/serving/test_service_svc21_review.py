"""Review tests (svc21) of the streaming service core: the model's training steps read
back, the ring buffer's usual step, the forward filter and the service's pushes."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.serving.model import model_channel_steps_s


def test_a_channel_step_beyond_the_float_range_is_a_config_error_not_an_overflow():
    with pytest.raises(ConfigError, match="channel_steps_s"):
        model_channel_steps_s({"channel_steps_s": {"vel_l": 10 ** 400}})


def test_a_numpy_channel_step_is_read_as_the_number_it_is():
    steps = model_channel_steps_s({"channel_steps_s": {"vel_l": np.float32(0.125),
                                                       "ax": np.int64(1)}})
    assert steps == {"vel_l": 0.125, "ax": 1.0}
    with pytest.raises(ConfigError, match="channel_steps_s"):
        model_channel_steps_s({"channel_steps_s": {"vel_l": np.bool_(True)}})
