"""Review tests (aud11) of terrain.audit: the reason given when the replay leaves nothing to
remove, the ceiling's unknown chi, one terrain per learned transfer, and mutants that the
earlier tests let through."""

from __future__ import annotations

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit.selection import SelectionSettings, select_group

FAST = SelectionSettings(n_bootstrap=100, n_param_bootstrap=0)


def _units(n=4, **kw):
    return [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, **kw)] for i in range(n)]


def test_a_replay_without_error_is_not_reported_as_having_no_samples():
    # a gyro that reads the replay exactly (noise 0): every turning sample is scored, the
    # replay leaves nothing to remove; the reason said "no scored samples in scope 'turning'"
    g = select_group(_units(noise=0.0), "yaw", "ASPHALT", FAST)
    assert g.selected == ()
    for e in g.effects:
        assert not e.supported
        assert "no scored samples" not in e.reason
        assert "no error" in e.reason and "scored samples" in e.reason


def test_the_replays_chi_is_the_reciprocal_slope_of_its_yaw_rate_on_the_command():
    # chi_replay = sum(x^2) / sum(x sim_wz) (as chi is of the gyro), not the least squares
    # of x on the replayed yaw rate, sum(x sim_wz) / sum(sim_wz^2): with a noisy replayed
    # yaw rate the two differ by the noise's share of sum(sim_wz^2)
    from dataclasses import replace

    from terrain.audit.effects import fit_yaw
    from terrain.audit.frames import CURVE, SPIN
    rng = np.random.default_rng(7)
    frames = []
    for i in range(3):
        f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, noise=0.0)
        frames.append(replace(f, sim_wz=f.sim_wz + 0.2 * rng.standard_normal(f.n)))
    p = fit_yaw(frames, ["icr_expansion"])
    turn = [f.score_imu & np.isin(f.manoeuvre, (CURVE, SPIN)) for f in frames]
    x = np.concatenate([f.commanded_yaw_rate[m] for f, m in zip(frames, turn)])
    s = np.concatenate([f.sim_wz[m] for f, m in zip(frames, turn)])
    assert p.fraction == 0.0 and p.chi == pytest.approx(1.5, rel=1e-9)
    assert p.chi_replay == pytest.approx(np.sum(x * x) / np.sum(x * s), rel=1e-9)
    assert abs(p.chi_replay - np.sum(x * s) / np.sum(s * s)) > 0.05


def test_a_pooled_row_of_one_run_per_terrain_says_so_not_one_run():
    # two terrains with one run each: the pooled row has 2 runs and no interval (one run per
    # terrain: resampling within terrains cannot vary); the page said "(one run: ...)"
    import pandas as pd

    from terrain.audit.physics import PhysicsComparisonSettings, comparison_markdown, gain_table
    per_run = pd.DataFrame(
        [("a", "ASPHALT", "wz", "moving", 100, 4.0, 1.0),
         ("b", "SNOW", "wz", "moving", 100, 9.0, 4.0)],
        columns=["run_id", "terrain", "signal", "scope", "n", "sse_ref", "sse_new"])
    table = gain_table(per_run, PhysicsComparisonSettings(n_bootstrap=50))
    pooled = table[table.terrain == "all"].iloc[0]
    assert pooled.n_runs == 2 and np.isnan(pooled.gain_lo)
    page = comparison_markdown(table, {"reference": "v1", "candidate": "v2"})
    assert "| ASPHALT | wz | moving | 1 | 100 | 0.2 | 0.1 | +0.500 (one run: no interval) |" \
        in page
    line = next(ln for ln in page.splitlines() if ln.startswith("| all |"))
    assert line.endswith("(one run per terrain: no interval) |")


def test_current_offsets_are_medians_of_straight_driving_not_means():
    # the right side reads 0.5 A more; the left reading jumps by 8 A on one straight sample
    # in ten (the replay fighting a sub-resolution speed split): the median offsets ignore
    # the jumps, a mean would move the left offset by 0.8 A
    from dataclasses import replace

    from terrain.audit.effects import fit_current
    from terrain.audit.frames import STRAIGHT
    frames = []
    for i in range(3):
        f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, offsets_a=(0.0, 0.5), noise=0.002)
        cur = f.cur.copy()
        jump = (f.manoeuvre == STRAIGHT) & (np.arange(f.n) % 10 == 0)
        cur[jump, 0] += 8.0
        frames.append(replace(f, cur=cur))
    p = fit_current(frames, ["current_offset"])
    assert p.offset_left_a == pytest.approx(0.0, abs=0.02)
    assert p.offset_a == pytest.approx(0.5, abs=0.02)


def test_the_ceiling_reports_an_unknown_chi_where_no_turn_was_commanded_not_a_dug_in_one():
    # straight driving with the wheels exactly level (x = 0): the measured chi of the
    # straight samples is unknown (NaN), as the replays' beside it, not inf ("dug in")
    from terrain.audit.ceiling import yaw_rate_ceiling_samples
    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5) for i in range(3)]
    tab = yaw_rate_ceiling_samples(frames[:2], train_frames=frames[2:])
    assert np.isnan(tab.attrs["chi_reference"]["straight"])
    assert np.isnan(tab.attrs["chi_shared"]["straight"])
    assert np.isnan(tab.attrs["chi_trained"]["straight"])
    assert tab.attrs["chi_shared"]["spin"] == pytest.approx(1.5, rel=0.01)
    # the predictions of the straight samples stay 0 yaw rate (x = 0), finite
    straight = tab[tab.manoeuvre == "straight"]
    assert np.isfinite(straight[["shared", "per_run", "trained"]].to_numpy()).all()


def test_the_scored_span_keeps_the_samples_exactly_edge_s_from_either_end():
    from terrain.audit.frames import FrameSettings, scored_span
    t = np.arange(0.0, 10.25, 0.25)
    m = scored_span(t, FrameSettings(edge_s=2.0))
    assert t[m][0] == 2.0 and t[m][-1] == 8.0 and m.sum() == 25


def test_the_online_forecast_uses_the_samples_exactly_lead_s_back():
    # _forgetting_sums' rule: samples with t_j <= t - lead_s; on a clock of 0.25 s steps,
    # lead 0.5 s reaches the sample two steps back exactly
    from dataclasses import replace

    from terrain.audit.ceiling import online_current_samples
    from terrain.audit.frames import STRAIGHT
    f = synthetic_frame("s/ASPHALT/0", noise=0.0)
    n = f.n
    t = np.arange(n) * 0.25
    cur = f.sim_cur.copy()
    cur[:, 1] += 1.0                                   # the right side reads 1 A more
    f = replace(f, t_s=t, cur=cur, manoeuvre=np.full(n, STRAIGHT, dtype=np.int8),
                score_cur=np.ones(n, dtype=bool))
    out = online_current_samples([f], lead_s=0.5, memory_s=1e9, prior_s=0.0)
    right = out[out.side == 1].online.to_numpy() - out[out.side == 1].reference.to_numpy()
    # sample 2 has samples 0 (t = 0 <= 0.5 - 0.5) as evidence: the full 1 A correction
    assert right[:2] == pytest.approx([0.0, 0.0]) and right[2] == pytest.approx(1.0)


def test_the_learned_transfer_refuses_runs_of_another_terrain():
    # its docstring asks for training and evaluated runs of one terrain (the family has one
    # parameter set per terrain, as the steady ones, which refuse a mix): a SNOW run among
    # ASPHALT training runs, or ASPHALT runs evaluated on SNOW, trained across terrains
    # without a word
    from terrain.audit.ceiling import learned_transfer_samples
    from terrain.errors import ConfigError
    asphalt = [synthetic_frame(f"s/ASPHALT/{i}", seed=i) for i in range(3)]
    snow = synthetic_frame("s/SNOW/0", terrain="SNOW", seed=9)
    with pytest.raises(ConfigError, match="terrain"):
        learned_transfer_samples(asphalt[:2], [snow], "wz")
    with pytest.raises(ConfigError, match="terrain"):
        learned_transfer_samples(asphalt[:1] + [snow], asphalt[2:], "wz")
    out = learned_transfer_samples(asphalt[:2], asphalt[2:], "wz")
    assert set(out.run_id) == {"s/ASPHALT/2"}


@pytest.mark.slow
def test_the_friction_sweep_replays_the_runs_the_audit_audited_only():
    # a run whose gyro holds a NaN is skipped by the audit (its measured chi is not in the
    # facts), but its wheels replay: the sweep replayed it beside the audited run and set
    # the replayed chi of two runs against the measured chi of one
    from dataclasses import replace

    import pandas as pd

    from terrain.audit import AuditSettings, run_audit
    from terrain.run import Run
    t = np.arange(0.0, 20.0, 0.15)
    ti = np.arange(0.0, 20.0, 0.01)

    def run(run_id):
        pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": -0.3, "vel_r": 0.3})
        imu = pd.DataFrame({"t_s": ti, "wz": 0.5, "ax": 0.0, "ay": 0.0})
        return Run(run_id=run_id, dataset="x", terrain="ASPHALT",
                   streams={"wheels": pro, "imu": imu}, vehicle="husky")
    good, bad = run("x/ASPHALT/00"), run("x/ASPHALT/01")
    imu = bad.streams["imu"].copy()
    imu.loc[500, "wz"] = np.nan
    bad = replace(bad, streams={**bad.streams, "imu": imu})
    res = run_audit([good, bad], AuditSettings(sweep_factors=(1.0,)))
    assert list(res.skipped) == ["x/ASPHALT/01"] and res.facts["ASPHALT"]["runs"] == 1
    assert list(res.sweep.n_runs) == [1]
