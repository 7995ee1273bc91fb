"""Validation harness of the estimators on simulated runs (outside the library).

Used by the tests, ``benchmarks/bench_ekf.py`` and ``terrain validate estimation``
(:mod:`pipelines.validation.estimation_tables`, every figure of
``docs/estimation_validation.md``); nothing in :mod:`terrain` imports it.

Simulated AgriMaRo runs use a fine wheel encoder (``speed_quantum_m_s=1e-6``, the true
wheel speed through the driver's filter, rounded to 1e-6 m/s), so that the figures show the
estimators alone. The simulator's default AgriMaRo encoder (``speed_quantum_m_s=0``) reports
the count rate of its 90 count/rev encoder before the driver's filter
(:func:`terrain.sim.sensors.encoder_count_rate`: quantised, unbiased on average); it no
longer rounds the filtered speed to 3.49 rad/s, and
:func:`pipelines.validation.estimation_tables.default_encoder_table` gives its figures.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from terrain.estimation.agrimaro import (STATE_NAMES, AgriMaRoEKFSettings, AgriMaRoModel,
                                         estimate_agrimaro, noise_derived_settings)
from terrain.estimation.consistency import (chi2_test, effective_sample_size,
                                            mean_chi2_bounds, nees, rmse, state_errors)
from terrain.estimation.observer import (AdaptiveObserverSettings, eta_from_truth,
                                         run_adaptive_observer)
from terrain.estimation.prefilter import robust_noise_std
from terrain.errors import DataWarning
from terrain.estimation.runner import EKFResult
from terrain.estimation.skid_steer import SkidSteerSettings, estimate_skid_steer, icr_chi
from terrain.run import TIME, Run
from terrain.sim import Effects, SensorSettings, SimConfig, Simulation, simulate_with_physics
from terrain.vehicles import HUSKY

#: AgriMaRo sensors with a fine wheel encoder (see the module docstring).
FINE_ENCODER = SensorSettings(wheel_rate_hz=50.0, speed_quantum_m_s=1e-6,
                              current_quantum_a=0.01)
THESIS_TERRAINS = ("TILES", "GRASS", "GRAVEL")


def truth_on_grid(result: Simulation, t_grid: np.ndarray) -> pd.DataFrame:
    """Physics ground truth linearly interpolated on ``t_grid``.

    Parameters
    ----------
    result : Simulation
        Simulated run with its physics-rate truth.
    t_grid : ndarray, shape (N,)
        Times, s.

    Returns
    -------
    pandas.DataFrame
        ``t_s, x, y, yaw, v_bx, v_by, yaw_rate, a_bx, a_by, delta_i, slip_i, omega_i``.
    """
    ph = result.physics
    cols = {"x": ph.pose[:, 0], "y": ph.pose[:, 1], "yaw": ph.pose[:, 2],
            "v_bx": ph.twist[:, 0], "v_by": ph.twist[:, 1], "yaw_rate": ph.twist[:, 2],
            "a_bx": ph.accel_body[:, 0], "a_by": ph.accel_body[:, 1]}
    for i in range(ph.delta.shape[1]):
        cols[f"delta_{i + 1}"] = ph.delta[:, i]
    for i in range(ph.slip_motor.shape[1]):
        cols[f"slip_{i + 1}"] = ph.slip_motor[:, i]
        cols[f"omega_{i + 1}"] = ph.omega[:, i]
    out = {"t_s": t_grid}
    for k, v in cols.items():
        out[k] = np.interp(t_grid, ph.t_s, v)
    return pd.DataFrame(out)


def simulate_agrimaro(terrain: str, seed: int, duration_s: float = 20.0,
                      scenario: str = "straight_accel", effects: Effects = Effects(),
                      sensors: SensorSettings = FINE_ENCODER) -> Simulation:
    """One simulated AgriMaRo run (fine encoder by default), with its physics-rate truth.

    Parameters
    ----------
    terrain : str
        Terrain class.
    seed : int
        Seed of the run.
    duration_s : float
        Simulated time, s.
    scenario : str
        Driving scenario (:data:`terrain.sim.SCENARIO_NAMES`).
    effects : Effects
        Planted effects.
    sensors : SensorSettings
        Sensor settings (default :data:`FINE_ENCODER`).

    Returns
    -------
    Simulation
    """
    return simulate_with_physics(SimConfig(vehicle="agrimaro", terrains=(terrain,),
                                           scenario=scenario, duration_s=duration_s, seed=seed,
                                           effects=effects, sensors=sensors))


def agrimaro_truth_states(result: Simulation, t_grid: np.ndarray) -> np.ndarray:
    """True 12-state vector of the AgriMaRo EKF on a time grid.

    Parameters
    ----------
    result : Simulation
        Simulated AgriMaRo run.
    t_grid : ndarray, shape (N,)
        Times, s.

    Returns
    -------
    ndarray, shape (N, 12)
        States in :data:`terrain.estimation.agrimaro.STATE_NAMES` order (SI units; the gyro
        bias is the planted effect).
    """
    tr = truth_on_grid(result, t_grid)
    bias = float(result.config.effects.gyro_bias)
    return np.column_stack([tr[s].to_numpy() if s in tr else np.full(len(tr), bias)
                            for s in STATE_NAMES])


def data_driven_settings(run: Run, **kwargs) -> AgriMaRoEKFSettings:
    """:func:`noise_derived_settings` with the accelerometer noise measured on the run.

    Parameters
    ----------
    run : Run
        Run with an ``imu`` stream.
    **kwargs
        Further arguments of :func:`noise_derived_settings`.

    Returns
    -------
    AgriMaRoEKFSettings
    """
    imu = run.streams["imu"]
    rate = float(1.0 / np.median(np.diff(imu[TIME].to_numpy())))
    acc = float(np.nanmax(robust_noise_std(imu[["ax", "ay"]].to_numpy(float), rate)))
    return noise_derived_settings(accel_std_m_s2=acc, **kwargs)


@dataclass(frozen=True)
class ConsistencyRow:
    """Monte Carlo consistency of the AgriMaRo EKF on one terrain.

    Parameters
    ----------
    terrain : str
        Terrain class.
    n_runs : int
        Number of Monte Carlo runs M.
    anees : float
        Time average of the run-averaged NEES (12 states).
    nees_bounds : tuple of float
        Two-sided chi-square bounds of ``anees``, the time average: those of the mean of
        ``M n_eff`` chi-square(12) values, ``n_eff`` the effective number of independent
        steps of the run-averaged NEES sequence
        (:func:`terrain.estimation.consistency.effective_sample_size`).
    nees_fraction_in_bounds : float
        Fraction of time steps whose run-averaged NEES is inside :attr:`nees_step_bounds`.
    nis_mean : float
        Mean NIS over runs and steps.
    nis_dof : float
        Mean number of measurement rows.
    nis_bounds : tuple of float
        Bounds of the mean NIS.
    rmse : dict
        State name -> RMSE (SI units) of ``v_bx, v_by, yaw_rate``.
    nees_step_bounds : tuple of float
        Bounds of one step's run-averaged NEES (``chi2(12 M) / M``), for
        ``nees_fraction_in_bounds``; not the bounds of ``anees``.
    nees_n_eff : float
        Effective number of independent steps of the run-averaged NEES sequence.
    """

    terrain: str
    n_runs: int
    anees: float
    nees_bounds: tuple[float, float]
    nees_fraction_in_bounds: float
    nis_mean: float
    nis_dof: float
    nis_bounds: tuple[float, float]
    rmse: dict[str, float]
    nees_step_bounds: tuple[float, float] = (float("nan"), float("nan"))
    nees_n_eff: float = float("nan")

    def as_dict(self) -> dict:
        """Flat row for a table.

        Returns
        -------
        dict
            Column -> value (bounds split into ``_lo``/``_hi``, ``rmse_<state>``;
            ``NEES_lo``/``NEES_hi`` are the bounds of the time-averaged ``ANEES``,
            ``NEES_step_lo``/``NEES_step_hi`` those of one step's run average).
        """
        d = {"terrain": self.terrain, "runs": self.n_runs, "ANEES": self.anees,
             "NEES_lo": self.nees_bounds[0], "NEES_hi": self.nees_bounds[1],
             "NEES_inside": self.nees_bounds[0] <= self.anees <= self.nees_bounds[1],
             "NEES_n_eff": self.nees_n_eff, "NEES_step_lo": self.nees_step_bounds[0],
             "NEES_step_hi": self.nees_step_bounds[1],
             "NEES_frac_steps_in": self.nees_fraction_in_bounds, "NIS": self.nis_mean,
             "NIS_dof": self.nis_dof, "NIS_lo": self.nis_bounds[0],
             "NIS_hi": self.nis_bounds[1]}
        d.update({f"rmse_{k}": v for k, v in self.rmse.items()})
        return d


def agrimaro_consistency(terrain: str, seeds: Sequence[int], duration_s: float = 20.0,
                         scenario: str = "straight_accel",
                         settings_fn: Callable[[Run], AgriMaRoEKFSettings] = data_driven_settings,
                         t_min_s: float = 0.0, probability: float = 0.95) -> ConsistencyRow:
    """Monte Carlo NEES / NIS of the 12-state EKF (Bar-Shalom's average NEES test).

    For each time step the NEES is averaged over the ``M = len(seeds)`` runs; ``M`` times
    that average is chi-square(12 M) for a consistent filter, which gives one step's bounds
    (``nees_step_bounds``; the fraction of time steps inside them is reported). The reported
    ANEES is the time average of the run-averaged NEES (``t >= t_min_s``); its bounds
    (``nees_bounds``) are those of the mean of ``M n_eff`` chi-square(12) values, ``n_eff``
    the effective number of independent steps of that sequence (its integrated
    autocorrelation time, :func:`terrain.estimation.consistency.effective_sample_size`).
    Before, the ANEES was compared with one step's bounds, 9-45x too wide for 20 s runs
    (GRASS, 10 runs: [9.16, 15.22] against [11.89, 12.11]). NIS: time and run average
    against the bounds of its mean number of rows.

    Parameters
    ----------
    terrain : str
        Terrain class.
    seeds : sequence of int
        Seeds of the Monte Carlo runs.
    duration_s : float
        Simulated time per run, s.
    scenario : str
        Driving scenario.
    settings_fn : callable
        Run -> EKF settings (default :func:`data_driven_settings`).
    t_min_s : float
        Start of the evaluated interval, s.
    probability : float
        Two-sided probability of the chi-square bounds.

    Returns
    -------
    ConsistencyRow
    """
    nees_runs, nis_all, dof_all, err = [], [], [], {k: [] for k in ("v_bx", "v_by", "yaw_rate")}
    grid = None
    for seed in seeds:
        result = simulate_agrimaro(terrain, seed, duration_s, scenario)
        run = result.run
        res = estimate_agrimaro(run, settings_fn(run), store_covariance=True)
        truth = agrimaro_truth_states(result, res.t_s)
        e = state_errors(res.x, truth, (2,))
        keep = res.t_s >= t_min_s
        nees_runs.append(nees(e, res.P)[keep])
        nis_all.append(res.nis[keep])
        dof_all.append(res.dof[keep])
        for k in err:
            j = STATE_NAMES.index(k)
            err[k].append(e[keep, j])
        grid = res.t_s[keep] if grid is None else grid
    n = min(len(a) for a in nees_runs)
    avg = np.mean([a[:n] for a in nees_runs], axis=0)
    m = len(seeds)
    lo, hi = mean_chi2_bounds(12, m, probability)
    n_eff = effective_sample_size(avg)
    nis = np.concatenate(nis_all)
    dof = np.concatenate(dof_all)
    test = chi2_test(nis, dof, probability)
    return ConsistencyRow(terrain=terrain, n_runs=m, anees=float(avg.mean()),
                          nees_bounds=mean_chi2_bounds(12, m * n_eff, probability),
                          nees_fraction_in_bounds=float(((avg >= lo) & (avg <= hi)).mean()),
                          nis_mean=test.mean, nis_dof=test.dof, nis_bounds=test.bounds,
                          rmse={k: rmse(np.concatenate(v)) for k, v in err.items()},
                          nees_step_bounds=(lo, hi), nees_n_eff=n_eff)


def coriolis_prediction_error(result: Simulation) -> dict[str, float]:
    """RMS one-step velocity prediction error of the process model fed with ground truth.

    For each physics step the model predicts ``v(t + dt)`` from the true ``v, yaw_rate``
    and the true accelerometer acceleration ``a_b``; the error against the true ``v(t+dt)``
    is the model error alone.

    Parameters
    ----------
    result : Simulation
        Simulated AgriMaRo run.

    Returns
    -------
    dict
        Convention (``body``, eqs. 4.33-4.34, and ``eq6.2``) -> RMS error, m/s.
    """
    ph = result.physics
    dt = float(ph.t_s[1] - ph.t_s[0])
    out = {}
    for conv in ("body", "eq6.2"):
        model = AgriMaRoModel(settings=AgriMaRoEKFSettings(coriolis=conv))
        x = np.zeros((len(ph.t_s) - 1, 12))
        x[:, 2] = ph.pose[:-1, 2]
        x[:, 3:6] = ph.twist[:-1]
        # the simulator's accel_body at step k is (V_{k} - V_{k-1}) / dt + r x V: use the
        # next step's value, which belongs to the interval [k, k + 1]
        x[:, 6:8] = ph.accel_body[1:]
        pred = np.array([model.f(xi, dt)[3:5] for xi in x])
        err = pred - ph.twist[1:, :2]
        out[conv] = rmse(err)
    return out


def coriolis_filter_rmse(result: Simulation, settings_fn: Callable[[Run], AgriMaRoEKFSettings]
                         = data_driven_settings) -> dict[str, dict[str, float]]:
    """Velocity RMSE of the whole EKF with each Coriolis convention, against truth.

    Parameters
    ----------
    result : Simulation
        Simulated AgriMaRo run.
    settings_fn : callable
        Run -> EKF settings.

    Returns
    -------
    dict
        Convention -> state (``v_bx, v_by, yaw_rate``) -> RMSE, m/s or rad/s.
    """
    run = result.run
    base = settings_fn(run)
    out = {}
    for conv in ("body", "eq6.2"):
        res = estimate_agrimaro(run, replace(base, coriolis=conv))
        tr = truth_on_grid(result, res.t_s)
        out[conv] = {k: rmse(res.state(k) - tr[k].to_numpy())
                     for k in ("v_bx", "v_by", "yaw_rate")}
    return out


# -- skid-steer ------------------------------------------------------------------------------

def simulate_husky(terrain: str, seed: int, duration_s: float = 60.0, scenario: str = "random",
                   icr_expansion: float = 1.5, gyro_bias: float = 0.01) -> Simulation:
    """One simulated Husky run with a planted ICR expansion and gyro bias.

    Parameters
    ----------
    terrain : str
        Terrain class.
    seed : int
        Seed of the run.
    duration_s : float
        Simulated time, s.
    scenario : str
        Driving scenario (:data:`terrain.sim.SCENARIO_NAMES`).
    icr_expansion : float
        Planted chi (dimensionless).
    gyro_bias : float
        Planted gyro bias, rad/s.

    Returns
    -------
    Simulation
    """
    return simulate_with_physics(SimConfig(vehicle="husky", terrains=(terrain,), scenario=scenario,
                                           duration_s=duration_s, seed=seed,
                                           effects=Effects(icr_expansion=icr_expansion,
                                                           gyro_bias=gyro_bias)))


def steady_turn_mask(t_s: np.ndarray, yaw_rate: np.ndarray, min_rate: float = 0.15,
                     max_yaw_accel: float = 0.05, t_min_s: float = 10.0) -> np.ndarray:
    """Samples in a steady turn, where the ICR factor and eta are defined and constant.

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Times, s.
    yaw_rate : ndarray, shape (N,)
        Yaw rate, rad/s.
    min_rate : float
        Smallest |yaw rate|, rad/s.
    max_yaw_accel : float
        Largest |d yaw rate / dt|, rad/s^2.
    t_min_s : float
        Samples before this time are excluded, s.

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    wd = np.gradient(yaw_rate, t_s)
    return (np.abs(yaw_rate) > min_rate) & (np.abs(wd) < max_yaw_accel) & (t_s >= t_min_s)


@dataclass(frozen=True)
class HuskyComparison:
    """EKF (ICR factor) and adaptive observer (eta_R, eta_L) on one simulated run.

    ``*_err`` are median relative errors over steady turns after 10 s; ``*_p90`` the 90th
    percentile; ``*_conv_s`` the time after which the relative error of the steady-turn
    samples stays below 5 % (``inf`` when the last of them is still over it; a NaN error,
    e.g. the observer's chi at a yaw rate of 0, is not below it).

    Parameters
    ----------
    terrain : str
        Terrain class.
    seed : int
        Seed of the run.
    chi_true : float
        Median true local ICR factor over steady turns.
    ekf_chi_err, ekf_chi_p90, ekf_chi_conv_s : float
        EKF ICR factor: median and 90th percentile relative error, convergence time (s).
    obs_chi_err, obs_chi_p90, obs_chi_conv_s : float
        Observer ICR factor: the same.
    ekf_eta_err : float
        Median relative error of the EKF's eta, over the samples where it is defined (a
        measured side speed below ``eta_from_truth``'s ``min_speed_m_s`` leaves it NaN;
        the observer's eta error keeps those samples).
    obs_eta_err, obs_eta_p90, obs_eta_conv_s : float
        Observer eta: median, 90th percentile relative error, convergence time (s).
    """

    terrain: str
    seed: int
    chi_true: float
    ekf_chi_err: float
    ekf_chi_p90: float
    ekf_chi_conv_s: float
    obs_chi_err: float
    obs_chi_p90: float
    obs_chi_conv_s: float
    ekf_eta_err: float
    obs_eta_err: float
    obs_eta_p90: float
    obs_eta_conv_s: float

    def as_dict(self) -> dict:
        """Flat row.

        Returns
        -------
        dict
            Field -> value.
        """
        return dict(self.__dict__)


def _conv_time(t: np.ndarray, rel_err: np.ndarray, tol: float = 0.05) -> float:
    bad = np.flatnonzero(~(rel_err <= tol))     # NaN (an error not computed) is not below
    if bad.size and bad[-1] == t.size - 1:     # still over tol at the end: never converged
        return float("inf")
    return float(t[bad[-1]]) if bad.size else float(t[0]) if t.size else float("nan")


def husky_comparison(result: Simulation,
                     observer: AdaptiveObserverSettings = AdaptiveObserverSettings(),
                     settings: SkidSteerSettings = SkidSteerSettings(),
                     pose_noise: tuple[float, float] = (0.01, 0.002),
                     rng: np.random.Generator | None = None) -> HuskyComparison:
    """Compare the skid-steer EKF and the seed 000 observer against simulated truth.

    The observer gets the true pose plus white noise (``pose_noise`` = position m, yaw rad),
    as from the GNSS + compass of the seed's experiments, and the measured side speeds. Truth:
    local ICR factor ``(v_R - v_L) / (B yaw_rate)`` and eta of seed 000 eq. 15 from the true
    rim speeds. The EKF's eta is eq. 15 evaluated with its own speed and yaw rate; the
    observer's ICR factor is ``(v_R - v_L) / (B Omega^)``, ``Omega^ = (eta_R^ v_R - eta_L^
    v_L) / (2 d)``.

    Parameters
    ----------
    result : Simulation
        Simulated Husky run.
    observer : AdaptiveObserverSettings
        Settings of the seed 000 observer.
    settings : SkidSteerSettings
        Settings of the skid-steer EKF.
    pose_noise : tuple of float
        Std of the position (m) and yaw (rad) noise given to the observer.
    rng : numpy.random.Generator, optional
        Noise source (default seeded with the run's seed, ``result.config.seed``).

    Returns
    -------
    HuskyComparison
    """
    # default: the run's own seed, so runs of different seeds get different observer noise
    rng = rng if rng is not None else np.random.default_rng(int(result.config.seed))
    run = result.run
    ekf = estimate_skid_steer(run, settings)
    tr = run.streams["truth"]
    rr, B, d = HUSKY.wheel_radius_m, HUSKY.track_m, HUSKY.track_m / 2.0
    t = ekf.t_s
    at = (lambda col: np.interp(t, tr[TIME].to_numpy(), np.asarray(col, dtype=float)))
    w_true, v_true = at(tr["yaw_rate"]), at(tr["v_bx"])
    rim_l, rim_r = at(tr["omega_1"] * rr), at(tr["omega_2"] * rr)
    wheels = run.streams["wheels"]
    vl = np.interp(t, wheels[TIME], wheels["vel_l"])
    vr = np.interp(t, wheels[TIME], wheels["vel_r"])
    steady = steady_turn_mask(t, w_true)
    chi_loc = (rim_r - rim_l) / (B * np.where(steady, w_true, 1.0))
    chi_ekf = icr_chi(ekf)
    pose = np.column_stack([at(tr["x"]), at(tr["y"]), at(tr["yaw"])])
    pose = pose + rng.standard_normal(pose.shape) * np.array(
        [pose_noise[0], pose_noise[0], pose_noise[1]])
    obs = run_adaptive_observer(t, pose, vr, vl, observer)
    # the observer's Omega^ with the d it estimated its etas with
    omega_obs = (obs.eta_right * vr - obs.eta_left * vl) / (2.0 * observer.half_track_m)
    with np.errstate(divide="ignore", invalid="ignore"):
        chi_obs = (vr - vl) / (B * omega_obs)
    eta_true = eta_from_truth(v_true, w_true, rim_r, rim_l, d)
    eta_ekf = eta_from_truth(ekf.state("v_bx"), ekf.state("yaw_rate"), vr, vl, d)
    ok_eta = steady & np.isfinite(eta_true).all(axis=1)

    def rel(a, b, mask):
        return np.abs(a[mask] / b[mask] - 1.0)

    e_chi_ekf = rel(chi_ekf, chi_loc, steady)
    e_chi_obs = rel(chi_obs, chi_loc, steady)
    # the EKF's eta is undefined where a measured side speed is below eta_from_truth's
    # min_speed_m_s: those samples leave the EKF's error only, not the observer's
    ok_ekf = ok_eta & np.isfinite(eta_ekf).all(axis=1)
    e_eta_obs = np.abs(obs.eta[ok_eta] / eta_true[ok_eta] - 1.0).max(axis=1)
    e_eta_ekf = np.abs(eta_ekf[ok_ekf] / eta_true[ok_ekf] - 1.0).max(axis=1)
    med = (lambda e: float(np.median(e)) if e.size else float("nan"))
    p90 = (lambda e: float(np.percentile(e, 90)) if e.size else float("nan"))
    chi_true = float(np.median(chi_loc[steady])) if steady.any() else float("nan")
    return HuskyComparison(
        terrain=str(run.terrain), seed=int(result.config.seed), chi_true=chi_true,
        ekf_chi_err=med(e_chi_ekf), ekf_chi_p90=p90(e_chi_ekf),
        ekf_chi_conv_s=_conv_time(t[steady], e_chi_ekf),
        obs_chi_err=med(e_chi_obs), obs_chi_p90=p90(e_chi_obs),
        obs_chi_conv_s=_conv_time(t[steady], e_chi_obs),
        ekf_eta_err=med(e_eta_ekf), obs_eta_err=med(e_eta_obs), obs_eta_p90=p90(e_eta_obs),
        obs_eta_conv_s=_conv_time(t[ok_eta], e_eta_obs))


def measured_skid_steer_summary(runs: Sequence[Run], settings: SkidSteerSettings =
                                SkidSteerSettings(), observer: AdaptiveObserverSettings =
                                AdaptiveObserverSettings(use_position=False)) -> pd.DataFrame:
    """Per-run ICR factor, gyro bias and the yaw-only observer's turning efficiency.

    The observer gets ``theta`` = integral of ``wz - b`` (b = the EKF's final gyro bias)
    and the side speeds interpolated on the EKF grid; its ICR factor is computed as in
    :func:`husky_comparison`. Both are summarised over the samples turning faster than
    0.15 rad/s (median), with the fraction of such samples.

    Parameters
    ----------
    runs : sequence of Run
        Measured runs (runs without IMU are skipped, with a warning that names them).
    settings : SkidSteerSettings
        Settings of the skid-steer EKF.
    observer : AdaptiveObserverSettings
        Settings of the yaw-only observer.

    Returns
    -------
    pandas.DataFrame
        One row per run with an IMU: run_id, terrain, chi_ekf, chi_observer, eta_R, eta_L,
        gyro_bias, turning_fraction, duration_s (these columns also when no run has one).

    Warns
    -----
    DataWarning
        Some runs have no ``imu`` stream: how many of how many, and their ids.
    """
    rows = []
    no_imu = [run.run_id for run in runs if "imu" not in run.streams]
    if no_imu:
        warnings.warn(f"measured_skid_steer_summary: {len(no_imu)} of {len(runs)} runs have "
                      f"no imu stream and are skipped: {', '.join(map(str, no_imu))}",
                      DataWarning, stacklevel=2)
    for run in runs:
        if "imu" not in run.streams:
            continue
        ekf = estimate_skid_steer(run, settings)
        t = ekf.t_s
        wheels = run.streams["wheels"]
        vl = np.interp(t, wheels[TIME], wheels["vel_l"])
        vr = np.interp(t, wheels[TIME], wheels["vel_r"])
        imu = run.streams["imu"]
        bias = float(ekf.state("gyro_bias")[-1])
        wz = np.interp(t, imu[TIME], imu["wz"]) - bias
        theta = np.concatenate([[0.0], np.cumsum(0.5 * (wz[1:] + wz[:-1]) * np.diff(t))])
        pose = np.column_stack([np.full(t.size, np.nan), np.full(t.size, np.nan), theta])
        obs = run_adaptive_observer(t, pose, vr, vl, observer)
        d = observer.half_track_m        # the d the observer estimated its etas with
        omega_obs = (obs.eta_right * vr - obs.eta_left * vl) / (2.0 * d)
        turning = np.abs(ekf.state("yaw_rate")) > 0.15
        with np.errstate(divide="ignore", invalid="ignore"):
            chi_obs = (vr - vl) / (settings.track_m * omega_obs)
        pick = (lambda a: float(np.nanmedian(a[turning])) if turning.any() else float("nan"))
        rows.append({"run_id": run.run_id, "terrain": run.terrain,
                     "chi_ekf": pick(icr_chi(ekf)), "chi_observer": pick(chi_obs),
                     "eta_R": pick(obs.eta_right), "eta_L": pick(obs.eta_left),
                     "gyro_bias": bias, "turning_fraction": float(turning.mean()),
                     "duration_s": float(t[-1] - t[0])})
    return pd.DataFrame(rows, columns=["run_id", "terrain", "chi_ekf", "chi_observer", "eta_R",
                                       "eta_L", "gyro_bias", "turning_fraction", "duration_s"])


def outage_experiment(result: Simulation, t_off_s: float = 8.0, t_on_s: float = 11.0,
                      settings_fn: Callable[[Run], AgriMaRoEKFSettings] = data_driven_settings
                      ) -> tuple[EKFResult, EKFResult]:
    """The EKF with every camera sample in ``[t_off_s, t_on_s)`` dropped, and with them NaN.

    Parameters
    ----------
    result : Simulation
        Simulated AgriMaRo run.
    t_off_s, t_on_s : float
        Start and end of the outage, s.
    settings_fn : callable
        Run -> EKF settings.

    Returns
    -------
    dropped, nanned : EKFResult
        Samples removed; samples replaced by NaN (skipped and counted).
    """
    run = result.run
    cam = run.streams["cam"]
    gone = (cam[TIME] >= t_off_s) & (cam[TIME] < t_on_s)
    dropped = Run(run.run_id, run.dataset, run.terrain,
                  {**run.streams, "cam": cam[~gone].reset_index(drop=True)}, run.vehicle,
                  run.source, run.meta)
    nan_cam = cam.copy()
    nan_cam.loc[gone, ["v_cx", "v_cy", "yaw_rate_c", "yaw_c"]] = np.nan
    nanned = Run(run.run_id, run.dataset, run.terrain, {**run.streams, "cam": nan_cam},
                 run.vehicle, run.source, run.meta)
    settings = settings_fn(run)
    return estimate_agrimaro(dropped, settings), estimate_agrimaro(nanned, settings)


__all__ = ["FINE_ENCODER", "THESIS_TERRAINS", "truth_on_grid",
           "simulate_agrimaro", "agrimaro_truth_states", "data_driven_settings",
           "ConsistencyRow", "agrimaro_consistency", "coriolis_prediction_error",
           "coriolis_filter_rmse", "simulate_husky", "steady_turn_mask", "HuskyComparison",
           "husky_comparison", "measured_skid_steer_summary", "outage_experiment"]
