"""The forward-speed bound of the slip-augmented skid-steer EKF, with and without.

``terrain estimate``'s batch estimator of a skid-steer run
(:func:`terrain.slip.estimate.estimate_skid_steer_slip_run`, source ``fused``: the physics
slip when no learned model is registered) keeps the forward speed within the range the latest
rim speeds allow at a braking slip down to ``speed_bound_braking_slip``
(:func:`terrain.estimation.skid_steer_slip.speed_bounds_m_s`). This script runs it with the
shipped setting and with the bound off, on

* simulated Husky runs with truth (``--terrains`` x ``--scenarios`` x ``--seeds``, 40 s,
  cached under ``out/slip_cache``): RMSE of ``v_bx`` and of the slips against the truth after
  the first 3 s, and the share of steps the bound held;
* the shipped BorealTC runs with an IMU (``data/borealtc``; no truth): the largest
  ``|v_bx|`` against the largest rim speed of the run, and the share of steps the bound
  held.

``--online`` instead replays the same measured runs through the closed loop's online
observer (:class:`terrain.control.estimators.FusedSlipObserver`, 50 Hz calls of
:func:`terrain.control.replay.measured_observations`, the run's label as terrain decision),
which applies the same bound sample by sample; figures per run as above, the share of
held samples counted per projected sample (MLflow run ``speed-bound-online``).

Simulated runs where the body slid off (went more than ``SLID_OFF_FACTOR`` times as far as
its fastest wheel: the Husky on the 15 deg icy slope) are listed and left out of the means.

Figures are printed and logged to MLflow (experiment ``terrain-benchmark``, run
``speed-bound``); ``docs/slip_learning.md``, "A bound on the forward speed".

Usage: ``python benchmarks/speed_bound.py [--bounds 0.3:1 0.5:0] [--seeds 0 1 2]
[--measured-terrains SNOW ...] [--skip-measured | --online [--imu full]]`` (about 3 min
with the defaults on 2 cores; ``--online`` about 2 min).
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
from tqdm.auto import tqdm

from features.slip_outputs import slip_model_outputs
from pipelines.arguments import DistinctSeeds, DistinctValues, seed_value, terrain_name
from terrain.control.estimators import IMU_VIEWS
from terrain.estimation.skid_steer_slip import STATE_NAMES
from terrain.io.shipped import read_shipped
from terrain.slip.dataset import SlipDataSpec, simulated_runs
from terrain.slip.estimate import BATCH_FUSION, estimate_skid_steer_slip_run
from terrain.slip.evaluation import SLID_OFF_FACTOR
from terrain.sim import SCENARIO_NAMES
from terrain.tracking import require_store, tracked_run


def settings(bounds, base=BATCH_FUSION) -> dict:
    """The fusion setting ``base`` (default: the batch estimate's) with each (braking slip,
    hold s) bound, and with none."""
    out = {f"bound {b:+.2f} hold {h:g} s": replace(base, filter=replace(
        base.filter, speed_bound_braking_slip=b, speed_bound_hold_s=h))
        for b, h in bounds}
    out["no bound"] = replace(base, filter=replace(base.filter, speed_bound_braking_slip=None))
    return out


def _metric_key(setting: str) -> str:
    """A setting's name as an MLflow metric key."""
    return setting.replace(" ", "_").replace("+", "").replace(":", "")


def _measured_runs(terrains):
    """The shipped BorealTC runs with an IMU (of ``terrains``, all when empty), each with its
    largest rim speed, m/s."""
    for run in read_shipped("borealtc"):
        if "imu" in run.streams and (not terrains or run.terrain in terrains):
            wheels = run.streams["wheels"][["vel_l", "vel_r"]].to_numpy()
            yield run, float(np.nanmax(np.abs(wheels)))


def _bound(text: str) -> tuple[float, float]:
    """``DEPTH[:HOLD_S]`` -> (braking slip ``-DEPTH``, hold s)."""
    depth, _, hold = text.partition(":")
    return -abs(float(depth)), float(hold or BATCH_FUSION.filter.speed_bound_hold_s)


def _estimate(run, outputs, fusion):
    est = estimate_skid_steer_slip_run(run, "fused", outputs=outputs, lag="xcorr",
                                       settings=fusion)
    return est.ekf, est.meta["speed_bound_active_steps"]


def simulated(terrains, scenarios, seeds, cache_dir, fusions) -> list[dict]:
    """Per run and setting: v_bx and slip RMSE against the truth, share of steps held."""
    runs = simulated_runs(SlipDataSpec(terrains=tuple(terrains), scenarios=tuple(scenarios),
                                       seeds=tuple(seeds)), cache_dir, progress=True)
    rows = []
    for run in tqdm(runs, desc="simulated runs", unit="run"):
        outputs = slip_model_outputs(run, None)
        tr = run.streams["truth"]
        # the body went more than SLID_OFF_FACTOR x as far as its fastest wheel could carry
        # it (the Husky sliding down the 15 deg icy slope): no wheel tells that speed
        wh = run.streams["wheels"]
        rim_path = float(np.trapezoid(np.abs(wh[["vel_l", "vel_r"]].to_numpy()).max(axis=1),
                                      wh["t_s"]))
        path = float(np.sum(np.hypot(*np.diff(tr[["x", "y"]].to_numpy(), axis=0).T)))
        slid_off = path > SLID_OFF_FACTOR * max(rim_path, 1e-9)
        for name, fusion in fusions.items():
            f, held = _estimate(run, outputs, fusion)
            late = f.t_s > 3.0
            t = f.t_s[late]
            v_err = f.x[late, f.state_names.index("v_bx")] - np.interp(t, tr["t_s"], tr["v_bx"])
            s_err = np.column_stack([f.x[late, f.state_names.index(c)]
                                     - np.interp(t, tr["t_s"], tr[c])
                                     for c in ("slip_1", "slip_2")])
            rows.append({"terrain": run.terrain, "scenario": run.meta["scenario"],
                         "slid_off": slid_off,
                         "setting": name, "v_rmse": float(np.sqrt(np.mean(v_err ** 2))),
                         "v_max_err": float(np.max(np.abs(v_err))),
                         "slip_rmse": float(np.sqrt(np.mean(s_err ** 2))),
                         "held_pct": 100.0 * held / f.t_s.size})
    return rows


def measured(terrains, fusions) -> list[dict]:
    """Per shipped BorealTC run with an IMU and setting: largest |v_bx|, largest rim speed,
    share of steps held."""
    rows = []
    for run, rim in tqdm(list(_measured_runs(terrains)), desc="measured runs", unit="run"):
        outputs = slip_model_outputs(run, None)
        for name, fusion in fusions.items():
            f, held = _estimate(run, outputs, fusion)
            v = np.abs(f.x[:, f.state_names.index("v_bx")])
            rows.append({"run": run.run_id, "terrain": run.terrain, "setting": name,
                         "v_max": float(v.max()), "rim_max": rim,
                         "over_1_5_rim_pct": 100.0 * float(np.mean(v > 1.5 * rim)),
                         "held_pct": 100.0 * held / f.t_s.size})
    return rows


def measured_online(terrains, bounds, imu: str = "full-gyro") -> list[dict]:
    """Per shipped BorealTC run with an IMU and bound (and none): the online observer's
    largest |v_bx| (from the streams' common start), the run's largest rim speed, the share of
    calls above 1.5 times it, the projected samples, and the IMU and wheel samples no call
    received (``not_replayed``)."""
    from terrain.control.estimators import CONTROL_FUSION, FusedSlipObserver
    from terrain.control.replay import measured_observations
    from terrain.vehicles import get_vehicle

    radius = get_vehicle("husky").wheel_radius_m
    rows = []
    for run, rim in tqdm(list(_measured_runs(terrains)), desc="measured runs, online",
                         unit="run"):
        for name, fusion in settings(bounds, CONTROL_FUSION).items():
            est = FusedSlipObserver("husky", lambda t, label=run.terrain: (label, 1.0),
                                    settings=fusion, imu=imu)
            pitch = []
            v = []
            replay = measured_observations(run, radius)
            for obs in replay:
                v.append(est.update(obs).chassis_speed_m_s)
                pitch.append(abs(float(est.x[STATE_NAMES.index("pitch")])))
            v = np.abs(v)
            rows.append({"run": run.run_id, "terrain": run.terrain, "setting": name,
                         "v_max": float(v.max()), "rim_max": rim,
                         "over_1_5_rim_pct": 100.0 * float(np.mean(v > 1.5 * rim)),
                         "held_samples": est.bound_count, "pitch_max": float(max(pitch)),
                         "not_replayed": sum(replay.dropped_before_start.values())
                         + sum(replay.dropped_after_end.values())})
    return rows


def online(args) -> int:
    """The ``--online`` comparison: print and log it."""
    import pandas as pd

    with tracked_run("terrain-benchmark", "speed-bound-online", vars(args)) as run:
        meas = pd.DataFrame(measured_online(args.measured_terrains, args.bounds, args.imu))
        wide = meas.pivot(index="run", columns="setting",
                          values=["v_max", "over_1_5_rim_pct", "held_samples"])
        wide[("rim_max", "")] = meas.groupby("run")["rim_max"].first()
        print("measured BorealTC runs through the online observer (no truth): largest "
              "|v_bx| and rim speed, m/s")
        print(wide.round(3).to_markdown())
        left = meas.groupby("run")["not_replayed"].first()
        print(f"samples outside the streams' common span (before the later start, after the "
              f"last call), not replayed: {int(left.sum())} on {int((left > 0).sum())} of "
              f"{len(left)} runs")
        by_setting = meas.groupby("setting")[["v_max", "over_1_5_rim_pct", "held_samples",
                                              "pitch_max"]]
        print(by_setting.agg(["mean", "max"]).round(3).to_markdown())
        for name, g in meas.groupby("setting"):
            key = _metric_key(name)
            print(f"{name}: pitch state beyond 0.5 rad on {int((g['pitch_max'] > 0.5).sum())} "
                  f"of {len(g)} runs")
            run.log_metrics({f"online.{key}.v_max_max": float(g["v_max"].max()),
                             f"online.{key}.runs_pitch_over_0_5_rad":
                                 float((g["pitch_max"] > 0.5).sum()),
                             f"online.{key}.over_1_5_rim_pct_mean":
                                 float(g["over_1_5_rim_pct"].mean()),
                             f"online.{key}.held_samples_mean": float(g["held_samples"].mean())})
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--terrains", nargs="+", action=DistinctValues, type=terrain_name,
                        default=["ASPHALT", "GRASS", "SANDY_LOAM", "SNOW", "ICE"])
    parser.add_argument("--scenarios", nargs="+", action=DistinctValues, choices=SCENARIO_NAMES,
                        default=["straight_accel", "orchard", "slope_turn", "random"])
    parser.add_argument("--seeds", nargs="+", type=seed_value, action=DistinctSeeds,
                        default=[0, 1, 2])
    parser.add_argument("--measured-terrains", nargs="*", action=DistinctValues,
                        type=terrain_name, default=[],
                        help="BorealTC terrains to run (default: all)")
    shipped = BATCH_FUSION.filter
    parser.add_argument("--bounds", nargs="+", action=DistinctValues, type=_bound,
                        default=[(shipped.speed_bound_braking_slip, shipped.speed_bound_hold_s)],
                        help="bounds to compare as DEPTH[:HOLD_S], the braking slip's depth "
                             "and the hold, e.g. 0.3:1 0.5:0 (default: the shipped one)")
    parser.add_argument("--skip-measured", action="store_true",
                        help="simulated runs only")
    parser.add_argument("--online", action="store_true",
                        help="only the measured runs, through the closed loop's online "
                             "observer")
    parser.add_argument("--imu", default="full-gyro", choices=IMU_VIEWS,
                        help="--online: what the observer reads of the IMU (its imu view, "
                             "default its default; on a measured run clean is the logged "
                             "ax, ay, wz)")
    parser.add_argument("--cache-dir", default="out/slip_cache")
    args = parser.parse_args()
    require_store()   # a store it cannot use stops it now, not after the work
    if args.measured_terrains:      # a terrain with no run selected none, silently
        held = {run.terrain for run in read_shipped("borealtc") if "imu" in run.streams}
        missing = sorted(set(args.measured_terrains) - held)
        if missing:
            parser.error(f"argument --measured-terrains: no shipped BorealTC run with an IMU "
                         f"on {', '.join(missing)} (they are on {', '.join(sorted(held))})")
    if args.online:
        return online(args)
    import pandas as pd

    with tracked_run("terrain-benchmark", "speed-bound", vars(args)) as run:
        fusions = settings(args.bounds)
        sim = pd.DataFrame(simulated(args.terrains, args.scenarios, args.seeds,
                                     args.cache_dir, fusions))
        table = sim.groupby(["terrain", "scenario", "setting"])[
            ["v_rmse", "v_max_err", "slip_rmse", "held_pct"]].mean().unstack("setting")
        print("simulated Husky runs (mean over seeds; RMSE after 3 s):")
        print(table.round(4).to_markdown())
        slid = sim[sim["slid_off"] & (sim["setting"] == "no bound")]
        print(f"{len(slid)} simulated run(s) slid off (left out of the means below): "
              f"{', '.join(slid['terrain'] + ' ' + slid['scenario']) or '-'}")
        overall = sim[~sim["slid_off"]].groupby("setting")[
            ["v_rmse", "v_max_err", "slip_rmse", "held_pct"]].mean()
        print(overall.round(4).to_markdown())
        for name, r in overall.iterrows():
            key = _metric_key(name)
            run.log_metrics({f"sim.{key}.{c}": float(r[c]) for c in overall.columns})
        if args.skip_measured:
            return 0
        meas = pd.DataFrame(measured(args.measured_terrains, fusions))
        wide = meas.pivot(index="run", columns="setting",
                          values=["v_max", "over_1_5_rim_pct", "held_pct"])
        wide[("rim_max", "")] = meas.groupby("run")["rim_max"].first()
        print("measured BorealTC runs (no truth): largest |v_bx| and rim speed, m/s")
        print(wide.round(3).to_markdown())
        by_setting = meas.groupby("setting")[["v_max", "over_1_5_rim_pct", "held_pct"]]
        print(by_setting.agg(["mean", "max"]).round(3).to_markdown())
        for name, g in meas.groupby("setting"):
            key = _metric_key(name)
            run.log_metrics({f"measured.{key}.v_max_max": float(g["v_max"].max()),
                             f"measured.{key}.over_1_5_rim_pct_mean":
                                 float(g["over_1_5_rim_pct"].mean()),
                             f"measured.{key}.held_pct_mean": float(g["held_pct"].mean())})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
