"""The v1/v2 physics comparison of the audit on shipped BorealTC runs."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.audit.physics import (PhysicsComparisonSettings, comparison_markdown,
                                   gain_table, per_run_errors)
from terrain.audit.replay import ReplaySettings, replay_run
from terrain.errors import ConfigError


@pytest.fixture(scope="module")
def loam_runs(shipped_borealtc):
    runs = [r for r in shipped_borealtc.values() if r.terrain == "SANDY_LOAM"]
    return sorted(runs, key=lambda r: r.run_id)[:3]


def test_same_version_gives_zero_gain(loam_runs):
    s = PhysicsComparisonSettings(reference="v1", candidate="v1", n_bootstrap=50)
    tab, skipped = per_run_errors(loam_runs[:1], s)
    assert not skipped
    np.testing.assert_allclose(tab.sse_ref, tab.sse_new)
    g = gain_table(tab, s)
    assert np.allclose(g.gain.dropna(), 0.0)


def test_v2_cuts_the_sandy_loam_yaw_error(loam_runs):
    s = PhysicsComparisonSettings(n_bootstrap=200)
    tab, _ = per_run_errors(loam_runs, s)
    g = gain_table(tab, s)
    row = g[(g.terrain == "SANDY_LOAM") & (g.signal == "wz") & (g.scope == "moving")].iloc[0]
    assert row.n_runs == len(loam_runs)
    assert row.gain > 0.1 and row.gain_lo <= row.gain <= row.gain_hi
    # pooled and per-terrain agree for a single terrain
    pooled = g[(g.terrain == "all") & (g.signal == "wz") & (g.scope == "moving")].iloc[0]
    assert pooled.rmse_new == pytest.approx(row.rmse_new)
    md = comparison_markdown(g, {"reference": "v1", "candidate": "v2"})
    assert "| SANDY_LOAM | wz | moving |" in md


def test_replay_physics_is_selectable_and_checked(loam_runs):
    run = max(loam_runs, key=lambda r: float(np.abs(r.streams["wheels"].vel_r
                                                    - r.streams["wheels"].vel_l).max()))
    a = replay_run(run, ReplaySettings(physics="v1"))
    b = replay_run(run, ReplaySettings(physics="v2"))
    assert np.max(np.abs(a.yaw_rate - b.yaw_rate)) > 0.01
    assert ReplaySettings().physics == "v1"
    with pytest.raises(ConfigError):
        ReplaySettings(physics="v0")
