"""A held-out concatenated stream as the robot would live it: true terrain, the classifier's
raw decision, the smoothed decision and the slip target it sends to traction control.

One fold of the held-out stream protocol of ``terrain stream-eval --part streams``
(:func:`terrain.serving.evaluation.held_out_folds`: the model is fitted on 4/5 of the
BorealTC runs, the held-out fifth is strung into one stream, terrain switching every
30-120 s) is replayed sample by sample through the streaming service twice per recipe: with
the forward filter off (the raw window decisions) and with the service's default smoothing
(:class:`terrain.serving.smoothing.SmoothingConfig`). The slip target is the one the
service emits with the default desired-slip table (:class:`terrain.serving.targets.TableTargets`,
the provider of ``terrain stream`` and of the served model). One panel pair per recipe: the
terrain track (truth as a band, raw decisions as dots, smoothed decision as a line) and the
traction slip target. Accuracies and switching delays are those of
:func:`terrain.serving.evaluation.score_stream`, so they are the stream-eval figures of this
fold. The figure is written to ``--out`` and logged to MLflow (experiment
``terrain-benchmark``, run ``stream-figure``) with the scores.

Run: ``python benchmarks/stream_figure.py [--seed 0] [--fold 0] [--kinds all-dense wheels]
--out docs/streaming_example.png`` (a few minutes for the default recipes).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from pipelines.arguments import DistinctValues, integer_in, output_file, seed_value
from terrain.io.shipped import load_dataset
from terrain.serving.evaluation import (held_out_folds, raw_decisions, recipe_stream_names,
                                        score_stream, truth_at)
from terrain.serving.recipes import DEFAULT_RECIPES, RECIPES, fit_stream_model
from terrain.serving.replay import replay_run
from terrain.serving.service import StreamConfig, StreamService
from terrain.serving.smoothing import SmoothingConfig
from terrain.serving.targets import TableTargets
from terrain.tracking import require_store, tracked_run

HOP_S = 0.5


def replay(kind: str, seed: int, fold: int, runs) -> dict:
    """Fit ``kind`` on the fold's training runs and replay its held-out stream.

    Parameters
    ----------
    kind : str
        Recipe name (:data:`terrain.serving.recipes.RECIPES`).
    seed : int
        Seed of the folds, the stream and the classifier.
    fold : int
        Fold of the held-out stream protocol.
    runs : sequence of Run
        The BorealTC runs.

    Returns
    -------
    dict
        ``t_s`` (decision times, s), ``classes``, ``truth``, ``raw`` and ``smoothed``
        (decided terrain names), ``target_slip_traction`` (SAE slip), ``segments`` and the
        two :class:`~terrain.serving.evaluation.StreamScore`.
    """
    recipe = RECIPES[kind]
    need = recipe_stream_names(recipe)
    folds = held_out_folds(runs, need, seed)
    _, train, stream, segments = next(f for f in folds if f[0] == fold)
    model = fit_stream_model(recipe, train, seed)
    t_raw, proba = raw_decisions(model, stream, HOP_S)
    names = np.array(model.classes, dtype=object)
    raw = np.where(np.isnan(proba).any(axis=1), None,
                   names[np.nan_to_num(proba, nan=0.0).argmax(axis=1)])
    svc = StreamService(model, TableTargets(model.classes),
                        StreamConfig(hop_s=HOP_S, smoothing=SmoothingConfig()))
    decisions = replay_run(svc, stream)
    t = np.array([d.t_s for d in decisions])
    smoothed = np.array([d.terrain for d in decisions], dtype=object)
    return {"t_s": t, "t_raw_s": t_raw, "classes": list(model.classes),
            "truth": truth_at(segments, t), "raw": raw, "smoothed": smoothed,
            "target_slip_traction": np.array([d.target_slip_traction for d in decisions]),
            "segments": segments,
            "score_raw": score_stream(segments, t_raw, raw, recipe.window_s),
            "score_smoothed": score_stream(segments, t, smoothed, recipe.window_s)}


def plot(results: dict, path: Path) -> None:
    """Write the figure: per recipe a terrain track panel and a slip-target panel.

    Parameters
    ----------
    results : dict
        Recipe name -> :func:`replay` result.
    path : pathlib.Path
        PNG file to write.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    classes = sorted({c for r in results.values() for c in r["classes"]})
    row = {c: i for i, c in enumerate(classes)}
    fig, axes = plt.subplots(2 * len(results), 1, figsize=(14, 3.6 * len(results)),
                             sharex=True, gridspec_kw={"height_ratios": [3, 1] * len(results)})
    for k, (kind, r) in enumerate(results.items()):
        track, slip = axes[2 * k], axes[2 * k + 1]
        for seg in r["segments"]:
            lo = seg.t_from_s + seg.t_offset_s
            track.add_patch(plt.Rectangle((lo, row[seg.terrain] - 0.35), seg.duration_s, 0.7,
                                          color="0.85", lw=0))
        ok = r["raw"] != None  # noqa: E711 (element-wise)
        track.plot(r["t_raw_s"][ok], [row[c] for c in r["raw"][ok]], ".", ms=2.5,
                   color="tab:orange", label="raw window decision")
        ok = r["smoothed"] != None  # noqa: E711
        track.step(r["t_s"][ok], [row[c] for c in r["smoothed"][ok]], where="post",
                   color="tab:blue", lw=1.3, label="smoothed decision (forward filter)")
        track.set_yticks(range(len(classes)), classes)
        track.set_ylim(-0.6, len(classes) - 0.4)
        sr, ss = r["score_raw"], r["score_smoothed"]
        track.set_title(f"{kind}: grey = true terrain; accuracy raw {sr.accuracy:.3f}, "
                        f"smoothed {ss.accuracy:.3f}; median switching delay "
                        f"{ss.median_delay_s:.1f} s ({len(ss.delays_s)} switches)",
                        fontsize=10)
        track.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8,
                     frameon=False)
        slip.plot(r["t_s"], r["target_slip_traction"], color="tab:green", lw=1.0)
        slip.set_ylabel("target slip\n(traction)")
    axes[-1].set_xlabel("stream time, s")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    """Replay one held-out stream per recipe; plot, print and log it."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=seed_value, default=0)
    parser.add_argument("--fold", type=integer_in(0, 4), default=0)
    parser.add_argument("--kinds", nargs="+", action=DistinctValues, choices=list(RECIPES),
                        default=list(DEFAULT_RECIPES.values()))
    parser.add_argument("--out", type=output_file, default=Path("docs/streaming_example.png"))
    args = parser.parse_args()
    require_store()   # a store it cannot use stops it now, not after the work
    runs = load_dataset("borealtc")
    results, t0 = {}, time.perf_counter()
    for kind in args.kinds:
        results[kind] = replay(kind, args.seed, args.fold, runs)
        sr, ss = results[kind]["score_raw"], results[kind]["score_smoothed"]
        print(f"{kind}: seed {args.seed} fold {args.fold}, {ss.n_decisions} decisions, "
              f"accuracy raw {sr.accuracy:.3f} / smoothed {ss.accuracy:.3f} (settled "
              f"{ss.accuracy_settled:.3f}), median switching delay {ss.median_delay_s:.1f} s "
              f"({time.perf_counter() - t0:.0f} s)")
    plot(results, args.out)
    print(f"figure: {args.out}")
    with tracked_run("terrain-benchmark", run_name="stream-figure",
                     params={"seed": args.seed, "fold": args.fold,
                             "kinds": ",".join(args.kinds), "hop_s": HOP_S}) as run:
        for kind, r in results.items():
            run.log_metrics({f"{kind}_accuracy_raw": r["score_raw"].accuracy,
                             f"{kind}_accuracy_smoothed": r["score_smoothed"].accuracy,
                             f"{kind}_median_delay_s": r["score_smoothed"].median_delay_s})
        run.log_artifact(args.out)
    print(run.describe())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
