"""NEES of the fused slip filter on simulated straight runs with truth (issue 10, item 4).

For each terrain and seed, a 40 s ``straight_accel`` Husky run (simulated once, cached under
``out/slip_cache``) is filtered by ``terrain estimate``'s batch estimator
(:func:`terrain.slip.estimate.estimate_skid_steer_slip_run`, source ``fused``, the latest
registered ``slip-husky`` model) with the simulation noise model of the physics slip (exact
motor and terrain constants); the NEES of ``slip_1, slip_2`` after 3 s is tested with
:func:`terrain.estimation.consistency.chi2_test` per triplet of seeds and over all runs.
``--settings`` is a JSON list of ``SkidSteerSlipSettings`` overrides of
:data:`terrain.slip.estimate.BATCH_FUSION` (``{}`` = the shipped setting; ``rho`` sets the
error correlation). Figures are printed and logged to MLflow (experiment
``terrain-benchmark``, run ``slip-nees``; per setting ``K`` and terrain ``T`` the metrics
``sK.T.mean_nees`` (mean of the run means), ``mean_nees_sem``, ``n_runs``,
``triplets_inside``, ``n_triplets`` and the pooled test's ``pooled_mean``, ``pooled_lo``,
``pooled_hi``, ... (:meth:`~terrain.estimation.consistency.ChiSquareTest.as_dict`)).
``docs/slip_learning.md`` section 5.

Usage: ``python benchmarks/slip_nees.py --seeds 200-211 [--settings '[{}]']`` (after
``terrain slip-fit``).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from features.slip_outputs import slip_model_outputs
from pipelines.arguments import seed_value
from pipelines.slip_model import resolve_slip_model
from terrain.estimation.consistency import chi2_test, nees
from terrain.slip.dataset import SlipDataSpec, simulated_runs
from terrain.slip.estimate import BATCH_FUSION, estimate_skid_steer_slip_run
from terrain.slip.physics import PhysicsSlipSettings
from terrain.tracking import require_store, tracked_run

TERRAINS = ("ASPHALT", "SANDY_LOAM", "SNOW", "ICE", "GRASS")


def _seeds(spec: str) -> tuple[int, ...]:
    """``--seeds``: seeds and increasing ranges ``A-B``, comma-separated, each seed once.

    Raises
    ------
    argparse.ArgumentTypeError
        A part that is not a seed (:func:`pipelines.arguments.seed_value`) or a range of
        them, a range running backwards, or a seed given twice.
    """
    out: list[int] = []
    for part in spec.split(","):
        lo, _, hi = part.strip().partition("-")
        try:
            first, last = seed_value(lo), seed_value(hi or lo)
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentTypeError(f"{part!r} is not a seed or a range A-B of "
                                             f"seeds: {exc}") from None
        if last < first:
            raise argparse.ArgumentTypeError(f"the range {part!r} runs backwards")
        out += range(first, last + 1)
    twice = sorted({s for s in out if out.count(s) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"seed(s) {twice} given twice in {spec!r}")
    return tuple(out)


def _fusion(override: dict):
    """(the override without ``rho``, rho, the fusion settings) of one ``--settings`` item."""
    cfg = dict(override)
    rho = cfg.pop("rho", BATCH_FUSION.error_correlation)
    return cfg, rho, replace(BATCH_FUSION, error_correlation=rho,
                             filter=replace(BATCH_FUSION.filter, **cfg))


def _settings(text: str) -> list:
    """``--settings``: (override, rho, fusion settings) of every item of the JSON list.

    Raises
    ------
    argparse.ArgumentTypeError
        Not JSON, not a non-empty list of objects, or an item naming no field of the
        filter settings or giving a value they refuse.
    """
    try:
        items = json.loads(text)
    except json.JSONDecodeError as exc:
        raise argparse.ArgumentTypeError(f"not JSON: {exc}") from None
    if not isinstance(items, list) or not items \
            or not all(isinstance(item, dict) for item in items):
        raise argparse.ArgumentTypeError(f"must be a non-empty JSON list of objects such as "
                                         f"'[{{}}]', got {text!r}")
    out = []
    for item in items:
        try:
            out.append(_fusion(item))
        except (TypeError, ValueError) as exc:     # an unknown field; ConfigError
            raise argparse.ArgumentTypeError(f"{json.dumps(item)}: {exc}") from None
    return out


def main() -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="200-211", help="e.g. 200-211 or 100-102,300-305")
    parser.add_argument("--settings", default="[{}]", help="JSON list of filter overrides")
    parser.add_argument("--cache-dir", default="out/slip_cache")
    args = parser.parse_args()
    require_store()   # a store it cannot use stops it now, not after the work
    for option, parse in (("--seeds", _seeds), ("--settings", _settings)):
        try:        # both before the runs are simulated (minutes when not cached)
            parse(getattr(args, option[2:]))
        except argparse.ArgumentTypeError as exc:
            parser.error(f"argument {option}: {exc}")
    model, _ = resolve_slip_model(None)
    runs = simulated_runs(SlipDataSpec(terrains=TERRAINS, scenarios=("straight_accel",),
                                       seeds=_seeds(args.seeds)), args.cache_dir)
    sim = PhysicsSlipSettings(efficiency_rel_std=0.0, hysteresis_rel_std=0.0)
    outputs = [slip_model_outputs(r, model, sim) for r in runs]
    with tracked_run("terrain-benchmark", "slip-nees", {"seeds": args.seeds,
                                                        "settings": args.settings}) as run:
        for k, (cfg, rho, fs) in enumerate(_settings(args.settings)):
            per_run: dict[str, list[np.ndarray]] = {}
            for r, out in zip(runs, outputs):
                tr = r.streams["truth"]
                f = estimate_skid_steer_slip_run(r, "fused", outputs=out, settings=fs).ekf
                i = [f.state_names.index(n) for n in ("slip_1", "slip_2")]
                late = f.t_s > 3.0
                err = f.x[late][:, i] - np.column_stack(
                    [np.interp(f.t_s[late], tr["t_s"], tr[c]) for c in ("slip_1", "slip_2")])
                per_run.setdefault(str(r.terrain), []).append(
                    nees(err, f.P[late][:, i][:, :, i]))
            print(f"setting {k}: {cfg} rho {rho}")
            for t, v in sorted(per_run.items()):
                means = [float(np.nanmean(x)) for x in v]
                trips = [chi2_test(np.concatenate(v[j:j + 3]), 2)
                         for j in range(0, len(v) - 2, 3)]
                inside = sum(tt.inside for tt in trips)
                pooled = chi2_test(np.concatenate(v), 2)
                # every printed figure is logged (the same values)
                m = {"mean_nees": float(np.mean(means)),
                     "mean_nees_sem": float(np.std(means) / np.sqrt(len(means))),
                     "n_runs": float(len(means)), "triplets_inside": float(inside),
                     "n_triplets": float(len(trips)), **pooled.as_dict("pooled")}
                print(f"  {t:11s} mean NEES {m['mean_nees']:.2f} +- {m['mean_nees_sem']:.2f} "
                      f"over {len(means)} runs; triplets inside {inside}/{len(trips)}; all "
                      f"runs pooled {m['pooled_mean']:.2f} [{m['pooled_lo']:.2f}, "
                      f"{m['pooled_hi']:.2f}]", flush=True)
                run.log_metrics({f"s{k}.{t}.{name}": value for name, value in m.items()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
