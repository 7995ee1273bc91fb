"""ftr18 review of features/: inputs silently taken, and properties of the windowing."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features.ekf_signals import window_ekf_channels
from features.windows import WindowConfig, WindowSet, make_windows
from terrain.errors import ConfigError, EstimationError
from terrain.run import Run
from test_features_ftr15_review import _run


def test_window_ekf_channels_refuse_a_boolean_mask_for_the_signals():
    # a mask handed over for the windows ran the filter on speeds of 0 and 1 m/s
    X = np.ones((2, 3, 20), dtype=bool)
    with pytest.raises(EstimationError, match="window_ekf_channels: X must hold numbers"):
        window_ekf_channels(X, ("vel_l", "vel_r", "wz"), 50.0)


@pytest.mark.parametrize("track", [0.0, -0.5708, float("nan"), float("inf"), True, "0.57"])
def test_derived_wheel_channels_refuse_a_track_that_is_not_a_positive_length(track):
    # 0 gave yaw_rate_wheels NaN (inf for a turn), a negative track the opposite yaw rate
    from features.windows import add_derived_channels, derived_wheel_arrays

    one = np.ones(3)
    with pytest.raises(ConfigError, match="derived_wheel_arrays.track_m"):
        derived_wheel_arrays(one, 2 * one, one, one, track)
    frame = pd.DataFrame({"t_s": [0.0, 0.02, 0.04], "vel_l": one, "vel_r": 2 * one,
                          "cur_l": one, "cur_r": one})
    with pytest.raises(ConfigError, match="derived_wheel_arrays.track_m"):
        add_derived_channels(frame, track)


def test_derived_wheel_channels_of_a_valid_track_are_unchanged():
    from features.windows import derived_wheel_arrays

    out = derived_wheel_arrays(np.array([0.2]), np.array([0.4]), np.array([1.0]),
                               np.array([3.0]), 0.5)
    assert out["yaw_rate_wheels"][0] == pytest.approx(0.4)
    assert out["vel_mean"][0] == pytest.approx(0.3)
    assert out["cur_diff"][0] == pytest.approx(2.0)


# --------------------------------------------------------------------------- properties
# (runs: ftr15's in-memory run, IMU at 100 Hz and wheels at 10 Hz, an optional wheel hole)


def _shifted(run, shift_s):
    streams = {k: v.assign(t_s=v["t_s"] + shift_s) for k, v in run.streams.items()}
    return Run(run_id=run.run_id, dataset=run.dataset, terrain=run.terrain, streams=streams,
               source=run.source)


@given(st.floats(2.5, 7.0), st.one_of(st.none(), st.floats(0.5, 1.5)),
       st.floats(-500.0, 5000.0), st.sampled_from([None, 0.5, 1.5]),
       st.sampled_from([None, 2.0]), st.integers(0, 2 ** 16))
@settings(max_examples=15, deadline=None)
def test_windows_of_a_run_do_not_depend_on_where_its_clock_starts(duration, hole, shift,
                                                                  hop_s, partition_s, seed):
    """A run whose every stream's clock is shifted by the same time gives the same windows
    (to round-off of the interpolation), the same counts, and window bounds shifted by it."""
    run = _run("t/X/0", duration, seed, None if hole is None else (hole, hole + 0.6))
    config = WindowConfig(window_s=1.0, hop_s=hop_s, rate_hz=20.0, partition_s=partition_s)
    a = make_windows([run], "all", config)
    b = make_windows([_shifted(run, shift)], "all", config)
    assert len(a) == len(b)
    np.testing.assert_allclose(b.X, a.X, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(b.t_start_s - shift, a.t_start_s, atol=1e-6)
    np.testing.assert_allclose(b.t_end_s - shift, a.t_end_s, atol=1e-6)
    assert list(a.groups) == list(b.groups)
    for key in ("windows", "dropped_gap", "empty_gap", "dropped_unsteady"):
        assert a.counts[key] == b.counts[key]
    for key in ("partition_tail_s", "window_tail_s", "between_windows_s"):
        assert a.counts[key] == pytest.approx(b.counts[key])


def _window_set(n_runs, per_run):
    ids = np.repeat([f"r{i}" for i in range(n_runs)], per_run)
    n = ids.size
    counts = {"windows": n, "dropped_gap": 3,
              "per_run": {f"r{i}": {"windows": per_run, "dropped_gap": 1}
                          for i in range(n_runs)}}
    return WindowSet(X=np.arange(n * 2 * 4, dtype=float).reshape(n, 2, 4), channels=("a", "b"),
                     run_ids=ids.astype(object), groups=ids.astype(object),
                     labels=np.full(n, "ICE", dtype=object),
                     t_start_s=np.arange(n, dtype=float), t_end_s=np.arange(n) + 1.0,
                     rate_hz=4.0, counts=counts)


@given(st.integers(1, 4), st.integers(1, 5), st.data())
@settings(max_examples=60, deadline=None)
def test_a_subset_keeps_its_counts_consistent_with_its_windows(n_runs, per_run, data):
    """After any selection (mask or indices, repeated, negative or none) and a subset of the
    subset: counts['windows'] is the windows held, per run too; per run, the windows held
    once plus those not selected make the windows cut; what windowing dropped is kept."""
    ws = _window_set(n_runs, per_run)
    n = len(ws)
    index = st.integers(-n, n - 1)
    sel = data.draw(st.one_of(st.lists(st.booleans(), min_size=n, max_size=n).map(np.array),
                              st.lists(index, max_size=2 * n).map(
                                  lambda v: np.array(v, dtype=int))))
    sub = ws.subset(sel)
    # a subset of the subset, by a mask (its rows once each)
    sub2 = sub.subset(np.arange(len(sub)) % 2 == 0) if len(set(sub.t_start_s)) == len(sub) \
        else sub
    for s in (sub, sub2):
        assert s.counts["windows"] == len(s)
        assert sum(e["windows"] for e in s.counts["per_run"].values()) == len(s)
        for rid, entry in s.counts["per_run"].items():
            held = s.run_ids == rid
            assert entry["windows"] == int(held.sum())
            assert entry["dropped_gap"] == 1
            unique = len(set(s.t_start_s[held]))
            assert unique + entry["not_selected"] == per_run
        assert len(set(s.t_start_s)) + s.counts["not_selected"] == n
        assert s.counts["dropped_gap"] == 3
        # each window keeps its own samples, run, group, label and bounds
        rows = s.t_start_s.astype(int)
        np.testing.assert_array_equal(s.X, ws.X[rows])
        assert list(s.run_ids) == list(ws.run_ids[rows])
    assert ws.counts["windows"] == n and "not_selected" not in ws.counts


def test_one_hot_probabilities_refuse_a_label_outside_the_terrains():
    # a row of zeros is no probability: the physics slip refused it later as 'terrain
    # probabilities sum to 0 on some rows', naming neither the label nor the window
    from features.slip_features import one_hot_probabilities

    with pytest.raises(ConfigError, match=r"label\(s\) \['MUD'\].*window 1.*'ICE', 'SNOW'"):
        one_hot_probabilities(["ICE", "MUD", "SNOW"], ["ICE", "SNOW"])
    with pytest.raises(ConfigError, match="sequence of labels.*the text 'ICE'"):
        one_hot_probabilities("ICE", ["ICE", "SNOW"])
    out = one_hot_probabilities(np.array(["SNOW", "ICE"], dtype=object), ["ICE", "SNOW"])
    np.testing.assert_array_equal(out.to_numpy(), [[0.0, 1.0], [1.0, 0.0]])
    assert list(out.columns) == ["ICE", "SNOW"]
    assert one_hot_probabilities([], ["ICE"]).shape == (0, 1)


@pytest.mark.parametrize("track", [0.0, -0.5708, float("nan"), True])
def test_slip_targets_refuse_a_track_that_is_not_a_positive_length(track):
    # track 0 gave chi inf (NaN at no wheel speed difference), a negative one chi < 0
    from features.slip_features import slip_targets

    with pytest.raises(ConfigError, match="slip_targets.track_m"):
        slip_targets([], _window_set(1, 2), track)


@given(st.integers(1, 4), st.integers(1, 40), st.integers(0, 2 ** 32 - 1),
       st.sampled_from([0.0, 9.81, -1e3]), st.booleans())
@settings(max_examples=60, deadline=None)
def test_the_compiled_statistics_equal_a_numpy_and_scipy_reference(m, n, seed, offset,
                                                                   constant_row):
    """The one compiled pass of calculators.statistics gives NumPy's mean, std, rms, min,
    max and mean |diff| and scipy's biased skewness and excess kurtosis (0 for a constant
    row) of each row, for any row length (one sample: mean |diff| NaN), offset and values
    on a 1/8 grid (so a row varies by far more than the constant-window threshold)."""
    from scipy import stats as sps

    from features.calculators import statistics

    rng = np.random.default_rng(seed)
    x = offset + rng.integers(-800, 800, size=(m, 2, n)) / 8.0
    if constant_row:
        x[0, 1] = offset + 1.25
    names = ("mean", "std", "skewness", "kurtosis", "rms", "min", "max", "mean_abs_diff")
    got = statistics(x, names)
    d = x - x.mean(axis=-1, keepdims=True)
    varies = (d ** 2).mean(axis=-1) > 1e-12
    with np.errstate(all="ignore"):
        skew = np.where(varies, sps.skew(x, axis=-1, bias=True), 0.0)
        kurt = np.where(varies, sps.kurtosis(x, axis=-1, bias=True), 0.0)
    ref = np.stack([x.mean(-1), x.std(-1), skew, kurt, np.sqrt((x ** 2).mean(-1)), x.min(-1),
                    x.max(-1), np.abs(np.diff(x, axis=-1)).mean(-1) if n > 1
                    else np.full(x.shape[:-1], np.nan)], axis=-1)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9 * (1 + abs(offset)))
