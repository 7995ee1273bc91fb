"""What the closed loop's estimators lose on the full, vibrating IMU.

The simulated closed loop hands its estimators two views of the same IMU samples
(:mod:`terrain.sim.closed_loop`): ``imu`` without the terrain's vibration band and gravity,
and ``imu_full``, what a robot logs. This script runs the control grid
(:func:`terrain.control.grid.run_grid`, ``DEFAULT_GAINS``, feed-forward on, the run's label
as terrain decision) once per estimator kind and IMU view
(:data:`terrain.control.estimators.ESTIMATORS`): the AgriMaRo's EKF with visual odometry on
the simplified (``ekf-vo``) and the full IMU (``ekf-vo-full-imu``; its accelerometer rows
as block means with their measured noise, ``ekf-vo-full-imu-averaged``; its gyro only,
``ekf-vo-full-gyro``, the default since 2026-11-26), the Husky's fused
estimate on the full IMU's gyro (``fused``, the default), with its accelerometer rows too
(``fused-full-imu``) and on the simplified IMU (``fused-clean-imu``). It prints the slip
RMSE under control (true slip against the set point, controller on) and the peak slip per
terrain and scenario, and their means per kind with the estimate's own speed error and the
slip beyond the enforced limit (:data:`DIRECT`), also over the cells where the robot does
not slide on its own (:data:`SLIDE_FACTOR`), and logs them to MLflow (experiment
``terrain-benchmark``, run ``control-imu-views``). ``docs/control_validation.md``, "The
Husky's observer on the full IMU".

Usage: ``python benchmarks/control_imu_views.py [--kinds ekf-vo ekf-vo-full-imu ...]
[--terrains ...] [--scenarios ...] [--seeds 0 1 2]`` (about 11 min with the defaults on one
core).
"""

from __future__ import annotations

import argparse

import pandas as pd

from pipelines.arguments import DistinctSeeds, DistinctValues, seed_value, terrain_name
from terrain.control.closed_loop import default_gains
from terrain.control.estimators import ESTIMATORS
from terrain.control.grid import compare, run_grid
from terrain.sim import SCENARIO_NAMES
from terrain.tracking import require_store, tracked_run

#: (vehicle, kind) compared by default: every IMU view of the two vehicles' estimators
KINDS = (("agrimaro", "ekf-vo"), ("agrimaro", "ekf-vo-full-imu"),
         ("agrimaro", "ekf-vo-full-imu-averaged"), ("agrimaro", "ekf-vo-full-gyro"),
         ("husky", "fused"),
         ("husky", "fused-full-imu"), ("husky", "fused-clean-imu"))


#: per-run metrics of the estimate itself (controller on): the slip RMSE is scored against
#: the set point of the mode the controller selected from the *estimated* acceleration, so
#: a noisy acceleration estimate raises it even where the controller never acts
DIRECT = ("speed_estimate_rmse_m_s", "slip_excess_rmse")

#: a cell *slides* when the robot's mean speed exceeds this multiple of the largest commanded
#: speed: it moves on its own (ICE slope_turn: down 15 deg ice, whose friction is below
#: tan 15 deg, at about 20 m/s mean speed), so no estimator or controller is being measured
#: there, and the means are also printed over the other (driveable) cells
SLIDE_FACTOR = 2.0


def main() -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--kinds", nargs="+", action=DistinctValues, default=[k for _, k in KINDS],
                        choices=sorted({k for v in ESTIMATORS.values() for k in v}))
    parser.add_argument("--terrains", nargs="+", action=DistinctValues, type=terrain_name,
                        default=["TILES", "GRASS", "UNPLOUGHED", "SANDY_LOAM", "SNOW", "ICE"])
    parser.add_argument("--scenarios", nargs="+", action=DistinctValues, choices=SCENARIO_NAMES,
                        default=["straight_accel", "orchard", "slope_turn"])
    parser.add_argument("--seeds", nargs="+", type=seed_value, action=DistinctSeeds,
                        default=[0, 1, 2])
    args = parser.parse_args()
    require_store()   # a store it cannot use stops it now, not after the work
    vehicle_of = {k: v for v, ks in ESTIMATORS.items() for k in ks}
    with tracked_run("terrain-benchmark", "control-imu-views", vars(args)) as run:
        tables = []
        for kind in args.kinds:
            vehicle = vehicle_of[kind]
            results, _ = run_grid([vehicle], args.terrains, args.scenarios, args.seeds,
                                  {vehicle: default_gains(vehicle, kind)},
                                  estimators={vehicle: kind})
            table = compare(results)[["vehicle", "terrain", "scenario", "slip_rmse_on",
                                      "peak_slip_on"]].assign(kind=kind)
            # what the estimate itself gets wrong, independent of the mode it selects
            on = results[results["controller"] == "traction"]
            direct = on.groupby(["vehicle", "terrain", "scenario"])[
                [*DIRECT, "mean_speed_m_s", "cruise_speed_m_s"]].mean()
            table = table.join(direct, on=["vehicle", "terrain", "scenario"])
            table["slides"] = table["mean_speed_m_s"] > SLIDE_FACTOR * table["cruise_speed_m_s"]
            tables.append(table)
            driveable = table[~table["slides"]]
            run.log_metrics({f"{kind}.{c}_mean{suffix}": float(part[c].mean())
                             for c in ("slip_rmse_on", "peak_slip_on") + DIRECT
                             for suffix, part in (("", table), ("_driveable", driveable))
                             if len(part)})
        both = pd.concat(tables)
        wide = both.pivot_table(index=["vehicle", "terrain", "scenario"], columns="kind",
                                values="slip_rmse_on")
        print("slip RMSE under control (controller on, mean over seeds):")
        print(wide.round(3).to_markdown())
        columns = ["slip_rmse_on", "peak_slip_on", *DIRECT]
        means = both.groupby(["vehicle", "kind"])[columns].mean()
        print(means.round(4).to_markdown())
        slides = both.loc[both["slides"], ["vehicle", "terrain", "scenario"]].drop_duplicates()
        if len(slides):
            print(f"cells where the robot slides (mean speed > {SLIDE_FACTOR:g} x the command):",
                  ", ".join(" ".join(r) for r in slides.itertuples(index=False)))
            print("means over the driveable cells:")
            print(both[~both["slides"]].groupby(["vehicle", "kind"])[columns].mean()
                  .round(4).to_markdown())
        run.log_table(wide.round(4).reset_index(), "slip_rmse_on.csv")
        run.log_table(both.round(5), "per_cell.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
