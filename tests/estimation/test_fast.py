"""Compiled (numba) run loop against the NumPy reference: same states, covariances,
innovations, NIS, gating and counts to round-off; engine selection and fall-back."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numba

import numpy as np
import pytest

from terrain.errors import ConfigError, CovarianceError
from terrain.estimation import Gate, SensorSamples, StateSpaceModel, make_grid, run_filter
from terrain.estimation.agrimaro import AgriMaRoModel, agrimaro_samples, estimate_agrimaro
from terrain.estimation.fast import FastKernel, fast_kernel_of, run_compiled
from terrain.estimation import skid_steer
from terrain.estimation.skid_steer import SkidSteerModel, estimate_skid_steer
from terrain.estimation.slip_state import SlipStateModel
from pipelines.validation.harness import (data_driven_settings, outage_experiment,
                                          simulate_agrimaro)

RTOL = 1e-9


def assert_same_result(fast, ref, covariance=False):
    """Every array of two EKFResults equal to RTOL of its scale; masks and counts exact."""
    assert fast.meta["engine"] == "numba" and ref.meta["engine"] == "numpy"
    names = ("x", "P_diag", "y", "S_diag", "nis") + (("P",) if covariance else ())
    for name in names:
        a, b = getattr(fast, name), getattr(ref, name)
        assert a.shape == b.shape, name
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        scale = max(float(np.nanmax(np.abs(b))), 1e-300)
        np.testing.assert_allclose(a, b, rtol=RTOL, atol=RTOL * scale, equal_nan=True,
                                   err_msg=name)
    np.testing.assert_array_equal(fast.accepted, ref.accepted)
    np.testing.assert_array_equal(fast.dof, ref.dof)
    assert fast.counts == ref.counts


@pytest.fixture(scope="module")
def grass():
    return simulate_agrimaro("GRASS", seed=2, duration_s=12.0, scenario="random")


def _both(model, grid, samples, **kw):
    return (run_filter(model, grid, samples, engine="numba", **kw),
            run_filter(model, grid, samples, engine="numpy", **kw))


def test_agrimaro_compiled_equals_reference_with_camera_outage(grass):
    run = grass.run
    settings = data_driven_settings(run)
    samples = agrimaro_samples(run, settings)
    cam = samples["cam"]
    vals = cam.values.copy()
    out = (cam.t_s >= 6.0) & (cam.t_s < 8.0)
    vals[out] = np.nan                        # 2 s camera outage (whole samples missing)
    vals[5, 1] = np.nan                       # one row of one sample missing
    samples["cam"] = SensorSamples(cam.t_s, vals)
    grid = make_grid(0.0, 12.0, 100.0)
    fast, ref = _both(AgriMaRoModel(settings=settings), grid, samples, store_covariance=True)
    assert_same_result(fast, ref, covariance=True)
    assert fast.counts["cam"]["non_finite"] == int(out.sum()) + 1
    idle = (grid > 6.05) & (grid < 7.95)
    assert not fast.accepted[idle][:, 10:].any() and fast.accepted[idle][:, 3:7].all()
    assert (fast.dof < 14).any() and (fast.dof == 14).any()   # partial and full updates


def test_agrimaro_compiled_equals_reference_with_gate(grass):
    run = grass.run
    settings = data_driven_settings(run)
    samples = agrimaro_samples(run, settings)
    imu = samples["imu"]
    vals = imu.values.copy()
    vals[300, 0] += 50.0                      # an accelerometer outlier
    samples["imu"] = SensorSamples(imu.t_s, vals)
    grid = make_grid(0.0, 12.0, 100.0)
    fast, ref = _both(AgriMaRoModel(settings=settings), grid, samples, gate=Gate(0.99))
    assert_same_result(fast, ref)
    assert fast.counts["imu"]["rejected"] >= 1
    rejected = np.isfinite(fast.y) & ~fast.accepted
    assert rejected.any() and (fast.dof[rejected.any(axis=1)] < 14).all()


def test_estimate_agrimaro_uses_the_compiled_loop_and_matches(grass):
    dropped, _ = outage_experiment(grass, t_off_s=5.0, t_on_s=7.0)
    assert dropped.meta["engine"] == "numba"
    run = grass.run
    fast = estimate_agrimaro(run, engine="auto")                      # thesis tuning
    ref = estimate_agrimaro(run, engine="numpy")
    assert_same_result(fast, ref)


def test_skid_steer_compiled_equals_reference():
    rng = np.random.default_rng(0)
    tw, tg = np.arange(300) * 0.1, np.arange(3001) * 0.01
    wheels = 0.5 + 0.01 * rng.standard_normal((300, 2))
    wheels[:, 1] += 0.3 * np.sin(tw)          # turning: chi observable, its column used
    wheels[10, 0] = np.nan
    wheels[50, 1] = 5.0                       # outlier for the gate
    gyro = 0.02 + 0.005 * rng.standard_normal((3001, 1))
    gyro[100:110] = np.nan
    samples = {"wheels": SensorSamples(tw, wheels), "gyro": SensorSamples(tg, gyro)}
    grid = make_grid(0.0, 30.0, 100.0)
    for gate in (None, Gate(0.999)):
        fast, ref = _both(SkidSteerModel(wheel_r_scale=2.0), grid, samples, gate=gate)
        assert_same_result(fast, ref)
    assert fast.counts["wheels"]["rejected"] == 1


def test_skid_steer_compiled_equals_reference_on_a_shipped_run(borealtc_runs, monkeypatch):
    """estimate_skid_steer on a measured BorealTC run (SNOW/04: 100 Hz IMU, 6.5 Hz wheels,
    turns, 22 gyro rows gated out): the compiled loop that it runs gives the NumPy
    reference's states, covariances, innovations, NIS, gate decisions and counts (the other
    tests use simulated streams), and every posterior covariance is symmetric and positive
    definite."""
    run = next(r for r in borealtc_runs if r.run_id == "borealtc/SNOW/04")
    gate = Gate(0.999)
    fast = estimate_skid_steer(run, gate=gate, store_covariance=True)
    monkeypatch.setattr(skid_steer, "run_filter", functools.partial(run_filter,
                                                                    engine="numpy"))
    ref = estimate_skid_steer(run, gate=gate, store_covariance=True)
    assert_same_result(fast, ref, covariance=True)
    assert fast.t_s.size > 2000 and fast.counts["gyro"]["rejected"] > 0
    assert np.ptp(fast.state("log_icr_chi")) > 0.5          # it turns: chi is corrected
    for P in (fast.P, ref.P):
        np.testing.assert_array_equal(P, P.transpose(0, 2, 1))
        assert np.linalg.eigvalsh(P).min() > 0.0


@dataclass(frozen=True)
class _SubclassedModel(AgriMaRoModel):
    """A subclass may change the model: it gets the reference loop."""


def test_engine_selection_and_fallback():
    grid = make_grid(0.0, 0.1, 100.0)
    z = {"gyro": SensorSamples(grid, np.zeros((grid.size, 1)))}
    assert run_filter(SkidSteerModel(), grid, z).meta["engine"] == "numba"
    assert run_filter(SkidSteerModel(), grid, z, engine="numpy").meta["engine"] == "numpy"
    assert fast_kernel_of(SlipStateModel()) is None
    assert fast_kernel_of(_SubclassedModel()) is None
    assert isinstance(fast_kernel_of(AgriMaRoModel()), FastKernel)
    assert run_filter(_SubclassedModel(), grid, {}).meta["engine"] == "numpy"
    with pytest.raises(ConfigError):
        run_filter(SlipStateModel(), grid, {}, engine="numba")
    with pytest.raises(ConfigError):
        run_filter(SkidSteerModel(), grid, z, engine="fortran")
    kernel = fast_kernel_of(SkidSteerModel())
    # (a plain ValueError before: the project's configuration errors are ConfigError)
    with pytest.raises(ConfigError, match="FastKernel q_diag needs 4 values, got 1"):
        replace(kernel, q_diag=(1.0,))                         # 1 variance for 4 states
    with pytest.raises(ConfigError, match="FastKernel q_per"):
        replace(kernel, q_per="minute")
    with pytest.raises(ConfigError, match=r"FastKernel angle rows \(3,\) outside 0..2"):
        replace(kernel, angle_rows=(3,))                       # 3 rows: 0..2


def test_indefinite_innovation_covariance_raises():
    kernel = SkidSteerModel().fast_kernel()
    Z = np.zeros((3, 3))
    with pytest.raises(CovarianceError):
        run_compiled(kernel, np.full(2, 0.01), Z, np.zeros(4), -np.eye(4), np.full(3, 1e-4),
                     np.array([0, 0, 1]), 2)


# -- a model the engine has never heard of ---------------------------------------------------

@numba.njit(cache=True)
def _pendulum_transition(x, u, dt, p, fx, F):
    """Pendulum ``[angle, rate]``, explicit Euler: ``rate' = rate - dt g/l sin(angle)``."""
    fx[0] = x[0] + dt * x[1]
    fx[1] = x[1] - dt * p[0] * math.sin(x[0])
    F[0, 0], F[0, 1] = 1.0, dt
    F[1, 0], F[1, 1] = -dt * p[0] * math.cos(x[0]), 1.0


@numba.njit(cache=True)
def _pendulum_observation(x, p, hx, H):
    """Angle (wrapped) and the tip's horizontal position ``l sin(angle)``."""
    hx[0] = x[0]
    hx[1] = p[1] * math.sin(x[0])
    H[0, 0], H[0, 1] = 1.0, 0.0
    H[1, 0], H[1, 1] = p[1] * math.cos(x[0]), 0.0


@dataclass(frozen=True)
class _Pendulum(StateSpaceModel):
    """g/l = 9.81 / 0.5; both engines through the same two kernels."""

    state_names: tuple = ("angle", "rate")
    measurement_names: tuple = ("angle_m", "tip_x")
    angle_rows: tuple = (0,)

    @property
    def sensor_rows(self):
        return {"encoder": (0,), "camera": (1,)}

    def transition(self, x, dt):
        fx, F = np.empty(2), np.empty((2, 2))
        _pendulum_transition(np.ascontiguousarray(x, float), np.zeros(0), float(dt),
                             np.array([19.62, 0.5]), fx, F)
        return fx, F

    def observation(self, x):
        hx, H = np.empty(2), np.empty((2, 2))
        _pendulum_observation(np.ascontiguousarray(x, float), np.array([19.62, 0.5]), hx, H)
        return hx, H

    def Q(self, dt):
        return np.diag([1e-6, 1e-3]) * dt

    @property
    def R_diag(self):
        return np.array([1e-4, 1e-4])

    @property
    def x0(self):
        return np.array([0.5, 0.0])

    @property
    def P0(self):
        return np.diag([0.1, 0.1])

    def fast_kernel(self):
        return FastKernel(_pendulum_transition, _pendulum_observation, (19.62, 0.5), 2, 2,
                          (1e-6, 1e-3), "second", (0,))


def test_a_new_model_runs_on_the_engine_without_editing_it():
    t = np.arange(0.0, 5.0, 0.01)
    angle = 0.4 * np.cos(math.sqrt(19.62) * t)
    rng = np.random.default_rng(1)
    samples = {"encoder": SensorSamples(t, (angle + 0.01 * rng.standard_normal(t.size))[:, None]),
               "camera": SensorSamples(t[::3], 0.5 * np.sin(angle[::3])[:, None])}
    fast, ref = _both(_Pendulum(), t, samples, gate=Gate(0.999))
    assert_same_result(fast, ref)
    assert np.abs(fast.state("angle")[100:] - angle[100:]).max() < 0.05
    engine = Path(__file__).resolve().parents[2] / "terrain" / "estimation" / "fast.py"
    code = engine.read_text().lower()
    assert not any(name in code for name in ("agrimaro", "skid", "husky", "pendulum"))


@pytest.mark.parametrize("tuning", ["thesis", "noise-derived"])
def test_compiled_equals_reference_at_the_edges(tuning):
    """Random samples on a non-uniform grid (Q per step and per second), the heading
    crossing +-pi in both yaw rows (wrapped innovations), wheels steered to +-90 deg, the
    body at rest, NaN rows and a camera gap, with and without the gate."""
    from terrain.estimation.agrimaro import AgriMaRoEKFSettings, noise_derived_settings
    rng = np.random.default_rng(5)
    grid = np.cumsum(np.r_[0.0, rng.uniform(0.005, 0.02, 399)])
    settings = AgriMaRoEKFSettings() if tuning == "thesis" else noise_derived_settings()
    x0 = np.zeros(12)
    x0[2], x0[8:11] = math.pi - 0.01, (math.pi / 2, -math.pi / 2, 0.0)
    t = grid[1:] - rng.uniform(0.0, 0.004, grid.size - 1)
    k = t.size
    yaw = (math.pi - 0.01 + 0.3 * t + math.pi) % (2 * math.pi) - math.pi
    imu = np.column_stack([rng.normal(0, .5, k), rng.normal(0, .5, k),
                           rng.normal(0.3, .01, k), yaw + rng.normal(0, .01, k)])
    imu[rng.integers(0, k, 10), rng.integers(0, 4, 10)] = np.nan
    steer = np.column_stack([np.full(k, math.pi / 2), np.full(k, -math.pi / 2),
                             np.zeros(k)]) + rng.normal(0, 1e-3, (k, 3))
    cam = np.column_stack([rng.normal(0, .01, (k, 2)), rng.normal(0.3, .01, k),
                           yaw - rng.normal(0, .001, k)])
    cam[100:150] = np.nan
    samples = {"imu": SensorSamples(t, imu),
               "omega": SensorSamples(t[::3], np.column_stack(
                   [np.zeros(k), rng.normal(0, 0.1, k), np.zeros(k)])[::3]),
               "steer": SensorSamples(t[::2], steer[::2]),
               "cam": SensorSamples(t[::5], cam[::5])}
    for gate in (None, Gate(0.99)):
        fast, ref = _both(AgriMaRoModel(settings=settings), grid, samples, gate=gate, x0=x0,
                          store_covariance=True)
        assert_same_result(fast, ref, covariance=True)
        assert np.abs(np.diff(fast.x[:, 2])).max() < 0.5    # no 2 pi jump of the state


@numba.njit(cache=True)
def _hold_transition(x, u, dt, p, fx, F):
    """A constant state ``[level]``."""
    fx[0] = x[0]
    F[0, 0] = 1.0


@numba.njit(cache=True)
def _sqrt_observation(x, p, hx, H):
    """``sqrt(level)``: NaN below zero, with a finite Jacobian row."""
    hx[0] = math.sqrt(x[0]) if x[0] >= 0.0 else math.nan
    H[0, 0] = 0.5


def test_a_non_finite_innovation_is_named_as_such_by_the_compiled_loop():
    # the NumPy path says "innovation y is not finite"; the compiled loop said "S is not
    # positive definite (NIS not >= 0)" for the same fault, a model's h(x) gone NaN
    from terrain.errors import NonFiniteInputError
    kernel = FastKernel(_hold_transition, _sqrt_observation, (), 1, 1, (1e-4,), "step", ())
    with pytest.raises(NonFiniteInputError, match="innovation y is not finite at step 0"):
        run_compiled(kernel, np.full(1, 0.1), np.ones((2, 1)), np.array([-1.0]), np.eye(1),
                     np.array([0.01]), np.array([0]), 1)
    fine = run_compiled(kernel, np.full(1, 0.1), np.ones((2, 1)), np.array([1.0]), np.eye(1),
                        np.array([0.01]), np.array([0]), 1)
    assert np.isfinite(fine.nis).all()
