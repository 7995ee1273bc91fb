"""How the streaming models are trained: recipes, their features and classifiers.

:class:`ModelRecipe` / :data:`RECIPES` say how each streaming model is trained: the
all-signal models are ``terrain train`` ones (window statistics + SVM, or an ensemble of it
with CNNs on the raw windows); the wheel-only one uses the drive-physics features
(:class:`features.wheel_physics.WheelPhysicsFeatures`) with extremely randomised trees.
:data:`DEFAULT_RECIPES` names the default per signal set; :func:`fit_stream_model` fits one
on labelled runs. How the recipes are scored (run-grouped windows, held-out concatenated
streams) is :mod:`terrain.serving.evaluation`.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Sequence

import numpy as np
from sklearn.ensemble import ExtraTreesClassifier
from sklearn.pipeline import Pipeline

from features.transformers import SerialFeatureUnion, WindowFeatures
from features.wheel_physics import WheelPhysicsFeatures
from features.windows import (HUSKY_TRACK_M, SIGNAL_SETS, WindowConfig, make_windows,
                              runs_track_m)
from terrain.errors import ConfigError, config_flags, config_integer
from terrain.models.forest import ForestPipeline
from terrain.models.registry import ENSEMBLES, ModelConfig, make_model
from terrain.models.svm import SVMConfig, SVMPipeline, make_svm
from terrain.models.weighting import run_shares
from terrain.run import Run
from terrain.serving.model import StreamModel, training_steps_s


def wheel_features(channels: tuple[str, ...], rate_hz: float, short_s: float | None = 2.0,
                   track_m: float = HUSKY_TRACK_M) -> SerialFeatureUnion:
    """Statistics + physics features of wheel windows (stateless).

    Parameters
    ----------
    channels : tuple of str
        Window channel order (must hold the four wheel channels).
    rate_hz : float
        Window sampling rate, Hz.
    short_s : float or None
        Recent time scale of the physics features, s.
    track_m : float
        Track width B of the physics features' yaw-rate command ``(v_R - v_L)/B``, m.

    Returns
    -------
    features.transformers.SerialFeatureUnion
        A ``FeatureUnion`` whose single-process ``transform`` skips joblib.
    """
    return SerialFeatureUnion([
        ("stats", WindowFeatures(channels=channels, rate_hz=rate_hz)),
        ("physics", WheelPhysicsFeatures(channels=channels, rate_hz=rate_hz,
                                         short_s=short_s, track_m=track_m))])


#: Trees of an ``extra_trees`` recipe unless it says otherwise.
_DEFAULT_N_TREES = 300
#: Feature sets and classifiers a recipe may name.
FEATURE_SETS = ("stats", "physics", "stats+physics")
CLASSIFIERS = ("svm", "extra_trees") + ENSEMBLES


@dataclass(frozen=True)
class ModelRecipe:
    """How a streaming model is trained.

    Parameters
    ----------
    signals : str
        Signal set of :data:`features.windows.SIGNAL_SETS` (``all``, ``all-no-speed`` or
        ``wheels``).
    window_s : float
        Window (history) length, s.
    rate_hz : float
        Aligned clock rate, Hz.
    train_hop_s : float
        Hop of the training windows, s.
    features : {"stats", "physics", "stats+physics"}
        Window statistics (:class:`~features.transformers.WindowFeatures`), the wheel
        physics features, or both.
    classifier : {"svm", "extra_trees", "ensemble", "ensemble3"}
        The project's SVM (:func:`terrain.models.svm.make_svm`, Platt-calibrated),
        extremely randomised trees (:func:`extra_trees`), or an ensemble model of
        ``terrain train --model`` (:data:`terrain.models.registry.ENSEMBLES`, built by
        :func:`terrain.models.registry.make_model`): ``ensemble``, the equal-weight soft vote
        of that SVM on window statistics and the spectrogram CNN, or ``ensemble3``, the same
        plus the raw 1-D CNN. An ensemble takes the raw windows, so ``features`` must be
        ``"stats"``, the SVM member's.
    n_trees : int
        Trees of ``extra_trees`` (an integer >= 1; another value on another classifier is
        refused, not ignored).
    run_balanced : bool
        Weight the training windows so that every class weighs the same and, inside a
        class, every run weighs the same (:func:`run_balanced_weights`), instead of
        class-balanced windows: one long run (BorealTC ICE/01, 716 of the 3063 wheel windows)
        then does not make its class mean that run. Extra trees, and the ensembles, whose
        every member keeps its own class balancing and weighs the runs of a class the same
        (``ModelConfig.run_balanced``).
    window_ekf : bool
        The model also sees the skid-steer EKF's channels computed from each window's own
        samples (:class:`terrain.models.window_ekf.WindowEKFClassifier`, ``terrain train
        --window-ekf``); ``svm`` and the ensembles on ``all`` signals only.
    spectrogram_noise_std : float
        ``ModelConfig.spectrogram_noise_std`` of an ensemble's spectrogram CNN (its training
        spectra plus a copy perturbed by white noise of this many standard deviations); 0:
        no copy. Ensembles only.
    cnn_seeds : int
        ``ModelConfig.cnn_seeds`` of an ensemble's CNNs: each is the probability average of
        this many independently seeded networks (seed bagging); 1: one network. Ensembles
        only.

    Raises
    ------
    ConfigError
        An unknown signal set, feature set or classifier, ``window_s``, ``rate_hz`` or
        ``train_hop_s`` not a finite number > 0 (:class:`~features.windows.WindowConfig`'s
        checks), ``run_balanced`` or ``window_ekf`` not a boolean (the text ``"False"``
        read as on), ``n_trees`` not an integer >= 1, or a setting the classifier does not
        use (``n_trees``, ``spectrogram_noise_std``, ``cnn_seeds``, ``run_balanced``,
        ``window_ekf``) given to it.
    """

    signals: str
    window_s: float
    rate_hz: float
    train_hop_s: float
    features: str = "stats"
    classifier: str = "svm"
    n_trees: int = _DEFAULT_N_TREES
    run_balanced: bool = False
    window_ekf: bool = False
    spectrogram_noise_std: float = 0.0
    cnn_seeds: int = 1

    def __post_init__(self) -> None:
        if not isinstance(self.signals, str) or self.signals not in SIGNAL_SETS:
            raise ConfigError(f"recipe signals must be one of {tuple(SIGNAL_SETS)}, got "
                              f"{self.signals!r:.60}")
        # the windows' own checks, now rather than at the first fit
        WindowConfig(window_s=self.window_s, hop_s=self.train_hop_s, rate_hz=self.rate_hz)
        config_flags("ModelRecipe", run_balanced=self.run_balanced, window_ekf=self.window_ekf)
        config_integer("n_trees", self.n_trees, 1)
        if self.n_trees != _DEFAULT_N_TREES and self.classifier != "extra_trees":
            raise ConfigError("n_trees sets the trees of an extra_trees recipe only")
        if self.spectrogram_noise_std and self.classifier not in ENSEMBLES:
            raise ConfigError("spectrogram_noise_std perturbs the spectrogram CNN of an "
                              "ensemble recipe only")
        if self.cnn_seeds != 1 and self.classifier not in ENSEMBLES:
            raise ConfigError("cnn_seeds bags the CNNs of an ensemble recipe only")
        if self.features not in FEATURE_SETS or self.classifier not in CLASSIFIERS:
            raise ConfigError(f"recipe features must be one of {FEATURE_SETS} and classifier "
                              f"one of {CLASSIFIERS}")
        if self.classifier in ENSEMBLES and self.features != "stats":
            raise ConfigError("the ensemble recipe uses its SVM member's window statistics: "
                              "features must be 'stats'")
        if self.run_balanced and self.classifier not in ("extra_trees",) + ENSEMBLES:
            raise ConfigError("run_balanced weights are implemented for extra_trees and the "
                              "ensembles only")
        if self.window_ekf and (self.classifier == "extra_trees" or self.features != "stats"
                                or self.signals != "all"):
            raise ConfigError("window_ekf recipes use the models of terrain train --window-ekf "
                              "(svm or an ensemble, window statistics, all signals)")


#: all signals: the ``terrain train --model svm --signals all --train-hop-s 2`` model (2 s at
#: the BorealTC IMU rate);
#: all-ensemble: the same windows, the ``ensemble`` model (SVM + spectrogram CNN, soft vote);
#: all-ensemble3: the same windows, the ``ensemble3`` model (SVM + raw CNN + spectrogram
#: CNN, soft vote; the BorealTC default of ``terrain train`` until that became ``ensemble`` on
#: ``all-no-speed``); ``all-dense`` and
#: ``all-ensemble-dense``: the SVM and the ensemble fitted on windows cut every 0.5 s
#: (overlapping) from the training runs
#: (as ``terrain cv --train-hop-s 0.5``, docs/streaming.md); ``all-ensemble-dense-window-ekf``:
#: the latter with the EKF channels of each window (``terrain train --window-ekf``);
#: ``all-ensemble-dense-augmented``: ``all-ensemble-dense`` whose spectrogram CNN also trains
#: on a copy of its spectra perturbed by white noise of 0.3 standard deviations
#: (docs/model_comparison.md,
#: "More members", the probe); ``all-dense-no-speed`` and ``all-ensemble-dense-no-speed``:
#: ``all-dense`` and ``all-ensemble-dense`` on the ``all-no-speed`` signals (every channel
#: but the forward wheel speeds, :data:`features.windows.SPEED_CHANNELS`);
#: ``all-ensemble-dense-no-speed-bagged``: the latter with its spectrogram CNN the average of
#: three independently seeded networks (``ModelConfig.cnn_seeds``);
#: ``all-ensemble-dense-no-speed-1s``: ``all-ensemble-dense-no-speed`` on 1 s windows (a
#: window clears a terrain switch 1 s sooner; run-grouped, 1 s windows over ten decisions
#: carried as much as 2 s windows over five, docs/model_comparison_grid.csv);
#: ``all-ensemble-dense-no-speed-1s-bagged``: the latter with three spectrogram CNNs averaged,
#: as ``-bagged`` on 2 s windows; ``all-ensemble-dense-no-speed-1s-hop025``: the 1 s recipe
#: with its training windows cut every 0.25 s, so that they overlap by 75 % as the 2 s
#: recipe's (every 0.5 s) do; ``all-ensemble-dense-no-speed-1s-run-balanced``: the 1 s recipe
#: with every run of a class weighing the same in both members' training (the held-out
#: streams take a stretch of every run once, so they weigh the runs alike; 0.921 on seeds
#: 0 1 2, 0.910 on 3 4 5, docs/streaming.md); wheels: 4 s
#: of history at 10 Hz, physics features, extremely randomised trees (chosen run-grouped,
#: see docs/streaming.md).
RECIPES = MappingProxyType({
    "all": ModelRecipe("all", 2.0, 100.0, 2.0, "stats", "svm"),
    "all-ensemble": ModelRecipe("all", 2.0, 100.0, 2.0, "stats", "ensemble"),
    "all-ensemble3": ModelRecipe("all", 2.0, 100.0, 2.0, "stats", "ensemble3"),
    "all-dense": ModelRecipe("all", 2.0, 100.0, 0.5, "stats", "svm"),
    "all-ensemble-dense": ModelRecipe("all", 2.0, 100.0, 0.5, "stats", "ensemble"),
    "all-ensemble-dense-window-ekf": ModelRecipe("all", 2.0, 100.0, 0.5, "stats", "ensemble",
                                                 window_ekf=True),
    "all-ensemble-dense-augmented": ModelRecipe("all", 2.0, 100.0, 0.5, "stats", "ensemble",
                                                spectrogram_noise_std=0.3),
    "all-dense-no-speed": ModelRecipe("all-no-speed", 2.0, 100.0, 0.5, "stats", "svm"),
    "all-ensemble-dense-no-speed": ModelRecipe("all-no-speed", 2.0, 100.0, 0.5, "stats",
                                               "ensemble"),
    "all-ensemble-dense-no-speed-bagged": ModelRecipe("all-no-speed", 2.0, 100.0, 0.5,
                                                      "stats", "ensemble", cnn_seeds=3),
    "all-ensemble-dense-no-speed-1s": ModelRecipe("all-no-speed", 1.0, 100.0, 0.5, "stats",
                                                  "ensemble"),
    "all-ensemble-dense-no-speed-1s-bagged": ModelRecipe("all-no-speed", 1.0, 100.0, 0.5,
                                                         "stats", "ensemble", cnn_seeds=3),
    "all-ensemble-dense-no-speed-1s-hop025": ModelRecipe("all-no-speed", 1.0, 100.0, 0.25,
                                                         "stats", "ensemble"),
    "all-ensemble-dense-no-speed-1s-run-balanced": ModelRecipe(
        "all-no-speed", 1.0, 100.0, 0.5, "stats", "ensemble", run_balanced=True),
    "wheels": ModelRecipe("wheels", 4.0, 10.0, 2.0, "physics", "extra_trees",
                          run_balanced=True),
})

#: Default streaming recipe per signal set (of ``terrain stream-eval --kinds`` and
#: ``--model-out`` and of ``bench_serving.py --kind``): the most accurate recipe on the
#: held-out concatenated streams whose in-process decision p99 stays under 1 ms
#: (docs/streaming.md). All signals: ``all-dense``, the SVM fitted on windows cut every
#: 0.5 s (more accurate on the streams than ``all``, 0.863 vs 0.852, at about the same
#: decision cost; ``all-ensemble-dense`` is more accurate still but its decision costs two to
#: four times the SVM's, p99 over 1 ms: docs/streaming.md, Latency); wheel-only: ``wheels``.
DEFAULT_RECIPES = MappingProxyType({"all": "all-dense", "wheels": "wheels"})


def extra_trees(n_trees: int = 300, random_state: int = 0,
                class_weight: str | None = "balanced") -> ExtraTreesClassifier:
    """Extremely randomised trees (Geurts et al., Machine Learning 63, 2006).

    Parameters
    ----------
    n_trees : int
        Number of trees.
    random_state : int
        Seed.
    class_weight : {"balanced", None}
        ``balanced``: class-balanced windows; None: the caller passes sample weights
        (:func:`run_balanced_weights`).

    Returns
    -------
    sklearn.ensemble.ExtraTreesClassifier
        ``min_samples_leaf=3``, ``max_features=0.3``.
    """
    return ExtraTreesClassifier(n_trees, min_samples_leaf=3, max_features=0.3,
                                class_weight=class_weight, n_jobs=1,
                                random_state=random_state)


def run_balanced_weights(labels: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Window weights giving every class the same total weight and, inside a class, every
    run the same share (mean weight 1).

    The windows of one run are not independent samples of their terrain: a long run (one
    surface patch, one speed profile) would otherwise dominate its class. ``w = 1 /
    (n_runs(class) n_windows(run))``, rescaled to mean 1.

    Parameters
    ----------
    labels, groups : numpy.ndarray
        ``(n_windows,)`` class and run of each window.

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)`` weights (> 0).

    Raises
    ------
    ShapeError
        ``labels`` and ``groups`` differ in length.
    """
    w = run_shares(labels, groups)     # every class sums to 1, its runs to equal shares
    return w * (w.size / w.sum())


def recipe_features(recipe: ModelRecipe, channels: tuple[str, ...],
                    track_m: float = HUSKY_TRACK_M):
    """Stateless feature transformer of a recipe.

    Parameters
    ----------
    recipe : ModelRecipe
    channels : tuple of str
        Window channel order.
    track_m : float
        Track width B of the wheel physics features, m (the training runs' vehicle's,
        :func:`features.windows.derived_track_m`).

    Returns
    -------
    sklearn transformer
    """
    if recipe.features == "stats":
        return WindowFeatures(channels=channels, rate_hz=recipe.rate_hz)
    if recipe.features == "physics":
        return WheelPhysicsFeatures(channels=channels, rate_hz=recipe.rate_hz, track_m=track_m)
    return wheel_features(channels, recipe.rate_hz, track_m=track_m)


def recipe_classifier(recipe: ModelRecipe, random_state: int = 0):
    """Unfitted classifier (with ``predict_proba``) of a recipe.

    Parameters
    ----------
    recipe : ModelRecipe
    random_state : int
        Seed.

    Returns
    -------
    sklearn estimator
        Taking the output of :func:`recipe_features`.

    Raises
    ------
    ConfigError
        An ensemble recipe, whose estimator takes raw windows (see
        :func:`fit_stream_model`).
    """
    if recipe.classifier == "extra_trees":
        return extra_trees(recipe.n_trees, random_state,
                           None if recipe.run_balanced else "balanced")
    if recipe.classifier in ENSEMBLES:
        raise ConfigError("the ensemble takes raw windows, not window features: use "
                          "fit_stream_model")
    return make_svm(SVMConfig(probability=True), random_state)


def fit_stream_model(recipe: ModelRecipe, runs: Sequence[Run], seed: int = 0) -> StreamModel:
    """Fit a streaming model (features + classifier on raw windows) on labelled runs.

    Parameters
    ----------
    recipe : ModelRecipe
    runs : sequence of Run
        Training runs (labelled).
    seed : int
        Seed of the classifier.

    Returns
    -------
    StreamModel
        With ``metadata["track_m"]``, the track width (m) its live windows derive the wheel
        yaw rate with, which its wheel physics features use too: the training runs'
        vehicle's (:func:`features.windows.runs_track_m`), and
        ``metadata["channel_steps_s"]``, the training runs' sample step of each channel (s,
        :func:`~terrain.serving.model.training_steps_s`).
    """
    window = WindowConfig(window_s=recipe.window_s, hop_s=recipe.train_hop_s,
                          rate_hz=recipe.rate_hz)
    ws = make_windows(runs, recipe.signals, window)
    labels = ws.labels.astype(str)
    # the live windows derive yaw_rate_wheels with the track the training windows used
    # (make_windows: each run's own vehicle's), and so do the wheel physics features
    track_m = runs_track_m(runs)
    if recipe.classifier in ENSEMBLES or recipe.window_ekf:
        # the `terrain train --model <ensemble> [--window-ekf]` estimator, raw windows in
        pipe = make_model(ModelConfig(kind=recipe.classifier, window_ekf=recipe.window_ekf,
                                      spectrogram_noise_std=recipe.spectrogram_noise_std,
                                      cnn_seeds=recipe.cnn_seeds,
                                      run_balanced=recipe.run_balanced, track_m=track_m),
                          ws.channels, recipe.rate_hz, "borealtc", random_state=seed)
        # the runs reach the members only where they weigh them (fixed vote weights)
        groups = {"groups": np.asarray(ws.run_ids)} if recipe.run_balanced else {}
        pipe.fit(ws.X, labels, **groups)
    else:
        features = ("features", recipe_features(recipe, ws.channels, track_m))
        classifier = recipe_classifier(recipe, seed)
        if isinstance(classifier, Pipeline):
            # the SVM: features -> scaler -> calibrated SVC flattened into the SVMPipeline of
            # `terrain train`, whose predict_proba runs in NumPy (same probabilities)
            pipe = SVMPipeline([features] + classifier.steps)
        else:
            # extra trees: a Pipeline whose predict_proba walks the fitted trees in one
            # compiled loop (terrain.tree_predict, same probabilities as scikit-learn's)
            pipe = ForestPipeline([features, ("classifier", classifier)])
        weights = ({"classifier__sample_weight": run_balanced_weights(
            labels, np.asarray(ws.run_ids))} if recipe.run_balanced else {})
        pipe.fit(ws.X, labels, **weights)
    # the training runs' sample steps judge a live stream's first steps
    steps = training_steps_s(runs, ws.channels)
    return StreamModel(pipe, ws.channels, WindowConfig(window_s=recipe.window_s,
                                                       rate_hz=recipe.rate_hz),
                       tuple(sorted(np.unique(labels).tolist())),
                       metadata=MappingProxyType({"track_m": track_m,
                                                  "channel_steps_s": steps}))
