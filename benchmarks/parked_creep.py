"""A parked Husky on a slope: how far the simulator lets it creep (a known limitation).

The Husky stands facing up a plane inclined by ``--slope-deg`` with its wheels held at
0 rad/s by the speed loop (zero commands) for ``--seconds``; for each terrain and physics
version the script prints the displacement and the mean body speed over the last second,
and logs them to MLflow (experiment ``terrain-benchmark``, run ``parked-creep``). Where the
terrain's friction holds the grade (``mu > tan(slope)``) a real robot stays put; the
simulator's slip-ratio traction law, whose denominator is floored at
:data:`terrain.sim.dynamics.SLIP_SPEED_FLOOR_M_S`, acts as a viscous damper at standstill and
lets it creep (docs/sim_validation.md, "Known limitations"). Where it does not hold (the
catalogue's ice, mu 0.05) the robot slides at ``g (sin - mu cos)``.

Run: ``python benchmarks/parked_creep.py [--seconds 20] [--slope-deg 15] [--terrains
ASPHALT,GRASS,SANDY_LOAM,SNOW,ICE] [--no-mlflow]`` (~5 s).
"""

from __future__ import annotations

import argparse

import numpy as np

from pipelines.arguments import parse_number, sim_duration_s
from terrain.errors import ConfigError
from terrain.sim import parse_terrain_list
from terrain.sim.dynamics import integrate
from terrain.sim.forces import PHYSICS_VERSIONS
from terrain.terramechanics import get_terrain
from terrain.tracking import require_store, tracked_run
from terrain.vehicles import get_vehicle

#: physics step, s (the simulator's default 100 Hz)
STEP_S = 0.01


def parked_speed(terrain: str, physics: str, seconds: float, slope_deg: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Body position and speed of a parked Husky facing up the slope.

    Parameters
    ----------
    terrain : str
        Catalogue terrain name.
    physics : str
        ``v1`` or ``v2``.
    seconds : float
        Simulated time, s.
    slope_deg : float
        Inclination of the plane, degrees (rising along the robot's heading).

    Returns
    -------
    x_m : ndarray, shape (n,)
        Position along the slope (positive uphill), m.
    v_m_s : ndarray, shape (n,)
        Longitudinal body speed, m/s.
    """
    husky = get_vehicle("husky")
    t = np.arange(0.0, seconds, STEP_S)
    p = integrate(husky, husky.contact_geometry(), (get_terrain(terrain),), 1e9, t,
                  np.zeros((len(t), 3)), np.radians(slope_deg), 1.0, physics=physics)
    return p.pose[:, 0], p.twist[:, 0]


def _slope_deg(text: str) -> float:
    """``--slope-deg``: a finite angle in (-90, 90) degrees (negative: facing down)."""
    return parse_number(text, lambda x: -90.0 < x < 90.0, "an angle in (-90, 90) degrees")


def _terrains(text: str) -> tuple[str, ...]:
    """``--terrains``: catalogue names, comma-separated (as ``terrain simulate --terrain``
    reads them: any case, spaces around the commas)."""
    try:
        return tuple(get_terrain(t).name for t in parse_terrain_list(text))
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def main() -> int:
    """Print and log the creep table; returns 0."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=sim_duration_s, default=20.0)
    parser.add_argument("--slope-deg", type=_slope_deg, default=15.0)
    parser.add_argument("--terrains", type=_terrains, default="ASPHALT,GRASS,SANDY_LOAM,SNOW,ICE")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    last = int(round(1.0 / STEP_S))
    metrics = {}
    print("physics | terrain | displacement mm | speed over the last second mm/s")
    for physics in PHYSICS_VERSIONS:
        for terrain in args.terrains:
            x, v = parked_speed(terrain, physics, args.seconds, args.slope_deg)
            disp_mm, speed_mm_s = 1e3 * x[-1], 1e3 * float(np.mean(v[-last:]))
            metrics[f"{physics}_{terrain}_displacement_mm"] = disp_mm
            metrics[f"{physics}_{terrain}_speed_mm_s"] = speed_mm_s
            print(f"{physics} | {terrain} | {disp_mm:.1f} | {speed_mm_s:.3f}", flush=True)
    if not args.no_mlflow:
        params = {"seconds": args.seconds, "slope_deg": args.slope_deg,
                  "terrains": ",".join(args.terrains), "vehicle": "husky"}
        with tracked_run("terrain-benchmark", run_name="parked-creep", params=params) as run:
            run.log_metrics(metrics)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
