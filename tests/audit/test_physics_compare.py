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


@pytest.mark.slow
def test_same_version_gives_zero_gain(loam_runs):
    s = PhysicsComparisonSettings(reference="v1", candidate="v1", n_bootstrap=50)
    tab, skipped = per_run_errors(loam_runs[:1], s)
    assert not skipped
    np.testing.assert_allclose(tab.sse_ref, tab.sse_new)
    g = gain_table(tab, s)
    # every gain is 0, none NaN (dropna() then allclose passed a table of NaN gains)
    assert len(g) > 0 and (g.rmse_ref > 0).all()
    np.testing.assert_array_equal(g.gain.to_numpy(), 0.0)


@pytest.mark.slow
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


@pytest.mark.slow
def test_replay_physics_is_selectable_and_checked(loam_runs):
    run = max(loam_runs, key=lambda r: float(np.abs(r.streams["wheels"].vel_r
                                                    - r.streams["wheels"].vel_l).max()))
    a = replay_run(run, ReplaySettings(physics="v1"))
    b = replay_run(run, ReplaySettings(physics="v2"))
    assert np.max(np.abs(a.yaw_rate - b.yaw_rate)) > 0.01
    assert ReplaySettings().physics == "v1"
    with pytest.raises(ConfigError):
        ReplaySettings(physics="v0")


def test_a_single_run_gets_no_bootstrap_interval():
    # resampling one run always draws that run: a zero-width "95 % interval" claimed a
    # certainty there is no run-to-run information for (vulpi DIRT_ROAD, one run)
    import pandas as pd
    tab = pd.DataFrame({"run_id": ["a/X/0", "a/Y/0", "a/Y/1"], "terrain": ["X", "Y", "Y"],
                        "signal": "cur", "scope": "moving", "n": [100, 100, 100],
                        "sse_ref": [400.0, 400.0, 300.0], "sse_new": [100.0, 200.0, 90.0]})
    g = gain_table(tab, PhysicsComparisonSettings(n_bootstrap=200)).set_index("terrain")
    assert g.loc["X", "gain"] == pytest.approx(0.5)
    assert np.isnan(g.loc["X", "gain_lo"]) and np.isnan(g.loc["X", "gain_hi"])
    assert g.loc["Y", "gain_lo"] < g.loc["Y", "gain_hi"]
    md = comparison_markdown(g.reset_index(), {"reference": "v1", "candidate": "v2"})
    assert "| X | cur | moving | 1 | 100 | 2 | 1 | +0.500 (one run: no interval) |" in md


def test_the_pooled_interval_resamples_runs_within_each_terrain():
    """The ``all`` row resampled runs across terrains, so every resample had its own terrain
    mix and the interval measured the mix as much as the runs: here every run of a terrain
    is alike (X gains 0.5, Y nothing), so the pooled gain (0.21) is the same in every
    resample that keeps three runs of each, but the unstratified interval spread over
    [0.06, 0.39]. The terrains' own rows draw as before."""
    import pandas as pd
    tab = pd.DataFrame({"run_id": [f"a/{t}/{k}" for t in "XY" for k in range(3)],
                        "terrain": ["X"] * 3 + ["Y"] * 3, "signal": "cur", "scope": "moving",
                        "n": 100, "sse_ref": 400.0, "sse_new": [100.0] * 3 + [400.0] * 3})
    s = PhysicsComparisonSettings(n_bootstrap=200)
    g = gain_table(tab, s).set_index("terrain")
    point = g.loc["all", "gain"]
    assert point == pytest.approx(0.2094, abs=1e-4)
    assert g.loc["all", "gain_lo"] == pytest.approx(point)
    assert g.loc["all", "gain_hi"] == pytest.approx(point)
    uneven = tab.assign(sse_new=[100.0, 200.0, 50.0, 400.0, 300.0, 390.0])
    per_terrain = gain_table(uneven, s).set_index("terrain")
    alone = gain_table(uneven[uneven.terrain == "X"], s).set_index("terrain")
    assert per_terrain.loc["X", ["gain_lo", "gain_hi"]].tolist() == pytest.approx(
        alone.loc["X", ["gain_lo", "gain_hi"]].tolist())


def test_a_scope_without_samples_gets_no_row():
    # the docstring said the gain is NaN where there is no sample; such a scope has no row
    # (behaviour unchanged, docstring corrected; this passed before too)
    import pandas as pd
    tab = pd.DataFrame({"run_id": ["a/X/0", "a/X/0", "a/X/1"], "terrain": "X",
                        "signal": "cur", "scope": ["moving", "stop", "stop"],
                        "n": [100, 0, 0], "sse_ref": [400.0, 0.0, 0.0],
                        "sse_new": [100.0, 0.0, 0.0]})
    g = gain_table(tab, PhysicsComparisonSettings(n_bootstrap=200))
    assert set(g.scope) == {"moving"} and set(g.terrain) == {"X", "all"}


def test_a_negative_turning_resistance_is_explained_in_its_direction():
    from terrain.audit.effects import EFFECT_VOCABULARY, CurrentParams, effect_cause
    assert effect_cause("turning_resistance", CurrentParams(k_a=1.5)) == \
        EFFECT_VOCABULARY["turning_resistance"].cause
    assert "less current than the simulated" in effect_cause("turning_resistance",
                                                             CurrentParams(k_a=-3.18))
    assert effect_cause("current_offset", CurrentParams(k_a=-3.18)) == \
        EFFECT_VOCABULARY["current_offset"].cause


def test_the_comparison_names_the_terrains_whose_runs_chose_v2_parameters():
    # the heading said every table's training runs were SANDY_LOAM's and SNOW's, also on the
    # Vulpi tables (no such terrain; PLOUGHED's K was chosen on its training runs) and
    # silent on ASPHALT, FLOORING and ICE (the tyre's k_S and the ICE friction were chosen
    # on their training halves): their all-run rows read as held out
    import pandas as pd
    tab = pd.DataFrame({"run_id": ["v/PLOUGHED/1", "v/PLOUGHED/3", "v/CONCRETE/1", "b/ICE/00"],
                        "terrain": ["PLOUGHED", "PLOUGHED", "CONCRETE", "ICE"],
                        "signal": "cur", "scope": "moving", "n": 100,
                        "sse_ref": 400.0, "sse_new": 100.0})
    md = comparison_markdown(gain_table(tab, PhysicsComparisonSettings(n_bootstrap=50)),
                             {"reference": "v1", "candidate": "v2"})
    head = md.split("| terrain |")[0]
    assert "SANDY_LOAM" not in head and "SNOW" not in head
    assert "ICE" in head and "PLOUGHED" in head and "CONCRETE" not in head


@pytest.mark.parametrize("kwargs", [dict(reference="v3"), dict(candidate="V2")])
def test_an_unknown_physics_version_is_refused_not_an_empty_table(kwargs):
    # every run was skipped by the replay's error and the comparison came back empty
    with pytest.raises(ConfigError, match="physics versions must be among"):
        PhysicsComparisonSettings(**kwargs)


def test_a_pooled_row_of_one_run_per_terrain_gets_no_bootstrap_interval():
    """Resampled within each terrain, one run per terrain always draws the same runs: the
    pooled row of X (gain 0.5) and Y (gain 0.1) got the zero-width interval [0.272, 0.272]
    around its gain, a certainty there is no run-to-run information for."""
    import pandas as pd
    tab = pd.DataFrame({"run_id": ["a/X/0", "a/Y/0"], "terrain": ["X", "Y"], "signal": "cur",
                        "scope": "moving", "n": [100, 100], "sse_ref": [400.0, 400.0],
                        "sse_new": [100.0, 324.0]})
    g = gain_table(tab, PhysicsComparisonSettings(n_bootstrap=200)).set_index("terrain")
    assert g.loc["all", "n_runs"] == 2 and np.isfinite(g.loc["all", "gain"])
    assert np.isnan(g.loc["all", "gain_lo"]) and np.isnan(g.loc["all", "gain_hi"])


@pytest.mark.parametrize("kwargs, match", [
    (dict(n_bootstrap=10.5), r"n_bootstrap must be an integer in \[10, "),
    (dict(n_bootstrap=5), r"n_bootstrap must be an integer in \[10, "),
    (dict(seed=float("nan")), r"seed must be an integer >= 0, got nan"),
    (dict(seed=1.5), r"seed must be an integer >= 0, got 1.5"),
    (dict(seed=-1), r"seed must be an integer >= 0, got -1")])
def test_comparison_settings_refuse_counts_that_are_not_integers(kwargs, match):
    # seed NaN and n_bootstrap 10.5 passed the range check; gain_table then raised numpy's
    # TypeError
    with pytest.raises(ConfigError, match=match):
        PhysicsComparisonSettings(**kwargs)
