"""One terrain-classification experiment: shipped dataset -> windows -> features -> CV.

The pipelines (``terrain cv``, ``terrain train``) only parse arguments, call these functions
and log the results; the composition itself lives here so it can be tested and reused.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np
from sklearn.pipeline import Pipeline

from features.ekf_signals import EKF_CHANNELS
from features.transformers import WindowFeatures
from features.windows import (WindowConfig, WindowSet, make_windows, resolve_signals,
                              runs_track_m)
from terrain.errors import (ConfigError, config_flags, config_integer, config_positive,
                            duplicated, is_integer, refuse_mixed_types)
from terrain.io.shipped import DATASET_SPECS, load_dataset
from terrain.models.cv import (PROTOCOLS, CVReport, TrainingWindows, block_notes,
                               cross_validate, fit_with_groups, grouped_units, training_units)
from terrain.models.registry import MODELS, ModelConfig, make_model
from terrain.models.svm import SVMConfig, make_search, make_svm, svm_window_pipeline
from terrain.models.weighting import run_balanced
from terrain.run import Run

#: Window settings of the papers' protocol (BorealTC, Vulpi): 1.7 s windows, 0.1 s hop,
#: inside non-overlapping 5 s partitions.
PAPER_WINDOW: Mapping[str, float] = MappingProxyType(
    {"window_s": 1.7, "hop_s": 0.1, "partition_s": 5.0})


#: Largest seed NumPy's legacy generator takes (scikit-learn's splitters seed it).
MAX_SEED = 2 ** 32 - 1


@dataclass(frozen=True)
class ExperimentConfig:
    """Everything that defines a classification experiment.

    Parameters
    ----------
    dataset : {"borealtc", "vulpi", "combined"}
        Shipped training set (:data:`terrain.io.shipped.DATASET_SPECS`).
    signals : tuple of str
        Signal sets or channels (see :func:`features.windows.resolve_signals`); one name
        given as text is kept as the one-name tuple.
    window_s : float
        Window length, s (the ``paper`` protocol fixes 1.7 s).
    hop_s : float or None
        Hop, s; ``None`` = non-overlapping (``paper`` fixes 0.1 s).
    train_hop_s : float or None
        Hop of the *training* windows, s: a finer hop cuts more, overlapping windows from the
        training runs only (each fold trains on those of its training runs,
        :func:`terrain.models.cv.training_units`; ``terrain train`` on those of every run),
        while the folds and the test windows stay those of ``hop_s``. ``None``: train on the
        evaluation windows. Not with the ``paper`` protocol (its windows already slide by
        0.1 s).
    rate_hz : float or None
        Aligned clock rate, Hz; ``None`` = the dataset's IMU rate.
    steady_only : bool
        Keep steady-motion windows only.
    protocol : {"grouped", "loro", "paper"}
        Split protocol (:func:`terrain.models.cv.iter_splits`); ``grouped`` is the headline.
    seeds : tuple of int
        Split and model seeds, distinct; one CV per seed.
    n_splits : int
        Outer folds (not used by ``loro``).
    search : bool
        Nested grouped grid search of C and gamma inside each training fold.
    single_run_blocks : int
        Blocks a single-run class is cut into (>= 2, see :mod:`terrain.models.cv`).
    svm : SVMConfig
        SVM hyperparameters and search grid (:class:`terrain.models.svm.SVMConfig`).
    model : {"svm", "cnn", "cnn-spectrogram", "minirocket", "ensemble", "ensemble3"}
        Classifier (see :mod:`terrain.models.registry`).
    max_epochs : int
        Fixed epoch budget of the CNNs.
    n_threads : int or None
        torch threads while training a CNN.
    window_ekf : bool
        The model appends the skid-steer EKF's channels computed from each window's own
        samples (:class:`terrain.models.window_ekf.WindowEKFClassifier`); the signals must
        hold ``vel_l``, ``vel_r`` and ``wz`` and no EKF channel.
    cnn_seeds : int
        Independently seeded networks averaged per CNN (``ModelConfig.cnn_seeds``).
    run_balanced : bool
        Every model (every member of an ensemble) weighs the runs of a class the same in
        training (``ModelConfig.run_balanced``, :mod:`terrain.models.weighting`).

    Raises
    ------
    ConfigError
        Unknown model, dataset, protocol or signal, a signal named twice, ``search`` not
        True or False or with a model other than the SVM or with ``window_ekf`` or
        ``run_balanced``, ``window_ekf`` with signals lacking ``vel_l``, ``vel_r`` or ``wz``
        or holding an EKF channel, a ``train_hop_s``
        that is not a finite positive number or comes with ``paper``, ``paper`` with a
        ``window_s`` or ``hop_s`` other than its own (or the defaults), no seed, one
        outside ``0..MAX_SEED`` or a repeated one, ``single_run_blocks`` or ``n_splits`` not
        an integer >= 2, the classifier's own refusals
        (:class:`~terrain.models.registry.ModelConfig`, e.g. ``cnn_seeds``), or window
        settings :class:`~features.windows.WindowConfig` refuses (``rate_hz`` 0 included).
    """

    dataset: str = "borealtc"
    signals: tuple[str, ...] = ("all",)
    window_s: float = 2.0
    hop_s: float | None = None
    train_hop_s: float | None = None
    rate_hz: float | None = None
    steady_only: bool = False
    protocol: str = "grouped"
    seeds: tuple[int, ...] = (0, 1, 2)
    n_splits: int = 5
    search: bool = False
    single_run_blocks: int = 5
    svm: SVMConfig = field(default_factory=SVMConfig)
    model: str = "svm"
    max_epochs: int = 30
    n_threads: int | None = None
    window_ekf: bool = False
    cnn_seeds: int = 1
    run_balanced: bool = False

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise ConfigError(f"unknown model {self.model!r}; valid: {list(MODELS)}")
        # a text such as "no" from a config file was truthy and ran the nested search
        config_flags("ExperimentConfig", search=self.search)
        if self.search and (self.model != "svm" or self.window_ekf or self.run_balanced):
            raise ConfigError("--search tunes the SVM on raw-signal features only; drop it "
                              "for other models and with --window-ekf or --run-balanced")
        self.model_config()  # the classifier's own checks (e.g. cnn_seeds), before any data
        if self.dataset not in DATASET_SPECS:
            raise ConfigError(f"unknown dataset {self.dataset!r}; valid: {list(DATASET_SPECS)}")
        if self.protocol not in PROTOCOLS:
            raise ConfigError(f"unknown protocol {self.protocol!r}; valid: {list(PROTOCOLS)}")
        channels = resolve_signals(self.signals)
        twice = [] if isinstance(self.signals, str) else duplicated(self.signals)
        if twice:   # one selection logged as 'imu,imu' and named '...-imu+imu'
            raise ConfigError(f"signals {twice} given twice: each signal set or channel once "
                              f"(the signals are the MLflow param 'signals' and part of the "
                              f"run name)")
        if self.window_ekf:
            missing = [c for c in ("vel_l", "vel_r", "wz") if c not in channels]
            if missing or set(channels) & set(EKF_CHANNELS):
                raise ConfigError("--window-ekf computes the EKF channels from each window's "
                                  "vel_l, vel_r and wz: the signals must hold them "
                                  f"(missing {missing}) and no EKF channel")
        if self.train_hop_s is not None:
            # (text such as '0.5' raised Python's TypeError in the comparison)
            config_positive("ExperimentConfig", train_hop_s=self.train_hop_s)
            if self.protocol == "paper":
                raise ConfigError("the paper protocol fixes its windows (0.1 s hop): drop "
                                  "--train-hop-s")
        if self.protocol == "paper" and (
                self.window_s not in (2.0, PAPER_WINDOW["window_s"])
                or self.hop_s not in (None, PAPER_WINDOW["hop_s"])):
            # it would run the paper's windows anyway: the options would be ignored
            raise ConfigError(f"the paper protocol fixes its windows "
                              f"({PAPER_WINDOW['window_s']:g} s every "
                              f"{PAPER_WINDOW['hop_s']:g} s): drop --window-s / --hop-s "
                              f"(got {self.window_s:g} s, hop {self.hop_s})")
        if isinstance(self.seeds, (str, bytes)) or not hasattr(self.seeds, "__iter__"):
            # one seed given bare reached Python's "'int' object is not iterable"
            raise ConfigError(f"seeds must be a sequence of integers in 0-{MAX_SEED}, e.g. "
                              f"(0,), got {type(self.seeds).__name__} {self.seeds!r:.60}")
        bad_seeds = [s for s in self.seeds if not is_integer(s) or not 0 <= s <= MAX_SEED]
        if not self.seeds or bad_seeds:
            raise ConfigError(f"seeds must be one or more integers in 0-{MAX_SEED} (NumPy's "
                              f"seed range), got {list(self.seeds)}")
        # single_run_blocks 0 reached NumPy's bare "number sections must be larger than 0"
        # in the CV, and 1 block never trains a single-run class when it is tested; 2.5
        # folds reached scikit-learn's bare ValueError after the data was windowed
        config_integer("ExperimentConfig.single_run_blocks", self.single_run_blocks, 2)
        config_integer("ExperimentConfig.n_splits", self.n_splits, 2)
        if duplicated(int(s) for s in self.seeds):
            raise ConfigError(f"seeds must be distinct (a repeated seed counts one split "
                              f"twice), got {list(self.seeds)}")
        # WindowConfig's checks: train_window_config builds window_config, then sets its hop
        self.train_window_config() if self.train_hop_s is not None else self.window_config()
        # the caller's lists were kept: changing one later changed the validated config; one
        # name given as text is the one-name tuple (as_params joined its letters: "i,m,u")
        object.__setattr__(self, "signals", (self.signals,) if isinstance(self.signals, str)
                           else tuple(self.signals))
        object.__setattr__(self, "seeds", tuple(self.seeds))

    def train_window_config(self) -> WindowConfig | None:
        """Window settings of the training cut, or None when training uses the evaluation
        windows (``train_hop_s`` unset).

        Returns
        -------
        WindowConfig or None
            :meth:`window_config` with ``hop_s = train_hop_s``.
        """
        if self.train_hop_s is None:
            return None
        return replace(self.window_config(), hop_s=self.train_hop_s)

    def window_config(self) -> WindowConfig:
        """Window settings implied by the protocol and the dataset.

        Returns
        -------
        WindowConfig
            :data:`PAPER_WINDOW` (1.7 s windows, 0.1 s hop, 5 s partitions) under the
            ``paper`` protocol, else ``window_s``/``hop_s``; the rate is ``rate_hz`` or the
            dataset's IMU rate (:data:`terrain.io.shipped.DATASET_SPECS`).
        """
        # 0 Hz is refused by WindowConfig, not taken for "unset"
        rate = self.rate_hz if self.rate_hz is not None else DATASET_SPECS[self.dataset].rate_hz
        if self.protocol == "paper":
            return WindowConfig(rate_hz=rate, steady_only=self.steady_only, **PAPER_WINDOW)
        return WindowConfig(window_s=self.window_s, hop_s=self.hop_s, rate_hz=rate,
                            steady_only=self.steady_only)

    def model_config(self, runs: Sequence[Run] = ()) -> ModelConfig:
        """The classifier settings of this experiment.

        Parameters
        ----------
        runs : sequence of Run
            The runs the model is fitted on: their vehicle's track width for the window
            EKF (:func:`features.windows.runs_track_m`); none: the Husky's.

        Returns
        -------
        ModelConfig
            Model name, epoch budget, threads, SVM settings, ``window_ekf``, ``cnn_seeds``,
            ``run_balanced`` and ``track_m``.
        """
        return ModelConfig(kind=self.model, max_epochs=self.max_epochs,
                           n_threads=self.n_threads, svm=self.svm, window_ekf=self.window_ekf,
                           cnn_seeds=self.cnn_seeds, run_balanced=self.run_balanced,
                           track_m=runs_track_m(runs))

    def as_params(self) -> dict:
        """Flat parameter dict for MLflow.

        Returns
        -------
        dict
            The fields, with ``svm`` flattened to ``svm_<field>``, ``signals`` and ``seeds``
            comma-joined, ``n_threads`` 0 for ``None``, and the effective window settings of
            :meth:`window_config` (``window_s``, ``hop_s``, ``rate_hz``, ``partition_s``; s, Hz)
            and the effective ``train_hop_s`` (``hop_s`` when unset), s.
        """
        d = asdict(self)
        svm = d.pop("svm")
        d.update({f"svm_{k}": v for k, v in svm.items()})
        d["signals"] = ",".join(self.signals)
        d["seeds"] = ",".join(map(str, self.seeds))
        w = self.window_config()
        d["n_threads"] = self.n_threads or 0
        d.update(window_s=w.window_s, hop_s=w.hop_s or w.window_s, rate_hz=w.rate_hz,
                 partition_s=w.partition_s)
        d["train_hop_s"] = self.train_hop_s or d["hop_s"]
        return d


def feature_extractor(windows: WindowSet) -> WindowFeatures:
    """The feature transformer matching a window set (fitted: it is stateless).

    Parameters
    ----------
    windows : WindowSet
        Windows whose ``channels`` and ``rate_hz`` (Hz) configure the extractor.

    Returns
    -------
    WindowFeatures
        Fitted extractor mapping ``(n_windows, n_channels, n_samples)`` windows to features.
    """
    return WindowFeatures(channels=windows.channels, rate_hz=windows.rate_hz).fit(windows.X)


def inference_pipeline(windows: WindowSet, svm: SVMConfig, random_state: int = 0) -> Pipeline:
    """Unfitted ``features -> scaler -> SVC`` pipeline taking raw windows as input.

    Parameters
    ----------
    windows : WindowSet
        Windows whose ``channels`` and ``rate_hz`` (Hz) configure the feature step.
    svm : SVMConfig
        SVM hyperparameters (see :func:`terrain.models.svm.make_svm`).
    random_state : int
        Seed of the SVC.

    Returns
    -------
    terrain.models.svm.SVMPipeline
        :func:`terrain.models.svm.svm_window_pipeline` for these windows; input
        ``(n_windows, n_channels, n_samples)``;
        a scikit-learn ``Pipeline`` with a NumPy ``predict_proba`` for the calibrated SVC.
    """
    return svm_window_pipeline(windows.channels, windows.rate_hz, svm, random_state)


@dataclass
class ExperimentResult:
    """What :func:`run_cv` produced: the report, the windows' book-keeping and timings.

    Attributes
    ----------
    config : ExperimentConfig
        The configuration that was run.
    report : CVReport
        Folds, pooled metrics, confusion, out-of-fold predictions and notes.
    n_windows : int
        Windows cross-validated (after purging those crossing a time-block boundary).
    n_runs : int
        Distinct runs among them.
    counts : dict
        Windowing book-keeping, :attr:`features.windows.WindowSet.counts`.
    feature_names : list of str
        Names of the window features (``get_feature_names_out`` of the extractor).
    timings_s : dict of str to float
        ``windowing_s`` (loading, cutting the evaluation windows), ``features_s`` (their
        features, and the training cut of ``train_hop_s``: its windows and features) and
        ``cv_s`` (the cross-validation): wall-clock time of each stage, s.
    input_notes : tuple of str
        The notes of ``report.notes`` that restate the windowing's book-keeping (runs
        skipped for a missing stream, windows dropped, window positions inside a gap, run
        tails after the last full partition or window, s), which
        :func:`terrain.io.report.input_report` also states: a command that prints that
        report leaves these out of its notes (the JSON report keeps every note).
    """

    config: ExperimentConfig
    report: CVReport
    n_windows: int
    n_runs: int
    counts: dict
    feature_names: list[str]
    timings_s: dict[str, float]
    input_notes: tuple[str, ...] = ()


def check_windows_left(ws: WindowSet, config: ExperimentConfig) -> None:
    """Refuse a selection that leaves no window (every run shorter than the window, or no
    run holding the signals), before scikit-learn's own "0 samples" ``ValueError``.

    Parameters
    ----------
    ws : WindowSet
        The windows cut from the dataset.
    config : ExperimentConfig
        Dataset, signals and the windows :meth:`ExperimentConfig.window_config` cuts (length,
        and partitions under the ``paper`` protocol), named in the message.

    Raises
    ------
    ConfigError
        ``ws`` holds no window.
    """
    if len(ws) == 0:
        window = config.window_config()
        within = f" in {window.partition_s:g} s partitions" if window.partition_s else ""
        raise ConfigError(f"no window left for this dataset, signal set and window (dataset "
                          f"{config.dataset!r}, signals {'+'.join(config.signals)}, "
                          f"{window.window_s:g} s windows{within})")


def check_two_classes(labels: np.ndarray, dataset: str, run_ids: np.ndarray) -> None:
    """Refuse windows of fewer than two terrain classes, naming the class and its runs.

    scikit-learn's own ``ValueError`` ("the number of classes has to be greater than one")
    names neither; a dataset converted from one terrain folder is the usual cause.

    Parameters
    ----------
    labels : numpy.ndarray
        ``(n_windows,)`` terrain class of each window.
    dataset : str
        Dataset name, for the message.
    run_ids : numpy.ndarray
        ``(n_windows,)`` run id of each window.

    Raises
    ------
    ConfigError
        One class only in ``labels`` (no window at all is left to the caller, whose
        message says why none was cut).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``labels``
        (:func:`terrain.errors.refuse_mixed_types`).
    """
    refuse_mixed_types("check_two_classes", "labels", labels)   # (NumPy's bare TypeError)
    classes = np.unique(labels)
    if len(classes) == 1:
        ids = sorted({str(r) for r in run_ids})
        raise ConfigError(f"dataset {dataset!r} holds windows of {len(classes)} terrain "
                          f"class(es) {[str(c) for c in classes]} (runs {ids[:5]}"
                          f"{' ...' if len(ids) > 5 else ''}); a terrain classifier needs "
                          "two at least: add runs of another terrain folder")


def load_windows(config: ExperimentConfig, runs: Sequence[Run] | None = None,
                 data_dir: str | Path | None = None, progress: bool = False) -> WindowSet:
    """Load the dataset (unless ``runs`` is given) and cut it into windows.

    Parameters
    ----------
    config : ExperimentConfig
        Dataset, signals and window settings (:meth:`ExperimentConfig.window_config`).
    runs : sequence of Run or None
        Already loaded runs (default: load ``config.dataset``).
    data_dir : str or pathlib.Path or None
        Shipped data folder (default: :func:`terrain.io.shipped.default_data_dir`).
    progress : bool
        Show a progress bar over runs.

    Returns
    -------
    WindowSet
        Windows ``(n_windows, n_channels, n_samples)`` with labels, run ids, groups, bounds
        (s) and book-keeping counts. Errors of :func:`terrain.io.shipped.load_dataset`
        propagate.
    """
    runs = load_dataset(config.dataset, data_dir) if runs is None else runs
    return make_windows(runs, config.signals, config.window_config(), progress=progress)


def load_training_windows(config: ExperimentConfig, runs: Sequence[Run], windows: WindowSet,
                          groups: np.ndarray, transform=None,
                          progress: bool = False) -> TrainingWindows | None:
    """The training cut of an experiment (``config.train_hop_s``), or None without one.

    Parameters
    ----------
    config : ExperimentConfig
        Signals, window and ``train_hop_s``.
    runs : sequence of Run
        The runs the evaluation windows were cut from.
    windows : WindowSet
        The evaluation windows (after any purge).
    groups : numpy.ndarray
        ``(len(windows),)`` their split units (runs, or time blocks of single-run classes).
    transform : callable or None
        Applied to the raw training windows (the SVM's feature extractor), else raw.
    progress : bool
        Show a progress bar over runs.

    Returns
    -------
    TrainingWindows or None
        Windows cut every ``train_hop_s`` with their units
        (:func:`terrain.models.cv.training_units`).
    """
    window = config.train_window_config()
    if window is None:
        return None
    dense = make_windows(runs, config.signals, window, progress)
    units = training_units(windows.run_ids, windows.t_start_s, windows.t_end_s, groups,
                           dense.run_ids, dense.t_start_s, dense.t_end_s)
    return TrainingWindows(dense.X if transform is None else transform(dense.X),
                           dense.labels.astype(str), units)


def run_cv(config: ExperimentConfig, runs: Sequence[Run] | None = None,
           data_dir: str | Path | None = None, progress: bool = False,
           n_jobs: int | None = None) -> ExperimentResult:
    """Cross-validate the configured model on a dataset with the configured protocol.

    For the SVM, features are computed once for all windows (the extractor is stateless, so
    this leaks nothing); the scaler, class weights and the optional search are fitted per
    training fold. Other models get the raw windows; their normalisation, weights and any
    inner validation are fitted per training fold.

    Parameters
    ----------
    config : ExperimentConfig
        Dataset, windows, protocol, model.
    runs : sequence of Run or None
        Already loaded runs (default: load ``config.dataset``).
    data_dir : str or Path or None
        Shipped data folder (default: the package's).
    progress : bool
        Show progress bars.
    n_jobs : int or None
        joblib workers (grid search for the SVM, folds otherwise).

    Returns
    -------
    ExperimentResult
        The CV report (notes list single-run classes cut into blocks and dropped windows),
        window counts, feature names and stage timings (s).

    Raises
    ------
    ConfigError
        If the selection leaves no window, or windows of one terrain class only.
    """
    t0 = time.perf_counter()
    runs = load_dataset(config.dataset, data_dir) if runs is None else runs
    ws = load_windows(config, runs, data_dir, progress)
    t1 = time.perf_counter()
    check_windows_left(ws, config)
    labels = ws.labels.astype(str)
    check_two_classes(labels, config.dataset, ws.run_ids)
    notes = []
    groups = ws.groups
    if config.protocol != "paper":
        ws, labels, groups, split, n_dropped = grouped_units(ws, config.single_run_blocks)
        notes += block_notes(labels, groups, split, config.single_run_blocks, n_dropped)
        if config.protocol == "loro" and len(config.seeds) > 1:
            # the folds are the same for every seed: the spread over seeds is only the
            # model's own randomness, not a different split
            notes.append(f"loro: leave-one-run-out folds are the same for all "
                         f"{len(config.seeds)} seeds; the seeds change only the model's own "
                         "randomness (a CNN's initialisation; the SVM has none: its "
                         "calibration folds are not shuffled), not the split")
    else:
        notes.append(f"paper protocol: run_majority_accuracy votes per "
                     f"{PAPER_WINDOW['partition_s']:g} s partition (its split unit), not per "
                     f"run")
    fx = feature_extractor(ws)
    # the SVM on raw-signal features is cross-validated on features computed once; every
    # other model (and the SVM with --window-ekf) takes the raw windows
    on_features = config.model == "svm" and not config.window_ekf
    F = fx.transform(ws.X) if on_features else ws.X
    input_notes = []
    if ws.counts["skipped_runs"]:
        input_notes.append(f"{len(ws.counts['skipped_runs'])} run(s) skipped for a missing "
                           f"stream: {ws.counts['skipped_runs']}")
    for key in ("dropped_gap", "dropped_unsteady"):
        if ws.counts[key]:
            input_notes.append(f"{ws.counts[key]} window(s) {key.replace('_', ' ')}")
    if ws.counts.get("empty_gap"):
        input_notes.append(f"{ws.counts['empty_gap']} window position(s) wholly inside a gap "
                           "of every stream (no data, not counted as dropped)")
    for key, after in (("partition_tail_s", "full partition (partition protocol)"),
                       ("window_tail_s", "full window")):
        if ws.counts.get(key):
            n_runs = sum(c.get(key, 0.0) > 0 for c in ws.counts["per_run"].values())
            input_notes.append(f"not windowed: {ws.counts[key]:.1f} s of run tails after the "
                               f"last {after} in {n_runs} run(s)")
    if ws.counts.get("between_windows_s"):
        n_runs = sum(c.get("between_windows_s", 0.0) > 0 for c in ws.counts["per_run"].values())
        input_notes.append(f"not windowed: {ws.counts['between_windows_s']:.1f} s between "
                           f"windows (a hop longer than the window) in {n_runs} run(s)")
    notes += input_notes
    training = load_training_windows(config, runs, ws, groups,
                                     fx.transform if on_features else None, progress)
    t2 = time.perf_counter()   # (the training cut was counted in cv_s)
    if training is not None:
        unused = int(sum(u is None for u in training.units))
        notes.append(f"each fold trains on the windows cut every {config.train_hop_s:g} s "
                     f"from its training runs ({len(training.y)} windows in all; {unused} "
                     "straddling a time-block boundary or outside every evaluation window "
                     "not used); test windows unchanged")
    fold_jobs = None
    if config.search:
        factory = (lambda seed: make_search(config.svm, seed, n_jobs=n_jobs))
    elif on_features and config.run_balanced:
        factory = (lambda seed: run_balanced(make_svm(config.svm, seed)))
    elif on_features:
        factory = (lambda seed: make_svm(config.svm, seed))
    else:
        mc = config.model_config(runs)
        factory = (lambda seed: make_model(mc, ws.channels, ws.rate_hz, config.dataset, seed))
        fold_jobs = n_jobs
    report = cross_validate(factory, F, labels, groups, ws.run_ids, ws.t_start_s, ws.t_end_s,
                            config.protocol, config.seeds, config.n_splits,
                            search=config.search, progress=progress, n_jobs=fold_jobs,
                            training=training)
    report.notes.extend(notes)
    t3 = time.perf_counter()
    return ExperimentResult(config, report, len(ws), len(np.unique(ws.run_ids)), ws.counts,
                            list(fx.get_feature_names_out()),
                            {"windowing_s": t1 - t0, "features_s": t2 - t1, "cv_s": t3 - t2},
                            tuple(input_notes))


def check_servable_signals(signals: Sequence[str]) -> None:
    """Refuse a signal set a served model could not be given: EKF-derived channels.

    Parameters
    ----------
    signals : sequence of str
        Signal sets or channel names (:func:`resolve_signals`).

    Raises
    ------
    ConfigError
        A set or name that resolves to an EKF channel (``ekf``, ``all+ekf``,
        :data:`EKF_CHANNELS`): those come from a causal EKF over the whole run, for
        cross-validation ablations; the served model takes raw aligned signals.
    """
    if set(resolve_signals(signals)) & set(EKF_CHANNELS):
        raise ConfigError("EKF-derived channels are for cross-validation ablations only: the "
                          "served model takes raw aligned signals (choose imu, wheels, all or "
                          "raw channel names; --window-ekf gives the model EKF channels "
                          "computed from each window)")


def fit_pipeline(config: ExperimentConfig, runs: Sequence[Run] | None = None,
                 data_dir: str | Path | None = None, progress: bool = False,
                 n_jobs: int | None = None) -> tuple[Pipeline, WindowSet, dict]:
    """Fit the whole inference model on every labelled window.

    The SVM is ``features + scaler + SVC`` with Platt-scaled probabilities; with
    ``config.search`` its hyperparameters come from a grouped grid search over all runs
    first, its inner folds over the split units of :func:`run_cv` (a single-run class cut
    into ``single_run_blocks`` time blocks, :func:`~terrain.models.cv.grouped_units`; the
    windows straddling a block boundary left out of the search only). Other models
    (``config.model``) take the raw windows directly; the ensembles vote with equal weights
    (:meth:`ExperimentConfig.model_config` leaves ``ModelConfig.tune_weights`` off), logged
    in ``info`` as ``weight_<member>``.

    Parameters
    ----------
    config : ExperimentConfig
        Dataset, windows, model (the first seed is the model seed); with ``train_hop_s``
        the model is fitted on the windows cut at that hop.
    runs : sequence of Run or None
        Already loaded runs (default: load ``config.dataset``).
    data_dir : str or Path or None
        Shipped data folder.
    progress : bool
        Show progress bars.
    n_jobs : int or None
        joblib workers of the SVM grid search.

    Raises
    ------
    ConfigError
        If the signals include EKF-derived channels (not computed by the served model), or
        the selection leaves no window (:func:`check_windows_left`), or the windows hold
        one terrain class only.

    Returns
    -------
    pipeline : estimator
        Input: windows ``(n, n_channels, n_samples)``; ``predict_proba`` gives class
        probabilities, ``predict`` terrain labels.
    windows : WindowSet
        The training windows.
    info : dict
        Chosen hyperparameters (``search_split_classes``: the classes the search cut into
        time blocks, when any).
    """
    check_servable_signals(config.signals)
    runs = load_dataset(config.dataset, data_dir) if runs is None else runs
    # training uses every window of the training cut (train_hop_s), when one is set
    ws = load_windows(config if config.train_hop_s is None
                      else replace(config, hop_s=config.train_hop_s), runs, data_dir, progress)
    check_windows_left(ws, config)
    labels = ws.labels.astype(str)
    check_two_classes(labels, config.dataset, ws.run_ids)
    info: dict = {"model": config.model}
    if config.model != "svm" or config.window_ekf or config.run_balanced:
        model = make_model(config.model_config(runs), ws.channels, ws.rate_hz, config.dataset,
                           config.seeds[0])
        model = fit_with_groups(model, ws.X, labels, ws.groups)
        vote = getattr(model, "estimator_", model)          # inside WindowEKFClassifier
        if hasattr(vote, "weights_"):
            info.update({f"weight_{name}": float(w)
                         for (name, _), w in zip(vote.estimators, vote.weights_)})
        return model, ws, info
    svm = replace(config.svm, probability=True)
    if config.search:
        # the inner folds split the units run_cv splits: a single-run class grouped by run
        # would be in one inner test fold only, absent from that fold's training
        tuned, tuned_y, units = ws, labels, ws.groups
        if config.protocol != "paper":
            tuned, tuned_y, units, split, _ = grouped_units(ws, config.single_run_blocks)
            if split:
                info["search_split_classes"] = ",".join(split)
        fx = feature_extractor(tuned)
        # the search picks C and gamma only (the pipeline below is calibrated either way):
        # it tunes the plain SVC, whose parameters are svc__C and svc__gamma
        search = make_search(replace(config.svm, probability=False), config.seeds[0],
                             n_jobs=n_jobs)
        search.fit(fx.transform(tuned.X), tuned_y, groups=units)
        best = search.best_params_
        svm = replace(svm, C=best["svc__C"], gamma=best["svc__gamma"])
        info.update({"best_C": best["svc__C"], "best_gamma": best["svc__gamma"]})
    pipe = inference_pipeline(ws, svm, config.seeds[0])
    pipe.fit(ws.X, labels)
    return pipe, ws, info
