"""Review tests (est19): estimation defects found by targeted and property-based checks."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from terrain.errors import (ConfigError, CovarianceError, EstimationError, ShapeError,
                            TimeStepError)
from terrain.estimation.agrimaro import AgriMaRoEKFSettings, agrimaro_samples, estimate_agrimaro
from terrain.estimation.consistency import (chi2_test, effective_sample_size,
                                            integrated_autocorrelation_time, nees, rmse)
from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer
from terrain.estimation.prefilter import ema_filter, robust_noise_std
from terrain.estimation.runner import SensorSamples, make_grid
from terrain.estimation.skid_steer import estimate_skid_steer
from terrain.estimation.slip_state import SlipStateModel

HALF_TRACK_M = 0.3


def _arc(t_s: np.ndarray, v_m_s: float, yaw_rate_rad_s: float) -> np.ndarray:
    """Pose (x, y, theta) of a vehicle on a circle from the origin, heading 0 at t = 0."""
    th = yaw_rate_rad_s * t_s
    return np.c_[np.sin(th) * v_m_s / yaw_rate_rad_s,
                 (1.0 - np.cos(th)) * v_m_s / yaw_rate_rad_s, th]


@settings(max_examples=25, deadline=None)
@given(v=st.floats(0.3, 1.5), w=st.floats(0.2, 0.8), gap_s=st.floats(0.3, 1.5))
def test_observer_predicts_a_gap_after_a_missing_sample_in_median_steps(v, w, gap_s):
    """A time gap opened by a missing sample is predicted in steps of at most the median
    step, as one opened by a sample read (module docstring): one Euler step over the whole
    gap left the pose 0.25 m off the arc after a 1 s gap in a 0.5 rad/s turn."""
    t = np.r_[np.arange(0.0, 1.0, 0.01), 1.0 + gap_s + np.arange(0.0, 1.0, 0.01)]
    pose = _arc(t, v, w)
    vr = np.full(t.size, v + HALF_TRACK_M * w)
    vl = np.full(t.size, v - HALF_TRACK_M * w)
    s = AdaptiveObserverSettings(half_track_m=HALF_TRACK_M)
    read = run_adaptive_observer(t, pose, vr, vl, s)
    missing = pose.copy()
    missing[99] = np.nan                         # the sample that opens the gap
    skipped = run_adaptive_observer(t, missing, vr, vl, s)
    assert skipped.missing_samples == 1
    # the first sample after the gap sees the same error either way (to the one correction
    # step the missing sample lacks: < 0.1 mm), about a centimetre at most, not the arc's
    # v w h^2 / 2 (3 mm to 1.3 m over these speeds and gaps)
    assert np.abs(skipped.error[100, :2]).max() < 0.02
    np.testing.assert_allclose(skipped.error[100, :2], read.error[100, :2], atol=5e-4)


def test_nees_refuses_a_covariance_that_makes_it_negative():
    """NEES is a quadratic form in P^-1: a negative value says P is not a covariance (a sign
    error in a hand-built P); it was returned as a NEES of -2."""
    e = np.array([[1.0, 1.0], [0.5, 0.0], [1.0, 0.0]])
    P = np.stack([np.eye(2), np.eye(2), np.diag([-1.0, 1.0])])
    with pytest.raises(CovarianceError, match=r"not positive definite .* at step 2$"):
        nees(e, P)
    np.testing.assert_allclose(nees(e[:2], P[:2]), [2.0, 0.25])


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(1, 4), st.integers(0, 2**32 - 1))
def test_nees_equals_its_definition_for_positive_definite_covariances(N, n, seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(N, n, n))
    P = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(n)
    e = rng.normal(size=(N, n))
    want = [float(e[k] @ np.linalg.inv(P[k]) @ e[k]) for k in range(N)]
    np.testing.assert_allclose(nees(e, P), want, rtol=1e-8)


def test_chi2_test_counts_an_infinite_value_and_refuses_a_negative_one():
    """An infinite NEES (a filter that diverged) was dropped as NaN is, so the rest of the run
    read consistent; a negative NIS (not a quadratic form) was averaged in."""
    good = np.full(50, 2.0)
    assert chi2_test(good, 2).inside
    diverged = chi2_test(np.r_[good, np.inf], 2)
    assert diverged.n_samples == 51 and diverged.mean == np.inf and not diverged.inside
    assert diverged.fraction_in_pointwise == pytest.approx(50 / 51)
    # NaN is still no sample
    assert chi2_test(np.r_[good, np.nan], 2) == chi2_test(good, 2)
    with pytest.raises(EstimationError, match=r"must be >= 0, got -1\.0 at index 1$"):
        chi2_test(np.array([1.0, -1.0, 2.0]), 2)


@pytest.mark.parametrize("t_s, values, name", [
    (np.arange(3.0), np.ones((3, 2), dtype=bool), "values"),
    (np.array([False, True]), np.ones((2, 2)), "t_s"),
    (np.arange(3.0), np.array(["0.1", "0.2", "fast"]), "values"),
])
def test_sensor_samples_refuse_booleans_and_text(t_s, values, name):
    """A mask given for a sensor's values was filtered as measurements of 0 and 1 (and one
    for the times as a clock of 0 and 1 s); text was NumPy's bare ValueError."""
    with pytest.raises(EstimationError, match=f"SensorSamples: {name} must hold numbers"):
        SensorSamples(t_s, values)


def test_sensor_samples_of_numbers_unchanged():
    s = SensorSamples([0, 1, 2], [0.5, 1, 2])
    assert s.t_s.dtype == float and s.values.shape == (3, 1)
    np.testing.assert_array_equal(s.values[:, 0], [0.5, 1.0, 2.0])


@pytest.mark.parametrize("ema_alpha, match", [
    ((("cam", 0.2), ("cam", 0.5)), r"gives sensor\(s\) \['cam'\] more than once"),
    ({"cam": 0.2}, r"ema_alpha must be \(sensor, alpha\) pairs"),
    (("cam", 0.2), r"ema_alpha must be \(sensor, alpha\) pairs"),
    ((("cam", 0.2, 1.0),), r"ema_alpha must be \(sensor, alpha\) pairs"),
    ("cam", r"ema_alpha must be \(sensor, alpha\) pairs"),
    (((["cam"], 0.2),), r"bad EMA entry"),
])
def test_agrimaro_ema_alpha_refuses_repeated_sensors_and_non_pairs(ema_alpha, match):
    """A sensor given twice had its last alpha used without a word (0.5 for the camera
    above); a dict, one bare pair or a triple was a bare ValueError 'too many values to
    unpack'."""
    with pytest.raises(ConfigError, match=match):
        AgriMaRoEKFSettings(ema_alpha=ema_alpha)


def test_agrimaro_ema_alpha_pairs_unchanged():
    s = AgriMaRoEKFSettings(ema_alpha=[["cam", 0.2], ("imu", 0.1)])
    assert (s.alpha("cam"), s.alpha("imu"), s.alpha("omega")) == (0.2, 0.1, 0.0)
    assert AgriMaRoEKFSettings(ema_alpha=()).alpha("cam") == 0.0


@pytest.mark.parametrize("offsets", [{"wheels": np.nan}, {"gyro": np.inf},
                                     {"gyro": -np.inf}])
def test_skid_steer_refuses_a_non_finite_latency_as_the_latency(steady_husky_run, offsets):
    """A NaN or infinite latency made every timestamp of its sensor NaN / inf, refused as the
    stream's own timestamps ('stream 'wheels': sensor timestamps must be finite')."""
    with pytest.raises(ConfigError, match=r"time_offsets_s must be finite latencies"):
        estimate_skid_steer(steady_husky_run(), time_offsets_s=offsets)


def test_agrimaro_samples_refuse_a_non_finite_latency(steady_husky_run):
    with pytest.raises(ConfigError, match=r"time_offsets_s must be finite latencies"):
        agrimaro_samples(steady_husky_run(), time_offsets_s={"imu": np.nan})


def test_skid_steer_streams_that_do_not_overlap_name_the_run_and_spans(steady_husky_run):
    """The grid spans the streams' overlap: none was make_grid's 'empty time span
    [10.0, 4.99] s', which named neither the run nor a stream."""
    with pytest.raises(TimeStepError, match=r"run test/ASPHALT/00: the streams the filter "
                       r"reads do not overlap in time \('wheels' 0\.\.4\.99 s, 'imu' "
                       r"10\.\.14\.99 s"):
        estimate_skid_steer(steady_husky_run(imu_shift_s=10.0))
    # a finite latency that still leaves an overlap runs on it
    res = estimate_skid_steer(steady_husky_run(), time_offsets_s={"wheels": -3.0})
    assert res.t_s[0] == pytest.approx(3.0) and res.counts["wheels"]["outside"] == 300


def test_skid_steer_streams_that_touch_at_one_instant_do_not_overlap(steady_husky_run):
    """One common instant is no span to filter over (make_grid needs t_end > t_start)."""
    last = np.arange(0.0, 5.0, 0.01)[-1]
    with pytest.raises(TimeStepError, match=r"run test/ASPHALT/00: the streams the filter "
                       r"reads do not overlap in time"):
        estimate_skid_steer(steady_husky_run(imu_shift_s=last))


@pytest.mark.parametrize("kwargs", [{"p0_diag": 0.1}, {"q_diag": None}, {"r_diag": 0.1},
                                    {"q_diag": "0.1"}, {"p0_diag": ((0.1,) * 14,)}])
def test_slip_state_model_refuses_variances_that_are_not_a_sequence(kwargs):
    """One number (or None) for a variance vector was a bare TypeError "object of type
    'float' has no len()"."""
    (label, _), = kwargs.items()
    with pytest.raises(ConfigError, match=f"SlipStateModel.{label} needs a sequence of "
                       "variances"):
        SlipStateModel(**kwargs)


def test_slip_state_model_sequences_unchanged():
    m = SlipStateModel(p0_diag=np.full(14, 0.1), camera=True)
    assert m.P0[0, 0] == 0.1 and m.R_diag.size == 14


def test_rmse_refuses_booleans():
    """rmse(np.ones(3, bool)) was 1.0: a mask read as errors of 1."""
    with pytest.raises(EstimationError, match="rmse: errors must hold numbers"):
        rmse(np.ones(3, dtype=bool))
    assert rmse(np.array([3.0, -4.0])) == pytest.approx(np.sqrt(12.5))


@pytest.mark.parametrize("args, name", [((0.0, 3.0, True), "rate_hz"),
                                        ((0.0, 3.0, "10"), "rate_hz"),
                                        ((False, True, 10.0), "t_start_s"),
                                        ((0.0, None, 10.0), "t_end_s")])
def test_make_grid_refuses_arguments_that_are_not_numbers(args, name):
    """make_grid(0, 3, True) was a 1 Hz grid of 4 steps, make_grid(False, True, 10) a grid
    over [0, 1] s, and a text rate a bare TypeError from np.isfinite."""
    with pytest.raises(ConfigError, match=f"make_grid.{name} must be a real number"):
        make_grid(*args)
    np.testing.assert_allclose(make_grid(0.0, 0.3, 10.0), [0.0, 0.1, 0.2, 0.3])


def test_prefilters_refuse_boolean_values():
    """A mask was averaged as 0 and 1 by the EMA (eq. 6.12) and its steps measured as noise
    by robust_noise_std (0.76 for an alternating mask at 100 Hz)."""
    mask = np.arange(200) % 2 == 0
    with pytest.raises(EstimationError, match="ema_filter: values must hold numbers"):
        ema_filter(mask, 0.5)
    with pytest.raises(EstimationError, match="robust_noise_std: values must hold numbers"):
        robust_noise_std(mask, 100.0)
    assert ema_filter(np.array([0.0, 10.0]), 0.5).tolist() == [0.0, 5.0]


@pytest.mark.parametrize("sensors", ["imu", ""])
def test_estimate_agrimaro_refuses_sensors_given_as_one_text(steady_husky_run, sensors):
    """sensors='imu' was read letter by letter ("sensors names ['i', 'm', 'u'], not a
    sensor"), and sensors='' passed the check and dropped every sensor: a filter that only
    predicted."""
    with pytest.raises(ConfigError, match="sensors must be a sequence of sensor names, got "
                       "the text"):
        estimate_agrimaro(steady_husky_run(), sensors=sensors)


def test_effective_sample_size_takes_one_series():
    """A 2-D array was flattened into one series: rows of a white sequence and a random walk
    (500 and about 4.6 effective samples each) gave 17.9 for the pair; a mask counted as a
    series of 0 and 1."""
    rng = np.random.default_rng(0)
    rows = rng.normal(size=(2, 500))
    rows[1] = 0.1 * np.cumsum(rows[1])
    with pytest.raises(ShapeError, match=r"series must have shape \(N,\), got \(2, 500\)"):
        effective_sample_size(rows)
    with pytest.raises(EstimationError, match="effective_sample_size: series must hold"):
        effective_sample_size(np.ones(5, dtype=bool))
    assert effective_sample_size(rows[0]) == 500.0
    assert effective_sample_size(rows[1]) < 10.0


def test_integrated_autocorrelation_time_refuses_booleans():
    """A mask was read as a series of 0 and 1 (tau 1.42 for a random mask of 50)."""
    with pytest.raises(EstimationError, match="integrated_autocorrelation_time: series must "
                       "hold numbers"):
        integrated_autocorrelation_time(np.random.default_rng(1).normal(size=50) > 0)
    assert integrated_autocorrelation_time(np.ones(10)) == 1.0
