"""Which members does the terrain ensemble gain from: seed-averaged CNNs, a drive-physics member?

Run-grouped ``StratifiedGroupKFold(5)`` on the windows and folds of a ``terrain compare``
cell (``terrain.models.compare.cell_windows``, ``terrain.models.cv.cross_validate``; all
signals, non-overlapping 2 s windows, the same folds as the README tables). Per split seed
every member is cross-validated on the same folds, its out-of-fold class probabilities kept:

* ``svm``: the calibrated SVM on window statistics (``terrain cv``'s model);
* ``cnn`` and ``cnn-spectrogram``: the raw 1-D CNN and the spectrogram CNN, each trained
  from ``--model-seeds`` initialisations, model seed ``split seed + 10 m`` (``m = 0`` is the
  seed ``terrain compare`` uses, so those members reproduce its figures);
* ``wheel-trees``: extremely randomised trees on the drive-physics features of the four
  wheel channels (``features.wheel_physics``: current balances against speed, acceleration
  and yaw rate), with run-balanced training weights: the wheel-only streaming recipe's
  classifier, fitted on the same 2 s windows.

Then it scores equal-weight soft votes of member sets (``terrain.models.compare.soft_vote``;
a seed-averaged CNN, ``cnn x3``, is itself the mean of its initialisations and counts as one
member) with the table metrics of ``terrain compare`` at a decision history of 1 and 10
windows (``score_rows``), mean and spread over the split seeds. The question it answers: is
the ensemble limited by the variance of its CNN members (then averaging initialisations
helps), or by information no member has (then a member built on other physics helps)?

Run: ``python benchmarks/ensemble_members.py [--dataset borealtc] [--seeds 0 1 2]
[--model-seeds 3] [--max-epochs 30] [--out DIR] [--no-mlflow]`` (BorealTC, 3 seeds, 3
initialisations: ~18 min on the 2-core machine).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.pipeline import Pipeline

from features.wheel_physics import WheelPhysicsFeatures
from pipelines.arguments import DistinctSeeds, output_file, positive_integer, seed_value
from terrain.io.shipped import DATASET_SPECS
from terrain.models.compare import Cell, CompareConfig, cell_windows, score_rows, soft_vote
from terrain.models.cv import cross_validate
from terrain.models.registry import ENSEMBLES, ModelConfig, ensemble_member_kinds, make_model
from terrain.serving.recipes import extra_trees, run_balanced_weights
from terrain.tracking import require_store, tracked_run


class RunBalancedWheelTrees(ClassifierMixin, BaseEstimator):
    """Extremely randomised trees on drive-physics features, run-balanced training weights.

    Parameters
    ----------
    channels : tuple of str
        Channel order of the windows (must hold ``vel_l, vel_r, cur_l, cur_r``).
    rate_hz : float
        Window sampling rate, Hz.
    n_trees : int
        Trees.
    random_state : int
        Seed.
    """

    def __init__(self, channels: tuple[str, ...] = (), rate_hz: float = 100.0,
                 n_trees: int = 300, random_state: int = 0) -> None:
        self.channels = channels
        self.rate_hz = rate_hz
        self.n_trees = n_trees
        self.random_state = random_state

    def fit(self, X: np.ndarray, y: np.ndarray, groups: np.ndarray) -> "RunBalancedWheelTrees":
        """Fit on raw windows; every class weighs the same and, inside it, every run.

        Parameters
        ----------
        X : numpy.ndarray
            ``(n_windows, n_channels, n_samples)`` raw windows, SI units.
        y, groups : numpy.ndarray
            ``(n_windows,)`` labels and runs (split units).

        Returns
        -------
        RunBalancedWheelTrees
        """
        self.pipeline_ = Pipeline([
            ("features", WheelPhysicsFeatures(channels=tuple(self.channels),
                                              rate_hz=self.rate_hz)),
            ("classifier", extra_trees(self.n_trees, self.random_state, None))])
        self.pipeline_.fit(X, y, classifier__sample_weight=run_balanced_weights(
            np.asarray(y), np.asarray(groups)))
        self.classes_ = self.pipeline_.classes_
        return self

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        """``(n_windows, n_classes)`` class probabilities of raw windows."""
        return self.pipeline_.predict_proba(X)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """``(n_windows,)`` most probable class of raw windows."""
        return self.classes_[self.predict_proba(X).argmax(axis=1)]


def member_votes(members: dict[str, list[pd.DataFrame]], classes: list[str]
                 ) -> dict[str, pd.DataFrame]:
    """The member sets scored, as out-of-fold prediction frames.

    Parameters
    ----------
    members : dict
        Member name -> prediction frames of its initialisations (one per model seed, same
        folds and windows; ``proba_<CLASS>`` columns). ``wheel-trees`` and ``svm`` have one.
    classes : list of str
        Class order.

    Returns
    -------
    dict
        Vote name -> predictions: every member alone (first initialisation), the CNNs
        averaged over their initialisations (``<cnn> xK``), the ``ensemble`` (SVM +
        spectrogram CNN) and ``ensemble3`` (SVM + raw CNN + spectrogram CNN) votes, both
        also with seed-averaged CNNs and with ``wheel-trees`` added.
    """
    k = len(members["cnn"])
    one = {name: frames[0] for name, frames in members.items()}
    avg = {name: soft_vote(frames, classes) for name, frames in members.items()}
    votes = dict(one)
    for cnn in ("cnn", "cnn-spectrogram"):
        votes[f"{cnn} x{k}"] = avg[cnn]
    sets = {kind: ensemble_member_kinds(ModelConfig(kind)) for kind in ENSEMBLES}
    for name, names in sets.items():
        votes[name] = soft_vote([one[m] for m in names], classes)
        votes[f"{name} + wheel-trees"] = soft_vote([one[m] for m in names]
                                                   + [one["wheel-trees"]], classes)
        votes[f"{name}, CNNs x{k}"] = soft_vote([avg[m] for m in names], classes)
        votes[f"{name}, CNNs x{k} + wheel-trees"] = soft_vote(
            [avg[m] for m in names] + [one["wheel-trees"]], classes)
    return votes


def main() -> int:
    """Cross-validate the members, score the votes, print and log the table."""
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", choices=list(DATASET_SPECS), default="borealtc")
    parser.add_argument("--seeds", type=seed_value, nargs="+", action=DistinctSeeds,
                        default=[0, 1, 2])
    parser.add_argument("--model-seeds", type=positive_integer, default=3,
                        help="initialisations of each CNN (model seed = split seed + 10 m)")
    parser.add_argument("--max-epochs", type=positive_integer, default=30)
    parser.add_argument("--threads", type=positive_integer, default=1, help="torch threads per CNN")
    parser.add_argument("--out", type=output_file, default=None, help="write the table as CSV here")
    parser.add_argument("--no-mlflow", action="store_true")
    args = parser.parse_args()
    if not args.no_mlflow:   # a store it cannot use stops it now, not after the work
        require_store()
    compare = CompareConfig()
    rows, fit_s = [], {}
    for seed in args.seeds:
        ws, labels, groups = cell_windows(Cell("svm", "all", 2.0, args.dataset, seed),
                                          compare.single_run_blocks)[:3]
        factories = {
            "svm": [lambda s: make_model(ModelConfig("svm"), ws.channels, ws.rate_hz,
                                         args.dataset, s)],
            "wheel-trees": [lambda s: RunBalancedWheelTrees(tuple(ws.channels), ws.rate_hz,
                                                            random_state=s)]}
        for kind in ("cnn", "cnn-spectrogram"):
            config = ModelConfig(kind, max_epochs=args.max_epochs, n_threads=args.threads)
            factories[kind] = [
                (lambda s, m=m, config=config: make_model(config, ws.channels, ws.rate_hz,
                                                          args.dataset, s + 10 * m))
                for m in range(args.model_seeds)]
        members, classes = {}, None
        for name, makers in factories.items():
            members[name] = []
            for make in makers:
                t0 = time.perf_counter()
                report = cross_validate(make, ws.X, labels, groups, ws.run_ids, ws.t_start_s,
                                        ws.t_end_s, "grouped", (seed,), compare.n_splits)
                fit_s.setdefault(name, []).append((time.perf_counter() - t0)
                                                  / compare.n_splits)
                classes = report.classes
                members[name].append(report.predictions)
            print(f"seed {seed}: {name} x{len(makers)} done", flush=True)
        for vote, pred in member_votes(members, classes).items():
            rows += score_rows(pred, classes, (1, 10), {"vote": vote, "seed": seed})
    scores = pd.DataFrame(rows)
    metrics = ["accuracy", "macro_f1"]
    table = (scores.groupby(["history", "vote"], sort=False)[metrics].agg(["mean", "std"])
             .round(4))
    table.columns = [f"{m}_{s}" for m, s in table.columns]
    table = table.reset_index()
    pd.set_option("display.width", 160)
    print(f"{args.dataset}, run-grouped StratifiedGroupKFold(5), seeds {args.seeds}, CNNs "
          f"x{args.model_seeds} initialisations; fit s per fold: "
          + ", ".join(f"{k} {np.mean(v):.1f}" for k, v in fit_s.items()))
    print(table.to_string(index=False))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(args.out, index=False)
    if not args.no_mlflow:
        params = {"dataset": args.dataset, "seeds": ",".join(map(str, args.seeds)),
                  "model_seeds": args.model_seeds, "max_epochs": args.max_epochs,
                  "window_s": 2.0, "signals": "all", "protocol": "grouped"}
        with tracked_run("terrain-benchmark", run_name="ensemble-members",
                         params=params) as run:
            run.log_metrics({f"{r.vote}__k{r.history}__accuracy".replace(" ", "_")
                             .replace(",", "").replace("+", "plus"): r.accuracy_mean
                             for r in table.itertuples()})
            run.log_table(table, "ensemble_members.csv")
            run.log_table(scores, "ensemble_members_seeds.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
