"""The model a stream is classified with: fitted pipeline + channels + window + classes.

A model trained by ``terrain train`` is an MLflow model directory whose ``MLmodel`` file
carries the settings in its ``metadata`` (``channels``, ``classes``, ``window_s``,
``rate_hz``) and whose ``artifacts/pipeline.joblib`` is the fitted scikit-learn pipeline
(raw windows ``(n, n_channels, n_samples)`` in, ``predict_proba`` out). It is read here
directly, so the streaming service needs no MLflow server or pyfunc wrapper.
"""

from __future__ import annotations

import contextlib
import errno
import math
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Iterator, Mapping, Sequence

import numpy as np
import yaml

from features.windows import DERIVED_WHEEL_CHANNELS, HUSKY_TRACK_M, WindowConfig
from terrain.errors import ConfigError, config_positive, duplicated
from terrain.io.shipped import dataset_vehicle
from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS, Run

PIPELINE_ARTIFACT = Path("artifacts") / "pipeline.joblib"


@contextlib.contextmanager
def new_model_directory(path: str | Path) -> Iterator[Path]:
    """Write a model directory whole or not at all.

    Yields a fresh, absent path beside ``path`` (same parent, so the same file system) to
    write the model to; on a clean exit it is renamed to ``path`` in one step, and on any
    error (an interrupt included) it is removed, so ``path`` never holds half a model that
    a later save refuses and a later load misreads.

    Parameters
    ----------
    path : str or pathlib.Path
        Model directory to create (absent or empty).

    Yields
    ------
    pathlib.Path
        The staging directory's path (absent: the writer creates it, as
        :func:`mlflow.pyfunc.save_model` does).

    Raises
    ------
    ConfigError
        ``path`` exists and is not an empty directory, at the start or when the model is
        renamed to it (another save of the same path finished first: its model is kept).
    """
    path = Path(path)
    if path.exists() and (not path.is_dir() or any(path.iterdir())):
        raise ConfigError(f"model directory {path} exists and is not empty")
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{path.name}.partial-", dir=path.parent))
    stage.rmdir()
    try:
        yield stage
        try:
            if path.exists():
                path.rmdir()
            stage.rename(path)
        except OSError as exc:
            # another save of the same path (another process) finished first: its model is
            # kept, this one is refused as at the start (a bare "Directory not empty")
            if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR):
                raise
            raise ConfigError(f"model directory {path} exists and is not empty (written "
                              "meanwhile by another save)") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)


@dataclass(frozen=True)
class StreamModel:
    """A fitted window classifier and the settings it was trained with.

    Parameters
    ----------
    pipeline : object
        Fitted scikit-learn estimator with ``predict_proba`` and ``classes_`` taking windows
        ``(n_windows, n_channels, n_samples)``.
    channels : tuple of str
        Channel order of the windows (may include derived wheel channels).
    window : WindowConfig
        Window length and aligned clock rate of the training windows.
    classes : tuple of str
        Terrain classes, in the order of the decision's ``proba_<CLASS>`` columns.
    metadata : Mapping
        The model directory's whole ``metadata`` (``dataset``, ``vehicle``, ...), read-only;
        empty for a model built in memory. Not compared or hashed.

    Raises
    ------
    ConfigError
        The pipeline's ``classes_`` hold none of ``classes`` (labels of another training,
        another case, integers for text): every window's probabilities would read 0 for
        every class, and the service decided the first class at confidence 1/K with its
        targets, unflagged. (A class the pipeline lacks, the others present, reads 0.)
        A class or a channel named more than once (as text: ``1`` and ``"1"`` are one
        ``proba_1`` column): the service read one class's probability twice (summing past
        1) and the decisions had two ``proba_<CLASS>`` columns.
    """

    pipeline: Any
    channels: tuple[str, ...]
    window: WindowConfig
    classes: tuple[str, ...]
    metadata: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}),
                                        compare=False, hash=False)

    def __post_init__(self) -> None:
        for what, names in (("classes", self.classes), ("channels", self.channels)):
            twice = duplicated([str(n) for n in names])
            if twice:
                raise ConfigError(f"StreamModel: {what} {twice[:10]!r:.200} named more than "
                                  f"once in {list(names)[:20]!r:.200}; name each once")
        held = getattr(self.pipeline, "classes_", None)
        # the service's own lookup (StreamService: a class of the model in classes_)
        if held is not None and not any(c in list(held) for c in self.classes):
            raise ConfigError(f"StreamModel: the pipeline's classes_ "
                              f"{[c for c in held][:10]!r:.200} hold none of the model's "
                              f"classes {list(self.classes)[:10]!r:.200}: every window would "
                              "read probability 0 for every class")

    def __reduce__(self):
        """Copies and pickles rebuild the model with a copy of its ``metadata`` as read-only
        as it was (a mapping proxy, the default, cannot be pickled: ``copy.deepcopy`` of a
        model, and of every service, raised TypeError)."""
        meta = self.metadata
        if isinstance(meta, MappingProxyType):
            return _frozen_model, (self.pipeline, self.channels, self.window, self.classes,
                                   dict(meta))
        return type(self), (self.pipeline, self.channels, self.window, self.classes, meta)

    @property
    def raw_channels(self) -> tuple[str, ...]:
        """Measured channels the model needs (:func:`measured_channels`)."""
        return measured_channels(self.channels)


def _frozen_model(pipeline: Any, channels: tuple[str, ...], window: WindowConfig,
                  classes: tuple[str, ...], metadata: dict) -> StreamModel:
    """A :class:`StreamModel` whose ``metadata`` is a read-only view of ``metadata`` (what
    :meth:`StreamModel.__reduce__` rebuilds)."""
    return StreamModel(pipeline, channels, window, classes, MappingProxyType(metadata))


def measured_channels(channels: Sequence[str]) -> tuple[str, ...]:
    """Measured channels that windows of ``channels`` are built from.

    Parameters
    ----------
    channels : sequence of str
        Window channels, derived wheel channels included.

    Returns
    -------
    tuple of str
        ``channels`` without the derived wheel channels, plus the four wheel channels they
        are derived from where one is asked for
        (:func:`features.windows.add_derived_channels`).
    """
    raw = [c for c in channels if c not in DERIVED_WHEEL_CHANNELS]
    if any(c in DERIVED_WHEEL_CHANNELS for c in channels):
        raw += [c for c in WHEEL_CHANNELS if c not in raw]
    return tuple(raw)


def model_vehicle(metadata: Mapping[str, Any]) -> str | None:
    """The vehicle whose runs trained a model.

    Parameters
    ----------
    metadata : Mapping
        The model directory's ``metadata``: its ``vehicle`` (``terrain train`` writes the
        training runs' vehicle; the live-sim classifier the simulated one), else the vehicle
        of its shipped ``dataset`` (:func:`terrain.io.shipped.dataset_vehicle`; models saved
        before the key existed).

    Returns
    -------
    str or None
        A name of :data:`terrain.vehicles.VEHICLE_NAMES`; None when the metadata names
        neither.
    """
    vehicle = metadata.get("vehicle")
    if isinstance(vehicle, str) and vehicle:
        return vehicle.lower()
    return dataset_vehicle(str(metadata.get("dataset", "")))


def model_track_m(metadata: Mapping[str, Any]) -> float:
    """Track width B of a model's derived wheel channels, m.

    The live windows must compute ``yaw_rate_wheels = (vel_r - vel_l) / B`` as the training
    windows did: the model's ``track_m``, written at saving (:func:`terrain.serving.pyfunc.
    save_model`: the track the model was fitted with, else the one of its training runs'
    vehicle, :func:`features.windows.derived_track_m` of :func:`model_vehicle`).

    Parameters
    ----------
    metadata : Mapping
        The model directory's ``metadata`` (:func:`read_model_metadata` checks that a
        ``track_m`` there is a positive number).

    Returns
    -------
    float
        ``metadata["track_m"]``; :data:`features.windows.HUSKY_TRACK_M` for a model saved
        before the key existed (every window then used the Husky's track).
    """
    value = metadata.get("track_m")
    return HUSKY_TRACK_M if value is None else float(value)


def training_steps_s(runs: Sequence[Run], channels: Sequence[str]) -> dict[str, float]:
    """Usual sample step of each channel in a model's training runs, s.

    The streaming service judges a stream's first steps against it
    (:meth:`~terrain.serving.buffers.RingBuffer.usual_step`): before a stream has sent a
    few steps, the steps it sent may all be holes (samples at 0 and 0.615 s of a 6.5 Hz
    wheel stream, then none until 2 s), and only a step known beforehand tells them from
    the stream's rate.

    Parameters
    ----------
    runs : sequence of Run
        The training runs.
    channels : sequence of str
        Channels of the model's windows (derived wheel channels stand for the wheel
        channels they are derived from, :func:`measured_channels`).

    Returns
    -------
    dict of str to float
        For each measured channel some run holds, the median over the runs holding it of the median
        step of the stream holding it (:meth:`Run.rate_hz`), s; channels no run holds are
        left out.

    Raises
    ------
    DataFormatError
        A stream holding one of ``channels`` has fewer than 2 samples or times out of
        order (:meth:`Run.rate_hz`).
    """
    channels = measured_channels(channels)
    steps: dict[str, list[float]] = {}
    for run in runs:
        for stream, frame in run.streams.items():
            held = [c for c in channels if c in frame.columns]
            if held:
                step = 1.0 / run.rate_hz(stream)
                for c in held:
                    steps.setdefault(c, []).append(step)
    return {c: float(np.median(steps[c])) for c in channels if c in steps}


def model_channel_steps_s(metadata: Mapping[str, Any]) -> dict[str, float]:
    """The training runs' usual sample step of a model's channels, s.

    Parameters
    ----------
    metadata : Mapping
        The model's ``metadata``; its ``channel_steps_s`` (written at training,
        :func:`training_steps_s`) is a mapping of channel names to positive numbers (s) or
        absent.

    Returns
    -------
    dict of str to float
        ``metadata["channel_steps_s"]``; empty for a model saved before the key existed or
        built in memory without it.

    Raises
    ------
    ConfigError
        ``channel_steps_s`` is neither absent, None nor a mapping of names to finite
        numbers > 0 (a boolean included).
    """
    value = metadata.get("channel_steps_s")
    if value is None:
        return {}
    if not isinstance(value, Mapping) or not all(
            isinstance(c, str) and _is_step(v) for c, v in value.items()):
        raise ConfigError(f"metadata channel_steps_s must map channel names to steps > 0 "
                          f"(s), got {value!r}"[:300])
    return {str(c): float(v) for c, v in value.items()}


def _is_step(value) -> bool:
    """Whether ``value`` is a real number > 0 finite as a float (a NumPy scalar included,
    a boolean not; an integer beyond the float range raised a bare OverflowError)."""
    try:
        config_positive("channel_steps_s", step=value)
        return math.isfinite(float(value))
    except (ConfigError, OverflowError):
        return False


def imu_rate_note(channels, model_rate_hz: float, run: Run) -> str | None:
    """A note for a run whose IMU is sampled slower than the model's windows.

    The windows are aligned to the model's rate, so a slower IMU is interpolated up: its
    windows hold nothing above the run's Nyquist frequency, where a model trained on
    faster IMU windows found part of its evidence (a 50 Hz Vulpi run before a 100 Hz
    BorealTC model ran without a word; a CLI fuzz found it). The wheel stream is slower
    than the model's rate by design (~6.5 Hz in BorealTC, interpolated in training too)
    and is not named.

    Parameters
    ----------
    channels : sequence of str
        The model's input channels.
    model_rate_hz : float
        The model's window rate, Hz.
    run : Run
        The run given to it.

    Returns
    -------
    str or None
        ``note: ...``; None when the model reads no IMU channel, the run has no IMU, or
        the run's IMU rate is within 5 % of the model's or above it.
    """
    if not (set(channels) & set(IMU_CHANNELS)) or not run.has_imu:
        return None
    rate_hz = run.rate_hz("imu")
    if not rate_hz < 0.95 * model_rate_hz:
        return None
    return (f"note: run {run.run_id}'s IMU is sampled at {rate_hz:.3g} Hz, the model's windows "
            f"at {model_rate_hz:g} Hz: its IMU is interpolated up and holds nothing above "
            f"{rate_hz / 2:.3g} Hz, where the model may have learned from its training runs")


def other_vehicle_note(metadata: Mapping[str, Any], run_vehicle: str, run_id: str) -> str | None:
    """A note for a run recorded by another vehicle than the one whose runs trained the model.

    The classifier's features (motor currents in A, wheel speeds, vibration) belong to the
    vehicle that recorded its training runs; on another vehicle its decisions are a transfer
    that nothing here has measured, and the user is told so.

    Parameters
    ----------
    metadata : Mapping
        The model directory's ``metadata`` (:func:`model_vehicle`).
    run_vehicle : str
        The run's vehicle (``meta_XX.json`` ``vehicle``; the readers' default is the Husky).
    run_id : str
        The run, named in the note.

    Returns
    -------
    str or None
        ``note: ...``; None when the vehicles agree or the model names none.
    """
    trained = model_vehicle(metadata)
    if trained is None or trained == str(run_vehicle).lower():
        return None
    dataset = metadata.get("dataset")
    where = f" (dataset {dataset})" if dataset else ""
    return (f"note: run {run_id} was recorded by vehicle {run_vehicle!r} (its meta_XX.json), "
            f"the model was trained on {trained!r} runs{where}: its decisions carry the "
            "model to another vehicle, which nothing here has measured")


#: Metadata keys every terrain model directory carries (``terrain train --model-out``).
REQUIRED_METADATA = ("channels", "classes", "window_s", "rate_hz")


def read_mlmodel(mlmodel: str | Path) -> dict:
    """Parse an MLflow ``MLmodel`` file.

    Parameters
    ----------
    mlmodel : str or Path
        The ``MLmodel`` file.

    Returns
    -------
    dict
        Its YAML mapping (``flavors``, ``metadata``, ...).

    Raises
    ------
    ConfigError
        Not UTF-8 text, not valid YAML (the message gives the line and column), empty or
        not a mapping; the message names the file.
    OSError
        The file is missing or unreadable.
    """
    mlmodel = Path(mlmodel)
    try:
        doc = yaml.safe_load(mlmodel.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{mlmodel}: not UTF-8 text (byte offset {exc.start})") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise ConfigError(f"{mlmodel}: not valid YAML ({problem}{where})") from None
    if not isinstance(doc, dict):
        raise ConfigError(f"{mlmodel}: empty or not a YAML mapping (an MLflow MLmodel file "
                          "maps flavors, metadata, ...)")
    return doc


def read_model_metadata(path: str | Path) -> dict:
    """Check a terrain model directory's files and return its ``MLmodel`` metadata.

    The one place where a model directory's settings are validated, shared by
    :func:`load_stream_model` and :func:`terrain.serving.pyfunc.load_model`; the fitted
    classifier itself is checked by :func:`load_pipeline`.

    Parameters
    ----------
    path : str or Path
        MLflow model directory.

    Returns
    -------
    dict
        The ``metadata`` mapping of ``MLmodel``: at least ``channels`` and ``classes``
        (non-empty lists of names), ``window_s`` and ``rate_hz`` (positive numbers, s and
        Hz); ``hop_s`` is a positive number or None (None, as :class:`WindowConfig` reads
        it: windows one window length apart); ``track_m``, where present, a positive number
        (m, :func:`model_track_m`); ``channel_steps_s``, where present, a mapping of
        channel names to positive numbers (s, :func:`model_channel_steps_s`).

    Raises
    ------
    ConfigError
        No such directory, missing ``MLmodel`` or pipeline artifact, an ``MLmodel`` that is
        not UTF-8 YAML text, is empty or not a mapping, or whose metadata lacks or mistypes
        a setting or names a class or channel more than once; the message names the file
        (and the YAML line).
    """
    path = Path(path)
    mlmodel, pipe_file = path / "MLmodel", path / PIPELINE_ARTIFACT
    if not path.exists():
        raise ConfigError(f"model directory {path} does not exist")
    if not mlmodel.is_file() or not pipe_file.is_file():
        raise ConfigError(f"{path} is not a terrain model directory (needs MLmodel and "
                          f"{PIPELINE_ARTIFACT})")
    meta = read_mlmodel(mlmodel).get("metadata")
    if not isinstance(meta, dict):
        raise ConfigError(f"{mlmodel}: no metadata mapping (a terrain model's MLmodel "
                          f"carries {list(REQUIRED_METADATA)} in metadata)")
    missing = [k for k in REQUIRED_METADATA if k not in meta]
    if missing:
        raise ConfigError(f"{mlmodel}: metadata lacks {missing}")
    for key in ("channels", "classes"):
        names = meta[key]
        if not isinstance(names, list) or not names or \
                not all(isinstance(c, (str, int)) and not isinstance(c, bool) for c in names):
            raise ConfigError(f"{mlmodel}: metadata {key} must be a non-empty list of names, "
                              f"got {names!r}"[:300])
        twice = duplicated([str(c) for c in names])   # 1 and "1": one proba_1 column
        if twice:
            raise ConfigError(f"{mlmodel}: metadata {key} names {twice[:10]!r:.200} more than "
                              "once; name each once")
    for key in ("window_s", "rate_hz", "hop_s", "track_m"):
        value = meta.get(key)
        if key in ("hop_s", "track_m") and value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value) or value <= 0:
            raise ConfigError(f"{mlmodel}: metadata {key} must be a positive number"
                              f"{' or null' if key in ('hop_s', 'track_m') else ''}, got "
                              f"{value!r}"[:300])
    try:
        WindowConfig(window_s=float(meta["window_s"]), rate_hz=float(meta["rate_hz"]))
    except ConfigError as exc:
        raise ConfigError(f"{mlmodel}: metadata window: {exc}") from None
    try:
        model_channel_steps_s(meta)
    except ConfigError as exc:
        raise ConfigError(f"{mlmodel}: {exc}") from None
    return dict(meta)


def load_pipeline(path: str | Path) -> Any:
    """Read the fitted classifier of a model directory (its ``artifacts/pipeline.joblib``).

    The one place where the joblib file of a model is loaded and checked, shared by
    :func:`load_stream_model` and the pyfunc's
    :meth:`terrain.serving.pyfunc.TerrainModel.load_context`.

    Parameters
    ----------
    path : str or Path
        The joblib file.

    Returns
    -------
    object
        The fitted estimator: it has ``predict_proba`` and ``classes_``.

    Raises
    ------
    ConfigError
        The file cannot be unpickled (truncated, empty, not a joblib file, a class that no
        longer imports: the message gives the exception), or it holds something other than
        a fitted classifier (names the type found).
    OSError
        The file is missing or unreadable.
    """
    import joblib

    path = Path(path)
    try:
        pipeline = joblib.load(path)
    except OSError:
        raise
    except Exception as exc:  # unpickling arbitrary bytes raises anything (EOF, zlib, Key...)
        kind = type(exc).__qualname__
        if type(exc).__module__ != "builtins":  # e.g. zlib.error
            kind = f"{type(exc).__module__}.{kind}"
        text = " ".join(str(exc).split())[:200]
        raise ConfigError(f"{path}: cannot be read as a fitted model ({kind}"
                          f"{': ' + text if text else ''})") from exc
    if not (hasattr(pipeline, "predict_proba") and hasattr(pipeline, "classes_")):
        raise ConfigError(f"{path}: holds a {type(pipeline).__name__}, not a fitted "
                          "classifier with predict_proba and classes_")
    return pipeline


def load_stream_model(path: str | Path) -> StreamModel:
    """Read a terrain model directory written by ``terrain train --model-out``.

    Parameters
    ----------
    path : str or Path
        MLflow model directory.

    Returns
    -------
    StreamModel
        With the directory's whole metadata in ``metadata``.

    Raises
    ------
    ConfigError
        ``path`` not a path (e.g. ``None``), a missing or malformed ``MLmodel`` or pipeline
        artifact, metadata lacking the
        settings (:func:`read_model_metadata`), or a pipeline file that does not hold a
        fitted classifier (:func:`load_pipeline`).
    OSError
        The pipeline file is unreadable.
    """
    if not isinstance(path, (str, Path)):
        raise ConfigError(f"load_stream_model needs a model directory path, got "
                          f"{type(path).__name__} {path!r:.60}")
    path = Path(path)
    meta = read_model_metadata(path)
    pipeline = load_pipeline(path / PIPELINE_ARTIFACT)
    return StreamModel(pipeline, tuple(str(c) for c in meta["channels"]),
                       WindowConfig(window_s=float(meta["window_s"]),
                                    rate_hz=float(meta["rate_hz"])),
                       tuple(str(c) for c in meta["classes"]), MappingProxyType(dict(meta)))
