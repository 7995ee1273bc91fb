"""Ceilings of a model family with one parameter set per terrain (terrain.audit.ceiling)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.audit.ceiling import (TransferSettings, ceiling_table, current_ceiling_samples,
                                   history_features, learned_transfer_samples,
                                   online_current_samples, online_yaw_rate_samples,
                                   yaw_rate_ceiling_samples)
from terrain.audit.frames import MANOEUVRES, AuditFrame
from terrain.audit.physics import alternate_split
from terrain.audit.timing import LagTrack
from terrain.errors import ConfigError

RATE_HZ = 6.5
SPIN, STRAIGHT = MANOEUVRES.index("spin"), MANOEUVRES.index("straight")


def _frame(run_id, wz_of, n_cycles=4, spin_s=12.0, straight_s=8.0, terrain="SNOW",
           rng=None, noise=0.0):
    """Alternating straight driving and spins in place; ``wz_of(x, t_in_spin)`` is the gyro."""
    x, v, man, t_in = [], [], [], []
    for k in range(n_cycles):
        n_st, n_sp = int(straight_s * RATE_HZ), int(spin_s * RATE_HZ)
        x += [0.0] * n_st + [(0.6 + 0.2 * k) * (-1) ** k] * n_sp
        v += [0.5] * n_st + [0.0] * n_sp
        man += [STRAIGHT] * n_st + [SPIN] * n_sp
        t_in += list(np.arange(n_st) / RATE_HZ) + list(np.arange(n_sp) / RATE_HZ)
    x, v, t_in = np.array(x), np.array(v), np.array(t_in)
    n = len(x)
    wz = wz_of(x, t_in)
    if rng is not None:
        wz = wz + noise * rng.standard_normal(n)
    ones = np.ones(n, dtype=bool)
    return AuditFrame(
        run_id=run_id, group=run_id, terrain=terrain, t_s=np.arange(n) / RATE_HZ,
        commanded_yaw_rate=x, commanded_speed=v, manoeuvre=np.array(man),
        quiet=~ones, sim_wz=x / 3.0, sim_ax=np.zeros(n), sim_ay=np.zeros(n),
        sim_vx=v.copy(), sim_cur=np.column_stack([2 + 3 * np.abs(x), 2 + 3 * np.abs(x)]),
        cur=np.column_stack([3.5 + 6.5 * np.abs(x), 3.5 + 6.5 * np.abs(x)]), has_imu=True,
        wz=wz, ax=np.zeros(n), ay=np.zeros(n), pitch=np.zeros(n), has_pitch=ones.copy(),
        imu_t_s=np.arange(n) / RATE_HZ, imu_wz=wz, score_imu=ones, score_cur=ones.copy(),
        lag=LagTrack(np.empty(0), np.empty(0), np.empty(0), 0))


def _row(tab, scope):
    return tab[tab.scope == scope].iloc[0]


def test_one_ground_state_per_terrain_reaches_the_per_run_fit():
    rng = np.random.default_rng(0)
    frames = [_frame(f"r{k}", lambda x, t: x / 2.0, rng=rng, noise=0.002) for k in range(3)]
    tab = yaw_rate_ceiling_samples(frames)
    assert tab.attrs["chi_shared"]["spin"] == pytest.approx(2.0, rel=0.01)
    # the replay's own chi on the same commanded turns: the frames' sim_wz is x / 3
    assert tab.attrs["chi_reference"]["spin"] == pytest.approx(3.0)
    assert "chi_candidate" not in tab.attrs
    candidates = [replace(f, sim_wz=f.commanded_yaw_rate / 1.5) for f in frames]
    with_candidate = yaw_rate_ceiling_samples(frames, candidates)
    assert with_candidate.attrs["chi_candidate"]["spin"] == pytest.approx(1.5)
    # straight driving commands no turn: its chi is not defined
    assert np.isnan(with_candidate.attrs["chi_candidate"]["straight"])
    t = ceiling_table(tab)
    spin = _row(t, "spin")
    assert spin.n_runs == 3
    # the replay's chi 3 against the true 2: the shared fit removes nearly all of it
    assert spin.gain_shared > 0.95
    assert spin.rmse_per_run <= spin.rmse_shared + 1e-12
    assert spin.gain_shared == pytest.approx(spin.gain_per_run, abs=0.01)
    assert set(t.scope) == {"moving", "straight", "spin"}


def test_bimodal_runs_cap_the_shared_model_at_the_between_run_spread():
    # half of the runs turn freely (chi 1.5), half dig in (chi 6): no single chi fits both
    frames = [_frame(f"free{k}", lambda x, t: x / 1.5) for k in range(2)]
    frames += [_frame(f"dug{k}", lambda x, t: x / 6.0) for k in range(2)]
    tab = yaw_rate_ceiling_samples(frames)
    x, y = np.concatenate([f.commanded_yaw_rate for f in frames]), \
        np.concatenate([f.wz for f in frames])
    spin = np.concatenate([f.manoeuvre for f in frames]) == SPIN
    a = (x[spin] @ y[spin]) / (x[spin] @ x[spin])
    assert tab.attrs["chi_shared"]["spin"] == pytest.approx(1.0 / a)
    row = _row(ceiling_table(tab), "spin")
    assert row.gain_per_run == pytest.approx(1.0, abs=1e-9)
    # analytic: the residual of one slope on two groups of equal x^2 is |a1 - a2| / 2 |x|
    resid = np.sqrt(np.mean((y[spin] - a * x[spin]) ** 2))
    assert row.rmse_shared == pytest.approx(resid)
    assert row.gain_shared < 0.2


def test_current_recalibration_recovers_an_affine_law_and_counts_fallbacks():
    frames = [_frame("a", lambda x, t: x / 2.0), _frame("b", lambda x, t: x / 2.0)]
    tab = current_ceiling_samples(frames)
    assert set(tab.side) == {0, 1}
    # both sides draw 0.5 + 1.5 x the replay's current + 2 |x|: one affine law, recovered
    np.testing.assert_allclose(tab.shared, tab.measured, atol=1e-9)
    np.testing.assert_allclose(tab.per_run, tab.measured, atol=1e-9)
    assert tab.attrs["per_run_fallback"] == 0
    short = replace(frames[0], run_id="c", score_cur=np.arange(frames[0].n) < 5)
    tab2 = current_ceiling_samples([frames[1], short])
    assert tab2.attrs["per_run_fallback"] == 2 * 5  # both sides of the 5 samples of "c"
    # a law that differs between the sides is not in the family (one set for both sides)
    skew = replace(frames[0], cur=frames[0].cur * np.array([1.0, 1.5]))
    row = _row(ceiling_table(current_ceiling_samples([skew])), "moving")
    assert row.gain_per_run == pytest.approx(row.gain_shared) and row.rmse_shared > 0.5


def test_the_family_fitted_on_training_runs_carries_over_only_what_the_runs_share():
    # training runs and held-out runs of one ground state: the trained chi is the shared one
    train = [_frame(f"t{k}", lambda x, t: x / 2.0) for k in range(2)]
    held = [_frame(f"h{k}", lambda x, t: x / 2.0, spin_s=10.0) for k in range(2)]
    tab = yaw_rate_ceiling_samples(held, train_frames=train)
    assert tab.attrs["chi_trained"]["spin"] == pytest.approx(2.0)
    assert tab.attrs["trained_fallback"] == 0
    np.testing.assert_allclose(tab.trained, tab.measured, atol=1e-12)
    # the training runs turn freely (chi 1.5), the held-out ones dig in (chi 6): what the
    # training runs teach is worse than the replay's chi 3, while the shared fit is exact
    free = [_frame(f"t{k}", lambda x, t: x / 1.5) for k in range(2)]
    dug = [_frame(f"h{k}", lambda x, t: x / 6.0) for k in range(2)]
    row = _row(ceiling_table(yaw_rate_ceiling_samples(dug, train_frames=free)), "spin")
    assert row.gain_shared == pytest.approx(1.0)
    assert row.gain_trained < 0.0
    # x / 1.5 against x / 6: the error is 3 times the replay's (x / 3 against x / 6)
    assert row.rmse_trained == pytest.approx(3.0 * row.rmse_reference)
    # no curve in the training runs: the held-out curve samples keep the replay, counted
    curve = MANOEUVRES.index("curve")
    bent = replace(dug[0], manoeuvre=np.where(dug[0].manoeuvre == SPIN, curve, STRAIGHT))
    tab = yaw_rate_ceiling_samples([bent], train_frames=free)
    n_curve = int((bent.manoeuvre == curve).sum())
    assert tab.attrs["trained_fallback"] == n_curve
    on_curve = (tab.manoeuvre == "curve").to_numpy()
    np.testing.assert_array_equal(tab.trained[on_curve], tab.reference[on_curve])
    # without training runs the column is empty and ceiling_table leaves it out
    assert tab.shape[0] and yaw_rate_ceiling_samples(dug).trained.isna().all()
    assert "gain_trained" not in ceiling_table(yaw_rate_ceiling_samples(dug)).columns


def test_current_recalibration_fitted_on_training_runs_is_applied_to_the_held_out_ones():
    train = [_frame("t0", lambda x, t: x), _frame("t1", lambda x, t: x)]
    held = [_frame("h0", lambda x, t: x, spin_s=9.0)]
    cand = [replace(f, sim_cur=0.5 * f.sim_cur) for f in held]
    train_cand = [replace(f, sim_cur=0.5 * f.sim_cur) for f in train]
    # the held-out run draws 2 A more than the training runs, on both sides
    shifted = [replace(held[0], cur=held[0].cur + 2.0)]
    tab = current_ceiling_samples(shifted, cand, train_frames=train, train_candidates=train_cand)
    assert tab.attrs["trained_fallback"] == 0
    # the affine law of the training runs, applied: exactly 2 A short everywhere
    np.testing.assert_allclose(tab.measured - tab.trained, 2.0, atol=1e-9)
    np.testing.assert_allclose(tab.shared, tab.measured, atol=1e-9)
    row = _row(ceiling_table(tab), "moving")
    assert row.rmse_trained == pytest.approx(2.0)
    # steady runs: the replay's current is constant within a manoeuvre but for 1e-7 A of
    # rounding, the measured one noisy; the fit must not read a law out of the rounding
    # (untruncated least squares fits the noise with coefficients of ~1e5 that cancel on
    # the training samples only)
    rng = np.random.default_rng(2)

    def flat(f, spin_a=4.0):
        return replace(f, sim_cur=np.where(f.manoeuvre[:, None] == SPIN, spin_a, 2.0)
                       + 1e-7 * rng.standard_normal(f.sim_cur.shape),
                       cur=f.cur + 0.1 * rng.standard_normal(f.cur.shape))
    # the held-out run's replay spins 0.2 A higher: the physics it is a correction of keeps
    # that step, where an undetermined coefficient would multiply it
    tab = current_ceiling_samples([flat(held[0], 4.2)], train_frames=[flat(f) for f in train])
    law = 3.5 + 6.5 * np.abs(np.concatenate([held[0].commanded_yaw_rate] * 2))
    step = np.where(tab.manoeuvre == "spin", 0.2, 0.0)
    assert np.sqrt(np.mean((tab.trained - law - step) ** 2)) < 0.02
    with pytest.raises(ConfigError, match="both"):
        current_ceiling_samples(held, cand, train_frames=train)
    with pytest.raises(ConfigError, match="overlap"):
        current_ceiling_samples(held, train_frames=held)
    with pytest.raises(ConfigError, match="another terrain"):
        current_ceiling_samples(held, train_frames=[replace(train[0], terrain="ICE")])
    with pytest.raises(ConfigError, match="train_frames"):
        current_ceiling_samples(held, cand, train_candidates=train_cand)
    # a terrain with training runs only (Vulpi's single DIRT_ROAD run): nothing to evaluate
    assert current_ceiling_samples([], train_frames=train).empty
    assert yaw_rate_ceiling_samples([], train_frames=train).empty


def test_learned_transfer_finds_a_planted_history_effect_the_steady_family_misses():
    # a rut that deepens while the wheels spin: chi grows with the time spent spinning
    def dig(x, t):
        return x / (1.2 + 0.4 * t)
    rng = np.random.default_rng(1)
    train = [_frame(f"t{k}", dig, spin_s=10.0 + 2 * k, rng=rng, noise=0.002) for k in range(4)]
    test = [_frame(f"h{k}", dig, spin_s=11.0 + 2 * k, rng=rng, noise=0.002) for k in range(2)]
    learned = ceiling_table(learned_transfer_samples(train, test, "wz"))
    steady = ceiling_table(yaw_rate_ceiling_samples(test))
    assert _row(learned, "spin").gain_learned > 0.85
    # even fitted on the evaluated runs, one chi per manoeuvre cannot follow it
    assert _row(steady, "spin").gain_shared < _row(learned, "spin").gain_learned - 0.1
    assert _row(learned, "spin").rmse_reference == pytest.approx(
        _row(steady, "spin").rmse_reference)


@pytest.mark.slow
def test_learned_transfer_ignores_last_place_differences_of_the_replay(monkeypatch):
    # two builds of the same physics differ in the last places of their replays (a compiled
    # kernel's floating-point order); the learned transfer must not split on that noise
    import terrain.audit.ceiling as ceiling

    def dig(x, t):
        return x / (1.2 + 0.4 * t)

    def jitter(frames, seed):
        r = np.random.default_rng(seed)
        return [replace(f, sim_wz=f.sim_wz * (1 + 1e-13 * r.standard_normal(f.n)))
                for f in frames]

    rng = np.random.default_rng(3)
    train = [_frame(f"t{k}", dig, spin_s=10.0 + 2 * k, rng=rng, noise=0.002) for k in range(4)]
    test = [_frame(f"h{k}", dig, spin_s=11.0 + 2 * k, rng=rng, noise=0.002) for k in range(2)]

    def learned(a, b):
        return learned_transfer_samples(jitter(train, a), jitter(test, b), "wz").learned

    np.testing.assert_array_equal(learned(0, 1), learned(2, 3))
    # unrounded, the histogram bins fall inside the jitter and the predictions move
    monkeypatch.setattr(ceiling, "LEARNED_INPUT_DECIMALS", 15)
    assert not np.array_equal(learned(0, 1), learned(2, 3))


def test_online_chi_recovers_each_runs_ground_state_where_one_chi_cannot():
    # bimodal runs again: the online estimate learns each run's chi from its own gyro
    frames = [_frame(f"free{k}", lambda x, t: x / 1.5) for k in range(2)]
    frames += [_frame(f"dug{k}", lambda x, t: x / 6.0) for k in range(2)]
    on = online_yaw_rate_samples(frames, lead_s=2.0, memory_s=30.0, prior_s=2.0)
    shared = yaw_rate_ceiling_samples(frames)
    np.testing.assert_array_equal(on.measured, shared.measured)   # same samples, same order
    shared["online"] = on["online"].to_numpy()
    row = _row(ceiling_table(shared), "spin")
    assert row.gain_online > 0.8 > 0.2 > row.gain_shared
    # before any evidence (the first spin's first lead_s) the forecast is the replay
    first = frames[0]
    spin = np.flatnonzero(first.manoeuvre[first.score_imu] == SPIN)
    start = spin[: int(2.0 * RATE_HZ)]
    np.testing.assert_allclose(on.online.to_numpy()[start], first.sim_wz[start])


def test_online_chi_is_causal_and_shrinks_towards_the_replay():
    base = _frame("a", lambda x, t: x / 2.0)
    on = online_yaw_rate_samples([base], lead_s=2.0, memory_s=30.0, prior_s=2.0).online
    # a different gyro after 40 s cannot change a forecast made before 42 s
    late = base.t_s > 40.0
    changed = replace(base, wz=np.where(late, 5 * base.wz, base.wz))
    on2 = online_yaw_rate_samples([changed], lead_s=2.0, memory_s=30.0, prior_s=2.0).online
    early = base.t_s[base.score_imu] <= 42.0 - 1e-9
    np.testing.assert_allclose(on2.to_numpy()[early], on.to_numpy()[early])
    assert not np.allclose(on2.to_numpy()[~early], on.to_numpy()[~early])
    # a heavier prior keeps the forecast closer to the replay (x / 3 here, truth x / 2)
    heavy = online_yaw_rate_samples([base], lead_s=2.0, memory_s=30.0, prior_s=500.0).online
    spin = base.manoeuvre == SPIN
    err = lambda p: np.abs(p.to_numpy()[spin] - base.wz[spin]).mean()  # noqa: E731
    assert err(on) < err(heavy) < np.abs(base.sim_wz[spin] - base.wz[spin]).mean()
    with pytest.raises(ConfigError):
        online_yaw_rate_samples([base], memory_s=0.0)


def test_online_current_learns_a_per_run_offset_causally():
    # two runs whose motors draw 1.5 A and 4 A above the replay: no shared offset fits both
    base = _frame("a", lambda x, t: x)
    runs = [replace(base, run_id="low", cur=base.sim_cur + 1.5),
            replace(base, run_id="high", cur=base.sim_cur + 4.0)]
    on = online_current_samples(runs, lead_s=2.0, memory_s=15.0, prior_s=0.5)
    ce = current_ceiling_samples(runs)
    np.testing.assert_array_equal(on.measured, ce.measured)       # same rows, same order
    np.testing.assert_array_equal(on.side, ce.side)
    ce["online"] = on["online"].to_numpy()
    row = _row(ceiling_table(ce), "moving")
    assert row.gain_per_run == pytest.approx(1.0)
    assert row.gain_online > row.gain_shared + 0.15
    # the first lead_s of each manoeuvre is the replay itself; later the offset is learned,
    # shrunk by the prior: W / (prior + W) of it, W -> memory_s in steady state
    low = on[(on.run_id == "low") & (on.side == 0)]
    np.testing.assert_allclose(low.online.to_numpy()[:13], base.sim_cur[:13, 0])
    learned = low.online.to_numpy()[-1] - base.sim_cur[-1, 0]
    assert 1.5 * 0.85 < learned < 1.5 * 15.0 / 15.5 + 1e-9


def test_history_features_look_back_and_time_the_manoeuvre():
    f = _frame("a", lambda x, t: x, n_cycles=1, straight_s=2.0, spin_s=2.0)
    X = history_features(f, f.sim_wz, lags=(1, 3))
    assert X.shape == (f.n, 4 + 2 * 2 + 2 + 1)
    x = f.commanded_yaw_rate
    np.testing.assert_allclose(X[3:, 4], x[2:-1])       # x one sample back
    np.testing.assert_allclose(X[5:, 6], x[2:-3])       # x three samples back
    first_spin = int(np.argmax(f.manoeuvre == SPIN))
    assert X[first_spin, 8] == 0.0 and X[first_spin - 1, 8] > 0.0
    assert X[first_spin + 2, 8] == pytest.approx(2 / RATE_HZ)


def test_inputs_are_checked():
    a, b = _frame("a", lambda x, t: x), _frame("b", lambda x, t: x)
    with pytest.raises(ConfigError, match="candidate"):
        yaw_rate_ceiling_samples([a, b], [a])
    with pytest.raises(ConfigError, match="clock"):
        yaw_rate_ceiling_samples([a], [b])
    with pytest.raises(ConfigError, match="one terrain"):
        current_ceiling_samples([a, replace(b, terrain="ICE")])
    with pytest.raises(ConfigError, match="overlap"):
        learned_transfer_samples([a], [a], "wz")
    with pytest.raises(ConfigError, match="signal"):
        learned_transfer_samples([a], [b], "ax")
    with pytest.raises(ConfigError, match="both"):
        learned_transfer_samples([a], [b], "wz", train_candidates=[a])


def test_alternate_split_takes_every_other_run_in_id_order():
    class R:
        def __init__(self, run_id):
            self.run_id = run_id
    train, held = alternate_split([R("S/03"), R("S/01"), R("S/02"), R("S/04"), R("S/05")])
    assert [r.run_id for r in train] == ["S/01", "S/03", "S/05"]
    assert [r.run_id for r in held] == ["S/02", "S/04"]


def test_fits_on_training_runs_never_see_the_evaluated_runs_measurements():
    # the trained and learned columns are fitted on the training runs only: replacing the
    # evaluated runs' gyro and currents changes their measured column, not those predictions
    rng = np.random.default_rng(4)
    train = [_frame(f"t{k}", lambda x, t: x / 2.0, rng=rng, noise=0.01) for k in range(3)]
    held = [_frame(f"h{k}", lambda x, t: x / 2.0, rng=rng, noise=0.01) for k in range(2)]
    other = [replace(f, wz=5.0 * f.wz + 0.3, cur=3.0 * f.cur + 4.0) for f in held]
    settings = TransferSettings(max_iter=20)
    for fn, col in ((yaw_rate_ceiling_samples, "trained"), (current_ceiling_samples, "trained")):
        a, b = fn(held, train_frames=train), fn(other, train_frames=train)
        assert not np.allclose(a.measured, b.measured)
        np.testing.assert_array_equal(a[col], b[col])
    for signal in ("wz", "cur_l"):
        a = learned_transfer_samples(train, held, signal, settings=settings)
        b = learned_transfer_samples(train, other, signal, settings=settings)
        assert not np.allclose(a.measured, b.measured)
        np.testing.assert_array_equal(a.learned, b.learned)


def test_unscorable_samples_are_left_out_of_every_fit():
    # standing samples and samples whose gyro is NaN are not scored: the table has no row
    # for them and the fits stay finite
    f = _frame("a", lambda x, t: x / 2.0)
    stop = np.zeros(f.n, dtype=bool)
    stop[:10] = True
    wz = f.wz.copy()
    wz[20:25] = np.nan
    g = replace(f, manoeuvre=np.where(stop, MANOEUVRES.index("stop"), f.manoeuvre), wz=wz)
    tab = yaw_rate_ceiling_samples([g])
    assert len(tab) == f.n - 10 - 5 and "stop" not in set(tab.manoeuvre)
    assert np.isfinite(tab[["measured", "shared", "per_run"]].to_numpy()).all()
    assert tab.attrs["chi_shared"]["spin"] == pytest.approx(2.0)
    cur = current_ceiling_samples([g])
    assert len(cur) == 2 * (f.n - 10) and "stop" not in set(cur.manoeuvre)


def test_side_speeds_are_the_left_and_right_ones():
    # on curves the sides run at v -+ x B / 2 (left, right); a current that grows with its
    # own side's speed is in the family, so the shared fit reproduces it exactly
    from terrain.vehicles import HUSKY
    f = _frame("a", lambda x, t: x / 2.0)
    curve = MANOEUVRES.index("curve")
    # a speed that varies along the curves: |v - xB/2| + |v + xB/2| = 2 v is then no
    # constant, and one side's speed cannot stand in for the other's
    v = np.where(f.manoeuvre == SPIN, 0.6 + 0.2 * np.sin(f.t_s), f.commanded_speed)
    x = f.commanded_yaw_rate
    half = 0.5 * HUSKY.track_m * x
    cur = np.column_stack([1.0 + 4.0 * np.abs(v - half), 1.0 + 4.0 * np.abs(v + half)])
    g = replace(f, commanded_speed=v, cur=cur,
                manoeuvre=np.where(f.manoeuvre == SPIN, curve, f.manoeuvre))
    tab = current_ceiling_samples([g])
    np.testing.assert_allclose(tab.shared, tab.measured, atol=1e-9)


def test_trained_currents_fall_back_to_the_reference_and_correct_the_candidate():
    # no spin in the training runs: the held-out spins keep the reference replay, counted
    straight = [replace(f, score_cur=f.manoeuvre != SPIN)
                for f in (_frame("t0", lambda x, t: x), _frame("t1", lambda x, t: x))]
    held = _frame("h0", lambda x, t: x)
    tab = current_ceiling_samples([held], train_frames=straight)
    spin = (tab.manoeuvre == "spin").to_numpy()
    assert tab.attrs["trained_fallback"] == spin.sum() > 0
    np.testing.assert_array_equal(tab.trained[spin], tab.reference[spin])
    # steady replays (constant within a manoeuvre): the correction is of the candidate, so
    # a candidate that spins 0.2 A higher on the held-out run keeps that step, whatever the
    # reference does
    rng = np.random.default_rng(6)

    def flat(f, ref_spin, cand_spin):
        def level(spin_a):
            return (np.where(f.manoeuvre[:, None] == SPIN, spin_a, 2.0)
                    + 1e-7 * rng.standard_normal(f.sim_cur.shape))
        return replace(f, sim_cur=level(ref_spin)), replace(f, sim_cur=level(cand_spin))
    train = [flat(_frame(f"t{k}", lambda x, t: x), 4.0, 5.0) for k in range(2)]
    frame, cand = flat(held, 4.0, 5.2)
    tab = current_ceiling_samples([frame], [cand], train_frames=[f for f, _ in train],
                                  train_candidates=[c for _, c in train])
    law = 3.5 + 6.5 * np.abs(np.concatenate([held.commanded_yaw_rate] * 2))
    step = np.where(tab.manoeuvre == "spin", 0.2, 0.0)
    np.testing.assert_allclose(tab.trained, law + step, atol=1e-3)


def test_ceiling_table_gain_is_undefined_without_a_reference_error():
    f = _frame("a", lambda x, t: x / 3.0)                 # the gyro is the replay exactly
    row = _row(ceiling_table(yaw_rate_ceiling_samples([f])), "spin")
    assert row.rmse_reference == 0.0 and np.isnan(row.gain_shared)


def test_candidates_off_the_frames_clock_are_refused():
    a = _frame("a", lambda x, t: x)
    short = _frame("a", lambda x, t: x, n_cycles=3)
    with pytest.raises(ConfigError, match="clock"):
        yaw_rate_ceiling_samples([a], [short])
    with pytest.raises(ConfigError, match="clock"):
        current_ceiling_samples([a], [short])


def test_forgetting_sums_read_at_the_lead_decay_from_the_last_available_sample():
    from terrain.audit.ceiling import _forgetting_sums
    t = np.array([0.0, 1.0, 10.0])
    code = np.array([0, 1, 0])
    (s,) = _forgetting_sums(t, code, (np.array([1.0, 5.0, 1.0]),), lead_s=2.0, memory_s=4.0)
    # at t = 10 the sums of t = 8 are available: the code-0 sample at 0, decayed over 8 s;
    # the code-1 sample is another manoeuvre, and nothing precedes t = 0 - 2 or t = 1 - 2
    np.testing.assert_allclose(s, [0.0, 0.0, np.exp(-8.0 / 4.0)])


@pytest.mark.parametrize("kwargs, match", [
    (dict(max_iter=float("nan")), r"max_iter must be an integer >= 1, got nan"),
    (dict(max_iter=2.5), r"max_iter must be an integer >= 1, got 2.5"),
    (dict(min_samples_leaf=float("nan")), r"min_samples_leaf must be an integer >= 1"),
    (dict(min_samples_leaf=0), r"min_samples_leaf must be an integer >= 1, got 0"),
    (dict(random_state=-1), r"random_state must be an integer in \[0, 4294967295\]"),
    (dict(learning_rate=float("inf")), r"learning_rate"),
    (dict(learning_rate=0.0), r"learning_rate")])
def test_transfer_settings_refuse_a_count_that_is_not_an_integer(kwargs, match):
    # NaN or 2.5 iterations passed the '< 1' check and failed later inside scikit-learn
    with pytest.raises(ConfigError, match=match):
        TransferSettings(**kwargs)
    assert TransferSettings(max_iter=1, min_samples_leaf=1, random_state=2 ** 32 - 1)
