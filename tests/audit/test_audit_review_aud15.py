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


def test_the_physics_comparison_low_passes_both_at_one_cut_off():
    # `terrain audit --compare-physics` takes its replay and frame settings apart
    # (per_run_errors, paired_frames): a 0.5 Hz replay against a 2 Hz gyro compared the
    # versions with the gyro's 0.5-2 Hz band in both errors, unsaid; refused before any run
    # is replayed (inside the loop a ConfigError only skips the run)
    from terrain.audit.physics import PhysicsComparisonSettings, per_run_errors

    with pytest.raises(ConfigError, match=r"paired_frames: replay.output_cutoff_hz \(0\.5"):
        per_run_errors([object()], PhysicsComparisonSettings(),
                       replay=ReplaySettings(output_cutoff_hz=0.5))


def test_a_dead_gyro_does_not_turn_in_the_ceiling():
    # a gyro reading exactly 0 in every turn gives 1 / chi = 0: the vehicle does not turn
    # the commanded way (chi inf), and the steady family predicts no yaw there
    f = synthetic_frame("r0", noise=0.0)
    dead = replace(f, wz=np.zeros(f.n), imu_wz=np.zeros(f.n))
    tab = yaw_rate_ceiling_samples([dead])
    assert tab.attrs["chi_shared"]["curve"] == tab.attrs["chi_shared"]["spin"] == np.inf
    assert np.isnan(tab.attrs["chi_shared"]["straight"])          # no turn commanded there
    assert (tab.shared == 0.0).all() and (tab.per_run == 0.0).all()


def test_a_dug_in_robot_that_turns_faster_than_ideal_is_not_named_immobilised():
    # the gyro reads 2x the commanded turn (a gyro scale or track-width error: chi 0.5,
    # which no ICR expansion gives) and shows nothing for 30 % of every turn; with the
    # kinematic mobile model (v_R - v_L) / (chi_m B), chi_m = 0.5 < 1, 'immobilised' took the
    # gain of correcting the scale error and was named, where icr_expansion with the same
    # chi is refused as unphysical
    from test_audit_properties_aud15 import NO_CI, _frames, plant
    from terrain.audit.selection import select_group

    rng = np.random.default_rng(0)
    frames = [plant(plant(f, "icr_expansion", 0.5, rng), "immobilised", 0.3, rng)
              for f in _frames(1)]
    res = select_group([[f] for f in frames], "yaw", "ASPHALT", NO_CI)
    e = {x.name: x for x in res.effects}
    assert e["immobilised"].details["mobile_model"] == "kinematic"
    assert e["immobilised"].details["chi_mobile"] == pytest.approx(0.5, abs=0.01)
    assert "unphysical" in e["immobilised"].details
    assert "chi" in e["immobilised"].details["unphysical"]
    assert res.selected == ()
    # with chi_m > 1 the same dug-in turns are named
    frames = [plant(plant(f, "icr_expansion", 1.8, rng), "immobilised", 0.3, rng)
              for f in _frames(1)]
    assert select_group([[f] for f in frames], "yaw", "ASPHALT", NO_CI).selected == (
        "immobilised",)


def test_a_run_with_three_rows_per_coefficient_gets_its_own_current_fit():
    # the per-run recalibration falls back to the shared one below 3 rows (samples x sides)
    # per coefficient of a manoeuvre; at exactly 3 (here 6 spin samples x 2 sides for the 4
    # coefficients [1, replay, |v_side|, |x|]) the run has its own fit
    from terrain.audit.ceiling import current_ceiling_samples
    from terrain.audit.frames import SPIN

    frames = [synthetic_frame(f"r{i}", seed=i, offsets_a=(0.3 * i, -0.2 * i), noise=0.05)
              for i in range(2)]
    f = frames[0]
    spin = np.flatnonzero(f.score_cur & (f.manoeuvre == SPIN))
    keep = f.score_cur & (f.manoeuvre != SPIN)
    keep[spin[:6]] = True
    frames[0] = replace(f, score_cur=keep)
    tab = current_ceiling_samples(frames)
    assert tab.attrs["per_run_fallback"] == 0
    rows = tab[(tab.run_id == "r0") & (tab.manoeuvre == "spin")]
    assert len(rows) == 12
    assert not np.allclose(rows.per_run, rows.shared)


def test_a_parameter_interval_is_the_2_5_and_97_5_percentile_of_unit_refits():
    from terrain.audit import selection
    from terrain.audit.effects import EffectSettings, fit_yaw

    units = [[synthetic_frame(f"s/A/{i}", seed=i, bias_rad_s=0.01 * (i + 1), noise=0.01)]
             for i in range(5)]
    ci = selection._param_ci(units, "yaw", ["gyro_bias"], "gyro_bias", None,
                             EffectSettings(), np.random.default_rng(3), 40)
    rng = np.random.default_rng(3)
    draws = []
    for _ in range(40):
        idx = selection.stratified_resamples(np.zeros(5), rng, 1)[0]
        draws.append(fit_yaw([units[i][0] for i in idx], ["gyro_bias"]).bias_rad_s)
    assert ci["bias_rad_s"] == (np.percentile(draws, 2.5), np.percentile(draws, 97.5))
    assert ci["bias_rad_s"][0] < ci["bias_rad_s"][1]
