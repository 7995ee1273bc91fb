"""Validation grid of the closed loop: gain tuning on tuning seeds, the evaluation grid, and
the quasi-static bound that decides whether a slip-limit target is reachable.

Tuning (:func:`tune_gains`): an exhaustive search over a small ``(kp, ki)`` grid, each pair
scored by simulated ``straight_accel`` runs on the tuning terrains and *tuning seeds* only
(:data:`TUNING_SEEDS`, disjoint from the evaluation seeds, which :func:`run_grid` refuses to
share), cost = mean slip RMSE against the target while enabled + ``time_weight`` x the mean
relative increase of the time to cruise against no control + ``steady_weight`` x the mean share
of steady control steps more than 0.02 from the target.

Quasi-static bound (:func:`slip_limit_bound`): with the wheel slip held at or below ``s``,
the largest forward acceleration on flat ground is
``a(s) = g (mu(s) - soil_resistance(s))`` (the traction balance of
:func:`terrain.terramechanics.steady_slip`); cutting the peak slip by a factor ``k`` needs
``a(k peak) > 0`` and costs time ``v / a(k peak)`` against the open-loop acceleration.
"""

from __future__ import annotations

import itertools
import math
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from terrain.control.closed_loop import check_gains, run_closed_loop
from terrain.control.feedforward import traction_acceleration_limit
from terrain.terramechanics.resistance import G_M_S2
from terrain.errors import (ConfigError, DataFormatError, config_positive, config_probability,
                            config_seed, duplicated)
from terrain.terramechanics import get_terrain, steady_slip

#: Seeds reserved for gain tuning; evaluation seeds must not overlap them.
TUNING_SEEDS: tuple[int, ...] = (1000, 1001)


def tune_gains(vehicle: str, terrains: Sequence[str], kp_grid: Sequence[float],
               ki_grid: Sequence[float], duration_s: float = 10.0,
               seeds: Sequence[int] = TUNING_SEEDS, time_weight: float = 0.5,
               steady_weight: float = 0.5,
               log: Callable[[dict], None] | None = None, estimator: str | None = None,
               feed_forward: bool = True) -> tuple[tuple[float, float], pd.DataFrame]:
    """Grid search of ``(kp, ki)`` on simulated ``straight_accel`` runs of the tuning seeds.

    Parameters
    ----------
    vehicle : str
        ``agrimaro`` or ``husky``.
    terrains : sequence of str
        Tuning terrains.
    kp_grid, ki_grid : sequence of float
        Candidate gains (rad/s per unit slip; rad/s per unit slip and s).
    duration_s : float
        Simulated time per run, s.
    seeds : sequence of int
        Tuning seeds.
    time_weight : float
        Weight of the relative time-to-cruise increase in the cost (a controlled run that
        never reaches cruise counts as reaching it at the end of the run, ``duration_s``,
        the earliest it could; a run whose uncontrolled twin never reaches it counts 1; a
        controlled run faster than its twin counts 0, not a negative increase).
    steady_weight : float
        Weight of the share of steady control steps with ``|slip - target| > 0.02`` (the
        issue's steady-driving target; a run without steady samples counts as 1).
    log : callable, optional
        Called with each candidate's row (e.g. to log it to MLflow).
    estimator : str, optional
        Estimator kind (:func:`terrain.control.estimators.estimator_for`); None: the
        vehicle's default.
    feed_forward : bool
        Feed-forward slip limit in the loop.

    Returns
    -------
    best : tuple of float
        ``(kp, ki)`` of the lowest cost; among candidates of the same cost the smallest
        ``kp``, then ``ki`` (the order of the grids does not matter).
    table : pandas.DataFrame
        ``kp, ki, slip_rmse, time_increase, steady_miss, cost`` per candidate.

    Raises
    ------
    ConfigError
        ``terrains``, ``seeds``, ``kp_grid`` or ``ki_grid`` empty or with a value given
        more than once (a repeated seed counts its runs twice), a seed that is not a whole
        number >= 0 (:func:`~terrain.errors.config_seed`), or a candidate gain or a weight
        that is not a finite real number >= 0 (named, ``kp_grid[i]``), before any run.
    """
    config_positive("tune_gains", allow_zero=True, time_weight=time_weight,
                    steady_weight=steady_weight)
    for i, seed in enumerate(seeds):   # (before the runs of the seeds before it)
        config_seed(f"tune_gains seeds[{i}]", seed)
    for axis, values in (("kp_grid", kp_grid), ("ki_grid", ki_grid)):
        for i, gain in enumerate(values):   # (the loop refused one when its turn came)
            config_positive("tune_gains", allow_zero=True, **{f"{axis}[{i}]": gain})
    _check_axes({"terrains": [str(t).upper() for t in terrains], "seeds": list(seeds),
                 "kp_grid": list(kp_grid), "ki_grid": list(ki_grid)}, "tune_gains ",
                nonempty=True)
    base = {}
    for ter, seed in itertools.product(terrains, seeds):
        base[ter, seed] = run_closed_loop(vehicle, ter, "straight_accel", False, seed,
                                          duration_s, estimator=estimator)[2]
    rows = []
    for kp, ki in itertools.product(kp_grid, ki_grid):
        rmse, dt, miss = [], [], []
        for ter, seed in itertools.product(terrains, seeds):
            m = run_closed_loop(vehicle, ter, "straight_accel", True, seed, duration_s,
                                (kp, ki), estimator=estimator, feed_forward=feed_forward)[2]
            t0, t1 = base[ter, seed]["time_to_speed_s"], m["time_to_speed_s"]
            rmse.append(m["slip_rmse"] if m["slip_rmse"] is not None else 1.0)
            if t1 is None:      # never reached in the run: at duration_s at the earliest
                t1 = float(duration_s)
            dt.append(1.0 if not t0 else max(t1 / t0 - 1.0, 0.0))
            within = m["steady_slip_within_0_02"]
            miss.append(1.0 if within is None else 1.0 - within)
        row = {"kp": kp, "ki": ki, "slip_rmse": float(np.mean(rmse)),
               "time_increase": float(np.mean(dt)), "steady_miss": float(np.mean(miss))}
        row["cost"] = (row["slip_rmse"] + time_weight * row["time_increase"]
                       + steady_weight * row["steady_miss"])
        rows.append(row)
        if log is not None:
            log(row)
    table = pd.DataFrame(rows)
    # ties (every candidate costs the same where the feedback never acts) go to the smallest
    # gains, whatever order the grids list them in (idxmin took the first listed)
    best = min(rows, key=lambda r: (r["cost"], r["kp"], r["ki"]))
    return (float(best["kp"]), float(best["ki"])), table


def check_grid_axes(vehicles: Sequence[str], terrains: Sequence[str], scenarios: Sequence[str],
                    seeds: Sequence[int]) -> None:
    """Refuse a value repeated on an axis of the evaluation grid.

    A repeated value would run its cells twice: the results table would hold them twice
    and the traces keep one of each.

    Parameters
    ----------
    vehicles, terrains, scenarios : sequence of str
        Grid axes (terrain names compared in upper case, as the catalogue reads them).
    seeds : sequence of int
        Evaluation seeds.

    Raises
    ------
    ConfigError
        A value given more than once, naming the axis, or a seed that is not a whole
        number >= 0 (:func:`~terrain.errors.config_seed`, named ``seeds[i]``).
    """
    for i, seed in enumerate(seeds):   # (int() made 0.5 a repeat of seed 0)
        config_seed(f"seeds[{i}]", seed)
    _check_axes({"vehicles": [str(v).lower() for v in vehicles],
                 "terrains": [str(t).upper() for t in terrains],
                 "scenarios": list(scenarios), "seeds": [int(s) for s in seeds]})


def _check_axes(axes: dict[str, list], owner: str = "", nonempty: bool = False) -> None:
    """Refuse a value repeated on an axis (or, with ``nonempty``, an empty axis), naming
    the axis after ``owner``: the one rule of :func:`check_grid_axes` and
    :func:`tune_gains`."""
    for axis, values in axes.items():
        if nonempty and not values:
            raise ConfigError(f"{owner}{axis}: empty (each value once, at least one)")
        repeated = duplicated(values)
        if repeated:
            raise ConfigError(f"{owner}{axis}: {repeated} given more than once (each value of "
                              "a grid axis once)")


def run_grid(vehicles: Sequence[str], terrains: Sequence[str], scenarios: Sequence[str],
             seeds: Sequence[int], gains: dict, duration_s: float = 20.0,
             estimators: dict | None = None, feed_forward: bool = True,
             decisions: dict | None = None) -> tuple[pd.DataFrame, dict]:
    """Run the evaluation grid (controller off and on for every cell).

    Parameters
    ----------
    vehicles, terrains, scenarios : sequence of str
        Grid axes.
    seeds : sequence of int
        Evaluation seeds (disjoint from :data:`TUNING_SEEDS`).
    gains : dict
        Vehicle -> ``(kp, ki)``.
    duration_s : float
        Simulated time per run, s.
    estimators : dict, optional
        Vehicle -> estimator kind (:func:`terrain.control.estimators.estimator_for`);
        missing vehicles use their default.
    feed_forward : bool
        Feed-forward slip limit in the loop.
    decisions : dict, optional
        Vehicle -> ``provider(terrain) -> (live or None, table or None, note)``, called for
        every run: a fresh live classifier (:class:`terrain.control.closed_loop.LiveTerrain`)
        fed with that run's own samples (the controller off and on each get their own);
        vehicles without a provider, or a provider returning no ``live``, use the run's
        label (``terrain_source`` says which).

    Returns
    -------
    results : pandas.DataFrame
        One row per run: the axes, ``controller``, ``terrain_source`` and the metrics of
        :func:`terrain.control.closed_loop.loop_metrics`.
    traces : dict
        ``(vehicle, terrain, scenario, controller, seed)`` -> per-call trace frame.

    Raises
    ------
    ConfigError
        An evaluation seed is a tuning seed, a value repeated on an axis
        (:func:`check_grid_axes`), a vehicle without ``gains`` or whose gains are not a
        pair of finite real numbers >= 0 (named), before any run.
    """
    from terrain.control.closed_loop import trace_frame

    check_grid_axes(vehicles, terrains, scenarios, seeds)   # (whole numbers: hashable)
    shared = sorted(set(seeds) & set(TUNING_SEEDS))
    if shared:
        raise ConfigError(f"evaluation seeds {shared} are tuning seeds")
    missing = [v for v in vehicles if v not in gains]
    if missing:   # a KeyError after every run of the vehicles before it
        raise ConfigError(f"run_grid: no gains (kp, ki) for vehicle(s) {missing}; gains has "
                          f"{sorted(gains)}")
    for veh in vehicles:   # bad gains stopped the grid at the vehicle's first run
        kp, ki = check_gains(gains[veh], f"run_grid gains[{veh!r}]")
        config_positive(f"run_grid gains[{veh!r}]", allow_zero=True, kp=kp, ki=ki)
    rows, traces = [], {}
    for veh, ter, sc, seed, on in itertools.product(vehicles, terrains, scenarios, seeds,
                                                    (False, True)):
        provider = (decisions or {}).get(veh)
        live, table, _ = provider(ter) if provider else (None, None, "label")
        sim, loop, m = run_closed_loop(veh, ter, sc, on, seed, duration_s, gains[veh],
                                       table=table, estimator=(estimators or {}).get(veh),
                                       feed_forward=feed_forward, live_terrain=live)
        ctrl = "traction" if on else "off"
        rows.append({"vehicle": veh, "terrain": ter, "scenario": sc, "seed": seed,
                     "controller": ctrl,
                     "terrain_source": "label" if live is None else "classifier",
                     **{k: v for k, v in m.items() if not isinstance(v, str)}})
        traces[veh, ter, sc, ctrl, seed] = trace_frame(sim, loop)
    return pd.DataFrame(rows), traces


def compare(results: pd.DataFrame) -> pd.DataFrame:
    """Controller on against off, per vehicle, terrain and scenario (means over seeds).

    Parameters
    ----------
    results : pandas.DataFrame
        Output of :func:`run_grid`.

    Returns
    -------
    pandas.DataFrame
        ``peak_slip_off/on``, ``peak_slip_cut`` (fraction), ``energy_off/on`` (J/m, mean
        over the seeds whose run moves: a run below
        :data:`~terrain.control.closed_loop.MIN_DISTANCE_M` has none),
        ``energy_runs_off/on`` (how many runs that mean is over, of ``runs``),
        ``energy_cut`` (fraction: one less the mean energy on over the mean energy off, both
        over the seeds where both runs have one, as ``time_increase``; equal to
        ``1 - energy_on / energy_off`` where every run has one), ``time_to_speed_off/on``
        (s, mean over the seeds whose run reaches cruise), ``time_to_speed_reached_off/on``
        (how many runs reach it, of ``runs``, the seeds of the cell), ``time_increase``
        (fraction: mean time on over mean time off, both over the seeds where both runs
        reach cruise, so a run that never gets there is counted, not averaged out),
        ``slip_rmse_off/on`` (mean over the seeds whose controller is ever enabled),
        ``slip_rmse_runs_off/on`` (how many runs that mean is over, of ``runs``),
        ``steady_within_0_02_on`` (fraction of steady samples with |slip - target| <=
        0.02, mean over the seeds whose controlled run has steady samples: a run without
        any has no share and is left out), ``steady_within_0_02_runs_on`` (how many runs
        that mean is over, of ``runs``), ``terrain_accuracy_on`` (share of control steps
        whose terrain decision is the true terrain, controller on).

    Raises
    ------
    DataFormatError
        ``results`` without one of :func:`run_grid`'s axis, ``controller`` or metric
        columns, or without any run of the controller ``off`` or ``traction`` (named).
    """
    keys = ["vehicle", "terrain", "scenario"]
    cols = ["peak_slip", "energy_j_per_m", "time_to_speed_s", "slip_rmse",
            "steady_slip_within_0_02", "mean_speed_m_s", "terrain_accuracy"]
    # (pandas' bare KeyError ('peak_slip', 'traction') for the uncontrolled runs alone)
    missing = [c for c in keys + ["seed", "controller"] + cols if c not in results.columns]
    if missing:
        raise DataFormatError(f"compare needs run_grid's results, which have the column(s) "
                              f"{', '.join(missing)}", column=missing[0])
    absent = [c for c in ("off", "traction") if not (results["controller"] == c).any()]
    if absent:
        raise DataFormatError(f"compare needs runs with the controller off and on; the results "
                              f"have none with controller {', '.join(absent)}",
                              column="controller")
    mean = results.groupby(keys + ["controller"])[cols].mean().unstack("controller")
    out = pd.DataFrame(index=mean.index)
    for c, short in (("peak_slip", "peak_slip"), ("energy_j_per_m", "energy"),
                     ("time_to_speed_s", "time_to_speed"), ("slip_rmse", "slip_rmse"),
                     ("mean_speed_m_s", "mean_speed")):
        out[f"{short}_off"] = mean[(c, "off")]
        out[f"{short}_on"] = mean[(c, "traction")]
    out["peak_slip_cut"] = 1.0 - out["peak_slip_on"] / out["peak_slip_off"]

    def paired(col):   # means of off and on over the seeds where both runs have a value
        pairs = results.assign(v=results[col].astype(float)).set_index(
            keys + ["seed", "controller"])["v"].unstack("controller").dropna()
        return pairs.groupby(level=keys).mean().reindex(out.index)

    # a seed where either run has no energy (did not move) is left out of the cut, as from
    # the time increase below: a ratio of means over different seeds compares other runs
    energy = paired("energy_j_per_m")
    out["energy_cut"] = 1.0 - energy["traction"] / energy["off"]
    # time to cruise: a seed where either run did not reach it is left out of the increase
    # (a mean over the seeds each run reached compares different seeds) and counted
    t = results.assign(t=results["time_to_speed_s"].astype(float))
    reached = t.groupby(keys + ["controller"])["t"].count().unstack("controller")
    out["time_to_speed_reached_off"] = reached["off"]
    out["time_to_speed_reached_on"] = reached["traction"]
    out["runs"] = t[t["controller"] == "off"].groupby(keys)["seed"].nunique()
    times = paired("time_to_speed_s")
    out["time_increase"] = times["traction"] / times["off"] - 1.0
    out["steady_within_0_02_on"] = mean[("steady_slip_within_0_02", "traction")]
    # a run without a value (None: no steady samples, no distance for J/m, never enabled for
    # the RMSE) is left out of that mean: counted
    for c, short, ctrls in (("steady_slip_within_0_02", "steady_within_0_02", ("traction",)),
                            ("energy_j_per_m", "energy", ("off", "traction")),
                            ("slip_rmse", "slip_rmse", ("off", "traction"))):
        valid = results.assign(s=results[c].astype(float))
        for ctrl in ctrls:
            runs = valid[valid["controller"] == ctrl].groupby(keys)["s"].count()
            out[f"{short}_runs_{'on' if ctrl == 'traction' else ctrl}"] = runs.reindex(
                out.index).fillna(0).astype(int)
    out["terrain_accuracy_on"] = mean[("terrain_accuracy", "traction")]
    return out.reset_index()


def slip_limit_bound(terrain: str, peak_slip_open: float, cut: float = 0.5,
                     accel_m_s2: float = 1.0, cruise_m_s: float = 1.0) -> dict:
    """Whether a slip limit of ``(1 - cut) x peak`` leaves room to accelerate (quasi-static).

    Parameters
    ----------
    terrain : str
        Catalogued terrain.
    peak_slip_open : float
        Peak slip magnitude without control, in [0, 1].
    cut : float
        Fraction of the peak to remove, in [0, 1] (0.5 = the issue's target).
    accel_m_s2 : float
        Commanded acceleration, m/s^2 (finite, > 0; straight_accel: 1).
    cruise_m_s : float
        Cruise speed, m/s (finite, > 0).

    Returns
    -------
    dict
        ``slip_limit``; ``steady_slip`` (slip balancing the soil resistance at cruise);
        ``slip_for_command`` (slip needed for ``accel_m_s2``); ``accel_at_limit_m_s2``
        (``g (mu - resistance)`` at the limit); ``min_time_to_cruise_s`` (``cruise /
        min(accel_at_limit, accel)``, inf when it is <= 0) against ``command_time_s``.

    Raises
    ------
    ConfigError
        An unknown terrain; an argument that is not a real number (a boolean included) or
        outside its range, named (an acceleration of 0 divided by zero, a cut above 1 gave a
        negative slip limit).
    """
    config_positive("slip_limit_bound", accel_m_s2=accel_m_s2, cruise_m_s=cruise_m_s)
    config_probability("slip_limit_bound", peak_slip_open=peak_slip_open, cut=cut)
    ter = get_terrain(terrain)
    s_lim = (1.0 - cut) * float(peak_slip_open)
    a_lim = traction_acceleration_limit(ter, s_lim)
    t_min = cruise_m_s / min(a_lim, accel_m_s2) if a_lim > 0 else math.inf
    return {"terrain": ter.name, "peak_slip_open": float(peak_slip_open), "slip_limit": s_lim,
            "steady_slip": steady_slip(ter), "slip_for_command": steady_slip(
                ter, accel_m_s2 / G_M_S2),
            "accel_at_limit_m_s2": a_lim, "min_time_to_cruise_s": t_min,
            "command_time_s": cruise_m_s / accel_m_s2}


def markdown_table(table: pd.DataFrame) -> str:
    """The comparison of :func:`compare` as a Markdown table (the README / docs rendering).

    Parameters
    ----------
    table : pandas.DataFrame
        Output of :func:`compare`.

    Returns
    -------
    str
        Markdown with peak slip, energy per metre (J/m, with how many runs it is over where
        some have none), time to cruise (s) off -> on (with how many runs reach it where not
        all do), the relative changes, the slip RMSE (with how many runs it is over where
        some have none), the steady-slip share within 0.02 of the target (with how many
        runs it is over where some have no steady samples) and the terrain decisions'
        accuracy.
    """
    head = ("| vehicle | terrain | scenario | peak slip off -> on | cut | energy J/m off -> on "
            "| cut | time to cruise s off -> on | longer | slip RMSE off -> on "
            "| steady within 0.02 (on) | terrain accuracy |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|\n")

    def f(v, fmt):
        return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) \
            else format(v, fmt)

    def reach(r):   # how many runs reach cruise, where not all of them do
        counts = (r.time_to_speed_reached_off, r.time_to_speed_reached_on)
        return "" if counts == (r.runs, r.runs) else \
            f" ({counts[0]:.0f} -> {counts[1]:.0f} of {r.runs:.0f} reach it)"

    def runs_of(r, short, ctrls=("off", "on")):   # how many runs a mean is over, if not all
        counts = [getattr(r, f"{short}_runs_{c}", r.runs) for c in ctrls]
        return "" if all(n == r.runs for n in counts) else \
            f" ({' -> '.join(f'{n:.0f}' for n in counts)} of {r.runs:.0f} runs)"

    lines = [f"| {r.vehicle} | {r.terrain} | {r.scenario} | {f(r.peak_slip_off, '.3f')} -> "
             f"{f(r.peak_slip_on, '.3f')} | {f(100 * r.peak_slip_cut, '.0f')} % | "
             f"{f(r.energy_off, '.0f')} -> {f(r.energy_on, '.0f')}{runs_of(r, 'energy')} | "
             f"{f(100 * r.energy_cut, '.1f')} % | {f(r.time_to_speed_off, '.2f')} -> "
             f"{f(r.time_to_speed_on, '.2f')}{reach(r)} | "
             f"{f(100 * r.time_increase, '.0f')} % | "
             f"{f(r.slip_rmse_off, '.3f')} -> {f(r.slip_rmse_on, '.3f')}"
             f"{runs_of(r, 'slip_rmse')} | "
             f"{f(r.steady_within_0_02_on, '.2f')}{runs_of(r, 'steady_within_0_02', ('on',))} | "
             f"{f(r.terrain_accuracy_on, '.2f')} |"
             for r in table.itertuples()]
    return head + "\n".join(lines) + "\n"
