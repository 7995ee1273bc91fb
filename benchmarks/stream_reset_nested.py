"""Which smoothing rule, chosen inside the training runs only? The reset and the smoothing grid.

``benchmarks/stream_switch_oracle.py`` scores the reset rule
(``SmoothingConfig(reset_confidence=theta, reset_windows=m)``) on the held-out streams and
picks its parameters on the first seed's streams, so its figure on that seed is optimistic;
the service's default smoothing (forward filter, dwell 10 s, evidence power 0.5) was itself
chosen on held-out streams of an earlier model (docs/streaming.md, "Temporal smoothing").
Here every outer fold of ``terrain stream-eval``'s protocol (same folds over runs, same
seeded held-out streams, :func:`terrain.serving.evaluation.held_out_folds`) chooses its
decision rule from its own training runs: they are split again, run-grouped, into
``--inner-folds`` folds whose held-out runs are strung into inner streams in the same way;
one classifier per inner fold is trained with ``--kind``'s recipe, and the rule with the
best pooled per-decision accuracy on the inner streams is chosen (ties go to the default).
Three candidate sets, each chosen from the same replays (``CANDIDATES``):

* ``reset``: the default filter (``filter``) and the filter with the reset, theta in
  {0.8, 0.9, 0.95}, m in {1, 2, 3} (the grid of ``stream_switch_oracle.py``, fixed before it
  was run);
* ``smoothing``: the smoothing grid of ``terrain stream-eval``
  (:data:`pipelines.stream_eval.SMOOTHINGS`: raw windows, hysteresis, forward filters of
  dwell 5-60 s and evidence power 0.2-1, both), whose ``dwell10_power0.5`` is the default;
* ``all``: both.

The classifier trained on the whole outer training fold then decides on the outer
held-out stream with each set's chosen rule. Nothing of an outer stream takes part in its
choice. The pooled per-decision accuracy, settled accuracy and median switching delay of
the default filter and of each set's nested choice are printed, per seed and pooled, and
logged to MLflow (experiment ``terrain-benchmark``, run ``stream-reset-nested``).

Run: ``python benchmarks/stream_reset_nested.py [--kind all-ensemble-dense-no-speed-1s]
[--seeds 0 1 2] [--no-mlflow]`` (five classifiers per outer fold: 19-25 min per seed with
the three seeds run as three processes side by side on a 2-core machine,
``OMP_NUM_THREADS=1``). Results: docs/streaming.md, "One-second windows" (the reset) and
"Held-out concatenated streams" (the smoothing grid, 2026-11-27).
``--out DIR`` keeps one JSON file per seed, and ``--merge FILE ...`` pools such files
(seeds run as separate processes) without training anything; each seed's outer fold once,
the recipe and number of inner folds those of the files.
"""

from __future__ import annotations

import argparse
import json
import re
import time
from collections.abc import Mapping
from pathlib import Path

import pandas as pd
from tqdm import tqdm

from pipelines.arguments import DistinctSeeds, DistinctValues, integer_in, output_dir, seed_value
from pipelines.stream_eval import SMOOTHINGS
from terrain.io.shipped import load_dataset
from terrain.serving.evaluation import (held_out_folds, pool_scores, raw_decisions,
                                        recipe_stream_names, score_smoothing)
from terrain.serving.recipes import RECIPES, fit_stream_model
from terrain.serving.smoothing import SmoothingConfig
from terrain.tracking import require_store, tracked_run

HOP_S = 0.5
#: the service's default rule (forward filter, dwell 10 s, power 0.5, no reset)
DEFAULT_RULE = "filter"
RESET_RULES = {DEFAULT_RULE: SmoothingConfig(),
               **{f"reset({th}, {m})": SmoothingConfig(reset_confidence=th, reset_windows=m)
                  for th in (0.8, 0.9, 0.95) for m in (1, 2, 3)}}
#: every rule scored; stream-eval's ``dwell10_power0.5`` is the default under its own name
RULES = {**RESET_RULES, **{name: rule for name, rule in SMOOTHINGS.items()
                           if rule != SmoothingConfig()}}
#: the candidate sets a fold chooses among (each includes the default)
CANDIDATES = {"reset": list(RESET_RULES),
              "smoothing": [DEFAULT_RULE] + [name for name in SMOOTHINGS if name in RULES],
              "all": list(RULES)}


def score_rows(folds: list[dict], rule: str) -> list[dict]:
    """Score rows (:meth:`StreamScore.as_row`) of one rule on replayed streams."""
    return [score_smoothing(fold["segments"], fold["t"], fold["proba"], fold["classes"],
                            RULES[rule], HOP_S, fold["window_s"]).as_row() for fold in folds]


def replay(recipe, train, stream, segments, seed: int) -> dict:
    """Train on ``train``, replay ``stream``, keep the raw window probabilities."""
    model = fit_stream_model(recipe, train, seed)
    t, proba = raw_decisions(model, stream, HOP_S)
    return {"t": t, "proba": proba, "segments": segments, "classes": model.classes,
            "window_s": recipe.window_s}


def choose(inner_accuracy: Mapping[str, float], candidates: list[str]) -> str:
    """The candidate with the best inner accuracy; a tie goes to the default rule."""
    return max(candidates, key=lambda r: (inner_accuracy[r], r == DEFAULT_RULE))


def run_seed(runs, recipe, seed: int, inner_folds: int, bar) -> list[dict]:
    """One row per outer fold: every rule's inner accuracy and outer score."""
    need = recipe_stream_names(recipe)
    out = []
    for fold, train, stream, segments in held_out_folds(runs, need, seed):
        inner = [replay(recipe, itrain, istream, isegs, seed) for _f, itrain, istream, isegs
                 in held_out_folds(train, need, seed, n_splits=inner_folds)]
        inner_acc = {rule: pool_scores(pd.DataFrame(score_rows(inner, rule)))["accuracy"]
                     for rule in RULES}
        outer = replay(recipe, train, stream, segments, seed)
        out.append({"seed": seed, "fold": fold, "inner_accuracy": inner_acc,
                    "outer": {rule: score_rows([outer], rule)[0] for rule in RULES}})
        bar.update()
    return out


def _jsonable(obj):
    """JSON form of the score rows' mappings and NumPy scalars."""
    return dict(obj) if isinstance(obj, Mapping) else float(obj)


def report(rows: list[dict]) -> dict[str, float]:
    """Print the pooled scores (all seeds and per seed); return the MLflow metrics.

    For every candidate set the nested arm decides each outer fold with the rule chosen on
    that fold's inner streams; the ``filter`` arm always with the default.
    """
    metrics = {}
    seeds = sorted({r["seed"] for r in rows})
    chosen = {name: [choose(r["inner_accuracy"], cands) for r in rows]
              for name, cands in CANDIDATES.items()}
    arms = {DEFAULT_RULE: [DEFAULT_RULE] * len(rows),
            **{f"nested_{name}": picks for name, picks in chosen.items()}}
    for label, sel in [("all", seeds)] + [(f"seed{s}", [s]) for s in seeds]:
        print(f"seeds {sel}:")
        for arm, picks in arms.items():
            part = [r["outer"][pick] for r, pick in zip(rows, picks) if r["seed"] in sel]
            score = pool_scores(pd.DataFrame(part))
            print(f"  {arm:<17} per decision {score['accuracy']:.4f}  settled "
                  f"{score['accuracy_settled']:.4f}  median delay {score['median_delay_s']:.2f} s")
            for key in ("accuracy", "accuracy_settled", "median_delay_s"):
                metrics[f"{label}_{arm}_{key}"] = score[key]
    for name, picks in chosen.items():
        counts = pd.Series(picks).value_counts()
        print(f"chosen among {name!r} inside the training runs (outer folds): "
              + ", ".join(f"{k} x {v}" for k, v in counts.items()))
        for k, v in counts.items():
            slug = re.sub(r"[^A-Za-z0-9.]+", "_", k).strip("_")
            metrics[f"chosen_{name}_{slug}"] = float(v)
    return metrics


def merged_rows(paths: list[Path]) -> tuple[str, int | None, list[dict]]:
    """Pool the rows of ``--out`` files of earlier runs.

    Parameters
    ----------
    paths : list of pathlib.Path
        JSON files written by ``--out`` (one per seed).

    Returns
    -------
    kind : str
        Their recipe.
    inner_folds : int or None
        Their number of inner folds (None: files written before it was kept).
    rows : list of dict
        Every outer fold's row.

    Raises
    ------
    SystemExit
        The files mix recipes or numbers of inner folds, or two of them hold the same
        seed and outer fold (a rerun beside the first: pooling both would count it twice).
    """
    rows, kinds, inner, where = [], set(), set(), {}
    for path in paths:
        doc = json.loads(Path(path).read_text())
        kinds.add(doc["kind"])
        inner.add(doc.get("inner_folds"))
        for row in doc["rows"]:
            key = (row["seed"], row["fold"])
            if key in where:
                raise SystemExit(f"seed {key[0]} fold {key[1]} is in both {where[key]} and "
                                 f"{path}: pool each seed once")
            where[key] = path
            rows.append(row)
    if len(kinds) != 1:
        raise SystemExit(f"the files mix recipes: {sorted(kinds)}")
    if len(inner) != 1:
        raise SystemExit(f"the files mix numbers of inner folds: "
                         f"{sorted(inner, key=str)}")
    return kinds.pop(), inner.pop(), rows


def main() -> int:
    ap = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0])
    ap.add_argument("--kind", default="all-ensemble-dense-no-speed-1s", choices=list(RECIPES))
    ap.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds, default=[0, 1, 2])
    ap.add_argument("--inner-folds", type=integer_in(2, 100), default=4)
    ap.add_argument("--out", type=output_dir, default=None, help="keep one JSON file per seed here")
    ap.add_argument("--merge", type=Path, nargs="+", action=DistinctValues, default=None,
                    help="pool these JSON files of earlier runs instead of training")
    ap.add_argument("--no-mlflow", action="store_true")
    args = ap.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    start = time.perf_counter()
    if args.merge:
        args.kind, args.inner_folds, rows = merged_rows(args.merge)
    else:
        recipe = RECIPES[args.kind]
        runs = load_dataset("borealtc")
        rows = []
        with tqdm(total=5 * len(args.seeds), desc="outer folds", unit="fold") as bar:
            for seed in args.seeds:
                seed_rows = run_seed(runs, recipe, seed, args.inner_folds, bar)
                rows += seed_rows
                if args.out is not None:
                    args.out.mkdir(parents=True, exist_ok=True)
                    (args.out / f"{args.kind}_seed{seed}.json").write_text(json.dumps(
                        {"kind": args.kind, "inner_folds": args.inner_folds,
                         "rows": seed_rows}, default=_jsonable))
    metrics = report(rows)
    print(f"{time.perf_counter() - start:.0f} s")
    if not args.no_mlflow:
        seeds = ",".join(str(s) for s in sorted({r["seed"] for r in rows}))
        with tracked_run("terrain-benchmark", run_name="stream-reset-nested",
                         params={"kind": args.kind, "seeds": seeds,
                                 "inner_folds": ("not recorded" if args.inner_folds is None
                                                 else args.inner_folds),
                                 "rules": ",".join(RULES)}) as run:
            run.log_metrics(metrics)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
