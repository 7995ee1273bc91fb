"""Features review (ftr22): metamorphic relations between windows, channels and entry points."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features import calculators
from features.slip_features import (SLIP_CHANNELS, one_hot_probabilities,
                                    slip_feature_matrix, slip_features, slip_targets,
                                    window_feature_vector)
from features.windows import WindowSet
from terrain.errors import ConfigError, DataFormatError
from terrain.run import TIME, Run
from terrain.vehicles import HUSKY


def _truth_run(slip_1, dt=0.25):
    """A simulated run whose truth holds ``slip_1`` on a ``dt`` clock (dyadic: exact sums)."""
    tt = np.arange(len(slip_1)) * dt
    truth = pd.DataFrame({TIME: tt, "slip_1": slip_1, "slip_2": 0.5, "yaw_rate": 0.5,
                          "v_by": 0.0, "terrain": "SNOW"})
    return Run("sim1", "sim", "SNOW", {"truth": truth})


def _windows(t0, length_s=2.0):
    n, dv = 100, 0.25
    values = {c: np.zeros((len(t0), n)) for c in SLIP_CHANNELS}
    values.update(vel_l=np.full((len(t0), n), 0.5), vel_r=np.full((len(t0), n), 0.5 + dv),
                  vel_diff=np.full((len(t0), n), dv))
    X = np.stack([values[c] for c in SLIP_CHANNELS], axis=1)
    ids = np.array(["sim1"] * len(t0), dtype=object)
    t0 = np.asarray(t0, dtype=float)
    return WindowSet(X, SLIP_CHANNELS, ids, ids, ids, t0, t0 + length_s, 50.0)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 39), st.sampled_from([np.nan, np.inf, -np.inf]),
       st.permutations(range(5)))
def test_a_truth_nan_makes_only_the_windows_holding_it_nan(bad, value, order):
    """A window's target is the mean of the truth inside that window only: a NaN truth
    sample made every LATER window NaN too (the running sum carried it), so a window's
    target depended on the samples of the windows before it (an inf likewise, as inf - inf);
    and the targets follow the windows whatever their order."""
    slip = np.arange(40) * 0.25
    slip[bad] = value
    run = _truth_run(slip)
    starts = np.array([0.0, 2.0, 4.0, 6.0, 8.0])
    Y = slip_targets([run], _windows(starts), 0.5)
    t = np.arange(40) * 0.25
    for k, t0 in enumerate(starts):
        inside = (t >= t0) & (t < t0 + 2.0)
        want = np.nan if inside[bad] else slip[inside].mean()
        np.testing.assert_array_equal(Y["slip_1"].to_numpy()[k], want)
    order = list(order)
    Yp = slip_targets([run], _windows(starts[order]), 0.5)
    np.testing.assert_array_equal(Yp["slip_1"].to_numpy(), Y["slip_1"].to_numpy()[order])


def test_one_hot_probabilities_refuse_a_terrain_named_twice():
    """The table has one column per terrain (``(n, len(terrains))``): a terrain named twice
    was one column, silently, so the feature table lost a ``p__`` column and its terrain
    order."""
    with pytest.raises(ConfigError, match="SNOW"):
        one_hot_probabilities(["SNOW", "ICE"], ["SNOW", "ICE", "SNOW"])
    got = one_hot_probabilities(["SNOW", "ICE"], ["ICE", "SNOW"])
    assert list(got.columns) == ["ICE", "SNOW"] and got.shape == (2, 2)


def _slip_window_set(n_windows=2):
    ws = _windows(np.arange(n_windows) * 2.0)
    ch = list(SLIP_CHANNELS)
    ws.X[:, ch.index("cur_l")] = 5.0
    ws.X[:, ch.index("cur_r")] = 5.5
    ws.X[:, ch.index("az")] = 9.81
    return ws


@pytest.mark.parametrize("columns", [["SNOW", "SNOW"], [1, "1"]])
def test_terrain_probability_columns_of_one_name_are_refused_naming_it(columns):
    """Two probability columns of one name (``p__<name>``) were one column (the second
    kept, 1 and '1' merged without a word, then 'probabilities sum to 0'), or a shape error
    naming neither column; the slip features and the one-window vector refuse them alike."""
    ws = _slip_window_set()
    probs = pd.DataFrame([[1.0, 0.0], [1.0, 0.0]], columns=columns)
    with pytest.raises(ConfigError, match=r"twice"):
        slip_features(ws, HUSKY, probs)
    if len(set(columns)) == 2:
        with pytest.raises(ConfigError, match=r"twice"):
            window_feature_vector(ws.X[0], SLIP_CHANNELS, ws.rate_hz, HUSKY,
                                  dict(zip(columns, (1.0, 0.0))))


def test_slip_feature_rows_equal_the_one_window_vectors_and_follow_a_permutation():
    """slip_features (a batch) and window_feature_vector (one window) give the same row, and
    permuting the windows (and their probabilities) permutes the rows."""
    rng = np.random.default_rng(5)
    ws = _slip_window_set(4)
    ws.X = ws.X + 0.01 * rng.standard_normal(ws.X.shape)
    p = rng.dirichlet([1.0, 1.0], 4)
    probs = pd.DataFrame(p, columns=["SNOW", "GRAVEL"])
    table = slip_features(ws, HUSKY, probs)
    for i in range(4):
        vec = window_feature_vector(ws.X[i], SLIP_CHANNELS, ws.rate_hz, HUSKY,
                                    {"SNOW": p[i, 0], "GRAVEL": p[i, 1]})
        np.testing.assert_array_equal(vec, table.to_numpy()[i])
    order = [2, 0, 3, 1]
    perm = slip_features(ws.subset(np.array(order)), HUSKY, probs.iloc[order])
    np.testing.assert_array_equal(perm.to_numpy(), table.to_numpy()[order])


@pytest.mark.parametrize("floor", [0.0, -0.05, np.nan, np.inf, True, "0.05"])
def test_per_speed_refuses_a_floor_that_does_not_keep_a_standing_window_finite(floor):
    """The floor "keeps near-standstill windows finite": 0 or a negative floor gave inf for a
    standing window, True a floor of 1 m/s, NaN a NaN feature (as WindowFeatures refuses
    them at fit)."""
    current, speed = np.ones((2, 5)), np.zeros((2, 5))
    with pytest.raises(ConfigError, match="min_speed_m_s"):
        calculators.per_speed(current, speed, floor)
    assert calculators.per_speed(current, speed, 0.05).tolist() == [20.0, 20.0]


_NAMES = tuple(calculators.STATISTICS)


@st.composite
def _windows_batch(draw):
    """(n_windows, n_channels, n_samples) of varying windows (population std well above the
    1e-6 floor of the shape moments), from a seed."""
    shape = (draw(st.integers(1, 4)), draw(st.integers(1, 3)), draw(st.integers(2, 40)))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    x = rng.standard_normal(shape) * draw(st.sampled_from([1e-2, 1.0, 30.0]))
    x += rng.exponential(1.0, shape) * draw(st.sampled_from([0.0, 0.1]))   # skewed
    x[..., 0] += 1.0     # no constant window
    return x


@settings(max_examples=60, deadline=None)
@given(_windows_batch(), st.sampled_from([0.25, 2.0, 4.0, -0.5, -1.0, -8.0]),
       st.data())
def test_statistics_follow_a_channel_scale_its_sign_and_permutations(x, c, data):
    """Per channel: a factor c (a power of 2, so scaling is exact) scales mean, min, max by
    c (min and max trade places for c < 0), std, rms and mean_abs_diff by |c|; skewness
    takes the sign of c, kurtosis is unchanged. Permuting windows and channels permutes the
    rows; each named function equals its column of statistics(all names)."""
    got = calculators.statistics(x, _NAMES)
    col = {name: got[..., k] for k, name in enumerate(_NAMES)}
    scaled = calculators.statistics(c * x, _NAMES)
    sc = {name: scaled[..., k] for k, name in enumerate(_NAMES)}
    lo, hi = ("min", "max") if c > 0 else ("max", "min")
    np.testing.assert_array_equal(sc["mean"], c * col["mean"])
    np.testing.assert_array_equal(sc[lo], c * col["min"])
    np.testing.assert_array_equal(sc[hi], c * col["max"])
    for name in ("std", "rms", "mean_abs_diff"):
        np.testing.assert_allclose(sc[name], abs(c) * col[name], rtol=1e-13, atol=0)
    np.testing.assert_allclose(sc["skewness"], np.sign(c) * col["skewness"], rtol=1e-9,
                               atol=1e-12)
    np.testing.assert_allclose(sc["kurtosis"], col["kurtosis"], rtol=1e-9, atol=1e-12)
    wins = data.draw(st.permutations(range(x.shape[0])))
    chans = data.draw(st.permutations(range(x.shape[1])))
    perm = calculators.statistics(x[wins][:, chans], _NAMES)
    np.testing.assert_array_equal(perm, got[wins][:, chans])
    for k, (name, fn) in enumerate(calculators.STATISTICS.items()):
        np.testing.assert_array_equal(fn(x), got[..., k])


@settings(max_examples=40, deadline=None)
@given(_windows_batch(), st.sampled_from([-3.0, 0.5, 9.81, 100.0]))
def test_an_offset_moves_the_mean_min_and_max_only(x, b):
    """An offset b (a gravity component, a current bias) adds b to mean, min and max and
    leaves std, skewness, kurtosis and mean_abs_diff as they were (to round-off)."""
    got = calculators.statistics(x, _NAMES)
    moved = calculators.statistics(x + b, _NAMES)
    scale = np.abs(x).max() + abs(b)
    for k, name in enumerate(_NAMES):
        if name in ("mean", "min", "max"):
            np.testing.assert_allclose(moved[..., k], got[..., k] + b, rtol=0,
                                       atol=1e-12 * scale)
        elif name in ("std", "mean_abs_diff"):
            np.testing.assert_allclose(moved[..., k], got[..., k], rtol=1e-9,
                                       atol=1e-12 * scale)
        elif name != "rms":
            np.testing.assert_allclose(moved[..., k], got[..., k], rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("kind", ["bool", "text"])
def test_the_one_window_vector_and_the_batch_judge_the_samples_alike(kind):
    """window_feature_vector read a boolean mask as samples of 0 and 1 (the batch path
    refuses it) and parsed text; text made the batch path fail inside NumPy (its slope),
    naming nothing. Both now refuse a mask (DataFormatError naming x) and give one row for
    text NumPy reads as numbers, as the statistics do."""
    ws = _slip_window_set(1)
    x = ws.X[0]
    if kind == "bool":
        mask = x > 0.1
        with pytest.raises(DataFormatError, match="booleans"):
            window_feature_vector(mask, SLIP_CHANNELS, ws.rate_hz, HUSKY)
        with pytest.raises(DataFormatError, match="booleans"):
            slip_feature_matrix(mask[None], SLIP_CHANNELS, ws.rate_hz, HUSKY)
    else:
        text = x.astype(str)
        want = slip_feature_matrix(x[None], SLIP_CHANNELS, ws.rate_hz, HUSKY)[1][0]
        np.testing.assert_array_equal(
            slip_feature_matrix(text[None], SLIP_CHANNELS, ws.rate_hz, HUSKY)[1][0], want)
        np.testing.assert_array_equal(
            window_feature_vector(text, SLIP_CHANNELS, ws.rate_hz, HUSKY), want)
        with pytest.raises(DataFormatError, match="x must hold real numbers"):
            slip_feature_matrix(np.full((1, len(SLIP_CHANNELS), 5), "fast"), SLIP_CHANNELS,
                                ws.rate_hz, HUSKY)


@pytest.mark.parametrize("drop", ["cur_r", TIME])
def test_window_frame_names_a_missing_column(drop):
    """window_frame on a frame lacking a channel asked for (or its clock) raised pandas' bare
    KeyError naming the whole selection (ftr22's left-alone); a MissingColumnError now names
    the first missing column and what the frame has."""
    from features.windows import WindowConfig, window_frame
    from terrain.errors import MissingColumnError

    frame = pd.DataFrame({TIME: np.arange(200) / 50.0, "vel_l": 0.5, "vel_r": 0.5,
                          "cur_l": 2.0, "cur_r": 2.0}).drop(columns=[drop])
    with pytest.raises(MissingColumnError, match=f"no column\\(s\\) \\['{drop}'\\]") as err:
        window_frame(frame, ["vel_l", "cur_r"], WindowConfig(window_s=1.0, hop_s=1.0))
    assert err.value.column == drop
    kept = frame if drop == TIME else frame.assign(cur_r=2.0)
    if drop != TIME:
        X, *_ = window_frame(kept, ["vel_l", "cur_r"], WindowConfig(window_s=1.0, hop_s=1.0))
        assert X.shape == (4, 2, 50)
