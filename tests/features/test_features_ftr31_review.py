"""ftr31 review of features/windows.py and features/slip_features.py: window cutting on an
epoch clock, frames out of time order, the slip features' units, symmetry and non-finite
windows."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features.slip_features import (SLIP_CHANNELS, slip_feature_matrix, slip_targets,
                                    window_feature_vector)
from features.windows import WindowConfig, WindowSet, make_windows, window_frame
from terrain.errors import NonFiniteInputError, TimestampError
from terrain.run import TIME, Run
from terrain.vehicles import HUSKY
from test_features_ftr15_review import _run
from test_features_ftr18_review import _shifted

EPOCH_S = 1.7e9


# --------------------------------------------------------------------------- window cutting


@given(st.floats(2.5, 6.0), st.one_of(st.none(), st.floats(0.5, 1.5)),
       st.floats(0.0, 1.0), st.sampled_from([None, 0.35, 0.5, 1.5]), st.integers(0, 2 ** 16))
@settings(max_examples=10, deadline=None)
def test_windows_on_an_epoch_clock_are_the_windows_of_the_same_run_from_zero(
        duration, hole, fraction, hop_s, seed):
    """Every stream's clock shifted to the Unix epoch (1.7e9 s plus a fraction of a second,
    resolved to 2.4e-7 s only) keeps the windows, their count, the counts of what was left
    out, and bounds shifted by it (a hop of 0.35 s is not a multiple of the 0.05 s period's
    float)."""
    run = _run("t/E/0", duration, seed, None if hole is None else (hole, hole + 0.6))
    shift = EPOCH_S + fraction
    config = WindowConfig(window_s=1.0, hop_s=hop_s, rate_hz=20.0)
    a = make_windows([run], "all", config)
    b = make_windows([_shifted(run, shift)], "all", config)
    assert len(a) == len(b)
    # (the streams' stamps themselves are rounded to 2.4e-7 s: so are the interpolated values)
    np.testing.assert_allclose(b.X, a.X, rtol=0, atol=1e-4)
    np.testing.assert_allclose(b.t_start_s - shift, a.t_start_s, atol=1e-6)
    np.testing.assert_allclose(b.t_end_s - b.t_start_s, 1.0, atol=1e-6)
    for key in ("windows", "dropped_gap", "empty_gap"):
        assert a.counts[key] == b.counts[key]
    for key in ("window_tail_s", "between_windows_s"):
        assert a.counts[key] == pytest.approx(b.counts[key])


def _frame(n, rate_hz=10.0, t0=0.0):
    t = t0 + np.arange(n) / rate_hz
    return pd.DataFrame({TIME: t, "a": np.arange(n, dtype=float), "b": -np.arange(n, dtype=float)})


@pytest.mark.parametrize("kind", ["swapped", "repeated", "nan", "inf"])
def test_window_frame_refuses_a_time_column_out_of_order_naming_column_and_row(kind):
    # a frame out of time order was cut by position without a word: windows with start
    # times going back, or two windows at one time, and a NaN start time
    frame = _frame(40)
    t = frame[TIME].to_numpy().copy()
    if kind == "swapped":
        t[[12, 13]] = t[[13, 12]]
    elif kind == "repeated":
        t[13] = t[12]
    else:
        t[13] = np.nan if kind == "nan" else np.inf
    frame[TIME] = t
    with pytest.raises(TimestampError, match=r"window_frame: .*'t_s'.* row 13") as err:
        window_frame(frame, ("a", "b"), WindowConfig(window_s=1.0, rate_hz=10.0))
    assert err.value.column == TIME and err.value.row == 13


@given(st.integers(0, 60), st.integers(4, 12), st.integers(1, 15), st.floats(-1e3, 1e3))
@settings(max_examples=60, deadline=None)
def test_window_frame_of_an_ordered_frame_is_its_slices_at_the_hop(total, n, hop, t0):
    """On an ordered frame: window k holds samples [k hop, k hop + n), starts at their first
    time, ends one period after their last; a frame shorter than one window gives none, its
    whole length counted as the tail."""
    frame = _frame(total, 10.0, t0)
    config = WindowConfig(window_s=n / 10.0, hop_s=hop / 10.0, rate_hz=10.0)
    X, t_start, t_end, _, counts = window_frame(frame, ("a", "b"), config)
    starts = np.arange(0, total - n + 1, min(hop, max(total, 1)))
    assert len(X) == starts.size
    for k, s in enumerate(starts):
        np.testing.assert_array_equal(X[k, 0], np.arange(s, s + n))
        np.testing.assert_array_equal(X[k, 1], -np.arange(s, s + n))
    np.testing.assert_allclose(t_start, t0 + starts / 10.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(t_end, t0 + (starts + n) / 10.0, rtol=0, atol=1e-9)
    if starts.size == 0:
        assert counts["window_tail_s"] == pytest.approx(total / 10.0)


# --------------------------------------------------------------------------- slip features


def _window(rng, n=100, speed=0.5, turn=0.2):
    x = rng.standard_normal((len(SLIP_CHANNELS), n)) * 0.05
    ch = {c: i for i, c in enumerate(SLIP_CHANNELS)}
    x[ch["vel_l"]] += speed - 0.5 * turn * HUSKY.track_m
    x[ch["vel_r"]] += speed + 0.5 * turn * HUSKY.track_m
    x[ch["vel_diff"]] = x[ch["vel_r"]] - x[ch["vel_l"]]
    x[ch["yaw_rate_wheels"]] = x[ch["vel_diff"]] / HUSKY.track_m
    x[ch["cur_l"]] += 5.0
    x[ch["cur_r"]] += 6.0
    x[ch["cur_diff"]] = x[ch["cur_r"]] - x[ch["cur_l"]]
    x[ch["az"]] += 9.81
    x[ch["wz"]] += 0.8 * turn
    return x


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("channel", ["cur_l", "vel_r", "wz"])
def test_slip_features_refuse_a_window_holding_nan_or_inf_naming_channel_and_window(
        value, channel):
    # a NaN or inf sample made that channel's mean and std NaN (and the slope, pitch,
    # inv_chi or the physics slip with them) without a word, batch and one window alike
    rng = np.random.default_rng(0)
    X = np.stack([_window(rng) for _ in range(3)])
    X[2, SLIP_CHANNELS.index(channel), 17] = value
    with pytest.raises(NonFiniteInputError, match=rf"slip features: .*'{channel}' in window 2"):
        slip_feature_matrix(X, SLIP_CHANNELS, 50.0, HUSKY)
    with pytest.raises(NonFiniteInputError, match=rf"'{channel}' in window 0"):
        window_feature_vector(X[2], SLIP_CHANNELS, 50.0, HUSKY, {"ASPHALT": 1.0})


@given(st.floats(-1.0, 1.0), st.floats(0.0, 5.0), st.integers(0, 2 ** 16))
@settings(max_examples=40, deadline=None)
def test_a_standing_or_constant_window_gives_finite_features(speed, current, seed):
    """Constant channels (the robot standing, wheel speeds 0, or any constant speed) give
    finite features: spreads 0, slope 0, inv_chi finite (its floor), physics slip finite."""
    rng = np.random.default_rng(seed)
    x = np.ones((len(SLIP_CHANNELS), 50)) * rng.uniform(-1, 1, (len(SLIP_CHANNELS), 1))
    ch = {c: i for i, c in enumerate(SLIP_CHANNELS)}
    x[ch["vel_l"]] = x[ch["vel_r"]] = speed
    x[ch["vel_diff"]] = x[ch["yaw_rate_wheels"]] = 0.0
    x[ch["cur_l"]] = x[ch["cur_r"]] = current
    x[ch["az"]] = 9.81
    names, v = slip_feature_matrix(x[None], SLIP_CHANNELS, 50.0, HUSKY,
                                   {"ASPHALT": np.array([1.0])})
    assert np.isfinite(v).all(), dict(zip(names, v[0]))
    f = dict(zip(names, v[0]))
    assert f["vel_mean__slope"] == pytest.approx(0.0, abs=1e-12)
    for c in SLIP_CHANNELS:
        assert f[f"{c}__std"] == pytest.approx(0.0, abs=1e-9)


@given(st.floats(0.1, 1.5), st.floats(-0.5, 0.5), st.floats(0.5, 3.0), st.integers(0, 2 ** 16))
@settings(max_examples=30, deadline=None)
def test_slip_feature_units_follow_a_change_of_time_unit(speed, turn, accel, seed):
    """A ramp of ``accel`` m/s^2 has slope ``accel`` (m/s per s): sampling the same ramp at
    twice the rate over the same time keeps the slope; a yaw rate in rad/s scaled by k with
    the wheel yaw rate scales inv_chi by nothing (a ratio, dimensionless)."""
    rng = np.random.default_rng(seed)
    ch = {c: i for i, c in enumerate(SLIP_CHANNELS)}
    slopes = []
    for rate in (25.0, 50.0):
        n = int(2.0 * rate)
        t = np.arange(n) / rate
        x = _window(rng, n, speed, turn)
        ramp = accel * (t - t.mean())
        x[ch["vel_l"]] = speed + ramp
        x[ch["vel_r"]] = speed + ramp
        slopes.append(slip_feature_matrix(x[None], SLIP_CHANNELS, rate, HUSKY)[1][0])
    names = slip_feature_matrix(x[None], SLIP_CHANNELS, 50.0, HUSKY)[0]
    k = names.index("vel_mean__slope")
    assert slopes[0][k] == pytest.approx(accel, rel=1e-9)
    assert slopes[1][k] == pytest.approx(accel, rel=1e-9)


@given(st.floats(0.0, 1.0), st.integers(0, 2 ** 16))
@settings(max_examples=20, deadline=None)
def test_slip_targets_of_a_run_on_an_epoch_clock_are_those_from_zero(fraction, seed):
    """Windows and the truth shifted together to the Unix epoch give the same targets: the
    truth samples on a window's edges go to the same window whichever way they round."""
    rng = np.random.default_rng(seed)
    tt = np.arange(0, 10.0, 0.01)
    truth = pd.DataFrame({TIME: tt, "slip_1": rng.random(tt.size),
                          "slip_2": rng.random(tt.size), "yaw_rate": 0.5 + rng.random(tt.size),
                          "v_by": rng.standard_normal(tt.size), "terrain": "SNOW"})
    n = 20      # 1.7 s windows at a 0.35 s hop: edges between the truth's 0.01 s stamps
    t0 = np.arange(n) * 0.35
    X = np.stack([_window(rng, 85) for _ in range(n)])
    ids = np.full(n, "sim", dtype=object)

    def targets(shift):
        run = Run("sim", "sim", "SNOW", {"truth": truth.assign(**{TIME: tt + shift})})
        ws = WindowSet(X, SLIP_CHANNELS, ids, ids, np.full(n, "SNOW", dtype=object),
                       t0 + shift, t0 + 1.7 + shift, 50.0)
        return slip_targets([run], ws, HUSKY.track_m)

    a, b = targets(0.0), targets(EPOCH_S + fraction)
    for c in ("slip_1", "slip_2", "chi", "v_by", "yaw_rate"):
        np.testing.assert_allclose(b[c], a[c], rtol=1e-12, atol=1e-12)
    assert list(a["terrain"]) == list(b["terrain"])


# window_frame cuts by row: a frame off config.rate_hz's uniform clock (a 100 Hz frame cut
# with a 50 Hz config, a missing row) is refused by the shared rule check_uniform_clock
@pytest.mark.parametrize("kind", ["rate", "hole"])
def test_window_frame_refuses_a_frame_off_the_configs_uniform_clock(kind):
    from terrain.errors import DataFormatError

    frame = _frame(400, 100.0)
    config = WindowConfig(window_s=1.0, rate_hz=50.0 if kind == "rate" else 100.0)
    if kind == "hole":
        frame = frame.drop(index=range(150, 170)).reset_index(drop=True)
    with pytest.raises(DataFormatError):
        window_frame(frame, ("a", "b"), config)


def _targets_inputs(channels=SLIP_CHANNELS, drop=None):
    tt = np.arange(0, 10.0, 0.01)
    truth = pd.DataFrame({TIME: tt, "slip_1": 0.1, "slip_2": 0.2, "yaw_rate": 0.5,
                          "v_by": 0.0, "terrain": "SNOW"})
    if drop is not None:
        truth = truth.drop(columns=[drop])
    n = 3
    ids = np.full(n, "sim", dtype=object)
    X = np.ones((n, len(channels), 100))
    ws = WindowSet(X, tuple(channels), ids, ids, ids, np.arange(n) * 1.0, np.arange(n) + 2.0,
                   50.0)
    return Run("sim", "sim", "SNOW", {"truth": truth}, source="sim.parquet"), ws


@pytest.mark.parametrize("column", ["slip_1", "slip_2", "yaw_rate", "v_by", "terrain"])
def test_slip_targets_name_the_run_stream_and_column_a_truth_stream_lacks(column):
    # pandas' bare KeyError "['v_by'] not in index" named neither run nor stream
    from terrain.errors import MissingColumnError

    run, ws = _targets_inputs(drop=column)
    with pytest.raises(MissingColumnError, match=rf"truth.*{column}") as err:
        slip_targets([run], ws, HUSKY.track_m)
    assert err.value.column == column


@pytest.mark.parametrize("missing", ["vel_l", "vel_r"])
def test_slip_targets_refuse_windows_without_the_wheel_speeds_naming_them(missing):
    # chi reads vel_r - vel_l of the windows: a bare KeyError 'vel_r' before
    from terrain.errors import ConfigError

    run, ws = _targets_inputs([c for c in SLIP_CHANNELS if c != missing])
    with pytest.raises(ConfigError, match=rf"slip_targets: .*'{missing}'"):
        slip_targets([run], ws, HUSKY.track_m)


@pytest.mark.parametrize("vehicle", ["agrimaro", None, 0.5708])
def test_slip_features_refuse_a_vehicle_without_left_and_right_sides(vehicle):
    # the AgriMaRo's parameters (no track), None or a bare track width failed in a bare
    # AttributeError "object has no attribute 'track_m'"
    from terrain.errors import ConfigError
    from terrain.vehicles import get_vehicle

    params = get_vehicle(vehicle) if isinstance(vehicle, str) else vehicle
    x = _window(np.random.default_rng(1))
    with pytest.raises(ConfigError, match="skid-steer vehicle"):
        slip_feature_matrix(x[None], SLIP_CHANNELS, 50.0, params)
    with pytest.raises(ConfigError, match="skid-steer vehicle"):
        window_feature_vector(x, SLIP_CHANNELS, 50.0, params)


def _mirrored(run):
    """The run driven mirror-wise: left and right sides swapped, the lateral acceleration,
    roll rate and yaw rate of the opposite sign."""
    imu = run.streams["imu"].assign(ay=-run.streams["imu"]["ay"],
                                    wx=-run.streams["imu"]["wx"],
                                    wz=-run.streams["imu"]["wz"])
    w = run.streams["wheels"]
    wheels = w.assign(vel_l=w["vel_r"], vel_r=w["vel_l"], cur_l=w["cur_r"], cur_r=w["cur_l"])
    return Run(run_id=run.run_id, dataset=run.dataset, terrain=run.terrain,
               streams={"imu": imu, "wheels": wheels}, source=run.source)


#: Slip features with a side: (feature, its mirror image, sign).
_SIDED = {"cur_l__mean": ("cur_r__mean", 1), "vel_l__mean": ("vel_r__mean", 1),
          "cur_l__std": ("cur_r__std", 1), "vel_l__std": ("vel_r__std", 1),
          "vel_diff__mean": ("vel_diff__mean", -1), "cur_diff__mean": ("cur_diff__mean", -1),
          "yaw_rate_wheels__mean": ("yaw_rate_wheels__mean", -1), "ay__mean": ("ay__mean", -1),
          "wz__mean": ("wz__mean", -1), "phys_slip_l": ("phys_slip_r", 1)}


@given(st.floats(2.5, 6.0), st.sampled_from([None, 0.5]), st.floats(0.0, 1e4),
       st.integers(0, 2 ** 16))
@settings(max_examples=8, deadline=None)
def test_slip_features_of_a_mirrored_run_are_mirrored_whatever_its_time_origin(
        duration, hop_s, origin, seed):
    """A run mirrored left <-> right (and started at another time) gives the same windows
    whose sided slip features are swapped or change sign, the others unchanged (pitch,
    spreads of the differences, inv_chi: a ratio of two yaw rates that both change sign)."""
    run = _run("t/M/0", duration, seed)
    config = WindowConfig(window_s=1.0, hop_s=hop_s, rate_hz=50.0)
    a = make_windows([run], SLIP_CHANNELS, config)
    b = make_windows([_shifted(_mirrored(run), origin)], SLIP_CHANNELS, config)
    assert len(a) == len(b) > 0
    probs = pd.DataFrame({"ASPHALT": np.full(len(a), 0.7), "ICE": np.full(len(a), 0.3)})
    from features.slip_features import slip_features

    fa = slip_features(a, HUSKY, probs)
    fb = slip_features(b, HUSKY, probs)
    mirror = {**_SIDED, **{m: (f, s) for f, (m, s) in _SIDED.items()}}
    for col in fa.columns:
        other, sign = mirror.get(col, (col, 1))
        np.testing.assert_allclose(fb[col], sign * fa[other], rtol=1e-6, atol=1e-7,
                                   err_msg=col)


# --------------------------------------------------------------------------- batch vs live


@pytest.fixture(scope="module")
def _wheel_model_and_run(borealtc_runs):
    """A small wheel-only model (20 Hz clock, 2 s windows) fitted on two runs per terrain,
    and a run it has not seen."""
    from types import MappingProxyType

    from terrain.models.experiment import inference_pipeline
    from terrain.models.svm import SVMConfig
    from terrain.serving import StreamModel
    from terrain.serving.model import training_steps_s

    train = []
    for terrain in sorted({r.terrain for r in borealtc_runs}):
        train += [r for r in borealtc_runs if r.terrain == terrain][:2]
    config = WindowConfig(window_s=2.0, rate_hz=20.0)
    ws = make_windows(train, "wheels", config)
    pipe = inference_pipeline(ws, SVMConfig(probability=True)).fit(ws.X, ws.labels.astype(str))
    classes = tuple(str(c) for c in np.unique(ws.labels.astype(str)))
    model = StreamModel(pipe, ws.channels, config, classes, MappingProxyType(
        {"channel_steps_s": training_steps_s(train, ws.channels)}))
    seen = {r.run_id for r in train}
    unseen = next(r for r in borealtc_runs if r.run_id not in seen and r.duration_s > 30)
    return model, unseen


@pytest.mark.parametrize("hop_s", [2.0, 0.35])
@pytest.mark.parametrize("shift", [0.0, 1234.56, EPOCH_S, EPOCH_S + 0.37])
def test_live_windows_are_the_batch_windows_whatever_the_clock_origin(
        _wheel_model_and_run, shift, hop_s):
    """A wheel stream on the model's clock pushed live with every stamp shifted (the Unix
    epoch included) gives the batch windows' decisions of the run from its own origin:
    the same decision times (shifted) and probabilities."""
    from terrain.io.align import align_streams
    from terrain.run import WHEEL_CHANNELS
    from terrain.serving import (CataloguePeakTargets, SmoothingConfig, StreamConfig,
                                 StreamService)
    from features.windows import add_derived_channels

    model, run = _wheel_model_and_run
    frame = align_streams(run, ("wheels",), model.window.rate_hz).iloc[:400]
    config = WindowConfig(window_s=model.window.window_s, hop_s=hop_s,
                          rate_hz=model.window.rate_hz)
    X, _, t1, _, _ = window_frame(add_derived_channels(frame), model.channels, config)
    svc = StreamService(model, CataloguePeakTargets(model.classes),
                        StreamConfig(smoothing=SmoothingConfig(dwell_s=None), hop_s=hop_s))
    decisions = []
    for row in frame.itertuples(index=False):
        values = {c: getattr(row, c) for c in WHEEL_CHANNELS}
        decisions += svc.push("wheels", row.t_s + shift, values)
    n = min(len(decisions), len(X))
    assert n >= len(X) - 1 > 5
    np.testing.assert_allclose([d.t_s - shift for d in decisions[:n]], t1[:n], atol=1e-6)
    expected = model.pipeline.predict_proba(X[:n])
    order = [list(model.pipeline.classes_).index(c) for c in model.classes]
    got = np.array([d.proba for d in decisions[:n]])
    np.testing.assert_allclose(got, expected[:, order], atol=1e-4)
    assert all(d.flags == "" for d in decisions[:n])


@pytest.mark.parametrize("column, error", [
    ([True, False, True], "ConfigError"),
    (pd.array([True, False, True], dtype="boolean"), "ConfigError"),
    (["0.5", "x", "1"], "DataFormatError")])
def test_slip_features_refuse_a_probability_column_of_booleans_or_text_naming_it(column,
                                                                                 error):
    # the batch path converted each column to float before slip_feature_matrix's boolean
    # check: a mask of the terrain seen was read as probabilities 0 and 1 (the one-window
    # path refuses it), and text a bare "could not convert string to float: 'x'"
    import terrain.errors as errors
    from features.slip_features import slip_features

    rng = np.random.default_rng(2)
    X = np.stack([_window(rng) for _ in range(3)])
    ids = np.full(3, "r", dtype=object)
    ws = WindowSet(X, SLIP_CHANNELS, ids, ids, ids, np.arange(3.0), np.arange(3.0) + 2, 50.0)
    probs = pd.DataFrame({"ASPHALT": column, "ICE": [0.5, 0.5, 0.5]})
    with pytest.raises(getattr(errors, error), match="slip_features: probability of ASPHALT"):
        slip_features(ws, HUSKY, probs)


@pytest.mark.parametrize("channels", [(), [], "a"])
def test_window_frame_refuses_no_channel_or_a_bare_string(channels):
    # no channel: every window came back empty and was counted as a gap as well; a string
    # was read letter by letter as channel names
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match="sequence of one or more channel names"):
        window_frame(_frame(400, 100.0), channels, WindowConfig(window_s=1.0, rate_hz=100.0))
