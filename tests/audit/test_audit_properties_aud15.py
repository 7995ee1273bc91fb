"""Properties of the audit's selection, held-out protocol, bootstrap and report (Hypothesis).

Every case is built from :func:`audit_helpers.synthetic_frame` (cycles of straight driving,
a curve and a spin in place at 10 Hz, no replay), with one effect of the vocabulary planted
in the measured signals the way the effect acts on them (module docstring of
:mod:`terrain.audit.effects`), so that each example runs in well under a second.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from audit_helpers import synthetic_frame
from terrain.audit import EFFECT_NAMES, AuditSettings, SelectionSettings, run_audit, to_dict
from terrain.audit.core import _stats
from terrain.audit.effects import EFFECT_VOCABULARY, CurrentParams, EffectSettings
from terrain.audit.frames import CURVE, SPIN, STOP
from terrain.audit.report import signal_table
from terrain.audit.selection import (bootstrap_gain, loro, select_group, stratified_resamples,
                                     unit_errors)
from terrain.audit.timing import LagTrack

FAST = SelectionSettings(n_bootstrap=200, n_param_bootstrap=20)
#: no parameter intervals (each of their refits fits the whole group again)
NO_CI = SelectionSettings(n_bootstrap=200, n_param_bootstrap=0)
PROPS = settings(max_examples=6, deadline=None,
                 suppress_health_check=[HealthCheck.too_slow])
N_UNITS = 4


def _turning(frame) -> np.ndarray:
    return np.isin(frame.manoeuvre, (CURVE, SPIN))


def plant(frame, name: str, size: float, rng: np.random.Generator):
    """``frame`` with effect ``name`` of vocabulary size ``size`` planted in its measured
    signals (``chi`` for icr_expansion: the replay's own is 1.2)."""
    if name == "gyro_bias":
        wz = frame.wz + size
        return replace(frame, wz=wz, imu_wz=wz)
    if name == "icr_expansion":
        wz = frame.wz - frame.sim_wz + frame.commanded_yaw_rate / size
        return replace(frame, wz=wz, imu_wz=wz)
    if name == "immobilised":
        # a contiguous dug-in stretch of `size` of every turn, at a random place
        # (the turn's mean yaw rate less the gyro's level when quiet: whatever the yaw
        # model planted before, a bias included)
        wz = frame.wz.copy()
        turn = _turning(frame)
        level = np.mean(frame.wz[frame.quiet])
        edges = np.flatnonzero(np.diff(np.r_[0, turn.astype(int), 0]))
        for i0, i1 in zip(edges[::2], edges[1::2]):
            k = int(round(size * (i1 - i0)))
            s = i0 + int(rng.integers(0, i1 - i0 - k + 1))
            wz[s:s + k] -= np.mean(frame.wz[i0:i1]) - level
        return replace(frame, wz=wz, imu_wz=wz)
    if name == "wheel_lag":
        # wheel data late by `size`: the gyro shows at t what the wheels are stamped t + size
        wz = np.interp(frame.t_s + size, frame.t_s, frame.wz)
        lags = size + 0.01 * rng.standard_normal(8)
        track = LagTrack(np.linspace(frame.t_s[0], frame.t_s[-1], 8), lags, np.ones(8), 8)
        return replace(frame, wz=np.interp(frame.t_s - size, frame.t_s, wz), imu_wz=wz,
                       lag=track)
    if name == "turning_resistance":
        g = CurrentParams().turning_shape(frame.commanded_yaw_rate, "coulomb")
        extra = np.where(_turning(frame), size * g, 0.0)
        return replace(frame, cur=frame.cur + extra[:, None])
    if name == "current_offset":
        moving = frame.manoeuvre != STOP
        return replace(frame, cur=frame.cur + np.outer(moving, [-0.5 * size, 0.5 * size]))
    if name == "grade_resistance":
        phase = rng.uniform(0.0, 2.0 * np.pi)
        pitch = 0.15 * np.sin(2.0 * np.pi * frame.t_s / 20.0 + phase)
        moving = frame.manoeuvre != STOP
        extra = np.where(moving, size * np.abs(pitch), 0.0)
        return replace(frame, pitch=pitch, cur=frame.cur + extra[:, None])
    raise KeyError(name)


#: effect -> (smallest, largest) planted size, well above its negligible floor and the
#: noise of :func:`synthetic_frame` (signed sizes draw either sign)
PLANTED = {
    "gyro_bias": (0.01, 0.05, True),
    "icr_expansion": (1.5, 2.5, False),
    "immobilised": (0.25, 0.5, False),
    "wheel_lag": (0.3, 0.8, True),
    "turning_resistance": (0.5, 3.0, True),
    "current_offset": (0.4, 2.0, True),
    "grade_resistance": (5.0, 20.0, False),
}


def _frames(seed: int, name: str | None = None, size: float = 0.0, n: int = N_UNITS):
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        f = synthetic_frame(f"run{i}", seed=seed * 10 + i)
        out.append(plant(f, name, size, rng) if name else f)
    return out


def test_the_plants_cover_the_vocabulary():
    assert set(PLANTED) == set(EFFECT_NAMES)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(PLANTED))
@PROPS
@given(data=st.data())
def test_a_planted_effect_is_named_alone_with_its_size(name, data):
    lo, hi, signed = PLANTED[name]
    size = data.draw(st.floats(lo, hi), label="size")
    if signed and data.draw(st.booleans(), label="negative"):
        size = -size
    seed = data.draw(st.integers(0, 10_000), label="seed")
    group = EFFECT_VOCABULARY[name].group
    frames = _frames(seed, name, size)
    res = select_group([[f] for f in frames], group, "ASPHALT", NO_CI)
    assert res.selected == (name,), [(e.name, e.params, e.heldout_gain, e.details)
                                     for e in res.effects]
    e = next(e for e in res.effects if e.name == name)
    value = e.params[EFFECT_VOCABULARY[name].param]
    tol = {"immobilised": 0.06, "wheel_lag": 0.02}.get(name, 0.05 * abs(size))
    assert value == pytest.approx(size, abs=tol)


@pytest.mark.parametrize("group", ["yaw", "current"])
@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_nothing_planted_names_nothing(group, seed):
    res = select_group([[f] for f in _frames(seed)], group, "ASPHALT", NO_CI)
    assert res.selected == ()


@pytest.mark.slow
@PROPS
@given(seed=st.integers(0, 10_000), perm=st.permutations(range(N_UNITS)),
       name=st.sampled_from(sorted(PLANTED)))
def test_the_selection_does_not_depend_on_run_order_or_run_names(seed, perm, name):
    lo, hi, _ = PLANTED[name]
    group = EFFECT_VOCABULARY[name].group
    frames = _frames(seed, name, 0.5 * (lo + hi))
    s = replace(FAST, n_param_bootstrap=5)
    a = select_group([[f] for f in frames], group, "ASPHALT", s)
    renamed = [replace(f, run_id=f"x{f.run_id}", group=f"x{f.group}") for f in frames]
    b = select_group([[f] for f in renamed], group, "ASPHALT", s)
    shuffled = [frames[i] for i in perm]
    c = select_group([[f] for f in shuffled], group, "ASPHALT", s)
    for other in (b, c):
        assert other.selected == a.selected
        assert other.baseline_rmse == pytest.approx(a.baseline_rmse, rel=1e-9)
        assert other.final_rmse == pytest.approx(a.final_rmse, rel=1e-9)
        for ea, eo in zip(a.effects, other.effects):
            assert eo.params == pytest.approx(ea.params, rel=1e-7, abs=1e-12)
            if ea.heldout_gain is not None:
                assert eo.heldout_gain == pytest.approx(ea.heldout_gain, rel=1e-7, abs=1e-12)
    # renaming alone keeps the unit order: the bootstrap draws the same units
    for ea, eb in zip(a.effects, b.effects):
        assert eb.heldout_gain_ci95 == ea.heldout_gain_ci95
        assert eb.ci95 == ea.ci95


@PROPS
@given(seed=st.integers(0, 10_000), held=st.integers(0, N_UNITS - 1),
       name=st.sampled_from(sorted(PLANTED)), shift=st.floats(-3.0, 3.0),
       scale=st.floats(0.2, 5.0))
def test_a_held_out_units_data_do_not_move_its_fold(seed, held, name, shift, scale):
    lo, hi, _ = PLANTED[name]
    group = EFFECT_VOCABULARY[name].group
    frames = _frames(seed, name, 0.5 * (lo + hi))
    f = frames[held]
    rng = np.random.default_rng(seed)
    wz = scale * f.wz + shift * rng.standard_normal(f.n)
    perturbed = replace(f, wz=wz, imu_wz=wz, cur=scale * f.cur + shift,
                        pitch=scale * f.pitch,
                        lag=LagTrack(f.lag.centres_s, f.lag.lags_s + shift, f.lag.r2,
                                     f.lag.n_windows))
    other = list(frames)
    other[held] = perturbed
    spec = [name]
    a = loro([[g] for g in frames], group, spec, [], EffectSettings())
    b = loro([[g] for g in other], group, spec, [], EffectSettings())
    assert b[held] == a[held]


@settings(max_examples=60, deadline=None)
@given(n=st.integers(2, 8), seed=st.integers(0, 2 ** 32 - 1), data=st.data())
def test_the_gain_interval_is_reproducible_and_bounds_the_resampled_gains(n, seed, data):
    pos = st.floats(1e-3, 1e3)
    base = np.array(data.draw(st.lists(pos, min_size=n, max_size=n)))
    ref = base * np.array(data.draw(st.lists(st.floats(0.1, 1.0), min_size=n, max_size=n)))
    new = ref * np.array(data.draw(st.lists(st.floats(0.0, 1.5), min_size=n, max_size=n)))
    g1, ci1 = bootstrap_gain(ref, new, base, np.random.default_rng(seed), 200)
    g2, ci2 = bootstrap_gain(ref, new, base, np.random.default_rng(seed), 200)
    assert (g1, ci1) == (g2, ci2)
    direct = (np.sqrt(ref.sum()) - np.sqrt(new.sum())) / np.sqrt(base.sum())
    assert g1 == pytest.approx(direct, rel=1e-12, abs=1e-15)
    idx = stratified_resamples(np.zeros(n), np.random.default_rng(seed), 200)
    g = ((np.sqrt(ref[idx].sum(1)) - np.sqrt(new[idx].sum(1)))
         / np.sqrt(base[idx].sum(1)))
    assert ci1 == [np.percentile(g, 2.5), np.percentile(g, 97.5)]
    assert ci1[0] - 1e-12 <= g1 <= ci1[1] + 1e-12      # the interval holds the estimate


@pytest.mark.slow
@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 10_000), sel_seed=st.integers(0, 2 ** 32 - 1),
       name=st.sampled_from(sorted(PLANTED)))
def test_a_selection_is_reproducible_with_its_seed(seed, sel_seed, name):
    lo, hi, _ = PLANTED[name]
    group = EFFECT_VOCABULARY[name].group
    units = [[f] for f in _frames(seed, name, 0.5 * (lo + hi))]
    s = replace(FAST, seed=sel_seed, n_param_bootstrap=12)
    a = select_group(units, group, "ASPHALT", s)
    b = select_group(units, group, "ASPHALT", s)
    assert [x.as_dict() for x in a.effects] == [x.as_dict() for x in b.effects]
    for e in a.effects:                     # the intervals hold the point estimates
        for k, (lo, hi) in e.ci95.items():
            assert lo - 1e-12 <= e.params[k] <= hi + 1e-12, (e.name, e.params, e.ci95)
        if e.heldout_gain_ci95 is not None:
            lo, hi = e.heldout_gain_ci95
            assert lo - 1e-12 <= e.heldout_gain <= hi + 1e-12, (e.name, e.heldout_gain, lo, hi)


@pytest.mark.slow
@PROPS
@given(seed=st.integers(0, 10_000), name=st.sampled_from(sorted(PLANTED)))
def test_the_group_rmses_are_the_pooled_held_out_errors(seed, name):
    lo, hi, _ = PLANTED[name]
    group = EFFECT_VOCABULARY[name].group
    frames = _frames(seed, name, 0.5 * (lo + hi))
    units = [[f] for f in frames]
    res = select_group(units, group, "ASPHALT", FAST)
    sse = n = 0
    for f in frames:
        if group == "current":
            r = (f.cur - f.sim_cur)[f.score_cur]
            sse += np.sum(r ** 2)
            n += r.size
        elif group == "yaw":
            r = (f.wz - f.sim_wz)[f.score_imu]
            sse += np.sum(r ** 2)
            n += r.size
        else:
            r = (f.wz_at_lag(0.0) - f.sim_wz)[f.score_imu]
            sse += np.sum(r ** 2)
            n += r.size
    assert res.baseline_rmse == pytest.approx(np.sqrt(sse / n), rel=1e-9)
    s, k = unit_errors(units, group, res.heldout_params)
    assert res.final_rmse == pytest.approx(np.sqrt(s.sum() / k.sum()), rel=1e-12)


@settings(max_examples=50, deadline=None)
@given(data=st.data(), n=st.integers(0, 30))
def test_the_residual_statistics_are_numpy_s(data, n):
    x = st.floats(-1e3, 1e3)
    meas = np.array(data.draw(st.lists(x, min_size=n, max_size=n)))
    pred = np.array(data.draw(st.lists(x, min_size=n, max_size=n)))
    k, rmse, bias, corr = _stats(meas, pred)
    assert k == n
    if n == 0:
        assert np.isnan(rmse) and np.isnan(bias) and np.isnan(corr)
        return
    assert rmse == pytest.approx(np.sqrt(np.mean((meas - pred) ** 2)), rel=1e-12, abs=1e-12)
    assert bias == pytest.approx(np.mean(meas - pred), rel=1e-9, abs=1e-9)
    assert -1.0 - 1e-12 <= corr <= 1.0 + 1e-12 or np.isnan(corr)


SIGNAL_FIELDS = {"signal", "terrain", "n", "replay_rmse", "extended_rmse"}


@pytest.mark.slow
@settings(max_examples=2, deadline=None)
@given(seed=st.integers(0, 10_000), name=st.sampled_from(sorted(PLANTED)))
def test_the_signals_records_keep_their_fields_and_their_meaning(seed, name):
    lo, hi, _ = PLANTED[name]
    frames = _frames(seed, name, 0.5 * (lo + hi))
    frames += [replace(f, run_id=f"ice{f.run_id}", group=f"ice{f.group}", terrain="ICE")
               for f in _frames(seed + 1)]
    result = run_audit([], AuditSettings(selection=NO_CI), frames=frames)
    report = to_dict(result)
    assert report["signals"]
    table = signal_table(result)
    for rec, (_, row) in zip(report["signals"], table.iterrows()):
        assert SIGNAL_FIELDS <= set(rec), rec
        fs = [f for f in frames if rec["terrain"] in ("all", f.terrain)]
        if rec["signal"] == "wz":
            meas = np.concatenate([f.wz[f.score_imu] for f in fs])
            rep = np.concatenate([f.sim_wz[f.score_imu] for f in fs])
        elif rec["signal"] in ("cur_l", "cur_r"):
            j = ("cur_l", "cur_r").index(rec["signal"])
            meas = np.concatenate([f.cur[f.score_cur, j] for f in fs])
            rep = np.concatenate([f.sim_cur[f.score_cur, j] for f in fs])
        else:
            continue
        # replay_rmse: the replay as it runs (no effect), on the scored samples
        assert rec["n"] == meas.size
        assert row["replay_rmse"] == pytest.approx(np.sqrt(np.mean((meas - rep) ** 2)),
                                                   rel=1e-12)
        if rec["signal"] == "wz":             # the yaw group's held-out predictions
            yaw = result.groups[(rec["terrain"], "yaw")]
            assert row["extended_rmse"] == pytest.approx(yaw.final_rmse, rel=1e-12)
            assert row["replay_rmse"] == pytest.approx(yaw.baseline_rmse, rel=1e-12)
        if row["replay_rmse"] > 0:
            assert row["extended_gain"] == pytest.approx(
                1.0 - row["extended_rmse"] / row["replay_rmse"], rel=1e-12)


def _ceiling_frames(seed: int, chis, offsets, prefix: str):
    return [synthetic_frame(f"{prefix}{i}", seed=seed * 10 + i, chi=c, offsets_a=(o, -o),
                            noise=0.02, drift_rad_s=0.03)
            for i, (c, o) in enumerate(zip(chis, offsets))]


@pytest.mark.slow
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000),
       chis=st.lists(st.floats(1.0, 3.0), min_size=4, max_size=4),
       offsets=st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4))
def test_the_ceiling_families_are_nested_least_squares(seed, chis, offsets):
    """Per manoeuvre, each run's own fit (``per_run``) is no worse than the fit shared by
    the evaluated runs (``shared``), which is no worse than the same family fitted on other
    runs (``trained``): least squares on the evaluated samples is the family's smallest
    error there (module docstring of :mod:`terrain.audit.ceiling`)."""
    from terrain.audit.ceiling import current_ceiling_samples, yaw_rate_ceiling_samples

    frames = _ceiling_frames(seed, chis[:2], offsets[:2], "eval")
    train = _ceiling_frames(seed + 1, chis[2:], offsets[2:], "train")
    for tab in (yaw_rate_ceiling_samples(frames, train_frames=train),
                current_ceiling_samples(frames, train_frames=train)):
        assert tab.attrs["trained_fallback"] == 0
        for man, sub in tab.groupby("manoeuvre"):
            sse = {c: float(np.sum((sub.measured - sub[c]) ** 2))
                   for c in ("per_run", "shared", "trained")}
            assert sse["per_run"] <= sse["shared"] * (1 + 1e-9) + 1e-9, (man, sse)
            assert sse["shared"] <= sse["trained"] * (1 + 1e-9) + 1e-9, (man, sse)
        # the trained column does not read the evaluated runs' measurements
        moved = [replace(f, wz=f.wz + 1.0, cur=f.cur * 2.0) for f in frames]
        again = (yaw_rate_ceiling_samples(moved, train_frames=train) if tab.side.iloc[0] < 0
                 else current_ceiling_samples(moved, train_frames=train))
        np.testing.assert_array_equal(again.trained.to_numpy(), tab.trained.to_numpy())


def _report_summary(frames):
    selection = SelectionSettings(n_bootstrap=50, n_param_bootstrap=0, min_units=2)
    report = to_dict(run_audit([], AuditSettings(selection=selection), frames=frames))
    effects = {(e["terrain"], e["name"]): (e["supported"], e["step"], e["params"],
                                           e["heldout_gain"]) for e in report["effects"]}
    signals = {(s["signal"], s["terrain"]): s for s in report["signals"]}
    return effects, signals, report["supported"], report["facts"]


@pytest.mark.slow
def test_the_audit_report_does_not_depend_on_run_order_or_names():
    frames = _frames(7, "icr_expansion", 1.8, n=3) + [
        replace(f, run_id=f"ice/{f.run_id}", group=f"ice/{f.group}", terrain="ICE")
        for f in _frames(8, "gyro_bias", 0.02, n=3)]
    a = _report_summary(frames)
    assert a[2] == {"ASPHALT": ["icr_expansion"], "ICE": ["gyro_bias"], "all": a[2]["all"]}
    shuffled = [frames[i] for i in (4, 0, 5, 2, 1, 3)]
    assert _report_summary(shuffled) == a
    renamed = [replace(f, run_id=f"z{f.run_id[::-1]}", group=f"z{f.group[::-1]}")
               for f in shuffled]
    assert _report_summary(renamed) == a


def _mirrored(frame):
    """The same drive seen with left and right swapped: every turn and yaw rate changes
    sign, the two motors change places."""
    return replace(frame, commanded_yaw_rate=-frame.commanded_yaw_rate, wz=-frame.wz,
                   sim_wz=-frame.sim_wz, imu_wz=-frame.imu_wz, ay=-frame.ay,
                   sim_ay=-frame.sim_ay, cur=frame.cur[:, ::-1].copy(),
                   sim_cur=frame.sim_cur[:, ::-1].copy())


@PROPS
@given(seed=st.integers(0, 10_000), name=st.sampled_from(sorted(PLANTED)))
def test_a_mirrored_drive_names_the_same_effects_with_mirrored_sizes(seed, name):
    """Only the bias of the gyro and the right-minus-left current offset change sign."""
    lo, hi, _ = PLANTED[name]
    group = EFFECT_VOCABULARY[name].group
    frames = _frames(seed, name, 0.5 * (lo + hi))
    a = select_group([[f] for f in frames], group, "ASPHALT", NO_CI)
    b = select_group([[_mirrored(f)] for f in frames], group, "ASPHALT", NO_CI)
    assert b.selected == a.selected == (name,)
    for ea, eb in zip(a.effects, b.effects):
        sign = -1.0 if ea.name in ("gyro_bias", "current_offset") else 1.0
        assert eb.params == pytest.approx({k: sign * v for k, v in ea.params.items()},
                                          rel=1e-6, abs=1e-9), ea.name
        if ea.heldout_gain is not None:
            assert eb.heldout_gain == pytest.approx(ea.heldout_gain, rel=1e-6, abs=1e-9)


@pytest.mark.slow
def test_a_held_out_segments_gyro_does_not_move_its_folds_training_data(tmp_path):
    from audit_helpers import simulated_streams, write_signal_files
    from terrain.audit.frames import prepare_frame, split_frame
    from terrain.audit.replay import replay_run
    from terrain.io.measured import read_runs_dir

    (imu, pro), = simulated_streams({"icr_expansion": 1.5, "wheel_lag": 0.3}, seeds=(5,),
                                    duration_s=90.0)

    def segments(imu, name):
        write_signal_files(tmp_path / name, "ASPHALT", 0, imu, pro)
        run, = read_runs_dir(tmp_path / name, progress=False)
        return split_frame(prepare_frame(run, replay_run(run)), 4)

    before = segments(imu, "a")
    held = before[3]
    inside = (imu.time >= held.t_s[0] + 1.0) & (imu.time <= held.t_s[-1])
    moved = imu.assign(wz=np.where(inside, 0.3 * imu.wz + 0.2, imu.wz))
    after = segments(moved, "b")
    for b, a in zip(before[:3], after[:3]):
        np.testing.assert_array_equal(a.wz[a.score_imu], b.wz[b.score_imu])


@pytest.mark.slow
def test_replay_rmse_is_the_default_physics_replay(tmp_path):
    """The ``replay_rmse`` of the JSON ``signals`` records (read by independent checks) is
    the error of the simulator's default physics (v1), with the audit's and the command's
    default settings alike."""
    import argparse

    from audit_helpers import simulated_streams, write_signal_files
    from pipelines.audit import add_arguments
    from terrain.audit.replay import ReplaySettings, replay_run
    from terrain.io.measured import read_runs_dir
    from terrain.sim.forces import DEFAULT_PHYSICS

    assert DEFAULT_PHYSICS == "v1"
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    assert parser.parse_args(["--json", str(tmp_path / "a.json")]).physics == DEFAULT_PHYSICS
    assert AuditSettings().replay.physics == DEFAULT_PHYSICS
    streams = simulated_streams(seeds=(3,), duration_s=20.0, scenario="orchard")
    for i, (imu, pro) in enumerate(streams):
        write_signal_files(tmp_path / "runs", "SNOW", i, imu, pro)
    runs = read_runs_dir(tmp_path / "runs", progress=False)
    result = run_audit(runs, AuditSettings(selection=replace(NO_CI, n_bootstrap=10)))
    records = {(s["signal"], s["terrain"]): s for s in to_dict(result)["signals"]}
    meas, pred = [], []
    for run, frame in zip(runs, result.frames):
        rep = replay_run(run, ReplaySettings(physics="v1"))
        meas.append(frame.cur[frame.score_cur, 0])
        pred.append(rep.cur[frame.score_cur, 0])
    meas, pred = np.concatenate(meas), np.concatenate(pred)
    rec = records[("cur_l", "SNOW")]
    assert rec["n"] == meas.size
    assert rec["replay_rmse"] == pytest.approx(np.sqrt(np.mean((meas - pred) ** 2)), abs=1e-5)
