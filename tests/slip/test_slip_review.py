"""Review tests of the slip estimate: bounds of the terrain weighting and of the lag gate."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.slip import gated_lag
from terrain.slip.physics import PhysicsSlipSettings, physics_slip
from terrain.vehicles import HUSKY

T = np.arange(0, 40, 0.01)
STEPS = (np.clip(T - 2.0, 0, 1) + 0.5 * np.clip(T - 8.0, 0, 1) * (T < 12)
         - 0.7 * np.clip(T - 25.0, 0, 1) + 0.4 * np.clip(T - 31.0, 0, 1) * (T < 35))


def test_a_terrain_exactly_at_the_minimum_probability_is_kept():
    """``min_probability`` drops the terrains *below* it: a share of exactly 0.25 with
    ``min_probability=0.25`` is averaged in (0.75 SNOW + 0.25 ICE), not dropped."""
    cur = np.array([[10.0, 10.0]])
    rim = np.array([[0.5, 0.5]])
    settings = PhysicsSlipSettings(min_probability=0.25)
    snow = physics_slip(HUSKY, {"SNOW": 1.0}, cur, rim, np.zeros(1), settings=settings)
    ice = physics_slip(HUSKY, {"ICE": 1.0}, cur, rim, np.zeros(1), settings=settings)
    assert np.all(np.abs(ice.slip - snow.slip) > 1e-3)
    mixed = physics_slip(HUSKY, {"SNOW": 0.75, "ICE": 0.25}, cur, rim, np.zeros(1),
                         settings=settings)
    np.testing.assert_allclose(mixed.slip, 0.75 * snow.slip + 0.25 * ice.slip, rtol=1e-12)
    np.testing.assert_allclose(mixed.mu, 0.75 * snow.mu + 0.25 * ice.mu, rtol=1e-12)


def test_a_lead_beyond_the_searched_range_is_flagged_at_its_lower_end():
    """A signal 1.5 s *ahead* of the reference, searched up to +-1 s: the maximum lies on the
    first lag searched (-1 s), a correlation still rising there, so it is not applied."""
    ahead = gated_lag(T, STEPS, T, np.interp(T + 1.5, T, STEPS), max_lag_s=1.0)
    assert ahead.at_range_end and not ahead.applied
    assert ahead.lag_s == pytest.approx(-1.0, abs=0.01)
    assert "end of the searched range" in ahead.reason
    # the same lead inside the range is a clear peak of the right sign
    inside = gated_lag(T, STEPS, T, np.interp(T + 0.6, T, STEPS), max_lag_s=1.0)
    assert inside.applied and inside.lag_s == pytest.approx(-0.6, abs=0.01)


def test_every_window_side_at_full_slip_without_an_interval_is_counted_in_meta():
    """Every window-side at full slip (+1) and no ``physics_interval``: all are skipped and
    the plain EKF answers; ``meta`` still counts them (``pseudo_full_slip`` of
    ``pseudo_window_sides``, used as ``"skipped"``), as when only some are."""
    from features.slip_outputs import slip_model_outputs
    from pipelines.validation.harness import simulate_husky
    from terrain.slip.estimate import estimate_skid_steer_slip_run

    run = simulate_husky("ASPHALT", seed=2, duration_s=8.0, icr_expansion=1.0,
                         scenario="straight_accel").run
    out = dict(slip_model_outputs(run))
    out.pop("physics_interval", None)
    t, slip, std = out["physics"]
    out["physics"] = (t, np.ones_like(slip), np.full_like(std, 0.01))
    est = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="none")
    assert est.meta["slip_model"] == "ekf"
    assert any(f"full slip (+-1) on every window-side ({slip.size})" in n for n in est.notes)
    assert est.meta.get("pseudo_full_slip") == slip.size
    assert est.meta.get("pseudo_window_sides") == slip.size
    assert est.meta.get("pseudo_full_slip_use") == "skipped"


def test_the_physics_std_is_floored_before_it_is_used_or_weighted():
    """A physics std under ``min_std`` (1e-4 on firm ground) is raised to it, both as the
    ``physics`` pseudo-measurement's std and in the ``fused`` weights: with physics 0.10
    at std 1e-4 (floored to 0.01) and a learned 0.20 at 0.01, the fused slip is the plain
    mean 0.15, not 0.10 (the unfloored weight 1e4 against 1)."""
    from terrain.slip.estimate import FusionSettings, pseudo_measurement
    t = np.arange(2.0)
    phys = (t, np.full((2, 2), 0.10), np.full((2, 2), 1e-4))
    learned = (t, np.full((2, 2), 0.20), np.full((2, 2), 0.01))
    s = FusionSettings(min_std=0.01, error_correlation=0.0)
    _, sp, vp = pseudo_measurement({"physics": phys}, "physics", s)
    np.testing.assert_allclose(sp, 0.10)
    np.testing.assert_allclose(vp, 0.01)
    _, sf, vf = pseudo_measurement({"physics": phys, "learned": learned}, "fused", s)
    np.testing.assert_allclose(sf, 0.15)
    # the mean of two independent errors, 0.0071, is itself floored
    np.testing.assert_allclose(vf, 0.01)


def test_only_a_finite_physics_slip_without_a_std_counts_as_unknown_std():
    """A window-side whose physics slip is itself NaN is a non-finite measurement, not one of
    unknown std: of a NaN slip with a NaN std and a finite slip with a NaN std, only the
    second is counted in ``pseudo_unknown_std``."""
    from features.slip_outputs import slip_model_outputs
    from pipelines.validation.harness import simulate_husky
    from terrain.slip.estimate import estimate_skid_steer_slip_run

    run = simulate_husky("ASPHALT", seed=2, duration_s=8.0, icr_expansion=1.0,
                         scenario="straight_accel").run
    out = dict(slip_model_outputs(run))
    t, slip, std = out["physics"]
    slip, std = slip.copy(), std.copy()
    slip[2, 0] = std[2, 0] = np.nan
    std[4, 1] = np.nan
    out["physics"] = (t, slip, std)
    est = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="none")
    assert est.meta["pseudo_unknown_std"] == 1
    assert any(f"physics slip without a std on 1 of {std.size} window-sides" in n
               for n in est.notes)


def test_fused_full_slip_window_sides_keep_the_learned_slip_in_the_fusion():
    """``fused`` with a learned model: a full-slip window-side's physics slip is replaced by
    its interval centre (0.3) and then still fused with the learned slip (0.1, ten times
    surer): the filter settles near the learned 0.1, not on the physics centre alone."""
    from features.slip_outputs import slip_model_outputs
    from pipelines.validation.harness import simulate_husky
    from terrain.slip.estimate import estimate_skid_steer_slip_run

    run = simulate_husky("ASPHALT", seed=2, duration_s=12.0, icr_expansion=1.0,
                         scenario="straight_accel").run
    out = dict(slip_model_outputs(run))
    t, slip, std = out["physics"]
    out["physics"] = (t, np.ones_like(slip), np.full_like(std, 0.02))
    out["physics_interval"] = (t, np.full_like(slip, 0.2), np.full_like(slip, 0.4))
    out["learned"] = (t, np.full_like(slip, 0.1), np.full_like(slip, 0.002))
    est = estimate_skid_steer_slip_run(run, "fused", outputs=out, lag="none")
    assert est.meta["slip_model"] == "fused"
    assert est.meta["pseudo_full_slip_use"] == "interval centre"
    late = est.ekf.t_s > 6.0
    np.testing.assert_allclose(np.median(est.slip[late], axis=0), 0.1, atol=0.03)


def test_full_slip_window_sides_without_an_interval_are_skipped_by_the_filter():
    """Windows 2 and 5 at full slip (+1) on both sides and no ``physics_interval``: their
    pseudo-measurement is skipped (the filter counts the two windows as non-finite), not
    taken as a slip of +1; ``meta`` counts the 4 window-sides as ``"skipped"``."""
    from features.slip_outputs import slip_model_outputs
    from pipelines.validation.harness import simulate_husky
    from terrain.slip.estimate import estimate_skid_steer_slip_run

    run = simulate_husky("ASPHALT", seed=2, duration_s=8.0, icr_expansion=1.0,
                         scenario="straight_accel").run
    out = dict(slip_model_outputs(run))
    out.pop("physics_interval", None)
    t, slip, std = out["physics"]
    slip = slip.copy()
    slip[[2, 5]] = 1.0
    out["physics"] = (t, slip, std)
    est = estimate_skid_steer_slip_run(run, "physics", outputs=out, lag="none")
    assert est.meta["pseudo_full_slip"] == 4
    assert est.meta["pseudo_full_slip_use"] == "skipped"
    assert est.ekf.counts["slip_model"]["non_finite"] == 2
    assert np.abs(est.slip).max() < 0.5
