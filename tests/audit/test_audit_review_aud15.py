"""Review tests of the audit's settings (aud15): what the report says of its filters."""

from __future__ import annotations

import pytest

from terrain.audit import AuditSettings, FrameSettings, ReplaySettings
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
