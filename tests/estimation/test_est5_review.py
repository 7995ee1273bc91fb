"""Review est5: inputs and settings of the estimators that were silently accepted."""

from dataclasses import dataclass

import numpy as np
import pytest

from terrain.errors import ConfigError, EstimationError, ShapeError, TimeStepError
from terrain.estimation.agrimaro import (THESIS_P0, THESIS_Q, THESIS_R, AgriMaRoEKFSettings,
                                         AgriMaRoModel)
from terrain.estimation.consistency import integrated_autocorrelation_time
from terrain.estimation.ekf import Gate
from terrain.estimation.equations import agrimaro as eq_agrimaro
from terrain.estimation.equations import skid_steer as eq_skid
from terrain.estimation.equations import skid_steer_slip as eq_skid_slip
from terrain.estimation.model import StateSpaceModel
from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer
from terrain.estimation.prefilter import ema_filter, robust_noise_std
from terrain.estimation.runner import SensorSamples, check_rate_hz, make_grid, run_filter
from terrain.estimation.skid_steer import SkidSteerModel
from terrain.estimation.skid_steer_slip import STATE_NAMES as SKID_SLIP_STATES
from terrain.estimation.skid_steer_slip import SkidSteerSlipModel, run_with_pseudo_slip
from terrain.estimation.slip_state import SlipStateModel


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_observer_refuses_a_non_finite_sample_time_naming_it(bad):
    # a NaN time passed the "strictly increasing" test (NaN compares False) and made every
    # estimate from that sample on NaN
    t = np.array([0.0, 0.01, bad, 0.03, 0.04])
    pose = np.zeros((5, 3))
    pose[:, 0] = np.arange(5) * 0.01
    v = np.ones(5)
    with pytest.raises(TimeStepError, match="sample 2"):
        run_adaptive_observer(t, pose, v, v)


def test_observer_still_runs_on_finite_increasing_times():
    t = np.arange(5) * 0.01
    pose = np.zeros((5, 3))
    pose[:, 0] = t
    v = np.ones(5)
    res = run_adaptive_observer(t, pose, v, v)
    assert np.isfinite(res.eta).all()


@pytest.mark.parametrize("value", ["no", 1, None])
def test_observer_use_position_must_be_a_boolean(value):
    # read by truthiness: the text "no" (or 1) ran the position rows
    with pytest.raises(ConfigError, match="use_position"):
        AdaptiveObserverSettings(use_position=value)


def test_observer_use_position_takes_a_numpy_boolean():
    assert AdaptiveObserverSettings(use_position=np.bool_(False)).use_position == np.False_


@pytest.mark.parametrize("value", ["2", True, 0.0, -1.0, np.nan, np.inf, None])
def test_skid_steer_wheel_variance_scale_must_be_a_finite_number_gt_0(value):
    # "2" gave a variance 2 x, True 1 x, a negative or NaN one failed later without naming it
    with pytest.raises(ConfigError, match="wheel_r_scale"):
        SkidSteerModel(wheel_r_scale=value)


def test_skid_steer_wheel_variance_scale_multiplies_the_wheel_rows_only():
    base = SkidSteerModel().R_diag
    np.testing.assert_allclose(SkidSteerModel(wheel_r_scale=np.float64(4.0)).R_diag,
                               base * [4.0, 4.0, 1.0])


@pytest.mark.parametrize("kwargs, match", [
    (dict(p0_diag=(True,) * 12), r"p0_diag\[0\]"),
    (dict(q_diag=("0.5",) + THESIS_Q[1:]), r"q_diag\[0\]"),
    (dict(r_diag=THESIS_R[:13] + ("5e-4",)), r"r_diag\[13\]"),
    (dict(ema_alpha=(("cam", "0.2"),)), "ema_alpha"),
    (dict(ema_alpha=(("cam", False),)), "ema_alpha"),
])
def test_agrimaro_settings_refuse_text_and_booleans_as_numbers(kwargs, match):
    # np.asarray(..., float) turned True into a variance of 1 and "0.5" into 0.5
    with pytest.raises(ConfigError, match=match):
        AgriMaRoEKFSettings(**kwargs)


def test_agrimaro_settings_take_numpy_numbers():
    s = AgriMaRoEKFSettings(p0_diag=tuple(np.float64(v) for v in THESIS_P0),
                            ema_alpha=(("cam", np.float32(0.2)),))
    assert s.alpha("cam") == pytest.approx(0.2)


@pytest.mark.parametrize("kwargs, match", [
    (dict(camera="no"), "camera"),
    (dict(camera=1), "camera"),
    (dict(p0_diag=(True,) * 14), r"p0_diag\[0\]"),
    (dict(q_diag=("0.1",) * 14), r"q_diag\[0\]"),
    (dict(r_diag=(1e-3,) * 9 + (True,)), r"r_diag\[9\]"),
])
def test_slip_state_model_refuses_text_and_booleans(kwargs, match):
    # camera="no" appended the four camera rows; True and "0.1" passed float()
    with pytest.raises(ConfigError, match=match):
        SlipStateModel(**kwargs)


def test_slip_state_model_takes_numpy_values():
    m = SlipStateModel(camera=np.bool_(True), q_diag=tuple(np.float64(0.01) for _ in range(14)))
    assert m.n_measurements == 14


@pytest.mark.parametrize("kwargs, match", [
    (dict(probability="0.999"), "probability"),
    (dict(max_dof=True), "max_dof"),
    (dict(max_dof=2.7), "max_dof"),
])
def test_gate_refuses_text_and_non_integer_sizes(kwargs, match):
    # "0.999" passed float(); max_dof=2.7 built thresholds for 2, True for 1 degree of freedom
    with pytest.raises(ConfigError, match=match):
        Gate(**kwargs)


def test_gate_takes_numpy_numbers():
    g = Gate(np.float64(0.99), max_dof=np.int64(3))
    assert g.threshold(1) == pytest.approx(6.634896601021214)


def test_a_non_finite_sample_outside_the_grid_is_counted_once_as_outside():
    # (mutation: counting it as non_finite too made the counts add up to more samples)
    t = np.array([-5.0, 0.5, 99.0])
    values = np.array([[np.nan], [0.0], [np.inf]])
    res = run_filter(SkidSteerModel(), make_grid(0.0, 1.0, 100.0),
                     {"gyro": SensorSamples(t, values)})
    c = res.counts["gyro"]
    assert (c["outside"], c["non_finite"], c["used"]) == (2, 0, 1)


@dataclass(frozen=True)
class _DriftModel(StateSpaceModel):
    """One state drifting up at 1 per second, bounded above by 0.5, one direct row."""

    state_names: tuple = ("s",)
    measurement_names: tuple = ("z",)

    @property
    def sensor_rows(self):
        return {"z": (0,)}

    def f(self, x, dt):
        return x + dt

    def F(self, x, dt):
        return np.eye(1)

    def h(self, x):
        return x.copy()

    def H(self, x):
        return np.eye(1)

    def Q(self, dt):
        return np.eye(1) * 1e-4

    @property
    def R_diag(self):
        return np.ones(1)

    @property
    def x0(self):
        return np.zeros(1)

    @property
    def P0(self):
        return np.eye(1)

    @property
    def state_bounds(self):
        return np.array([-np.inf]), np.array([0.5])


def test_state_bounds_clip_every_step_when_step_bounds_are_given():
    # run_filter: with step_bounds the model's state_bounds clip after each step's update
    # or prediction (a step with no sample included), not only after an update
    grid = make_grid(0.0, 2.0, 10.0)
    free = (np.full((grid.size, 1), -np.inf), np.full((grid.size, 1), np.inf))
    res = run_filter(_DriftModel(), grid, {}, step_bounds=free)
    assert res.x.max() <= 0.5
    assert res.meta["state_bounds_clipped"] == int((grid > 0.5 + 1e-9).sum())   # after 0.5 s
    # without step_bounds and without samples nothing clips (the documented rule)
    assert run_filter(_DriftModel(), grid, {}).x[-1, 0] == pytest.approx(2.0)


@pytest.mark.parametrize("alpha", [0.1, 0.5, 0.9])
def test_ema_starts_at_the_first_sample(alpha):
    # eq. 6.12 with y_0 = z_0: a constant input comes out unchanged from the first sample
    out = ema_filter(np.full((4, 2), 3.0), alpha)
    np.testing.assert_allclose(out, 3.0)


@pytest.mark.parametrize("name, value", [("pseudo_std", np.full((1, 3), 0.1)),
                                         ("drift_std", np.full((1, 3), 0.1)),
                                         ("transient_std", np.full((1, 3), 0.1))])
def test_pseudo_slip_stds_of_three_columns_are_a_shape_error(name, value):
    # (k, 3) passed the shape check after its max over the columns; pseudo_std then failed
    # in a bare NumPy broadcast ValueError
    kwargs = dict(pseudo_t_s=np.array([0.5]), pseudo_slip=np.zeros((1, 2)),
                  pseudo_std=np.full(1, 0.1))
    kwargs[name] = value
    with pytest.raises(ShapeError, match="pseudo-measurements"):
        run_with_pseudo_slip(make_grid(0.0, 1.0, 10.0), {}, **kwargs)


def test_slip_states_are_bounded_to_the_sae_range_and_nothing_else():
    lower, upper = SkidSteerSlipModel().state_bounds
    slips = [SKID_SLIP_STATES.index("slip_1"), SKID_SLIP_STATES.index("slip_2")]
    np.testing.assert_array_equal(lower[slips], -1.0)
    np.testing.assert_array_equal(upper[slips], 1.0)
    others = np.setdiff1d(np.arange(lower.size), slips)
    assert np.isneginf(lower[others]).all() and np.isposinf(upper[others]).all()


def test_the_autocorrelation_sum_stops_at_the_first_lag_below_the_threshold():
    # Sokal's window: a periodic series whose autocorrelation comes back above the threshold
    # after its first dip sums only the lags before that dip
    rng = np.random.default_rng(3)
    k = np.arange(4000)
    x = np.sin(2 * np.pi * k / 40.0) + 0.3 * rng.standard_normal(k.size)
    d = x - x.mean()
    rho = np.array([d[:-j] @ d[j:] for j in range(1, 200)]) / (d @ d)
    first_below = int(np.argmax(rho < 0.05))
    expected = 1.0 + 2.0 * rho[:first_below].sum()
    assert rho[first_below:].max() > 0.5              # it does come back
    tau = float(integrated_autocorrelation_time(x, max_lag=200))
    assert tau == pytest.approx(expected, rel=1e-9)


def test_robust_noise_std_uses_a_centred_odd_window():
    # +-1 alternating: a centred 5-sample mean is +-0.2, so the residual is +-0.8 (an even
    # 4-sample window would average to 0 and give 1.0)
    x = np.where(np.arange(400) % 2 == 0, 1.0, -1.0)
    assert float(robust_noise_std(x, rate_hz=8.0, window_s=0.5)) == pytest.approx(1.4826 * 0.8)


@pytest.mark.parametrize("rate", [True, np.True_, "100"])
def test_a_filter_rate_that_is_a_boolean_or_text_is_refused(rate):
    # float(True) ran the filter at 1 Hz, float("100") at 100 Hz from text
    with pytest.raises(ConfigError, match="rate_hz must be a number"):
        check_rate_hz(rate)


def test_a_filter_rate_may_be_a_numpy_number():
    assert check_rate_hz(np.float32(200.0)) == 200.0 and check_rate_hz(np.int64(50)) == 50.0


@pytest.mark.parametrize("alpha", [False, np.False_, "0.5", None])
def test_ema_alpha_that_is_a_boolean_or_text_is_refused(alpha):
    # float("0.5") smoothed with text, float(False) passed as "no filtering"
    with pytest.raises(EstimationError, match="EMA alpha must be"):
        ema_filter(np.arange(4.0), alpha)


def _models_of_every_kernel():
    return [AgriMaRoModel(), SlipStateModel(), SkidSteerModel(), SkidSteerSlipModel()]


@pytest.mark.parametrize("model", _models_of_every_kernel(), ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("method", ["f", "F", "h", "H", "transition", "observation"])
def test_a_state_of_the_wrong_length_is_a_shape_error_not_a_kernel_call(model, method):
    # the compiled kernels run without bounds checks: AgriMaRoModel().f(np.ones(5), 0.1)
    # returned values read past the array, SkidSteerModel().h(np.ones(2)) crashed the
    # interpreter (segmentation fault)
    x = np.ones(model.n_states - 2)
    call = getattr(model, method)
    with pytest.raises(ShapeError, match=f"{model.n_states}"):
        call(x, 0.1) if method in ("f", "F", "transition") else call(x)


@pytest.mark.parametrize("module, n", [(eq_skid, 4), (eq_skid_slip, 8), (eq_agrimaro, 12)])
def test_the_equation_functions_refuse_a_state_of_the_wrong_length(module, n):
    with pytest.raises(ShapeError, match=f"{n}"):
        module.h(np.ones(n - 1))
    with pytest.raises(ShapeError, match=f"{n}"):
        module.H(np.ones(n + 1))


def test_a_state_of_the_right_length_still_evaluates():
    m = SkidSteerModel()
    np.testing.assert_allclose(m.h(np.array([1.0, 0.0, 0.01, 0.0])), [1.0, 1.0, 0.01])


@pytest.mark.parametrize("n", [5, 13, 15])
def test_the_agrimaro_process_function_takes_12_or_14_states_only(n):
    # its kernel reads states 0..7 and copies n: a 5-state vector was read past its end
    for fun in (eq_agrimaro.f, eq_agrimaro.F):
        with pytest.raises(ShapeError, match="12 or 14"):
            fun(np.ones(n), None, 0.1)
    assert eq_agrimaro.f(np.zeros(14), None, 0.1).shape == (14,)
