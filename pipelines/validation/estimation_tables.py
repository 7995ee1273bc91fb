"""Tables of ``docs/estimation_validation.md``: estimators on simulated and measured runs.

``terrain validate estimation [--quick] [--out FILE]`` (:mod:`pipelines.validate`) prints every
table as Markdown (and writes them to FILE). Nothing in the library imports this module.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
import pandas as pd

from terrain.estimation.agrimaro import estimate_agrimaro
from terrain.estimation.consistency import nees, rmse, state_errors
from terrain.estimation.slip_state import STATE_NAMES as SLIP_STATE_NAMES
from terrain.estimation.slip_state import SlipStateModel, noise_derived_slip_state_model
from pipelines.validation.harness import (THESIS_TERRAINS, agrimaro_consistency,
                                          coriolis_filter_rmse, coriolis_prediction_error,
                                          data_driven_settings, husky_comparison,
                                          measured_skid_steer_summary, outage_experiment,
                                          simulate_agrimaro, simulate_husky, truth_on_grid)
from terrain.sim import Effects, SensorSettings
from terrain.slip.estimate import estimate_run

SLIPS = ("slip_1", "slip_2", "slip_3")


def _slip_errors(result, est, t_steady_s: float = 5.0, t_transient_s: float = 3.0) -> dict:
    tr = truth_on_grid(result, est.ekf.t_s)
    truth = tr[list(SLIPS)].to_numpy()
    e = est.slip - truth
    steady = est.ekf.t_s > t_steady_s
    trans = est.ekf.t_s < t_transient_s
    out = {f"steady_err_{j + 1}": float(np.nanmean(e[steady, j])) for j in range(3)}
    out["steady_truth"] = float(np.mean(truth[steady]))
    out["transient_rmse"] = rmse(e[trans], ignore_nan=True)
    out["rmse"] = rmse(e, ignore_nan=True)
    return out


def _worst_steady_error(err: dict) -> float:
    """The largest ``|steady_err_i|`` of the three wheels; NaN when a wheel has none (the
    builtin ``max`` dropped a NaN unless it came first)."""
    return float(np.max(np.abs([err[f"steady_err_{j}"] for j in (1, 2, 3)])))


def steady_slip_table(seeds: Sequence[int] = (1, 2, 3), duration_s: float = 20.0) -> pd.DataFrame:
    """Steady-state slip error per wheel (straight_accel, thesis scenario), per tuning.

    Parameters
    ----------
    seeds : sequence of int
        Seeds of the simulated runs.
    duration_s : float
        Simulated time per run, s.

    Returns
    -------
    pandas.DataFrame
        One row per case (columns as printed in the report).
    """
    rows = []
    for terrain in THESIS_TERRAINS:
        for seed in seeds:
            result = simulate_agrimaro(terrain, seed, duration_s)
            run = result.run
            for tuning in ("noise", "thesis"):
                row = {"terrain": terrain, "seed": seed, "tuning": tuning}
                row.update(_slip_errors(result, estimate_run(run, tuning=tuning)))
                rows.append(row)
    return pd.DataFrame(rows)


def default_encoder_table(seed: int = 1) -> pd.DataFrame:
    """The same with the simulator's default AgriMaRo encoder: the count rate of its
    90 count/rev encoder before the driver's filter (``speed_quantum_m_s=0``,
    :func:`terrain.sim.sensors.encoder_count_rate`), not the fine encoder of the other tables.

    Parameters
    ----------
    seed : int
        Seed of the simulated run(s).

    Returns
    -------
    pandas.DataFrame
        One row per case (columns as printed in the report).
    """
    rows = []
    for terrain in THESIS_TERRAINS:
        result = simulate_agrimaro(terrain, seed, 20.0, sensors=SensorSettings(
            wheel_rate_hz=50.0, speed_quantum_m_s=0.0, current_quantum_a=0.01))
        est = estimate_run(result.run)
        rows.append({"terrain": terrain, **_slip_errors(result, est),
                     "lag_s": est.lag.lag_s if est.lag else float("nan")})
    return pd.DataFrame(rows)


def consistency_table(n_runs: int = 10, duration_s: float = 20.0) -> pd.DataFrame:
    """Monte Carlo NEES / NIS and RMSE per terrain (straight_accel), with slip RMSE.

    Parameters
    ----------
    n_runs : int
        Monte Carlo runs per terrain.
    duration_s : float
        Simulated time per run, s.

    Returns
    -------
    pandas.DataFrame
        One row per case (columns as printed in the report).
    """
    rows = []
    for terrain in THESIS_TERRAINS:
        row = agrimaro_consistency(terrain, range(n_runs), duration_s).as_dict()
        slip_rmse = []
        for seed in range(min(n_runs, 3)):
            result = simulate_agrimaro(terrain, seed, duration_s)
            slip_rmse.append(_slip_errors(result, estimate_run(result.run))["rmse"])
        row["rmse_slip"] = float(np.mean(slip_rmse))
        rows.append(row)
    return pd.DataFrame(rows)


def coriolis_table(seeds: Sequence[int] = (1, 2)) -> pd.DataFrame:
    """One-step model error and filter RMSE with each Coriolis sign (random driving).

    Parameters
    ----------
    seeds : sequence of int
        Seeds of the simulated runs.

    Returns
    -------
    pandas.DataFrame
        One row per case (columns as printed in the report).
    """
    rows = []
    for seed in seeds:
        result = simulate_agrimaro("GRASS", seed, 30.0, scenario="random")
        pred = coriolis_prediction_error(result)
        rmse = coriolis_filter_rmse(result)
        for conv in ("body", "eq6.2"):
            rows.append({"seed": seed, "convention": conv, "one_step_err_m_s": pred[conv],
                         **{f"rmse_{k}": v for k, v in rmse[conv].items()}})
    return pd.DataFrame(rows)


def slip_state_table(seeds: Sequence[int] = (1, 2), duration_s: float = 20.0) -> pd.DataFrame:
    """The 14-state slip-in-state EKF (ch. 4.3) against the 12-state design + post-hoc slip.

    Parameters
    ----------
    seeds : sequence of int
        Seeds of the simulated runs.
    duration_s : float
        Simulated time per run, s.

    Returns
    -------
    pandas.DataFrame
        One row per case (columns as printed in the report).
    """
    rows = []
    for terrain in THESIS_TERRAINS:
        for seed in seeds:
            result = simulate_agrimaro(terrain, seed, duration_s)
            run = result.run
            settings = data_driven_settings(run)
            acc = float(np.sqrt(settings.r_diag[3]))
            for label, model in (("ch4.3 as published (no camera)", SlipStateModel()),
                                 ("ch4.3 + camera rows, thesis Q", SlipStateModel(
                                     accel="direct", camera=True)),
                                 ("ch4.3 + camera rows, noise-derived",
                                  noise_derived_slip_state_model(accel_std_m_s2=acc))):
                res = estimate_agrimaro(run, settings, model=model, store_covariance=True)
                tr = truth_on_grid(result, res.t_s)
                truth = np.column_stack([tr[s].to_numpy() for s in SLIP_STATE_NAMES])
                e = state_errors(res.x, truth, (2,))
                est = res.x[:, 8:11]
                steady = res.t_s > 5.0
                slip_e = est - tr[list(SLIPS)].to_numpy()
                rows.append({"terrain": terrain, "seed": seed, "design": label,
                             "steady_slip_err": float(np.abs(slip_e[steady].mean(axis=0)).max()),
                             "slip_rmse": rmse(slip_e),
                             "v_bx_rmse": rmse(e[:, 3]),
                             "max_abs_slip": float(np.abs(est).max()),
                             "anees_per_state": float(np.mean(nees(e, res.P)) / 14)})
            est12 = estimate_run(run)
            err = _slip_errors(result, est12)
            tr = truth_on_grid(result, est12.ekf.t_s)
            rows.append({"terrain": terrain, "seed": seed,
                         "design": "12-state (ch. 6.1) + post-hoc slip (ch. 7)",
                         "steady_slip_err": _worst_steady_error(err),
                         "slip_rmse": err["rmse"],
                         "v_bx_rmse": rmse(est12.ekf.state("v_bx") - tr["v_bx"], ignore_nan=True),
                         "max_abs_slip": float(np.nanmax(np.abs(est12.slip))),
                         "anees_per_state": float("nan")})
    return pd.DataFrame(rows)


def lag_table(lags_s: Sequence[float] = (0.0, 0.1, 0.3), seed: int = 1) -> pd.DataFrame:
    """Transient slip RMSE (first 3 s) with each lag remedy, planted encoder lags.

    Parameters
    ----------
    lags_s : sequence of float
        Planted ``wheel_lag`` values, s.
    seed : int
        Seed of the simulated run(s).

    Returns
    -------
    pandas.DataFrame
        One row per case (columns as printed in the report).
    """
    rows = []
    for lag in lags_s:
        for terrain in THESIS_TERRAINS:
            result = simulate_agrimaro(terrain, seed, 15.0, effects=Effects(wheel_lag=lag))
            run = result.run
            row = {"planted_lag_s": lag, "terrain": terrain}
            for mode in ("none", "ema", "xcorr"):
                est = estimate_run(run, lag=mode)
                err = _slip_errors(result, est)
                row[f"transient_rmse_{mode}"] = err["transient_rmse"]
                row[f"steady_err_{mode}"] = _worst_steady_error(err)
                if mode == "xcorr":
                    row["estimated_lag_s"] = est.lag.lag_s if est.lag else float("nan")
            rows.append(row)
    return pd.DataFrame(rows)


def outage_table(seed: int = 2) -> pd.DataFrame:
    """Velocity std and error before, during and after a 3 s camera outage.

    Parameters
    ----------
    seed : int
        Seed of the simulated run(s).

    Returns
    -------
    pandas.DataFrame
        One row per case (columns as printed in the report).
    """
    result = simulate_agrimaro("GRASS", seed, 16.0, scenario="random")
    dropped, _ = outage_experiment(result, 8.0, 11.0)
    tr = truth_on_grid(result, dropped.t_s)
    t = dropped.t_s
    rows = []
    for label, mask in (("before (6-8 s)", (t > 6) & (t < 8)),
                        ("end of outage (10.5-11 s)", (t > 10.5) & (t < 11)),
                        ("after (13-16 s)", t > 13)):
        rows.append({"phase": label,
                     **{f"std_{k}": float(dropped.std(k)[mask].mean())
                        for k in ("v_bx", "v_by", "yaw")},
                     **{f"abs_err_{k}": float(np.abs(dropped.state(k) - tr[k])[mask].mean())
                        for k in ("v_bx", "v_by")}})
    return pd.DataFrame(rows)


def husky_table(seeds: Sequence[int] = (3, 4, 5)) -> pd.DataFrame:
    """EKF vs adaptive observer on mixed driving and on orchard rows (Assumption 1).

    Parameters
    ----------
    seeds : sequence of int
        Seeds of the simulated runs.

    Returns
    -------
    pandas.DataFrame
        One row per case (columns as printed in the report).
    """
    rows = []
    for scenario, duration, terrains in (("random", 60.0, ("ASPHALT", "FLOORING", "ICE")),
                                         ("orchard", 120.0, ("ASPHALT", "FLOORING"))):
        for terrain in terrains:
            for seed in seeds:
                comp = husky_comparison(simulate_husky(terrain, seed, duration, scenario))
                rows.append({"scenario": scenario, **comp.as_dict()})
    return pd.DataFrame(rows)


def measured_table(datasets: Sequence[str] = ("borealtc", "vulpi")) -> pd.DataFrame:
    """Per-terrain medians of the skid-steer EKF and the yaw-only observer on shipped runs.

    Parameters
    ----------
    datasets : sequence of str
        Shipped datasets (``borealtc``, ``vulpi``).

    Returns
    -------
    pandas.DataFrame
        One row per dataset and terrain: ``runs`` (runs with an IMU), ``runs_turning``
        (those with a defined EKF chi, i.e. a sample turning faster than 0.15 rad/s: the
        chi and eta medians are over these only), the medians of ``chi_ekf, chi_observer,
        eta_R, eta_L`` and, over every run, of ``gyro_bias`` (rad/s) and
        ``turning_fraction``.
    """
    from terrain.io.shipped import load_dataset
    frames = []
    for name in datasets:
        summary = measured_skid_steer_summary(load_dataset(name))
        summary.insert(0, "dataset", name)
        frames.append(summary)
    df = pd.concat(frames, ignore_index=True)
    return (df.groupby(["dataset", "terrain"])
            .agg(runs=("run_id", "count"), runs_turning=("chi_ekf", "count"),
                 chi_ekf=("chi_ekf", "median"),
                 chi_observer=("chi_observer", "median"), eta_R=("eta_R", "median"),
                 eta_L=("eta_L", "median"), gyro_bias=("gyro_bias", "median"),
                 turning_fraction=("turning_fraction", "median"))
            .reset_index())


def sections(quick: bool = False) -> list[tuple[str, Callable[[], pd.DataFrame]]]:
    """The report's tables, in order.

    Parameters
    ----------
    quick : bool
        Fewer seeds / runs (a smoke run, not the published figures).

    Returns
    -------
    list of (title, table function)
    """
    q = quick
    return [
        ("Steady-state slip error per wheel (straight_accel, 20 s)",
         lambda: steady_slip_table((1,) if q else (1, 2, 3))),
        ("Simulator default encoder (count-rate quantisation)", default_encoder_table),
        ("Consistency (Monte Carlo NEES/NIS) and RMSE per terrain",
         lambda: consistency_table(4 if q else 10)),
        ("Coriolis sign convention (random driving, GRASS)", coriolis_table),
        ("Slip inside the state (ch. 4.3) vs the final design",
         lambda: slip_state_table((1,) if q else (1, 2))),
        ("Encoder lag: none / EMA (thesis) / cross-correlation", lag_table),
        ("Camera outage 8-11 s (GRASS, random)", outage_table),
        ("Husky: skid-steer EKF vs adaptive observer (simulated)",
         lambda: husky_table((3,) if q else (3, 4, 5))),
        ("Measured runs: per-terrain estimates", measured_table),
    ]
