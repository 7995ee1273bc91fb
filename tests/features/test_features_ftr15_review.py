"""Feature-layer review (ftr15): property-based invariants of the windowing's book-keeping,
of run order and batching, and of the physical symmetries of the wheel, slip and EKF
features (hypothesis)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features.ekf_signals import EKF_CHANNELS, ekf_channel_frame, window_ekf_channels
from features.slip_features import SLIP_CHANNELS, slip_feature_matrix, window_feature_vector
from features.transformers import WindowFeatures
from features.wheel_physics import PHYSICS_FEATURES, WheelPhysicsFeatures, physics_features
from features.windows import WindowConfig, make_windows, window_frame
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run
from terrain.slip import skid_steer_side_slip
from terrain.vehicles import HUSKY


# --------------------------------------------------------------------------- windowing

@st.composite
def _frames(draw):
    """An aligned frame (rate, samples, a NaN pattern) and a window config of any hop and
    partition."""
    rate = draw(st.sampled_from([10.0, 20.0, 50.0]))
    n = draw(st.integers(4, 30))
    hop = draw(st.one_of(st.none(), st.integers(1, 45)))
    part = draw(st.one_of(st.none(), st.integers(n, 3 * n + 5)))
    total = draw(st.integers(0, 200))
    config = WindowConfig(window_s=n / rate, hop_s=None if hop is None else hop / rate,
                          rate_hz=rate, partition_s=None if part is None else part / rate)
    values = np.arange(2 * total, dtype=float).reshape(total, 2)
    holes = draw(st.lists(st.tuples(st.integers(0, max(total - 1, 0)), st.integers(1, 40),
                                    st.sampled_from([0, 1, None])), max_size=3))
    for a, length, col in holes:
        values[a:a + length, slice(None) if col is None else col] = np.nan
    frame = pd.DataFrame({TIME: np.arange(total) / rate, "a": values[:, 0],
                          "b": values[:, 1]})
    return frame, config


@pytest.mark.slow
@given(_frames())
@settings(max_examples=200, deadline=None)
def test_every_sample_of_a_frame_is_in_a_window_position_or_a_counted_tail(case):
    """Each sample of the frame is in a window position (kept, dropped or empty), in the
    time after the last full partition, after the last window of its partition, or between
    two windows of a hop longer than the window: exactly, for any window, hop, partition,
    frame length and gap pattern."""
    frame, config = case
    X, t0, t1, part, c = window_frame(frame, ["a", "b"], config)
    rate, n, hop = config.rate_hz, config.n_samples, config.hop_samples
    total = len(frame)
    length = config.partition_samples or total
    n_parts = total // length if length else 0
    per = (length - n) // hop + 1 if length >= n else 0
    positions = len(X) + c["dropped_gap"] + c["empty_gap"] + c["dropped_unsteady"]
    assert positions == per * n_parts
    covered = n_parts * (n + (per - 1) * min(hop, n)) if per else 0
    accounted = (covered + (c["partition_tail_s"] + c["window_tail_s"]
                            + c["between_windows_s"]) * rate)
    assert accounted == pytest.approx(total, abs=1e-6)
    # the brute force: a window position is kept when finite, empty when wholly NaN
    values = frame[["a", "b"]].to_numpy()
    kept = dropped = empty = 0
    for k in range(n_parts):
        for s in range(k * length, (k + 1) * length - n + 1, hop):
            win = values[s:s + n]
            kept += np.isfinite(win).all()
            empty += not np.isfinite(win).any()
            dropped += np.isfinite(win).any() and not np.isfinite(win).all()
    assert (len(X), c["dropped_gap"], c["empty_gap"]) == (kept, dropped, empty)
    # a kept window is the frame's samples from its start, inside one partition
    assert np.isfinite(X).all()
    for w, start, end, k in zip(X, t0, t1, part):
        s = int(round(start * rate))
        np.testing.assert_array_equal(w, values[s:s + n].T)
        assert end == pytest.approx(start + n / rate)
        assert s // length == k == (s + n - 1) // length


def _run(run_id: str, duration_s: float, seed: int, hole=None) -> Run:
    """IMU at 100 Hz and wheels at 10 Hz over [0, duration_s] s, random values; ``hole``
    (a, b) s with no wheel sample strictly inside."""
    rng = np.random.default_rng(seed)
    ti = np.arange(int(round(duration_s * 100)) + 1) / 100.0
    imu = pd.DataFrame({TIME: ti, **{c: rng.standard_normal(ti.size) for c in IMU_CHANNELS}})
    tw = np.arange(int(round(duration_s * 10)) + 1) / 10.0
    if hole is not None:
        tw = tw[(tw <= hole[0]) | (tw >= hole[1])]
    wheels = pd.DataFrame({TIME: tw, "vel_l": 0.5 + 0.05 * rng.standard_normal(tw.size),
                           "vel_r": 0.6 + 0.05 * rng.standard_normal(tw.size),
                           "cur_l": 5.0 + rng.standard_normal(tw.size),
                           "cur_r": 6.0 + rng.standard_normal(tw.size)})
    return Run(run_id=run_id, dataset="t", terrain=("ICE", "SAND", "GRASS")[seed % 3],
               streams={"imu": imu, "wheels": wheels}, source="in-memory test run")


def _by_run(ws):
    return {rid: (ws.X[ws.run_ids == rid], ws.t_start_s[ws.run_ids == rid],
                  list(ws.groups[ws.run_ids == rid]), list(ws.labels[ws.run_ids == rid]))
            for rid in set(ws.run_ids)}


@pytest.mark.slow
@given(st.lists(st.tuples(st.floats(2.0, 9.0), st.one_of(st.none(), st.floats(0.5, 5.0))),
                min_size=2, max_size=3),
       st.permutations(range(3)), st.sampled_from([0.5, 1.0, 1.5, None]),
       st.sampled_from([None, 3.0]), st.booleans())
@settings(max_examples=20, deadline=None)
def test_windows_and_counts_do_not_depend_on_the_run_order_or_batching(
        specs, order, hop_s, partition_s, steady):
    """The windows of a run, their counts and the totals are the same whether the runs are
    windowed in any order, together or one by one."""
    runs = [_run(f"t/X/{i}", d, i, None if h is None else (h, h + 0.6))
            for i, (d, h) in enumerate(specs)]
    config = WindowConfig(window_s=1.0, hop_s=hop_s, rate_hz=20.0, partition_s=partition_s,
                          steady_only=steady, max_speed_std_m_s=0.05)
    ws = make_windows(runs, "all", config)
    shuffled = make_windows([runs[i] for i in order if i < len(runs)], "all", config)
    alone = [make_windows([r], "all", config) for r in runs]
    a, b = _by_run(ws), _by_run(shuffled)
    assert a.keys() == b.keys()
    for rid in a:
        np.testing.assert_array_equal(a[rid][0], b[rid][0])
        np.testing.assert_array_equal(a[rid][1], b[rid][1])
        assert a[rid][2:] == b[rid][2:]
    for r, one in zip(runs, alone):
        assert one.counts["per_run"][r.run_id] == ws.counts["per_run"][r.run_id]
        np.testing.assert_array_equal(one.X, ws.X[ws.run_ids == r.run_id])
    for key in ("windows", "dropped_gap", "empty_gap", "dropped_unsteady"):
        assert ws.counts[key] == shuffled.counts[key] == sum(o.counts[key] for o in alone)
    for key in ("partition_tail_s", "window_tail_s", "between_windows_s"):
        assert ws.counts[key] == pytest.approx(sum(o.counts[key] for o in alone))
        assert ws.counts[key] == pytest.approx(shuffled.counts[key])


# --------------------------------------------------------------------------- batching

_FEATURE_CHANNELS = ("ax", "wz", "vel_l", "vel_r", "cur_l", "cur_r", "yaw_rate_wheels")


@given(st.integers(1, 6), st.integers(8, 64), st.sampled_from([20.0, 50.0]),
       st.integers(0, 2 ** 32 - 1), st.data())
@settings(max_examples=30, deadline=None)
def test_window_features_of_a_window_do_not_depend_on_its_batch(n_windows, n_samples,
                                                                rate, seed, data):
    """The features of a window are the same computed in a batch of any size, alone, or
    in a shuffled batch (rows follow their windows); the wheel-physics features likewise."""
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n_windows, len(_FEATURE_CHANNELS), n_samples))
    X[:, 2:4] += 0.5
    X[:, 4:6] = np.abs(X[:, 4:6]) * 5.0
    perm = np.asarray(data.draw(st.permutations(range(n_windows))))
    for fx in (WindowFeatures(_FEATURE_CHANNELS, rate),
               WheelPhysicsFeatures(_FEATURE_CHANNELS, rate, short_s=0.25)):
        F = fx.fit(X).transform(X)
        assert F.shape == (n_windows, len(fx.get_feature_names_out()))
        np.testing.assert_allclose(fx.transform(X[perm]), F[perm], rtol=1e-12, atol=1e-12)
        for i in range(n_windows):
            np.testing.assert_allclose(fx.transform(X[i:i + 1])[0], F[i], rtol=1e-12,
                                       atol=1e-12)
        # a fit on one window fixes the same names as a fit on the batch
        np.testing.assert_array_equal(type(fx)(**fx.get_params()).fit(X[:1])
                                      .get_feature_names_out(), fx.get_feature_names_out())


# --------------------------------------------------------------------------- symmetries

def _wheel_windows(rng, n_windows, n_samples):
    """Wheel windows (vel_l, vel_r m/s, cur_l, cur_r A) of random arcs and turns."""
    t = np.arange(n_samples)
    v = rng.uniform(-1.0, 1.0, (n_windows, 1)) + 0.1 * np.sin(
        t / rng.uniform(2.0, 8.0, (n_windows, 1)))
    dv = rng.uniform(-0.6, 0.6, (n_windows, 1)) + 0.05 * rng.standard_normal(
        (n_windows, n_samples))
    cur = np.abs(rng.normal(5.0, 2.0, (n_windows, 2, n_samples)))
    return v - dv / 2, v + dv / 2, cur[:, 0], cur[:, 1]


_CURRENT_FEATURES = [f for f in PHYSICS_FEATURES
                     if f.startswith(("cur_sum__", "cur_diff__", "cur_diff_abs__"))]


@given(st.integers(1, 4), st.integers(3, 60), st.sampled_from([6.5, 10.0, 50.0]),
       st.floats(0.2, 5.0), st.integers(0, 2 ** 32 - 1))
@settings(max_examples=60, deadline=None)
def test_wheel_physics_is_mirror_symmetric_linear_in_current_and_time_reversible(
        n_windows, n_samples, rate, k, seed):
    """A mirrored window (left and right swapped: a left turn made a right turn) has the
    same physics features: the turn regressors and the side-to-side current change sign
    together; currents k times larger give current features k times larger and the same
    motion features; a window played backwards (|a| is unchanged) gives the same whole-
    window features."""
    vl, vr, cl, cr = _wheel_windows(np.random.default_rng(seed), n_windows, n_samples)
    F = physics_features(vl, vr, cl, cr, rate)
    assert np.isfinite(F).all()
    np.testing.assert_allclose(physics_features(vr, vl, cr, cl, rate), F, rtol=1e-9,
                               atol=1e-9)
    scaled = physics_features(vl, vr, k * cl, k * cr, rate)
    cur = [PHYSICS_FEATURES.index(f) for f in _CURRENT_FEATURES]
    motion = [i for i in range(len(PHYSICS_FEATURES)) if i not in cur]
    np.testing.assert_allclose(scaled[:, cur], k * F[:, cur], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(scaled[:, motion], F[:, motion])
    back = physics_features(vl[:, ::-1], vr[:, ::-1], cl[:, ::-1], cr[:, ::-1], rate)
    np.testing.assert_allclose(back, F, rtol=1e-9, atol=1e-9)


def _slip_windows(rng, n_windows, n_samples):
    """Windows of SLIP_CHANNELS: wheel arcs, currents, a tilted accelerometer, a gyro."""
    vl, vr, cl, cr = _wheel_windows(rng, n_windows, n_samples)
    ch = {"cur_l": cl, "cur_r": cr, "vel_l": vl, "vel_r": vr, "vel_diff": vr - vl,
          "cur_diff": cr - cl, "yaw_rate_wheels": (vr - vl) / HUSKY.track_m,
          "ax": rng.normal(0.5, 0.3, vl.shape), "ay": rng.normal(0.3, 0.3, vl.shape),
          "az": rng.normal(9.7, 0.1, vl.shape),
          "wz": 0.8 * (vr - vl) / HUSKY.track_m + 0.02 * rng.standard_normal(vl.shape)}
    return np.stack([ch[c] for c in SLIP_CHANNELS], axis=1)


def _mirror(X, channels, swap, negate):
    idx = {c: i for i, c in enumerate(channels)}
    out = X.copy()
    for a, b in swap:
        out[:, idx[a]], out[:, idx[b]] = X[:, idx[b]], X[:, idx[a]]
    for c in negate:
        out[:, idx[c]] = -X[:, idx[c]]
    return out


@given(st.integers(1, 4), st.integers(4, 60), st.sampled_from([20.0, 50.0]),
       st.integers(0, 2 ** 32 - 1))
@settings(max_examples=30, deadline=None)
def test_slip_features_of_a_mirrored_window_are_mirrored(n_windows, n_samples, rate, seed):
    """Left and right swapped and the lateral and yaw channels negated (the same drive
    mirrored): left and right features swap, side differences and lateral means change
    sign, spreads, slope, pitch and inv_chi are unchanged, the physics slip of each side is
    the other's."""
    X = _slip_windows(np.random.default_rng(seed), n_windows, n_samples)
    probs = {"ASPHALT": np.full(n_windows, 0.3), "SANDY_LOAM": np.full(n_windows, 0.7)}
    names, F = slip_feature_matrix(X, SLIP_CHANNELS, rate, HUSKY, probs)
    M = _mirror(X, SLIP_CHANNELS, [("cur_l", "cur_r"), ("vel_l", "vel_r")],
                ["vel_diff", "cur_diff", "yaw_rate_wheels", "ay", "wz"])
    names_m, G = slip_feature_matrix(M, SLIP_CHANNELS, rate, HUSKY, probs)
    assert names_m == names and len(set(names)) == len(names)
    col = {name: j for j, name in enumerate(names)}

    def partner(name):
        for a, b in (("_l", "_r"), ("_r", "_l")):
            for tail in ("__mean", "__std", ""):
                if name.endswith(a + tail) and name.startswith(("cur", "vel", "phys_slip")):
                    return name[:len(name) - len(a + tail)] + b + tail
        return name

    for name in names:
        sign = -1.0 if name in ("vel_diff__mean", "cur_diff__mean", "yaw_rate_wheels__mean",
                                "ay__mean", "wz__mean") else 1.0
        np.testing.assert_allclose(G[:, col[partner(name)]], sign * F[:, col[name]],
                                   rtol=1e-9, atol=1e-9, err_msg=name)


@given(st.integers(1, 3), st.integers(4, 40), st.integers(0, 2 ** 32 - 1))
@settings(max_examples=15, deadline=None)
def test_window_ekf_channels_of_a_mirrored_window_are_mirrored(n_windows, n_samples, seed):
    """The per-window EKF on a mirrored drive (wheels swapped, gyro negated) gives the same
    speed, ICR factor and NIS, the negated yaw rate, gyro bias and gyro innovation, and
    each side's wheel innovation and slip on the other side; each window's channels are the
    same in a batch or alone."""
    rng = np.random.default_rng(seed)
    vl, vr, _, _ = _wheel_windows(rng, n_windows, n_samples)
    wz = 0.8 * (vr - vl) / HUSKY.track_m + 0.02 * rng.standard_normal(vl.shape)
    channels = ("vel_l", "vel_r", "wz")
    X = np.stack([vl, vr, wz], axis=1)
    E = window_ekf_channels(X, channels, 50.0, wheel_rate_hz=10.0)
    M = window_ekf_channels(_mirror(X, channels, [("vel_l", "vel_r")], ["wz"]), channels,
                            50.0, wheel_rate_hz=10.0)
    idx = {c: i for i, c in enumerate(EKF_CHANNELS)}
    rules = {"ekf_v_bx": ("ekf_v_bx", 1), "ekf_yaw_rate": ("ekf_yaw_rate", -1),
             "ekf_gyro_bias": ("ekf_gyro_bias", -1), "ekf_icr_chi": ("ekf_icr_chi", 1),
             "ekf_innov_vel_l": ("ekf_innov_vel_r", 1), "ekf_innov_vel_r": ("ekf_innov_vel_l", 1),
             "ekf_innov_wz": ("ekf_innov_wz", -1), "ekf_nis": ("ekf_nis", 1),
             "ekf_slip_l": ("ekf_slip_r", 1), "ekf_slip_r": ("ekf_slip_l", 1)}
    assert set(rules) == set(EKF_CHANNELS)
    for name, (other, sign) in rules.items():
        np.testing.assert_allclose(M[:, idx[other]], sign * E[:, idx[name]], rtol=1e-7,
                                   atol=1e-9, err_msg=name)
    # each side's slip is that of its own contact line, y = +B/2 left, from the states
    # (a yaw rate of the wrong sign is mirror symmetric too and survived every test)
    vel = np.moveaxis(X[:, :2], 1, 2).reshape(-1, 2)
    side = skid_steer_side_slip(vel, E[:, idx["ekf_v_bx"]].reshape(-1),
                                E[:, idx["ekf_yaw_rate"]].reshape(-1), HUSKY.track_m)
    np.testing.assert_allclose(E[:, [idx["ekf_slip_l"], idx["ekf_slip_r"]]],
                               np.moveaxis(side.reshape(n_windows, n_samples, 2), 2, 1),
                               rtol=1e-12, atol=1e-12)
    for i in range(n_windows):
        np.testing.assert_allclose(window_ekf_channels(X[i:i + 1], channels, 50.0,
                                                       wheel_rate_hz=10.0)[0], E[i],
                                   rtol=1e-12, atol=1e-12)


@given(st.integers(3, 120), st.integers(0, 2 ** 32 - 1),
       st.one_of(st.none(), st.tuples(st.integers(0, 119), st.integers(1, 30))))
@settings(max_examples=15, deadline=None)
def test_the_ekf_channels_of_a_run_are_causal(k, seed, hole):
    """The EKF channels of the first k samples of a frame are those of the whole frame (the
    module docstring: each value depends on the run's past only; no label, no future sample,
    so they may be computed before a split); gap rows are NaN in every channel."""
    rng = np.random.default_rng(seed)
    vl, vr, _, _ = _wheel_windows(rng, 1, 120)
    wz = 0.8 * (vr - vl) / HUSKY.track_m + 0.02 * rng.standard_normal(vl.shape)
    frame = pd.DataFrame({TIME: np.arange(120) / 50.0, "vel_l": vl[0], "vel_r": vr[0],
                          "wz": wz[0]})
    if hole is not None:
        frame.loc[hole[0]:hole[0] + hole[1] - 1, ["vel_l", "vel_r", "wz"]] = np.nan
    whole = ekf_channel_frame(frame, wheel_rate_hz=10.0)
    head = ekf_channel_frame(frame.iloc[:k], wheel_rate_hz=10.0)
    np.testing.assert_allclose(head.to_numpy(), whole.to_numpy()[:k], rtol=1e-12,
                               atol=1e-12)
    gap = frame[["vel_l", "vel_r", "wz"]].isna().any(axis=1).to_numpy()
    assert whole.to_numpy()[gap].size == 0 or np.isnan(whole.to_numpy()[gap]).all()
    assert np.isfinite(whole.to_numpy()[~gap]).all()


# --------------------------------------------------------------------------- calculators

@given(st.integers(1, 4), st.integers(4, 80), st.sampled_from([10.0, 50.0, 100.0]),
       st.floats(0.1, 10.0), st.floats(-20.0, 20.0), st.integers(0, 2 ** 32 - 1))
@settings(max_examples=60, deadline=None)
def test_window_features_follow_a_sign_change_a_scale_and_an_offset(n_windows, n_samples,
                                                                    rate, k, c, seed):
    """Of a channel negated, mean, skewness, min and max change into -mean, -skewness,
    -max and -min, the other statistics and the band powers stay; scaled by k, the
    statistics in the channel's unit scale by k, skewness and kurtosis stay and the band
    powers' densities by k^2; offset by c, only mean, rms, min and max
    move (mean, min and max by c) and the band powers stay (the window mean is removed)."""
    rng = np.random.default_rng(seed)
    channels = ("ax", "wz")
    X = rng.standard_normal((n_windows, 2, n_samples)) * rng.uniform(0.5, 2.0, (1, 2, 1))
    fx = WindowFeatures(channels, rate).fit(X)
    names = list(fx.get_feature_names_out())
    F = fx.transform(X)

    def cols(F, ch, feats):
        return F[:, [names.index(f"{ch}__{f}") for f in feats]]

    bands = [n.split("__")[1] for n in names if n.startswith("ax__band_")]
    G = fx.transform(X * np.array([-1.0, 1.0])[None, :, None])
    np.testing.assert_allclose(cols(G, "ax", ["mean", "skewness", "min", "max"]),
                               -cols(F, "ax", ["mean", "skewness", "max", "min"]),
                               rtol=1e-9, atol=1e-9)
    same = ["std", "kurtosis", "rms", "mean_abs_diff"] + bands
    np.testing.assert_allclose(cols(G, "ax", same), cols(F, "ax", same), rtol=1e-9,
                               atol=1e-9)
    wz = [i for i, name in enumerate(names) if name.startswith("wz__")]
    np.testing.assert_array_equal(G[:, wz], F[:, wz])
    S = fx.transform(k * X)
    unit = ["mean", "std", "rms", "min", "max", "mean_abs_diff"]
    np.testing.assert_allclose(cols(S, "ax", unit), k * cols(F, "ax", unit), rtol=1e-9,
                               atol=1e-12)
    np.testing.assert_allclose(cols(S, "ax", ["skewness", "kurtosis"]),
                               cols(F, "ax", ["skewness", "kurtosis"]), rtol=1e-7, atol=1e-7)
    density = (lambda F: 10.0 ** cols(F, "ax", bands) - 1e-12)    # (log10 of it + 1e-12)
    np.testing.assert_allclose(density(S), k ** 2 * density(F), rtol=1e-6, atol=1e-18)
    off = fx.transform(X + c)
    np.testing.assert_allclose(cols(off, "ax", ["mean", "min", "max"]),
                               cols(F, "ax", ["mean", "min", "max"]) + c, rtol=1e-9,
                               atol=1e-9)
    rms, sd = cols(off, "ax", ["rms"]), cols(off, "ax", ["std"])
    np.testing.assert_allclose(rms ** 2 - sd ** 2, cols(off, "ax", ["mean"]) ** 2, rtol=1e-6,
                               atol=1e-6)
    steady = ["std", "skewness", "kurtosis", "mean_abs_diff"]
    np.testing.assert_allclose(cols(off, "ax", steady), cols(F, "ax", steady), rtol=1e-6,
                               atol=1e-6)
    np.testing.assert_allclose(density(off), density(F), rtol=1e-6, atol=1e-18)


@pytest.mark.slow
@given(st.integers(1, 3), st.integers(8, 50), st.sampled_from([20.0, 50.0]),
       st.integers(0, 2 ** 32 - 1), st.data())
@settings(max_examples=25, deadline=None)
def test_a_feature_is_the_same_whatever_the_channel_order(n_windows, n_samples, rate, seed,
                                                          data):
    """The channels are read by position and named by ``channels``: the column of a name
    holds the same value for any order of the channels (cross terms included), and the
    slip features of one window (the streaming path) are its row of the batch table."""
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n_windows, len(_FEATURE_CHANNELS), n_samples))
    X[:, 2:4] += 0.5
    perm = list(data.draw(st.permutations(range(len(_FEATURE_CHANNELS)))))
    channels = tuple(_FEATURE_CHANNELS[i] for i in perm)
    for make in (WindowFeatures, WheelPhysicsFeatures):
        fx = make(_FEATURE_CHANNELS, rate).fit(X)
        gx = make(channels, rate).fit(X[:, perm])
        a = dict(zip(fx.get_feature_names_out(), fx.transform(X).T))
        b = dict(zip(gx.get_feature_names_out(), gx.transform(X[:, perm]).T))
        assert a.keys() == b.keys() and len(a) == len(fx.get_feature_names_out())
        for name in a:
            np.testing.assert_allclose(b[name], a[name], rtol=1e-12, atol=1e-12,
                                       err_msg=name)
    S = _slip_windows(rng, n_windows, n_samples)
    # (a weight of the one terrain; below min_probability, 0.001, it is refused as no
    # terrain at all: a draw below it failed this test in a local run, seed 3395)
    probs = {"ICE": rng.uniform(0.01, 1.0, n_windows)}
    names, F = slip_feature_matrix(S, SLIP_CHANNELS, rate, HUSKY, probs)
    order = list(data.draw(st.permutations(range(len(SLIP_CHANNELS)))))
    shuffled = tuple(SLIP_CHANNELS[i] for i in order)
    for i in range(n_windows):
        one = window_feature_vector(S[i][order], shuffled, rate, HUSKY,
                                    {"ICE": float(probs["ICE"][i])})
        np.testing.assert_allclose(one, F[i], rtol=1e-12, atol=1e-12)


def test_the_current_per_yaw_rate_divides_by_the_mean_turn_rate_whichever_way():
    """cur_sum__per_yaw_rate is mean(I_L + I_R) / max(mean |omega|, w0): an S-curve turning
    at 1 rad/s one way then the other (mean omega 0) needs its current for 1 rad/s, not for
    the 0.1 rad/s floor (|mean omega| gave 10 times the value, and mirror symmetry holds
    for both)."""
    n = 40
    om = np.where(np.arange(n) < n // 2, 1.0, -1.0)
    v = np.full(n, 0.5)
    vl, vr = v - om * HUSKY.track_m / 2, v + om * HUSKY.track_m / 2
    F = physics_features(vl[None], vr[None], np.full((1, n), 4.0), np.full((1, n), 6.0), 10.0)
    col = dict(zip(PHYSICS_FEATURES, F[0]))
    assert col["yaw_rate_cmd__abs_mean"] == pytest.approx(1.0)
    assert col["cur_sum__per_yaw_rate"] == pytest.approx(10.0)


@pytest.mark.parametrize("n", [5, 40])
def test_the_ridge_weight_is_per_sample(n):
    """The fits solve (A^T A + ridge n I) b = A^T y with a per-sample ridge (a ridge added
    once, not per sample, gave a window-length-dependent fit). On a standing window
    (regressors 1, 0, 0, 0 and 0, 0) the no-load current is mean(I_L + I_R) whatever the
    window length: the no-load term is not penalised (this test pinned mean / (1 + ridge)
    while the ridge also shrank c0, which let a current-sensor offset move the load
    coefficients, tests/features/test_features_ftr25_review.py); the residual spread is that
    of the current about it."""
    rng = np.random.default_rng(n)
    cur = 5.0 + rng.standard_normal((2, 1, n))
    zeros = np.zeros((1, n))
    F = physics_features(zeros, zeros, cur[0], cur[1], 10.0, ridge=0.5)
    col = dict(zip(PHYSICS_FEATURES, F[0]))
    total = cur[0, 0] + cur[1, 0]
    assert col["cur_sum__noload_a"] == pytest.approx(total.mean(), rel=1e-12)
    for name in ("cur_sum__drive_a", "cur_sum__inertia_a_s2_per_m", "cur_sum__turn_a",
                 "cur_diff__arc_turn_a", "cur_diff__viscous_a_s_per_rad"):
        assert col[name] == 0.0
    assert col["cur_sum__resid_std_a"] == pytest.approx(total.std(), rel=1e-12)


@given(st.integers(1, 4), st.integers(3, 60), st.sampled_from([6.5, 10.0, 50.0]),
       st.integers(0, 2 ** 32 - 1))
@settings(max_examples=30, deadline=None)
def test_the_operating_point_features_are_numpys_of_the_speed_and_turn_rate(
        n_windows, n_samples, rate, seed):
    """The operating point the currents are read against, on windows driving forward,
    backward or reversing: vel_mean__abs_mean / __std are mean |v| and std(v) of
    v = (v_L + v_R)/2, yaw_rate_cmd__abs_mean / __std those of omega = (v_R - v_L)/B,
    accel__abs_mean mean |numpy.gradient(v, 1/rate)| (a spread about mean |v| survived
    every test: 1 m/s for a window backing at a steady 0.5 m/s)."""
    vl, vr, cl, cr = _wheel_windows(np.random.default_rng(seed), n_windows, n_samples)
    F = physics_features(vl, vr, cl, cr, rate)
    col = {name: F[:, j] for j, name in enumerate(PHYSICS_FEATURES)}
    v, om = 0.5 * (vl + vr), (vr - vl) / HUSKY.track_m
    for name, value in (("vel_mean__abs_mean", np.abs(v).mean(axis=1)),
                        ("vel_mean__std", v.std(axis=1)),
                        ("yaw_rate_cmd__abs_mean", np.abs(om).mean(axis=1)),
                        ("yaw_rate_cmd__std", om.std(axis=1)),
                        ("accel__abs_mean",
                         np.abs(np.gradient(v, 1.0 / rate, axis=1)).mean(axis=1))):
        np.testing.assert_allclose(col[name], value, rtol=1e-9, atol=1e-12, err_msg=name)
    back = physics_features(-np.full((1, n_samples), 0.5), -np.full((1, n_samples), 0.5),
                            cl[:1], cr[:1], rate)
    assert back[0, PHYSICS_FEATURES.index("vel_mean__std")] == 0.0


@pytest.mark.parametrize("missing", [None, pd.NA, np.nan])
@pytest.mark.parametrize("make", [WindowFeatures, WheelPhysicsFeatures])
def test_a_missing_value_of_an_object_window_array_is_refused_as_nan_naming_its_channel(
        missing, make):
    """Windows of a nullable pandas column are an object array holding pd.NA where a value
    is missing: as None, it is a NaN the transformers refuse naming channel and window (it
    was a bare TypeError of float(), naming neither)."""
    X = np.ones((2, 4, 10), dtype=object)
    X[1, 2, 3] = missing
    fx = make(WHEEL_CHANNELS, 10.0)
    with pytest.raises(ValueError, match=r"X contains NaN or inf \(1 value\): 'cur_l' in "
                                         r"window 1"):
        fx.fit_transform(X)
    # (a frame of nullable columns: its to_numpy() is an object array holding pd.NA)
    frame = pd.DataFrame({"x": pd.array([1.0] * 79 + [None], dtype="Float64"),
                          "n": pd.array([2] * 80, dtype="Int64")})
    windows = frame.to_numpy()[:, 0].reshape(2, 4, 10)
    assert windows.dtype == object and windows[1, 3, 9] is pd.NA
    with pytest.raises(ValueError, match=r"'cur_r' in window 1"):
        fx.fit_transform(windows)


@pytest.mark.parametrize("value", [np.datetime64("2026-01-01"), np.timedelta64(3, "s"),
                                   pd.Timestamp("2026-01-01"), pd.Timedelta(3, "s"), pd.NaT,
                                   [1.0], {"a": 1.0}])
def test_an_object_window_array_holding_times_or_containers_is_refused_naming_the_item(value):
    """A datetime64 item was read as its days since 1970 (the datetime64 dtype itself is
    refused), a Timestamp, Timedelta, NaT (a missing time) or a dict ended in a bare
    TypeError of float(), a list in NumPy's 'setting an array element with a sequence':
    each is refused as not a real number, naming the item."""
    X = np.ones((2, 4, 10), dtype=object)
    X[0, 1, 5] = value
    for make in (WindowFeatures, WheelPhysicsFeatures):
        with pytest.raises(ValueError, match=r"X must hold real numbers \(signal samples\), "
                                             r"got an object array holding"):
            make(WHEEL_CHANNELS, 10.0).fit_transform(X)
    # plain numbers of any kind in an object array are still read
    ok = np.ones((2, 4, 10), dtype=object)
    ok[0, 1, 5], ok[1, 0, 0] = np.float32(2.0), 3
    assert np.isfinite(WheelPhysicsFeatures(WHEEL_CHANNELS, 10.0).fit_transform(ok)).all()
