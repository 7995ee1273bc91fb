"""Benchmark: CPU train time of one fold and inference latency of every terrain classifier.

For each model of :data:`terrain.models.registry.MODELS` (or ``--models``), on BorealTC
(all signals, 2 s windows, the first ``StratifiedGroupKFold(5)`` fold of seed 0, grouped by
run): ``fit_s`` is the wall time of training on the fold's training runs, ``infer_ms`` the
median wall time of ``predict_proba`` on one test window (batch of 1, ``--repeats`` windows,
after one warm-up call), and ``accuracy`` the fold's window accuracy (a sanity check, not the
comparison: use ``terrain compare``). Targets of issue 13: one CNN fold < 120 s on the 2-core
CPU machine; < 1 ms per window for every model. Figures are printed and logged to MLflow
(experiment ``terrain-benchmark``, run ``models``).

The machine is shared, so the run also times references in the same process: the SVM
through scikit-learn's own ``Pipeline.predict_proba`` on the same fitted steps
(``svm_sklearn_infer_ms``, the path before the NumPy fast path of
:class:`terrain.models.svm.SVMPipeline`) and a fixed NumPy workload (``reference_ms``: a
256 x 256 matrix product, median of 200) whose ratio to the model figures
(``{kind}_infer_over_reference``, printed and logged) is comparable between loaded and quiet
runs.

``--minirocket-max-dilations`` sets MiniRocket's dilations per kernel (aeon's default 32, the
library default); its single-window time grows with the number of dilations (see
:mod:`terrain.models.minirocket`).

Run: ``python benchmarks/bench_models.py [--models cnn svm] [--threads 2] [--repeats 50]
[--minirocket-max-dilations 32]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from sklearn.pipeline import Pipeline

from pipelines.arguments import DistinctValues, integer_up_to, positive_integer
from terrain.errors import ConfigError
from terrain.models.cv import fit_with_groups, inference_ms_per_window, iter_splits
from terrain.models.experiment import ExperimentConfig, load_windows
from terrain.models.registry import (MAX_CNN_SEEDS, MODELS, ModelConfig, cnn_seeds_for,
                                     make_model)
from terrain.tracking import require_store, tracked_run


def _reference_ms(repeats: int = 200) -> float:
    """Median wall time of a fixed NumPy workload (256 x 256 float64 matrix product), ms."""
    a = np.random.default_rng(0).standard_normal((256, 256))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        a @ a
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def reference_ratios(figures: dict[str, float], kinds: list[str]) -> dict[str, float]:
    """Each model's single-window inference time over the same run's reference workload.

    Parameters
    ----------
    figures : dict
        ``{kind}_infer_ms`` of every kind and ``reference_ms`` (ms).
    kinds : list of str
        Models timed.

    Returns
    -------
    dict
        ``{kind}_infer_over_reference``: dimensionless, comparable between a loaded and a
        quiet machine (the "/ reference" column of docs/model_comparison.md).
    """
    return {f"{k}_infer_over_reference": figures[f"{k}_infer_ms"] / figures["reference_ms"]
            for k in kinds}


def main() -> int:
    """Time every model on one BorealTC fold; print and log the figures."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", action=DistinctValues,
                        choices=MODELS, default=list(MODELS))
    parser.add_argument("--threads", type=positive_integer, default=2,
                        help="torch threads when training")
    parser.add_argument("--repeats", type=positive_integer, default=50, help="timed single windows")
    parser.add_argument("--minirocket-max-dilations", type=positive_integer,
                        default=ModelConfig().minirocket_max_dilations,
                        help="MiniRocket dilations per kernel at most")
    parser.add_argument("--cnn-seeds", type=integer_up_to(MAX_CNN_SEEDS), default=1,
                        help="networks averaged per CNN (models holding a CNN only)")
    args = parser.parse_args()
    require_store()   # a store it cannot use stops it now, not after the work
    ws = load_windows(ExperimentConfig(dataset="borealtc"))
    y = ws.labels.astype(str)
    train, test = next(iter_splits("grouped", y, ws.groups, 0))
    figures = {}
    skipped: list[str] = []
    with tracked_run("terrain-benchmark", run_name="models",
                     params={"models": ",".join(args.models), "threads": args.threads,
                             "minirocket_max_dilations": args.minirocket_max_dilations,
                             "cnn_seeds": args.cnn_seeds,
                             "n_train": len(train), "n_test": len(test)}) as run:
        for kind in args.models:
            config = ModelConfig(kind=kind, n_threads=args.threads,
                                 minirocket_max_dilations=args.minirocket_max_dilations,
                                 cnn_seeds=cnn_seeds_for(kind, args.cnn_seeds))
            model = make_model(config, ws.channels, ws.rate_hz, "borealtc", 0)
            t0 = time.perf_counter()
            try:
                fit_with_groups(model, ws.X[train], y[train], ws.groups[train])
            except ConfigError as exc:      # an optional dependency (aeon) is missing
                skipped.append(kind)
                print(f"  {kind:16s} skipped: {exc}", flush=True)
                continue
            fit_s = time.perf_counter() - t0
            infer_ms = inference_ms_per_window(model, ws.X[test], args.repeats)
            acc = float((model.predict(ws.X[test]) == y[test]).mean())
            if kind == "svm":
                ref_ms = inference_ms_per_window(Pipeline(model.steps), ws.X[test], args.repeats)
                figures["svm_sklearn_infer_ms"] = ref_ms
                figures["svm_sklearn_over_numpy_path"] = ref_ms / infer_ms
                print(f"  svm via sklearn Pipeline.predict_proba (reference) {ref_ms:7.3f} "
                      f"ms/window: NumPy path {ref_ms / infer_ms:.1f}x faster", flush=True)
            figures.update({f"{kind}_fit_s": fit_s, f"{kind}_infer_ms": infer_ms,
                            f"{kind}_accuracy": acc})
            print(f"  {kind:16s} fit {fit_s:7.1f} s   infer {infer_ms:7.3f} ms/window   "
                  f"fold accuracy {acc:.3f}", flush=True)
        figures["reference_ms"] = _reference_ms()
        ratios = reference_ratios(figures, [k for k in args.models if k not in skipped])
        figures.update(ratios)
        print(f"  reference workload (256x256 matmul) {figures['reference_ms']:.3f} ms; "
              "model inference / reference: " + ", ".join(
                  f"{k[:-len('_infer_over_reference')]} {v:.1f}" for k, v in ratios.items()),
              flush=True)
        run.log_metrics(figures)
    for kind in (k for k in args.models if k not in skipped):
        fit_ok = figures[f"{kind}_fit_s"] < 120 or not kind.startswith("cnn")
        print(f"  target {kind}: fit {'met' if fit_ok else 'MISSED'} (CNN < 120 s), "
              f"inference {'met' if figures[f'{kind}_infer_ms'] < 1 else 'MISSED'} (< 1 ms)")
    print(run.describe())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
