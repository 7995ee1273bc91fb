"""Windowing review (feat3): the columns the EKF channels and the steady-motion filter read
are checked per run, naming the run, the stream and the column."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig, make_windows
from terrain.errors import MissingColumnError
from terrain.run import IMU_CHANNELS, TIME, Run


def _run(drop_imu=(), drop_wheels=(), duration_s=20.0):
    rng = np.random.default_rng(0)
    ti = np.arange(int(duration_s * 100) + 1) / 100.0
    imu = pd.DataFrame({TIME: ti, **{c: 0.05 * rng.standard_normal(len(ti))
                                     for c in IMU_CHANNELS if c not in drop_imu}})
    tw = np.arange(int(duration_s * 10) + 1) / 10.0
    wheels = pd.DataFrame({TIME: tw, "vel_l": 0.5, "vel_r": 0.6, "cur_l": 5.0, "cur_r": 6.0})
    wheels = wheels.drop(columns=list(drop_wheels))
    return Run("r7", "test", "ASPHALT", {"imu": imu, "wheels": wheels}, source="r7.csv")


@pytest.mark.parametrize("signals, drop_imu, drop_wheels, stream, column", [
    ("ekf", ("wz",), (), "imu", "wz"),
    (["ekf_v_bx"], ("wz",), (), "imu", "wz"),
    ("ekf", (), ("vel_r",), "wheels", "vel_r"),
    (["ax", "ekf_nis"], (), ("vel_l",), "wheels", "vel_l"),
])
def test_ekf_channels_of_a_run_lacking_an_ekf_input_name_run_stream_and_column(
        signals, drop_imu, drop_wheels, stream, column):
    # the EKF reads wz, vel_l and vel_r whatever channels are selected: a stream lacking
    # one skipped the EKF without a word and the windowing ended in a bare KeyError on
    # "None of [Index(['ekf_v_bx', ...])] are in the [columns]"
    run = _run(drop_imu, drop_wheels)
    with pytest.raises(MissingColumnError, match=f"run r7: stream '{stream}' lacks columns "
                                                 rf"\['{column}'\]"):
        make_windows([run], signals, WindowConfig())


def test_steady_only_on_a_wheel_stream_without_speeds_names_run_stream_and_column():
    # an IMU-only selection with steady_only reads the wheel speeds too: a wheels stream
    # without vel_r was refused by a ConfigError naming neither run nor stream
    run = _run(drop_wheels=("vel_r",))
    with pytest.raises(MissingColumnError, match=r"run r7: stream 'wheels' lacks columns "
                                                 r"\['vel_r'\]"):
        make_windows([run], "imu", WindowConfig(steady_only=True))


def test_ekf_and_steady_windows_of_complete_runs_are_unchanged():
    run = _run()
    assert len(make_windows([run], "ekf", WindowConfig())) == 10
    assert len(make_windows([run], "imu", WindowConfig(steady_only=True))) == 10
