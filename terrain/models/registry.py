"""The terrain classifiers by name: one factory for CV, training, comparison and serving.

Every model takes raw windows ``(n_windows, n_channels, n_samples)`` and gives class
probabilities, so each one is served by :mod:`terrain.serving` unchanged:

* ``svm``: window features -> scaler -> RBF SVC with Platt-scaled probabilities
  (:mod:`terrain.models.svm`, :class:`features.transformers.WindowFeatures`).
* ``cnn``: 1-D CNN on the raw channels (:class:`terrain.models.cnn.RawCNNClassifier`).
* ``cnn-spectrogram``: BorealTC's multichannel-spectrogram CNN
  (:class:`terrain.models.cnn.SpectrogramCNNClassifier`).
* ``minirocket``: aeon MiniRocket + logistic regression (:mod:`terrain.models.minirocket`).
* ``ensemble``: soft vote of ``svm`` and ``cnn-spectrogram`` (``ensemble_members``) with
  equal weights (README "Model comparison"); with ``tune_weights`` the weights are chosen on
  runs held out of the training data (:class:`terrain.models.ensemble.SoftVotingEnsemble`).
* ``ensemble3``: equal-weight soft vote of ``svm``, ``cnn`` and ``cnn-spectrogram``
  (:data:`ENSEMBLE3_MEMBERS`, fixed), the best model measured on BorealTC run-grouped
  (README "Model comparison": accuracy 0.902 against 0.883 for ``ensemble``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np

from features.ekf_signals import EKF_CHANNELS
from features.windows import DERIVED_WHEEL_CHANNELS, HUSKY_TRACK_M
from terrain.errors import (ConfigError, config_flags, config_integer, config_positive,
                            duplicated, is_integer)
from terrain.models.cnn import RawCNNClassifier, SpectrogramCNNClassifier
from terrain.models.ensemble import SoftVotingEnsemble
from terrain.models.minirocket import make_minirocket, require_aeon
from terrain.models.svm import SVMConfig, svm_window_pipeline
from terrain.models.weighting import run_balanced
from terrain.models.window_ekf import WindowEKFClassifier
from terrain.run import WHEEL_CHANNELS

MODELS = ("svm", "cnn", "cnn-spectrogram", "minirocket", "ensemble", "ensemble3")

#: Model kinds that are neural networks (seed-bagged with ``ModelConfig.cnn_seeds``).
CNN_MODELS = ("cnn", "cnn-spectrogram")

#: Model kinds that are soft-voting ensembles of other kinds.
ENSEMBLES = ("ensemble", "ensemble3")

#: Default members of ``ensemble`` (``ModelConfig.ensemble_members``): the SVM and the
#: spectrogram CNN.
ENSEMBLE_MEMBERS = ("svm", "cnn-spectrogram")

#: Members of ``ensemble3``: SVM + raw 1-D CNN + spectrogram CNN, equal weights (README
#: "Model comparison", run-grouped StratifiedGroupKFold(5), seeds 0 1 2).
ENSEMBLE3_MEMBERS = ("svm", "cnn", "cnn-spectrogram")

#: Most networks one CNN may average (``ModelConfig.cnn_seeds``): each costs a whole
#: training; three were measured (docs/model_comparison.md, "More members").
MAX_CNN_SEEDS = 10

#: Native rate of the wheel (``pro``) stream of each shipped dataset, Hz: median sample
#: interval of the shipped parquet files (BorealTC 6.5 Hz, Vulpi 15 Hz); ``combined`` takes
#: the lower one. Spectrogram bins of wheel channels above half of it are zeroed.
WHEEL_RATE_HZ: Mapping[str, float] = MappingProxyType(
    {"borealtc": 6.5, "vulpi": 15.0, "combined": 6.5})


#: torch threads per CNN fit at most: more threads than any machine's cores only cost
#: memory, and torch 2.13 crashes (segmentation fault at exit) after
#: ``torch.set_num_threads(10**6)``, measured here
MAX_TORCH_THREADS = 1024


@dataclass(frozen=True)
class ModelConfig:
    """Which classifier and its training budget.

    Parameters
    ----------
    kind : {"svm", "cnn", "cnn-spectrogram", "minirocket", "ensemble", "ensemble3"}
        Model name (see the module docstring).
    max_epochs : int
        Fixed epoch budget of the CNNs (no early stopping, see README "Model comparison").
    n_threads : int or None
        torch threads while training a CNN (``None``: torch's default); at most
        :data:`MAX_TORCH_THREADS`.
    minirocket_kernels : int
        MiniRocket features (a multiple of 84 rounded down, at least 84:
        :class:`~terrain.models.minirocket.MiniRocketFeatures`).
    minirocket_max_dilations : int
        MiniRocket dilations per kernel at most (its single-window time grows with it, see
        :mod:`terrain.models.minirocket`).
    svm : SVMConfig
        SVM hyperparameters (also the SVM member of the ensemble).
    ensemble_members : tuple of str
        Members of the ``ensemble`` model (other, non-ensemble model names); ``ensemble3``
        always has :data:`ENSEMBLE3_MEMBERS`.
    tune_weights : bool
        Choose the ensemble weights (``ensemble``, ``ensemble3``) on held-out training runs
        instead of equal weights.
    early_stopping : bool
        CNNs stop on the validation loss of whole training runs held out of the fit
        (``max_epochs`` is then the upper bound); off by default (README "Model comparison").
    window_ekf : bool
        Append the skid-steer EKF's channels computed from each window's own samples
        (:class:`terrain.models.window_ekf.WindowEKFClassifier`); the windows need ``vel_l``,
        ``vel_r`` and ``wz``.
    spectrogram_noise_std : float
        ``augment_noise_std`` of the spectrogram CNN (alone or as an ensemble member): fit
        on the training spectra plus a copy perturbed by white noise of this many standard
        deviations; 0 (default): no copy.
    cnn_seeds : int
        Independently seeded networks per CNN (alone or as an ensemble member) whose class
        probabilities are averaged with equal weights (seed bagging: seeds ``random_state``,
        ``random_state + 1``, ... modulo ``2**32``); 1 (default): one network; at most
        :data:`MAX_CNN_SEEDS`.
    run_balanced : bool
        Fit every single model (alone, as an ensemble member or in a seed bag) with
        :func:`terrain.models.weighting.within_class_run_weights` of its training windows,
        so that every run of a class weighs the same
        (:class:`terrain.models.weighting.RunBalancedClassifier`; ``fit`` then needs the
        run of every window, ``groups``); False (default): every window the same.
    track_m : float
        Track width B of the training runs' vehicle, m, for ``window_ekf``'s skid-steer
        filter (:func:`features.windows.runs_track_m`; default the Husky's).

    Raises
    ------
    ConfigError
        An unknown ``kind`` or ensemble member, a member named twice, or one name given as
        ``ensemble_members`` (text, not a tuple);
        ``tune_weights``, ``early_stopping``, ``window_ekf`` or ``run_balanced`` not True or
        False; ``max_epochs``,
        ``minirocket_kernels`` or ``minirocket_max_dilations`` not an integer >= 1;
        ``spectrogram_noise_std`` not a finite number >= 0; ``track_m`` not a finite number
        > 0; ``cnn_seeds`` or ``n_threads`` out of range, ``cnn_seeds > 1`` without a CNN,
        or ``run_balanced`` with ``window_ekf``.
    """

    kind: str = "svm"
    max_epochs: int = 30
    n_threads: int | None = None
    minirocket_kernels: int = 10_000
    minirocket_max_dilations: int = 32
    svm: SVMConfig = SVMConfig()
    ensemble_members: tuple[str, ...] = ENSEMBLE_MEMBERS
    tune_weights: bool = False
    early_stopping: bool = False
    window_ekf: bool = False
    spectrogram_noise_std: float = 0.0
    cnn_seeds: int = 1
    run_balanced: bool = False
    track_m: float = HUSKY_TRACK_M

    def __post_init__(self) -> None:
        if self.kind not in MODELS:
            raise ConfigError(f"unknown model {self.kind!r}; valid: {list(MODELS)}")
        # a text such as "no" from a config file was truthy and switched the setting on
        config_flags("ModelConfig", **{flag: getattr(self, flag) for flag in (
            "tune_weights", "early_stopping", "window_ekf", "run_balanced")})
        if self.run_balanced and self.window_ekf:
            raise ConfigError("run_balanced (--run-balanced) is not implemented with "
                              "window_ekf (--window-ekf): choose one")
        singles = [m for m in MODELS if m not in ENSEMBLES]
        # a budget of 0 epochs trained nothing and served the untrained network; 0 dilations
        # reached aeon's bare ZeroDivisionError; an infinite noise level passed ">= 0"
        config_integer("ModelConfig.max_epochs", self.max_epochs, 1)
        config_integer("ModelConfig.minirocket_kernels", self.minirocket_kernels, 1)
        config_integer("ModelConfig.minirocket_max_dilations", self.minirocket_max_dilations, 1)
        config_positive("ModelConfig", allow_zero=True,
                        spectrogram_noise_std=self.spectrogram_noise_std)
        config_positive("ModelConfig", track_m=self.track_m)
        if isinstance(self.ensemble_members, (str, bytes)):   # read letter by letter
            raise ConfigError(f"ensemble_members must be a tuple of member names, e.g. "
                              f"{ENSEMBLE_MEMBERS}, got {self.ensemble_members!r}")
        if not self.ensemble_members or set(self.ensemble_members) - set(singles):
            raise ConfigError(f"ensemble members must be among {singles}, "
                              f"got {list(self.ensemble_members)}")
        if duplicated(self.ensemble_members):
            # two members of one kind are built with the same seed: the same model twice
            raise ConfigError(f"ensemble members name {duplicated(self.ensemble_members)} "
                              f"more than once, got {list(self.ensemble_members)}: name each "
                              "member once")
        # is_integer: NumPy's integers too (as config_integer takes max_epochs), no boolean
        if not (is_integer(self.cnn_seeds) and 1 <= self.cnn_seeds <= MAX_CNN_SEEDS):
            raise ConfigError(f"cnn_seeds must be an integer in 1-{MAX_CNN_SEEDS}, got "
                              f"{self.cnn_seeds!r}")
        if self.n_threads is not None and not (
                is_integer(self.n_threads) and 1 <= self.n_threads <= MAX_TORCH_THREADS):
            raise ConfigError(f"n_threads must be an integer in 1-{MAX_TORCH_THREADS} or "
                              f"None, got {self.n_threads!r}")
        if self.cnn_seeds > 1 and not cnn_kinds(self.kind, self.ensemble_members):
            raise ConfigError(f"cnn_seeds={self.cnn_seeds} averages CNNs, and model "
                              f"{self.kind!r} has none (CNN kinds: {list(CNN_MODELS)})")
        # the caller's list was kept: changing it later changed the validated members
        object.__setattr__(self, "ensemble_members", tuple(self.ensemble_members))


def cnn_kinds(kind: str, ensemble_members: Sequence[str] = ENSEMBLE_MEMBERS) -> tuple[str, ...]:
    """The CNN kinds a model holds (those ``ModelConfig.cnn_seeds`` bags).

    Parameters
    ----------
    kind : str
        Model name (:data:`MODELS`).
    ensemble_members : sequence of str
        Members of an ``ensemble`` (``ModelConfig.ensemble_members``).

    Returns
    -------
    tuple of str
        ``(kind,)`` for a CNN, the CNN members of an ensemble, ``()`` otherwise.
    """
    return tuple(k for k in _component_kinds(kind, ensemble_members) if k in CNN_MODELS)


def _component_kinds(kind: str, ensemble_members: Sequence[str]) -> tuple[str, ...]:
    """The single models a model is made of: an ensemble's members (``ensemble``:
    ``ensemble_members``, ``ensemble3``: :data:`ENSEMBLE3_MEMBERS`), else ``(kind,)``."""
    members = {"ensemble": tuple(ensemble_members), "ensemble3": ENSEMBLE3_MEMBERS}
    return members.get(kind, (kind,))


def cnn_seeds_for(kind: str, cnn_seeds: int,
                  ensemble_members: Sequence[str] = ENSEMBLE_MEMBERS) -> int:
    """``ModelConfig.cnn_seeds`` for a model of ``kind``: as asked when it holds a CNN, else 1.

    One seed-bagging setting applied across several models (a comparison grid, a benchmark,
    the members of an ensemble) bags only those that hold a CNN; ``ModelConfig`` refuses
    ``cnn_seeds > 1`` for the others.

    Parameters
    ----------
    kind : str
        Model name (:data:`MODELS`).
    cnn_seeds : int
        Networks per CNN asked for (>= 1).
    ensemble_members : sequence of str
        Members of an ``ensemble`` (``ModelConfig.ensemble_members``).

    Returns
    -------
    int
        ``cnn_seeds`` when :func:`cnn_kinds` of the model is not empty, else 1.
    """
    return cnn_seeds if cnn_kinds(kind, ensemble_members) else 1


def band_limits_hz(channels: Sequence[str], dataset: str) -> tuple[float, ...]:
    """Highest meaningful frequency of each channel, Hz (Nyquist of its native rate).

    Parameters
    ----------
    channels : sequence of str
        Window channels.
    dataset : str
        Shipped dataset name (key of :data:`WHEEL_RATE_HZ`).

    Returns
    -------
    tuple of float
        ``(n_channels,)``; ``inf`` for channels at the aligned (IMU) rate.
    """
    wheel = set(WHEEL_CHANNELS) | set(DERIVED_WHEEL_CHANNELS)
    nyquist = WHEEL_RATE_HZ.get(dataset, np.inf) / 2.0
    return tuple(float(nyquist) if c in wheel else float("inf") for c in channels)


def ensemble_member_kinds(config: ModelConfig) -> tuple[str, ...]:
    """The member models of an ensemble configuration, in vote order.

    Parameters
    ----------
    config : ModelConfig
        An ``ensemble`` or ``ensemble3`` configuration.

    Returns
    -------
    tuple of str
        :data:`ENSEMBLE3_MEMBERS` for ``ensemble3``, ``config.ensemble_members`` for
        ``ensemble``.

    Raises
    ------
    ConfigError
        ``config.kind`` is not an ensemble.
    """
    if config.kind not in ENSEMBLES:
        raise ConfigError(f"{config.kind!r} is not an ensemble; ensembles: {list(ENSEMBLES)}")
    return ENSEMBLE3_MEMBERS if config.kind == "ensemble3" else tuple(config.ensemble_members)


def check_dependencies(kind: str, ensemble_members: Sequence[str] = ENSEMBLE_MEMBERS) -> None:
    """Refuse a model whose optional extra is not installed, before any data is read.

    Parameters
    ----------
    kind : str
        One of :data:`MODELS`.
    ensemble_members : sequence of str
        Members of an ``ensemble`` (``ModelConfig.ensemble_members``).

    Raises
    ------
    ConfigError
        ``minirocket`` (alone or as an ensemble member) without aeon
        (:func:`terrain.models.minirocket.require_aeon`).
    """
    if "minirocket" in _component_kinds(kind, ensemble_members):
        require_aeon()


def make_model(config: ModelConfig, channels: Sequence[str], rate_hz: float, dataset: str,
               random_state: int = 0, probability: bool = True):
    """Unfitted classifier taking raw windows.

    Parameters
    ----------
    config : ModelConfig
        Model name and budget.
    channels : sequence of str
        Channel order of the windows' axis 1.
    rate_hz : float
        Window sampling rate, Hz.
    dataset : str
        Shipped dataset (native wheel rate of the spectrogram band limits).
    random_state : int
        Seed.
    probability : bool
        SVM with Platt-scaled probabilities (needed for serving, the ensemble and the
        decision history; plain SVC otherwise).

    Returns
    -------
    estimator
        scikit-learn classifier with ``predict_proba`` (the plain SVM excepted); with
        ``config.window_ekf`` a :class:`~terrain.models.window_ekf.WindowEKFClassifier`
        around the model built for the augmented channels; with ``config.cnn_seeds > 1``
        every CNN is a :class:`~terrain.models.ensemble.SoftVotingEnsemble` of that many
        networks seeded ``random_state``, ``random_state + 1``, ... (modulo ``2**32``, NumPy's
        seed range: ``2**32 - 1`` is followed by 0) with equal weights; with
        ``config.run_balanced`` every single model in it is a
        :class:`~terrain.models.weighting.RunBalancedClassifier`
        (:func:`~terrain.models.weighting.run_balanced`).
    """
    kind = config.kind
    if config.window_ekf:
        inner = make_model(replace(config, window_ekf=False),
                           tuple(channels) + tuple(EKF_CHANNELS), rate_hz, dataset,
                           random_state, probability)
        return WindowEKFClassifier(inner, tuple(channels), rate_hz, WHEEL_RATE_HZ.get(dataset),
                                   config.track_m)
    if config.run_balanced and kind not in ENSEMBLES and not (kind in CNN_MODELS
                                                              and config.cnn_seeds > 1):
        return run_balanced(make_model(replace(config, run_balanced=False), channels,
                                       rate_hz, dataset, random_state, probability))
    if kind in CNN_MODELS and config.cnn_seeds > 1:
        single = replace(config, cnn_seeds=1)
        # modulo NumPy's seed range: a valid seed near 2**32 - 1 gave the last networks
        # seeds their fit refused
        seeds = [(random_state + i) % 2 ** 32 for i in range(config.cnn_seeds)]
        bag = [(f"{kind}-seed{seed}",
                make_model(single, channels, rate_hz, dataset, seed, probability))
               for seed in seeds]
        return SoftVotingEnsemble(bag, weights=(1.0,) * len(bag), random_state=random_state)
    if kind == "svm":
        return svm_window_pipeline(channels, rate_hz,
                                   replace(config.svm, probability=probability), random_state)
    if kind == "cnn":
        return RawCNNClassifier(max_epochs=config.max_epochs, random_state=random_state,
                                n_threads=config.n_threads,
                                early_stopping=config.early_stopping)
    if kind == "cnn-spectrogram":
        return SpectrogramCNNClassifier(rate_hz=rate_hz,
                                        band_limits_hz=band_limits_hz(channels, dataset),
                                        max_epochs=config.max_epochs,
                                        random_state=random_state, n_threads=config.n_threads,
                                        early_stopping=config.early_stopping,
                                        augment_noise_std=config.spectrogram_noise_std)
    if kind == "minirocket":
        return make_minirocket(random_state, n_kernels=config.minirocket_kernels,
                               max_dilations_per_kernel=config.minirocket_max_dilations)
    members = [(k, make_model(replace(config, kind=k,
                                      cnn_seeds=cnn_seeds_for(k, config.cnn_seeds)),
                              channels, rate_hz, dataset, random_state, probability=True))
               for k in ensemble_member_kinds(config)]
    weights = None if config.tune_weights else (1.0,) * len(members)
    return SoftVotingEnsemble(members, weights=weights, random_state=random_state)
