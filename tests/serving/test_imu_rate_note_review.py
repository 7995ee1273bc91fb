"""Review of :func:`terrain.serving.model.imu_rate_note`: a run's IMU more than 5 % slower
than the model's windows is named, one within 5 % is not (its docstring)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.run import IMU_CHANNELS, TIME, Run
from terrain.serving.model import imu_rate_note


def _run(rate_hz: float) -> Run:
    t = np.arange(400) / rate_hz
    imu = pd.DataFrame({TIME: t, **{c: np.zeros(t.size) for c in IMU_CHANNELS}})
    return Run("test/ICE/00", "test", "ICE", {"imu": imu})


@pytest.mark.parametrize("rate_hz, named", [(50.0, True), (94.0, True), (96.0, False),
                                            (100.0, False), (400.0, False)])
def test_an_imu_more_than_5_percent_slower_than_the_model_is_named(rate_hz, named):
    note = imu_rate_note(IMU_CHANNELS, 100.0, _run(rate_hz))
    assert (note is not None) == named
    if named:
        assert note.startswith("note: run test/ICE/00's IMU is sampled at ")
        assert f"holds nothing above {rate_hz / 2:.3g} Hz" in note


def test_a_model_reading_no_imu_channel_gets_no_note():
    assert imu_rate_note(("vel_l", "vel_r"), 100.0, _run(50.0)) is None
