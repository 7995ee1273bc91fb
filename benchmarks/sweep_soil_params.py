"""Sweep physics-v2 soil parameters on training runs; score them on held-out runs.

Issue 14 allows parameters of the lateral wheel-soil model to be chosen on measured runs
only inside the literature ranges and only on *training* runs. This script fixes the split
(per terrain, runs in run-id order: positions 0, 2, 4, ... train, 1, 3, 5, ... held out),
replays every run once with physics v1 (the reference clock of
:func:`terrain.audit.physics.per_run_errors`) and, for each candidate
:class:`terrain.terramechanics.lateral.SoilParams` (overrides of the shipped entry), with
physics v2; it prints the yaw-rate and current RMSE of both versions on the training and the
held-out runs, and the chi of a simulated spin and orchard headland turn (Husky, seed 1; the
same manoeuvres as docs/physics_v2.md). Nothing is written to the repository.

Run::

    python benchmarks/sweep_soil_params.py --terrain SANDY_LOAM \\
        --variants '[{}, {"lateral_shear_modulus_m": 0.01}]'
    python benchmarks/sweep_soil_params.py --terrain ASPHALT,FLOORING,ICE \\
        --side-force-factors 0.5 0.6 0.7 0.8 1.0

``--friction-factors 1 2 3`` with ``--terrain ICE`` sweeps instead the factor on that surface's
catalogue friction for the Husky tyre (``CombinedSlipParams.friction_scale``), same table and
criterion. The second form sweeps the side-force factor of the Husky's combined-slip tyre law on
rigid surfaces (:data:`terrain.sim.forces.COMBINED_SLIP`) over the listed terrains at once: per
terrain and pooled over them (samples of all runs together), training and held-out RMSE of
yaw rate and current, and the criterion the shipped value was chosen by, the sum of the
pooled *training* yaw-rate and current RMSE ratios to v1.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from types import MappingProxyType

import numpy as np

import terrain.sim.dynamics as dynamics
from pipelines.arguments import DistinctValues, output_file, positive_number
from terrain.audit.frames import MANOEUVRES, prepare_frame
from terrain.audit.physics import (TUNED_TERRAINS, PhysicsComparisonSettings, _errors, _on,
                                   alternate_split, gain_table, per_run_errors)
from terrain.audit.replay import ReplaySettings, replay_run
from terrain.io.shipped import load_dataset
from terrain.sim import SimConfig
from terrain.sim.simulate import simulate_with_physics
from terrain.terramechanics.lateral import SOILS
from terrain.vehicles import HUSKY
from terrain.vehicles.icr import icr_expansion_factor
from terrain.vehicles.skid_steer import skid_steer_forward

SCOPES = {"moving": None, "curve": "curve", "spin": "spin"}


def rmse(errs, sig, scope):
    """Pooled RMSE of one signal within a manoeuvre scope over runs' error dicts.

    Parameters
    ----------
    errs : list of dict
        Per run, :func:`terrain.audit.physics._errors` (signal -> squared errors, manoeuvre).
    sig : str
        Signal (``wz``, ``cur``, ...).
    scope : str or None
        Manoeuvre name, or None for every moving sample.

    Returns
    -------
    float
        RMSE in the signal's unit (NaN without samples).
    """
    s, n = 0.0, 0
    for e in errs:
        if sig not in e:
            continue
        sq, man = e[sig]
        keep = man != MANOEUVRES.index("stop") if scope is None else man == MANOEUVRES.index(
            scope)
        s += float(np.sum(sq[keep]))
        n += int(np.count_nonzero(keep))
    return np.sqrt(s / n) if n else np.nan


def sim_chi(terrain, scenario, duration):
    """chi of a simulated Husky manoeuvre with physics v2 (docs/physics_v2.md, chi table).

    Parameters
    ----------
    terrain : str
        Catalogue terrain.
    scenario : str
        ``spin`` or ``orchard`` (headland turns).
    duration : float
        Simulated time, s.

    Returns
    -------
    float
        Least-squares chi of the yaw rate on ``(v_R - v_L) / B`` where ``|x| > 0.1 rad/s``.
    """
    sim = simulate_with_physics(SimConfig(vehicle="husky", terrains=(terrain,),
                                          scenario=scenario, duration_s=duration, seed=1,
                                          physics="v2"))
    ph = sim.physics
    v = ph.omega * HUSKY.wheel_radius_m        # motor 0 the left side, 1 the right
    _, x = skid_steer_forward(v[:, 0], v[:, 1], HUSKY.track_m)    # seed 000 eq. 2
    m = np.abs(x) > 0.1
    return icr_expansion_factor(ph.twist[m, 2], x[m])


def per_run_chi(terrain: str, dataset: str = "borealtc") -> int:
    """Per run and manoeuvre: chi of the measured yaw rate and of both replays, currents.

    Parameters
    ----------
    terrain : str
        Terrain of ``dataset``.
    dataset : str
        Shipped dataset (``borealtc`` or ``vulpi``).

    Returns
    -------
    int
        0 (the table is printed).
    """
    for r in sorted((r for r in load_dataset(dataset) if r.terrain == terrain),
                    key=lambda r: r.run_id):
        f = prepare_frame(r, replay_run(r, ReplaySettings(physics="v1")))
        rep = replay_run(r, ReplaySettings(physics="v2"))
        wz2 = _on(f, rep.yaw_rate)
        cur2 = np.column_stack([_on(f, rep.cur[:, 0]), _on(f, rep.cur[:, 1])])
        for scope in ("curve", "spin"):
            m = (f.score_imu & np.isfinite(f.wz) & (f.manoeuvre == MANOEUVRES.index(scope))
                 & (np.abs(f.commanded_yaw_rate) > 0.1))
            if m.sum() < 20:
                continue
            x = f.commanded_yaw_rate[m]
            print(f"{r.run_id} {scope}: n {m.sum()}, |x| {np.mean(np.abs(x)):.2f} rad/s, chi "
                  f"measured {icr_expansion_factor(f.wz[m], x):.3g} v1 "
                  f"{icr_expansion_factor(f.sim_wz[m], x):.3g} v2 "
                  f"{icr_expansion_factor(wz2[m], x):.3g}; current measured "
                  f"{f.cur[m].mean():.1f} v1 {f.sim_cur[m].mean():.1f} v2 {cur2[m].mean():.1f} A")
    return 0


def heldout_table(path: str, dataset: str = "borealtc") -> int:
    """Gain of v2 over v1 on the held-out runs only (see ``--heldout-table``).

    Parameters
    ----------
    path : str
        CSV written with :func:`terrain.audit.physics.gain_table`'s columns.
    dataset : str
        Shipped dataset (``borealtc`` or ``vulpi``).

    Returns
    -------
    int
        0.
    """
    runs = load_dataset(dataset)
    held = []
    for terrain in sorted({r.terrain for r in runs}):
        group = [r for r in runs if r.terrain == terrain]
        held += alternate_split(group)[1] if terrain in TUNED_TERRAINS else group
    settings = PhysicsComparisonSettings()
    per_run, _ = per_run_errors(held, settings)
    table = gain_table(per_run, settings)
    table.to_csv(path, index=False)
    keep = table.signal.isin(["wz", "cur"]) & table.scope.isin(["moving", "curve", "spin"])
    print(table[keep].round(4).to_string(index=False))
    return 0


def _v2_errors(runs, refs, settings):
    """Per run, the error dicts of a v2 replay on the v1 reference clock."""
    out = []
    for r in runs:
        ref = refs[r.run_id]
        rep = replay_run(r, replace(settings, physics="v2"))
        new = replace(ref, sim_wz=_on(ref, rep.yaw_rate), sim_ax=_on(ref, rep.ax),
                      sim_ay=_on(ref, rep.ay), sim_vx=_on(ref, rep.v_x),
                      sim_cur=np.column_stack([_on(ref, rep.cur[:, 0]),
                                               _on(ref, rep.cur[:, 1])]))
        out.append(_errors(ref, new))
    return out


def sweep_side_force(terrains: list[str], factors: list[float], chi: bool = True,
                     friction: bool = False) -> int:
    """Sweep the Husky tyre's side-force factor, or its friction factor, over rigid terrains.

    Parameters
    ----------
    terrains : list of str
        BorealTC rigid terrains, each split into training and held-out runs by
        :func:`~terrain.audit.physics.alternate_split`.
    factors : list of float
        Side-force factors to replay with (``k_S`` in (0, 1]); with ``friction``, factors on
        the catalogue friction of every terrain in ``terrains``
        (``CombinedSlipParams.friction_scale``), the shipped ``k_S`` kept.
    chi : bool
        Also print the chi of a simulated spin and headland turn per terrain.
    friction : bool
        Sweep the friction factor instead of ``k_S``.

    Returns
    -------
    int
        0 (the table is printed).
    """
    settings = ReplaySettings()
    data = load_dataset("borealtc")
    parts, refs = {}, {}
    for terrain in terrains:
        runs = [r for r in data if r.terrain == terrain]
        parts[terrain] = dict(zip(("train", "held"), alternate_split(runs)))
        print(f"{terrain} training:", [r.run_id.split("/")[-1] for r in parts[terrain]["train"]],
              "held out:", [r.run_id.split("/")[-1] for r in parts[terrain]["held"]])
        refs.update({r.run_id: prepare_frame(r, replay_run(r, replace(settings, physics="v1")))
                     for r in runs})
    base = {(t, k): [_errors(refs[r.run_id], refs[r.run_id]) for r in parts[t][k]]
            for t in terrains for k in ("train", "held")}
    cols = [f"{s}_{sc}" for s in ("wz", "cur") for sc in SCOPES]

    def row(errs, label, ref=None):
        pooled = {k: sum((errs[(t, k)] for t in terrains), []) for k in ("train", "held")}
        cells = [rmse(pooled[k], s, SCOPES[sc]) for k in ("train", "held") for s in ("wz", "cur")
                 for sc in SCOPES]
        line = f"{label} | all | " + " | ".join(f"{c:.4g}" for c in cells)
        if ref is not None:
            crit = sum(rmse(pooled["train"], s, None) / rmse(ref["train"], s, None)
                       for s in ("wz", "cur"))
            line += f" | criterion {crit:.4f}"
        print(line, flush=True)
        for t in terrains:
            print(f"{label} | {t} | " + " | ".join(
                f"{rmse(errs[(t, k)], s, SCOPES[sc]):.4g}" for k in ("train", "held")
                for s in ("wz", "cur") for sc in SCOPES), flush=True)
        return pooled

    print("k_S | terrain | " + " | ".join(f"{k}:{c}" for k in ("train", "held") for c in cols))
    ref = row(base, "v1")
    original = dynamics.COMBINED_SLIP
    try:
        for k_s in factors:
            scale = {**original["husky"].friction_scale, **{t: k_s for t in terrains}}
            tyre = (replace(original["husky"], friction_scale=MappingProxyType(scale))
                    if friction else replace(original["husky"], side_force_factor=k_s))
            dynamics.COMBINED_SLIP = MappingProxyType({**original, "husky": tyre})
            errs = {(t, k): _v2_errors(parts[t][k], refs, settings)
                    for t in terrains for k in ("train", "held")}
            row(errs, f"{k_s:g}", ref)
            if chi:
                for t in terrains:
                    print(f"{k_s:g} | {t} | chi spin {sim_chi(t, 'spin', 32.0):.3g} headland "
                          f"{sim_chi(t, 'orchard', 100.0):.3g}", flush=True)
    finally:
        dynamics.COMBINED_SLIP = original
    return 0


def _variants(ap: argparse.ArgumentParser, text: str, start: str | None, terrain: str
              ) -> list[dict]:
    """``--variants``: the JSON list of SoilParams overrides of ``start``'s soil, each
    checked before any replay (a usage error otherwise)."""
    try:
        variants = json.loads(text)
    except json.JSONDecodeError as exc:
        ap.error(f"argument --variants: not JSON: {exc}")
    if not isinstance(variants, list) or not variants \
            or not all(isinstance(v, dict) for v in variants):
        ap.error(f"argument --variants: must be a non-empty JSON list of objects such as "
                 f"'[{{}}]', got {text!r}")
    if start not in SOILS:
        if any(variants):       # nothing to override: every variant would be the same run
            ap.error(f"argument --variants: {terrain} has no SOILS entry to override; give "
                     f"--base-soil, one of {', '.join(SOILS)}")
        return variants
    for var in variants:
        try:
            replace(SOILS[start], **var)
        except (TypeError, ValueError) as exc:      # an unknown field; ConfigError
            ap.error(f"argument --variants: {json.dumps(var)}: {exc}")
    return variants


def main() -> int:
    """Run the sweep; returns 0."""
    ap = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    ap.add_argument("--terrain", required=True)
    ap.add_argument("--dataset", default="borealtc", choices=["borealtc", "vulpi"],
                    help="shipped dataset of the --terrain runs (soil sweeps, --per-run-chi "
                         "and --heldout-table)")
    ap.add_argument("--replay-input-lowpass-hz", type=positive_number, default=None, metavar="HZ",
                    help="soil sweep with the replay's wheel-speed input low-passed at HZ "
                         "(ReplaySettings.input_cutoff_hz; default: as recorded)")
    ap.add_argument("--base-soil", metavar="TERRAIN",
                    help="soil sweep of a terrain without a SOILS entry: start every variant "
                         "from this terrain's SoilParams")
    ap.add_argument("--variants", default="[{}]", help="JSON list of SoilParams overrides")
    ap.add_argument("--no-chi", action="store_true")
    ap.add_argument("--side-force-factors", type=positive_number, nargs="+", action=DistinctValues,
                    metavar="K",
                    help="instead of a soil sweep: the Husky tyre's side-force factor of the "
                         "rigid-surface combined-slip law, over the comma-separated --terrain "
                         "list (module docstring)")
    ap.add_argument("--friction-factors", type=positive_number, nargs="+", action=DistinctValues,
                    metavar="F",
                    help="instead of a soil sweep: factors on the catalogue friction of the "
                         "Husky tyre on the --terrain list (rigid; friction_scale of "
                         "terrain.sim.forces.COMBINED_SLIP), the shipped k_S kept")
    ap.add_argument("--heldout-table", type=output_file, metavar="CSV",
                    help="instead of a sweep: v2 (shipped parameters) against v1 on the runs no "
                         "parameter was chosen on (the held-out half of the TUNED_TERRAINS, "
                         "every run of the others), the gain table of terrain.audit.physics "
                         "written to CSV")
    ap.add_argument("--per-run-chi", action="store_true",
                    help="instead of a sweep: per run of --terrain and manoeuvre (curve, spin), "
                         "the chi of the measured gyro, the v1 and the v2 replay and the mean "
                         "measured and replayed currents")
    args = ap.parse_args()
    if args.side_force_factors:
        return sweep_side_force(args.terrain.split(","), args.side_force_factors,
                                not args.no_chi)
    if args.friction_factors:
        return sweep_side_force(args.terrain.split(","), args.friction_factors,
                                not args.no_chi, friction=True)
    if args.per_run_chi:
        return per_run_chi(args.terrain, args.dataset)
    if args.heldout_table:
        return heldout_table(args.heldout_table, args.dataset)
    # the soil every variant starts from: the terrain's own entry, else --base-soil's
    start = args.terrain if args.terrain in SOILS else args.base_soil
    variants = _variants(ap, args.variants, start, args.terrain)
    runs = [r for r in load_dataset(args.dataset) if r.terrain == args.terrain]
    if not runs:
        ap.error(f"--terrain {args.terrain}: {args.dataset} has no run of it (--dataset)")
    train, held = alternate_split(runs)
    print("training:", [r.run_id.split("/")[-1] for r in train])
    print("held out:", [r.run_id.split("/")[-1] for r in held])
    settings = ReplaySettings(input_cutoff_hz=args.replay_input_lowpass_hz)
    refs = {r.run_id: prepare_frame(r, replay_run(r, replace(settings, physics="v1")))
            for r in runs}
    base = {k: [_errors(refs[r.run_id], refs[r.run_id]) for r in rs]
            for k, rs in (("train", train), ("held", held))}
    original = dynamics.SOILS
    cols = [f"{s}_{sc}" for s in ("wz", "cur") for sc in SCOPES]
    print("variant | " + " | ".join(f"{k}:{c}" for k in ("train", "held") for c in cols)
          + " | chi spin | chi headland")
    print("v1 | " + " | ".join(f"{rmse(base[k], s, SCOPES[sc]):.4g}" for k in ("train", "held")
                               for s in ("wz", "cur") for sc in SCOPES))
    try:
        for var in variants:
            if start in SOILS:
                dynamics.SOILS = MappingProxyType({**SOILS,
                                                   args.terrain: replace(SOILS[start], **var)})
            errs = {k: _v2_errors(rs, refs, settings)
                    for k, rs in (("train", train), ("held", held))}
            chi = ("", "") if args.no_chi else (
                f"{sim_chi(args.terrain, 'spin', 32.0):.3g}",
                f"{sim_chi(args.terrain, 'orchard', 100.0):.3g}")
            print(f"{json.dumps(var)} | " + " | ".join(
                f"{rmse(errs[k], s, SCOPES[sc]):.4g}" for k in ("train", "held")
                for s in ("wz", "cur") for sc in SCOPES) + f" | {chi[0]} | {chi[1]}",
                flush=True)
    finally:
        dynamics.SOILS = original
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
