"""A stream's first steps are judged against its training step: the model's
``channel_steps_s`` (written at training from the training runs), read back checked, and
used by the ring buffer's usual step while few steps are known."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError
from terrain.serving.buffers import FEW_STEPS, RingBuffer
from terrain.serving.model import (model_channel_steps_s, read_model_metadata,
                                   training_steps_s)
from test_model_metadata_review import META, _model_dir


def test_training_steps_are_the_shipped_streams_rates(train_runs):
    """BorealTC's wheel stream runs at about 6.5 Hz (0.154 s) and its IMU at 100 Hz
    (data README); the derived wheel channels stand for the four wheel channels."""
    steps = training_steps_s(train_runs, ["wz", "yaw_rate_wheels"])
    assert set(steps) == {"wz", "vel_l", "vel_r", "cur_l", "cur_r"}
    assert steps["vel_l"] == steps["cur_r"] == pytest.approx(1 / 6.5, rel=0.02)
    imu = [1.0 / r.rate_hz("imu") for r in train_runs]
    assert steps["wz"] == pytest.approx(np.median(imu)) == pytest.approx(0.01, rel=0.05)
    assert training_steps_s(train_runs, ["no_such_channel"]) == {}


def test_the_fitted_stream_model_records_its_training_steps(wheel_model):
    steps = model_channel_steps_s(wheel_model.metadata)
    assert set(steps) == set(wheel_model.raw_channels)
    assert all(0.1 < s < 0.2 for s in steps.values()), steps


@pytest.mark.parametrize("value", [{"vel_l": True}, {"vel_l": 0.0}, {"vel_l": -0.1},
                                   {"vel_l": float("nan")}, {"vel_l": "0.15"}, [0.15], 0.15])
def test_a_bad_channel_step_is_refused_naming_the_file_and_the_key(tmp_path, value):
    path = _model_dir(tmp_path, {**META, "channel_steps_s": value})
    with pytest.raises(ConfigError, match="channel_steps_s") as exc:
        read_model_metadata(path)
    assert str(path / "MLmodel") in str(exc.value)


def test_channel_steps_read_back_and_absent_is_none(tmp_path):
    path = _model_dir(tmp_path, {**META, "channel_steps_s": {"vel_l": 0.154, "acc_x": 0.02}})
    meta = read_model_metadata(path)
    assert model_channel_steps_s(meta) == {"vel_l": 0.154, "acc_x": 0.02}
    assert model_channel_steps_s(META) == model_channel_steps_s(
        {**META, "channel_steps_s": None}) == {}
    assert "channel_steps_s" in yaml.safe_dump(meta)


@settings(max_examples=60, deadline=None)
@given(steps=st.lists(st.floats(0.01, 2.0), min_size=1, max_size=20),
       prior=st.floats(0.01, 2.0))
def test_the_prior_caps_the_usual_step_only_while_few_steps_are_known(steps, prior):
    buf = RingBuffer(1, 64)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    buf.append(t, np.zeros((len(t), 1)))
    got, without = buf.usual_step(prior_s=prior), buf.usual_step()
    if len(steps) < FEW_STEPS:
        assert got == min(min(np.diff(t)), prior)
    else:
        assert got == without == buf.median_step()


def test_a_stream_of_holes_from_its_start_is_a_gap_with_the_prior_only():
    """Samples at 0 and 0.615 s of a 6.5 Hz stream, then none until 2 s: without a
    prior the usual step is the hole itself."""
    buf = RingBuffer(1, 64)
    buf.append(np.r_[0.0, 0.615, 2.0], np.zeros((3, 1)))
    assert buf.usual_step(through_s=2.0) == pytest.approx(0.615)
    assert buf.usual_step(through_s=2.0, prior_s=0.154) == pytest.approx(0.154)
