"""The integrator's step at 100 Hz against the converged model: iterated or linearly implicit.

Each step of :func:`terrain.sim.dynamics.integrate` is implicit Euler solved by Newton's method
(:func:`terrain.sim.dynamics.implicit_euler_step`); until 2026-11-30 it stopped after the
first, linearly implicit, Newton step. For each vehicle, physics version, terrain and
scenario this script simulates the run at the default 100 Hz twice, iterated (the default)
and linearly implicit (the Newton tolerance set to infinity, which is the old step bit for
bit), and once at 1 kHz iterated (the reference: the model converged in its step), and prints
the RMS error of the 100 Hz truth against the reference: forward speed (m/s), yaw rate
(rad/s), slip ratio and torque of motor 1 (N m); the wall time of each 100 Hz run and the
Newton iterations the iterated run took. Two planted cases follow, the defects the
iteration fixed: a Husky ramping at the friction limit of ice from rest (largest slip error
against a 0.5 ms run) and a spin at 0.375 rad/s on packed snow (end yaw rate and slip
against a 1 ms run). Everything is logged to MLflow (experiment ``terrain-benchmark``, run
``implicit-step``).

Run: ``python benchmarks/implicit_step.py [--seconds 20] [--no-mlflow]`` (~2 min).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import time

import numpy as np

import terrain.sim.dynamics as dynamics
from pipelines.arguments import sim_duration_s
from terrain.sim import SimConfig
from terrain.sim.dynamics import integrate
from terrain.sim.simulate import simulate_with_physics
from terrain.terramechanics import get_terrain
from terrain.tracking import require_store, tracked_run
from terrain.vehicles import get_vehicle

#: (vehicle, physics) pairs: the AgriMaRo's v2 is its v1 (no soil or load-transfer model)
CASES = (("husky", "v1"), ("husky", "v2"), ("tracked", "v1"), ("tracked", "v2"),
         ("agrimaro", "v1"))
TERRAINS = ("ASPHALT", "ICE", "SNOW", "SANDY_LOAM")
SCENARIOS = ("random", "spin")
#: what is compared, with the unit printed
SIGNALS = (("v_x", "m/s"), ("yaw_rate", "rad/s"), ("slip_1", ""), ("torque_1", "N m"))


def _signals(p) -> tuple[np.ndarray, ...]:
    return p.twist[:, 0], p.twist[:, 2], p.slip_motor[:, 0], p.torque[:, 0]


@contextlib.contextmanager
def _step(iterated: bool):
    """The integrator's step inside the block: iterated (the default) or, where ``iterated``
    is False, the linearly implicit step alone (the Newton tolerance set to infinity)."""
    saved = dynamics.IMPLICIT_TOLERANCE_PER_S3
    dynamics.IMPLICIT_TOLERANCE_PER_S3 = saved if iterated else math.inf
    try:
        yield
    finally:
        dynamics.IMPLICIT_TOLERANCE_PER_S3 = saved


def _simulate(config: SimConfig, iterated: bool):
    """The physics of ``config`` and the wall time it took, s."""
    with _step(iterated):
        t0 = time.perf_counter()
        phys = simulate_with_physics(config).physics
        return phys, time.perf_counter() - t0


def rms_errors(vehicle: str, physics: str, terrain: str, scenario: str, seconds: float
               ) -> dict[str, float]:
    """RMS errors of the 100 Hz runs against the 1 kHz iterated run, wall times, iterations.

    Parameters
    ----------
    vehicle, physics, terrain, scenario : str
        What is simulated (seed 1).
    seconds : float
        Simulated time, s.

    Returns
    -------
    dict
        ``<step>_<signal>_rmse`` for step ``iterated`` / ``linear`` and each signal of
        :data:`SIGNALS` (their units), ``<step>_wall_s`` (s) and ``iterations`` (Newton
        iterations of the iterated 100 Hz run).
    """
    base = dict(vehicle=vehicle, terrains=(terrain,), scenario=scenario, duration_s=seconds,
                seed=1, physics=physics)
    ref, _ = _simulate(SimConfig(**base, physics_rate_hz=1000.0), True)
    out: dict[str, float] = {}
    for name, iterated in (("iterated", True), ("linear", False)):
        p, wall = _simulate(SimConfig(**base), iterated)
        for (sig, _), got, want in zip(SIGNALS, _signals(p), _signals(ref)):
            err = got - np.interp(p.t_s, ref.t_s, want)
            out[f"{name}_{sig}_rmse"] = float(np.sqrt(np.mean(err ** 2)))
        out[f"{name}_wall_s"] = wall
        if iterated:
            out["iterations"] = float(p.implicit_iterations)
            out["unconverged_steps"] = float(p.implicit_unconverged_steps)
    return out


def ice_ramp_slip_error(iterated: bool) -> float:
    """Largest slip error of a Husky ramping at the friction limit of ice at 100 Hz.

    Rims commanded to ramp at 0.5 m/s^2 from rest to 0.5 m/s over 1 s (v1; the friction
    limit of the catalogue's ice is mu g = 0.49 m/s^2), against the same run at 0.5 ms
    (iterated); ``tests/sim/test_sim_sim24_review.py``.
    """
    veh = get_vehicle("husky")

    def run(dt, it):
        t = np.arange(0.0, 1.0 + 0.5 * dt, dt)
        tw = np.zeros((len(t), 3))
        tw[:, 0] = np.minimum(0.5 * (t + dt), 0.5)
        with _step(it):
            return integrate(veh, veh.contact_geometry(), (get_terrain("ICE"),), np.inf, t,
                             tw, 0.0, 1.0)

    ref, p = run(0.0005, True), run(0.01, iterated)
    return float(np.abs(p.slip_motor[:, 0] - np.interp(p.t_s, ref.t_s,
                                                       ref.slip_motor[:, 0])).max())


def spin_end(rate_rad_s: float, dt: float, iterated: bool) -> tuple[float, float]:
    """Yaw rate (rad/s) and right-side slip after a 5 s spin in place on PACKED_SNOW (v1).

    The command ramps to ``rate_rad_s`` over 0.5 s; ``tests/sim/test_sim_review_sim17.py``.
    """
    veh = get_vehicle("husky")
    t = np.arange(0.0, 5.0 + 0.5 * dt, dt)
    tw = np.column_stack([0 * t, 0 * t, rate_rad_s * np.minimum(t / 0.5, 1.0)])
    with _step(iterated):
        p = integrate(veh, veh.contact_geometry(), (get_terrain("PACKED_SNOW"),), np.inf, t,
                      tw, 0.0, 1.0)
    return float(p.twist[-1, 2]), float(p.slip_motor[-1, 1])


def main() -> int:
    """Print and log the comparison; returns 0."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=sim_duration_s, default=20.0)
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    metrics: dict[str, float] = {}
    head = " | ".join(f"{sig} ({unit or '-'}) linear / iterated" for sig, unit in SIGNALS)
    print(f"vehicle | physics | terrain | scenario | {head} | wall s linear / iterated | "
          f"iterations")
    walls = {"linear": 0.0, "iterated": 0.0}
    for vehicle, physics in CASES:
        for terrain in TERRAINS:
            for scenario in SCENARIOS:
                row = rms_errors(vehicle, physics, terrain, scenario, args.seconds)
                key = f"{vehicle}_{physics}_{terrain}_{scenario}"
                metrics.update({f"{key}_{k}": v for k, v in row.items()})
                for name in walls:
                    walls[name] += row[f"{name}_wall_s"]
                cells = " | ".join(f"{row[f'linear_{sig}_rmse']:.4f} / "
                                   f"{row[f'iterated_{sig}_rmse']:.4f}" for sig, _ in SIGNALS)
                print(f"{vehicle} | {physics} | {terrain} | {scenario} | {cells} | "
                      f"{row['linear_wall_s']:.2f} / {row['iterated_wall_s']:.2f} | "
                      f"{int(row['iterations'])} ({int(row['unconverged_steps'])} "
                      f"unconverged)", flush=True)
    metrics["wall_ratio_iterated_to_linear"] = walls["iterated"] / walls["linear"]
    print(f"wall time of all 100 Hz runs: linear {walls['linear']:.1f} s, iterated "
          f"{walls['iterated']:.1f} s (ratio {metrics['wall_ratio_iterated_to_linear']:.2f})")
    for name, iterated in (("linear", False), ("iterated", True)):
        metrics[f"ice_ramp_{name}_max_slip_error"] = ice_ramp_slip_error(iterated)
        rate, slip = spin_end(0.375, 0.01, iterated)
        metrics[f"spin_0375_{name}_yaw_rate_rad_s"] = rate
        metrics[f"spin_0375_{name}_slip"] = slip
        print(f"{name}: ice ramp, largest slip error against 0.5 ms "
              f"{metrics[f'ice_ramp_{name}_max_slip_error']:.3f}; spin 0.375 rad/s on "
              f"PACKED_SNOW after 5 s: yaw rate {rate:.3f} rad/s, slip {slip:.2f}")
    rate, slip = spin_end(0.375, 0.001, True)
    metrics["spin_0375_1ms_yaw_rate_rad_s"], metrics["spin_0375_1ms_slip"] = rate, slip
    print(f"1 ms reference: spin yaw rate {rate:.3f} rad/s, slip {slip:.2f}")
    if not args.no_mlflow:
        params = {"seconds": args.seconds, "reference_rate_hz": 1000.0, "rate_hz": 100.0,
                  "tolerance_per_s3": dynamics.IMPLICIT_TOLERANCE_PER_S3,
                  "max_iterations": dynamics.IMPLICIT_MAX_ITERATIONS}
        with tracked_run("terrain-benchmark", run_name="implicit-step", params=params) as run:
            run.log_metrics(metrics)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
