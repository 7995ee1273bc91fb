"""Serving: the whole terrain inference pipeline as one MLflow pyfunc model.

The model takes *aligned samples* (the output of :func:`terrain.io.align.align_streams`, see
:func:`runs_to_model_input`) in long format, one row per sample::

    run (str), t_s (float, s), wx, wy, wz (rad/s), ax, ay, az (m/s^2),
    vel_l, vel_r (m/s), cur_l, cur_r (A)          -- the channels the model needs

at the model's clock rate (``metadata["rate_hz"]``), windows each run itself, runs the
classifier on the raw windows (any model of :mod:`terrain.models.registry`: the SVM computes
its features inside its pipeline, the CNNs their normalisation or spectra) and returns one
row per window::

    run, t_start_s, t_end_s, predicted, proba_<CLASS> ...

Windows holding NaN (a timestamp gap) are dropped and counted in the ``dropped_windows``
attribute of the returned frame; window positions wholly inside a gap of every stream (not a
single sample in them: no data was dropped) are counted apart, in ``empty_windows``; runs
shorter than one window are listed in ``short_runs``. The same
model is served by ``mlflow models serve -m DIR``.

Other input columns are not read, and the answer cannot name them (unlike ``terrain serve``'s
``ignored_columns``): MLflow's signature enforcement removes the columns the input schema
(:func:`model_signature`) lacks before :meth:`TerrainModel.predict` runs, and logs them
itself ("Found extra inputs in the model input that are not defined in the model signature:
[...]. These inputs will be ignored.").
"""

from __future__ import annotations

import contextlib
import json
import tempfile
from collections.abc import Hashable
from pathlib import Path
from urllib.parse import urlparse
from urllib.request import url2pathname
from typing import Any, Sequence

import numpy as np
import pandas as pd

from features.windows import (HUSKY_TRACK_M, WindowConfig, add_derived_channels,
                              check_uniform_clock, derived_track_m, required_streams,
                              window_frame)
from terrain.errors import (ConfigError, DataFormatError, MissingColumnError, NonFiniteError,
                            TimestampError, duplicated)
from terrain.io.align import align_streams
from terrain.io.plausibility import check_accel_units, check_ranges
from terrain.process_state import environment_variable
from terrain.run import TIME, Run
from terrain.serving.model import (load_pipeline, measured_channels, model_vehicle,
                                   new_model_directory, read_model_metadata)
from terrain.serving.request import numeric_column

try:  # mlflow is a hard dependency; the guard keeps the class importable for docs tools
    from mlflow.pyfunc import PythonModel
except ImportError:  # pragma: no cover
    PythonModel = object

PIPELINE_FILE = "pipeline.joblib"
RUN = "run"
#: Schemes of the model URIs :func:`load_model` resolves through MLflow's store.
STORE_SCHEMES = ("models", "runs")
#: What :func:`load_model` accepts, for error messages.
SUPPORTED_URIS = ("a local model directory (terrain train --model-out DIR; or file:///DIR), "
                  "models:/NAME/VERSION (or models:/NAME/latest) or runs:/RUN_ID/PATH, "
                  "both resolved in the tracking store in force")


def input_channels(channels: Sequence[str]) -> list[str]:
    """Raw channels the model input must carry (derived channels are computed inside).

    Parameters
    ----------
    channels : sequence of str
        Channels of the model's windows, possibly including derived wheel channels
        (:data:`features.windows.DERIVED_WHEEL_CHANNELS`).

    Returns
    -------
    list of str
        The raw channels of ``channels``, in order, followed by ``vel_l, vel_r, cur_l,
        cur_r`` (m/s, A) when a derived channel needs them
        (:func:`~terrain.serving.model.measured_channels`).
    """
    return list(measured_channels(channels))


def runs_to_model_input(runs: Sequence[Run], channels: Sequence[str],
                        rate_hz: float) -> tuple[pd.DataFrame, list[str]]:
    """Align runs and stack them into the model's long input format.

    Parameters
    ----------
    runs : sequence of Run
        Runs to predict (labelled or not).
    channels : sequence of str
        Channels of the model (``metadata["channels"]``); see :func:`input_channels`.
    rate_hz : float
        Model clock rate, Hz: each run is resampled to it by
        :func:`terrain.io.align.align_streams`.

    Returns
    -------
    frame : pandas.DataFrame
        ``run, t_s`` and the raw channels.
    skipped : list of str
        Runs lacking a stream the model needs (e.g. no IMU file).
    """
    cols = input_channels(channels)
    need = required_streams(cols)
    parts, skipped = [], []
    for run in runs:
        if any(s not in run.streams for s in need):
            skipped.append(run.run_id)
            continue
        aligned = align_streams(run, need, rate_hz)
        part = aligned[[TIME] + cols].copy()
        part.insert(0, RUN, run.run_id)
        parts.append(part)
    if not parts:
        return pd.DataFrame(columns=[RUN, TIME] + cols), skipped
    return pd.concat(parts, ignore_index=True), skipped


class TerrainModel(PythonModel):
    """MLflow pyfunc wrapper of a fitted classifier on raw windows (SVM pipeline, CNN, ...).

    Context artifact ``pipeline``: the joblib file of the fitted scikit-learn estimator
    (anything with ``classes_`` and ``predict_proba`` on ``(n, n_channels, n_samples)``).
    Settings (channels, window, rate) are passed at construction and pickled with the model.

    Parameters
    ----------
    channels : sequence of str
        Channel order of the windows the pipeline expects.
    window : dict
        :class:`features.windows.WindowConfig` fields (``window_s``, ``hop_s``,
        ``rate_hz``).
    classes : sequence of str
        Terrain classes, in the order of ``predict_proba``.
    track_m : float
        Track width of the derived wheel channels, m (the training runs' vehicle's,
        :func:`terrain.serving.model.model_track_m`).
    """

    def __init__(self, channels: Sequence[str] = (), window: dict | None = None,
                 classes: Sequence[str] = (), track_m: float = HUSKY_TRACK_M) -> None:
        self.channels = list(channels)
        self.window = dict(window or {})
        self.classes = list(classes)
        self.track_m = float(track_m)
        self._pipeline = None

    def load_context(self, context: Any) -> None:
        """Load the fitted classifier; settings from ``context.model_config`` when the model
        was logged from code (:mod:`terrain.serving.pyfunc_entry`).

        Parameters
        ----------
        context : mlflow.pyfunc.PythonModelContext
            ``artifacts["pipeline"]`` (the joblib file) and ``model_config``.

        Raises
        ------
        ConfigError
            The model config lacks a setting, or the pipeline file does not hold a fitted
            classifier (:func:`terrain.serving.model.load_pipeline`, which names the file).
        """
        config = getattr(context, "model_config", None) or {}
        settings = (self.channels, self.window, self.classes, self.track_m)
        if config:
            missing = [k for k in ("channels", "window", "classes") if k not in config]
            if missing:
                raise ConfigError(f"model config lacks {missing} (flavor python_function of "
                                  "the model's MLmodel)")
            # models saved before the setting existed derived their channels with the Husky's
            settings = (list(config["channels"]), dict(config["window"]),
                        list(config["classes"]), float(config.get("track_m", HUSKY_TRACK_M)))
        # kept together once the pipeline is read: a failed load leaves the model as it was
        pipeline = load_pipeline(context.artifacts["pipeline"])
        (self.channels, self.window, self.classes, self.track_m), self._pipeline = \
            settings, pipeline

    def predict(self, context: Any, model_input: pd.DataFrame, params: dict | None = None
                ) -> pd.DataFrame:
        """Per-window terrain predictions for aligned samples of one or more runs.

        Parameters
        ----------
        context : mlflow.pyfunc.PythonModelContext
            MLflow context; used to load the pipeline if :meth:`load_context` has not run.
        model_input : pandas.DataFrame
            Aligned samples in the long format of the module docstring (``run``, ``t_s`` in
            s, raw channels in SI units) at the model's rate.
        params : dict or None
            MLflow inference parameters (unused).

        Returns
        -------
        pandas.DataFrame
            One row per window, see :func:`predict_windows`.

        Raises
        ------
        MissingColumnError
            A required input column is missing.
        NonNumericError
            A time or channel cell that is not a number (text, a boolean).
        ImplausibleValueError
            A value beyond its channel's plausibility range (:mod:`terrain.io.plausibility`).
        UnitError
            An accelerometer in g (the readers' rule ``accel_units``).
        DataFormatError
            Samples not at the model's rate, timestamps not increasing within a run, or a
            sample without a run.
        """
        if self._pipeline is None:
            self.load_context(context)
        return predict_windows(self._pipeline, model_input, self.channels,
                               WindowConfig(**self.window), self.classes, self.track_m)


def predict_windows(pipeline: Any, samples: pd.DataFrame, channels: Sequence[str],
                    config: WindowConfig, classes: Sequence[str],
                    track_m: float = HUSKY_TRACK_M) -> pd.DataFrame:
    """Window aligned samples per run and predict (see module docstring for the format).

    Parameters
    ----------
    pipeline : estimator
        Fitted classifier with ``classes_`` and ``predict_proba`` on raw windows
        ``(n_windows, n_channels, n_samples)``.
    samples : pandas.DataFrame
        Aligned samples: ``run``, ``t_s`` (s, strictly increasing within a run) and the
        channels of :func:`input_channels` (SI units), at ``config.rate_hz``. Other columns
        are not read (through MLflow they never arrive: see the module docstring).
    channels : sequence of str
        Channel order of the windows (derived channels are added from the raw ones).
    config : WindowConfig
        Window length and hop (s) and clock rate (Hz) of the model.
    classes : sequence of str
        Classes whose ``proba_<CLASS>`` columns are returned (0 for a class the pipeline
        does not know).
    track_m : float
        Track width B of the derived ``yaw_rate_wheels`` channel, m (the model's,
        :func:`terrain.serving.model.model_track_m`).

    Returns
    -------
    pandas.DataFrame
        ``run, t_start_s, t_end_s`` (s), ``predicted`` and ``proba_<CLASS>`` per window; its
        ``attrs["dropped_windows"]`` counts windows of data dropped for holding NaN (a
        timestamp gap), ``attrs["empty_windows"]`` the window positions wholly inside a gap
        of every stream (no sample at all, so not counted as dropped),
        ``attrs["window_tail_s"]`` the time after each run's last window, which no window
        covers (s, summed over the runs), ``attrs["between_windows_s"]`` the time between
        windows cut at a hop longer than the window (s, summed over the runs), and
        ``attrs["short_runs"]`` lists the runs shorter than one window (no row).

    Raises
    ------
    MissingColumnError
        A required input column is missing.
    NonNumericError
        A time or channel cell that is not a number (text, a boolean); names the column and
        row.
    ImplausibleValueError
        A value beyond its channel's plausibility range (:func:`terrain.io.plausibility.
        check_ranges`).
    UnitError
        A run whose accelerometer reads in g (the readers' rule ``accel_units``,
        :func:`terrain.io.plausibility.check_accel_units`, on its finite samples).
    NonFiniteError
        A NaN or infinite timestamp (names the run and the row of ``samples``).
    TimestampError
        Timestamps not strictly increasing within a run, or a step longer than 1.5 sample
        periods (a hole without rows: a gap must be NaN rows on the uniform clock); names
        the run and the row of ``samples`` (0-based, runs interleaved or not).
    DataFormatError
        A median sample rate more than 1 % off ``config.rate_hz``, a sample without a
        run (``run`` missing: names the first row), a run named by a list or a mapping
        (names the first row), or two runs given as values that read alike (``1`` and
        ``"1"``: the answer would name both ``"1"``).
    """
    cols = [RUN, TIME] + input_channels(channels)
    missing = [c for c in cols if c not in samples.columns]
    if missing:
        raise MissingColumnError(f"model input lacks column(s) {missing}; expected {cols}",
                                 "model input", missing[0])
    # numbers only, as floats: text failed later with Python's bare ValueError (the
    # plausibility ranges once looked at float columns alone: 1000 m/s as integers passed)
    rows = np.arange(len(samples))
    samples = samples.assign(**{c: numeric_column(samples, c, rows, "model input")
                                for c in cols[1:]})
    # the readers' plausibility ranges also guard served input (1e300 would overflow features)
    check_ranges(samples, "model input", {c: c for c in cols[2:]})
    no_run = samples[RUN].isna().to_numpy()
    if no_run.any():  # groupby would leave these samples out without a word
        row = int(np.flatnonzero(no_run)[0])
        raise DataFormatError(f"{int(no_run.sum())} sample(s) without a run (every sample "
                              "names the run it belongs to)", "model input", RUN, row)
    # a run is named by a value (text, a number); a list or a mapping (JSON) cannot be
    # grouped on: pandas failed with Python's bare "unhashable type"
    runs = samples[RUN].to_numpy()
    odd = (np.flatnonzero([not isinstance(r, Hashable) for r in runs])
           if runs.dtype == object else np.empty(0, dtype=int))
    if odd.size:
        row = int(odd[0])
        raise DataFormatError(f"{odd.size} sample(s) whose run name is a "
                              f"{type(samples[RUN].iat[row]).__name__}, not text or a number",
                              "model input", RUN, row)
    # the answer names a run str(run): 1 and "1" are two runs to groupby, one name there
    alike = duplicated([str(r) for r in pd.unique(samples[RUN])])
    if alike:
        raise DataFormatError(f"runs {alike} given as different values (a number and text?) "
                              "would be answered under the same name; give each run one "
                              "name", "model input", RUN)
    out, dropped, empty, tail, between, short = [], 0, 0, 0.0, 0.0, []
    samples = samples.reset_index(drop=True)    # errors name the request's row
    for run_id, frame in samples.groupby(RUN, sort=False):
        at = frame.index.to_numpy()     # request row of each of the run's samples
        frame = frame.reset_index(drop=True)
        t = frame[TIME].to_numpy(dtype=float)
        if not np.isfinite(t).all():
            row = int(np.flatnonzero(~np.isfinite(t))[0])
            raise NonFiniteError(f"non-finite timestamp {t[row]}",
                                 f"model input, run {run_id}", TIME, int(at[row]))
        dt = np.diff(t)
        if (dt <= 0).any():
            row = int(np.flatnonzero(dt <= 0)[0]) + 1
            raise TimestampError("timestamps must increase strictly within a run",
                                 f"model input, run {run_id}", TIME, int(at[row]))
        check_uniform_clock(t, config.rate_hz, f"model input, run {run_id}", at)
        if {"ax", "ay", "az"} <= set(frame.columns):
            # the readers' rule accel_units on the run's live samples (NaN rows are gaps):
            # an accelerometer in g was classified as if gravity were 1 m/s^2 (its likely
            # finding, a dead sensor, is the readers' to warn of: not repeated here)
            acc = frame[[TIME, "ax", "ay", "az"]]
            check_accel_units(acc[np.isfinite(acc.to_numpy(dtype=float)).all(axis=1)],
                              f"model input, run {run_id}", [])
        frame = add_derived_channels(frame, track_m)
        X, t0, t1, _, counts = window_frame(frame, channels, config)
        empty += counts["empty_gap"]
        dropped += counts["dropped_gap"]
        tail += counts["window_tail_s"]
        between += counts["between_windows_s"]
        if len(X) == 0:
            if len(frame) < config.n_samples:
                short.append(str(run_id))   # no window fits: named, not left out unsaid
            continue
        proba = pipeline.predict_proba(X)
        order = list(pipeline.classes_)
        part = pd.DataFrame({RUN: str(run_id), "t_start_s": t0, "t_end_s": t1,
                             "predicted": np.asarray(order, dtype=object)[proba.argmax(1)]})
        for c in classes:
            part[f"proba_{c}"] = proba[:, order.index(c)] if c in order else 0.0
        out.append(part)
    columns = [RUN, "t_start_s", "t_end_s", "predicted"] + [f"proba_{c}" for c in classes]
    result = pd.concat(out, ignore_index=True) if out else pd.DataFrame(columns=columns)
    result = result[columns]
    result.attrs.update(dropped_windows=dropped, empty_windows=empty, window_tail_s=tail,
                        between_windows_s=between, short_runs=short)
    return result


def model_signature(channels: Sequence[str], classes: Sequence[str]):
    """MLflow signature of :class:`TerrainModel` (input samples, output windows).

    Parameters
    ----------
    channels : sequence of str
        Channels of the model; the input schema holds those of :func:`input_channels`.
    classes : sequence of str
        Terrain classes, one ``proba_<CLASS>`` output column each.

    Returns
    -------
    mlflow.models.ModelSignature
        Input ``run`` (string), ``t_s`` and channels (double); output ``run``,
        ``t_start_s``, ``t_end_s``, ``predicted`` and the probabilities.
    """
    from mlflow.models import ModelSignature
    from mlflow.types import ColSpec, Schema

    inputs = Schema([ColSpec("string", RUN), ColSpec("double", TIME)]
                    + [ColSpec("double", c) for c in input_channels(channels)])
    outputs = Schema([ColSpec("string", RUN), ColSpec("double", "t_start_s"),
                      ColSpec("double", "t_end_s"), ColSpec("string", "predicted")]
                     + [ColSpec("double", f"proba_{c}") for c in classes])
    return ModelSignature(inputs=inputs, outputs=outputs)


def _components(estimator: Any) -> list:
    """The estimator and every estimator nested in it (pipeline steps, ensemble members, the
    fitted estimator a wrapper such as ``WindowEKFClassifier`` holds)."""
    out = [estimator]
    for _, step in getattr(estimator, "steps", []):
        out += _components(step)
    for member in getattr(estimator, "estimators_", []):
        out += _components(member)
    inner = getattr(estimator, "estimator_", None)
    if inner is not None:
        out += _components(inner)
    return out


def pip_requirements(pipeline: Any) -> list[str]:
    """Pinned pip requirements of a fitted model (torch/skorch, aeon and numba only where
    used).

    Parameters
    ----------
    pipeline : estimator
        Fitted classifier.

    Returns
    -------
    list of str
        Requirement strings for :func:`mlflow.pyfunc.save_model`.
    """
    from importlib.metadata import version

    reqs = [f"scikit-learn=={version('scikit-learn')}", "numpy", "pandas", "scipy", "joblib"]
    modules = {type(c).__module__ for c in _components(pipeline)}
    if "terrain.models.cnn" in modules:
        reqs += [f"torch=={version('torch').split('+')[0]}", f"skorch=={version('skorch')}"]
    if "terrain.models.minirocket" in modules:
        reqs.append(f"aeon=={version('aeon')}")
    if "terrain.models.window_ekf" in modules:     # the compiled EKF loop
        reqs.append(f"numba=={version('numba')}")
    return reqs


def _model_kwargs(pipeline: Any, channels: Sequence[str], window: WindowConfig,
                  classes: Sequence[str], metadata: dict, tmp: Path) -> dict:
    import joblib

    path = tmp / PIPELINE_FILE
    joblib.dump(pipeline, path)
    window_d = {"window_s": window.window_s, "hop_s": window.hop_s, "rate_hz": window.rate_hz}
    # the live windows derive yaw_rate_wheels with the track its training windows used (a
    # StreamModel's own, terrain.serving.recipes.fit_stream_model), else the training
    # vehicle's (make_windows: each run's own)
    track_m = float(metadata["track_m"]) if metadata.get("track_m") is not None \
        else derived_track_m(model_vehicle(metadata))
    root = Path(__file__).resolve().parents[2]  # the checkout: terrain/, features/
    return dict(
        python_model=str(Path(__file__).with_name("pyfunc_entry.py")),
        model_config={"channels": list(channels), "window": window_d,
                      "classes": list(classes), "track_m": track_m},
        artifacts={"pipeline": str(path)},
        signature=model_signature(channels, classes),
        code_paths=[str(root / "terrain"), str(root / "features")],
        pip_requirements=pip_requirements(pipeline),
        metadata={**metadata, "channels": list(channels), "classes": list(classes),
                  "track_m": track_m, **window_d},
    )


def save_model(path: str | Path, pipeline: Any, channels: Sequence[str],
               window: WindowConfig, classes: Sequence[str], metadata: dict,
               input_example: pd.DataFrame | None = None, progress: bool = True) -> Path:
    """Save the inference pipeline as an MLflow model directory at ``path``.

    Parameters
    ----------
    path : str or pathlib.Path
        Model directory to create (absent or empty).
    pipeline : estimator
        Fitted classifier on raw windows (see :class:`TerrainModel`), stored with joblib.
    channels : sequence of str
        Channel order of the windows.
    window : WindowConfig
        Window settings of the model (``window_s``, ``hop_s`` in s, ``rate_hz`` in Hz).
    classes : sequence of str
        Terrain classes, in the order of ``predict_proba``.
    metadata : dict
        Extra model metadata (dataset, signals...); channels, classes and window settings
        are added to it, and ``track_m`` (m) where it lacks one: the track width of the
        vehicle it names (:func:`features.windows.derived_track_m` of
        :func:`terrain.serving.model.model_vehicle`).
    input_example : pandas.DataFrame, optional
        Aligned samples in the model's input format, stored with the model.
    progress : bool
        Let MLflow show its artifact progress bars (validating the input example downloads
        the model).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ConfigError
        If ``path`` exists and is not empty.
    """
    import mlflow.pyfunc

    path = Path(path)
    with new_model_directory(path) as stage, tempfile.TemporaryDirectory() as tmp, \
            artifact_progress(progress):
        mlflow.pyfunc.save_model(path=str(stage), input_example=input_example, **_model_kwargs(
            pipeline, channels, window, classes, metadata, Path(tmp)))
    return path


def log_model(pipeline: Any, channels: Sequence[str], window: WindowConfig,
              classes: Sequence[str], metadata: dict,
              input_example: pd.DataFrame | None = None, progress: bool = True) -> str:
    """Log the inference pipeline in the active MLflow run (registering it is
    :func:`register_model`'s).

    Parameters
    ----------
    pipeline : sklearn.pipeline.Pipeline
        The fitted ``features -> scaler -> SVC`` pipeline.
    channels : sequence of str
        Channel order of the windows.
    window : WindowConfig
        Window settings of the model.
    classes : sequence of str
        Terrain classes.
    metadata : dict
        Extra model metadata (dataset, signals...).
    input_example : pandas.DataFrame, optional
        Aligned samples in the model's input format (a few windows), stored with the model.
    progress : bool
        Let MLflow show its artifact progress bars (upload, input-example validation).

    Returns
    -------
    str
        The model URI (``models:/...``), unregistered.
    """
    import mlflow.pyfunc

    with tempfile.TemporaryDirectory() as tmp, artifact_progress(progress):
        info = mlflow.pyfunc.log_model(name="terrain-model", input_example=input_example,
                                       **_model_kwargs(pipeline, channels, window, classes,
                                                       metadata, Path(tmp)))
    return info.model_uri


def register_model(model_uri: str, name: str) -> str:
    """Register a logged model under ``name`` in MLflow's model registry.

    Registering apart from :func:`log_model` lets a command register its model as the last
    step of its run: a failure after the logging (a full disk while saving ``--model-out``,
    Ctrl-C) then ends the run ``FAILED`` with no version of ``name`` pointing at it, which
    ``models:/<name>/latest`` would serve.

    Parameters
    ----------
    model_uri : str
        URI of the logged model (``models:/...`` as :func:`log_model` returns it, or
        ``runs:/RUN_ID/PATH``).
    name : str
        Registry name (created when missing; otherwise a new version of it).

    Returns
    -------
    str
        The version number created.
    """
    import mlflow

    return str(mlflow.register_model(model_uri, name).version)


#: the contexts of :func:`artifact_progress` hiding the bars now, and the value the first
#: found (restored by the last to leave); guarded by :data:`_PROGRESS_LOCK`
_PROGRESS_HIDDEN = environment_variable("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")
"""MLflow's artifact progress bars hidden while any :func:`artifact_progress` context is open."""


@contextlib.contextmanager
def artifact_progress(enabled: bool):
    """Context in which MLflow shows (or hides) its artifact up/download progress bars.

    MLflow reads ``MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR`` from the environment at every
    transfer; it is set inside the context and restored after, on success or failure.
    The environment is the process's: contexts open at once in several threads (models
    loaded concurrently) share one setting, which the last to leave restores to what the
    first found (:class:`terrain.process_state.SharedSetting`; each restoring what it found
    left ``"false"`` for ever when they overlapped, and the first to leave showed the bars
    to the others).

    Parameters
    ----------
    enabled : bool
        False hides the bars (a command's ``--no-progress``); True leaves the setting as is.

    Yields
    ------
    None
    """
    if enabled:
        yield
        return
    with _PROGRESS_HIDDEN:
        yield


def local_model_dir(uri: str | Path) -> Path | None:
    """The local directory a model URI names, or None for a URI of MLflow's store.

    Parameters
    ----------
    uri : str or pathlib.Path
        A path, a ``file:`` URI, or a ``models:/`` / ``runs:/`` URI.

    Returns
    -------
    pathlib.Path or None
        The directory for an existing path, a path without a scheme or a ``file:`` URI (not
        checked further here); None for ``models:/...`` and ``runs:/...``.

    Raises
    ------
    ConfigError
        Any other scheme (``http:``, ``s3:``, ...): the message lists the supported URIs.
    """
    if isinstance(uri, Path) or Path(uri).exists():
        return Path(uri)
    parsed = urlparse(uri)
    scheme = parsed.scheme.lower()
    if scheme == "" or len(scheme) == 1:  # a path (a Windows drive letter is no scheme)
        return Path(uri)
    if scheme == "file":
        return Path(url2pathname(parsed.path))
    if scheme in STORE_SCHEMES:
        return None
    raise ConfigError(f"unsupported model URI {uri!r} (scheme {scheme}:): give "
                      f"{SUPPORTED_URIS}")


def load_model(uri: str | Path, progress: bool = True) -> tuple[Any, dict]:
    """Load a saved or logged terrain model; returns the pyfunc model and its metadata.

    A ``models:/`` or ``runs:/`` model is first downloaded from the store; the directory is
    then checked (:func:`terrain.serving.model.read_model_metadata`, and the fitted
    classifier by :meth:`TerrainModel.load_context`) before MLflow loads it, so a corrupt
    model gives a :class:`~terrain.errors.ConfigError` naming its file.

    Parameters
    ----------
    uri : str or pathlib.Path
        Model directory (or ``file:`` URI) or MLflow URI (``runs:/RUN_ID/PATH``,
        ``models:/NAME/VERSION``), resolved in MLflow's process-wide store (set by the
        ``terrain`` entry point with :func:`terrain.tracking.activate_store`).
    progress : bool
        Show MLflow's download progress bars (see :func:`artifact_progress`).

    Returns
    -------
    model : mlflow.pyfunc.PyFuncModel
        The loaded model (its ``predict`` is :meth:`TerrainModel.predict`).
    meta : dict
        Model metadata: ``channels``, ``classes``, ``window_s``, ``hop_s``, ``rate_hz`` and
        the extra metadata given at saving.

    Raises
    ------
    ConfigError
        An unsupported URI scheme (:func:`local_model_dir`); a ``models:/`` / ``runs:/``
        URI whose store cannot be used (:func:`terrain.tracking.check_store`); a directory
        that is not a terrain model or holds a malformed ``MLmodel`` or pipeline file
        (names the file).
    mlflow.exceptions.MlflowException
        A ``models:/`` / ``runs:/`` URI the store does not resolve, or a model MLflow
        refuses.
    OSError
        A file of the model that cannot be read.
    """
    import mlflow.pyfunc

    local = local_model_dir(uri)
    with artifact_progress(progress):
        if local is None:
            from mlflow.artifacts import download_artifacts

            from terrain.tracking import check_store
            check_store(mlflow.get_tracking_uri())   # at once, not after MLflow's retries
            local = Path(download_artifacts(artifact_uri=str(uri)))
        meta = read_model_metadata(local)
        model = mlflow.pyfunc.load_model(str(local))
    return model, meta


def metadata_json(meta: dict) -> str:
    """Model metadata as compact JSON (for printing).

    Parameters
    ----------
    meta : dict
        Metadata as returned by :func:`load_model`.

    Returns
    -------
    str
        One-line JSON with sorted keys; non-JSON values are written with ``str``.
    """
    return json.dumps(meta, sort_keys=True, default=str)
