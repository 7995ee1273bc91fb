"""Review tests of the audit's settings (aud15): what the report says of its filters."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit import AuditSettings, FrameSettings, ReplaySettings
from terrain.audit.ceiling import yaw_rate_ceiling_samples
from terrain.audit.report import BASELINE
from terrain.errors import ConfigError


def test_the_predictions_and_the_imu_are_low_passed_at_one_cut_off():
    # the report says so of every audit ("predictions and IMU low-passed at the same
    # cut-off"), and FrameSettings.imu_cutoff_hz "should equal" the replay's output cut-off;
    # a replay filtered at 0.5 Hz against a gyro filtered at 2 Hz was audited without a
    # word, its yaw-rate "error" holding the 0.5-2 Hz band of the gyro
    assert "low-passed at the same cut-off" in BASELINE
    with pytest.raises(ConfigError, match=r"output_cutoff_hz.*0\.5.*imu_cutoff_hz.*2"):
        AuditSettings(replay=ReplaySettings(output_cutoff_hz=0.5))
    with pytest.raises(ConfigError, match=r"output_cutoff_hz.*2.*imu_cutoff_hz.*1"):
        AuditSettings(frames=FrameSettings(imu_cutoff_hz=1.0))
    same = AuditSettings(replay=ReplaySettings(output_cutoff_hz=1.0),
                         frames=FrameSettings(imu_cutoff_hz=1.0))
    assert same.replay.output_cutoff_hz == same.frames.imu_cutoff_hz == 1.0
    assert AuditSettings().replay.output_cutoff_hz == AuditSettings().frames.imu_cutoff_hz


def test_a_dead_gyro_does_not_turn_in_the_ceiling():
    # a gyro reading exactly 0 in every turn gives 1 / chi = 0: the vehicle does not turn
    # the commanded way (chi inf), and the steady family predicts no yaw there
    f = synthetic_frame("r0", noise=0.0)
    dead = replace(f, wz=np.zeros(f.n), imu_wz=np.zeros(f.n))
    tab = yaw_rate_ceiling_samples([dead])
    assert tab.attrs["chi_shared"]["curve"] == tab.attrs["chi_shared"]["spin"] == np.inf
    assert np.isnan(tab.attrs["chi_shared"]["straight"])          # no turn commanded there
    assert (tab.shared == 0.0).all() and (tab.per_run == 0.0).all()
