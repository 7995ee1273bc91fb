"""The streaming service as one MLflow pyfunc: raw logged streams in, decisions out.

:class:`ServedStreamModel` bundles the fitted window classifier (the ``pipeline.joblib`` of
a model written by ``terrain train --model-out``), its windowing, the smoothing settings and
the desired-slip table (:class:`~terrain.serving.targets.TableTargets`). Each request is
replayed through a fresh :class:`~terrain.serving.service.StreamService` (samples in
timestamp order, streams interleaved), so the served answer is exactly what the in-process
service would have decided on the same samples; nothing is resampled by the client.

Request: a pandas frame (e.g. the ``dataframe_split`` JSON of ``mlflow models serve``) of
the raw streams in the long format (a ``stream`` column) or the wide one (``<stream>_t_s``
columns), validated by :func:`terrain.serving.request.parse_request` (the formats are
described in :mod:`terrain.serving.request`).

Answer: one row per window, ``t_s, terrain, confidence, proba_<CLASS>...,
target_slip_traction, target_slip_braking, target_slip_steady, window_age_s, flags,
dropped, ignored_columns, n_ignored_columns``; ``dropped`` is true for a window that was
not classified, and its reason is in ``flags`` (one of
:data:`~terrain.serving.service.UNCLASSIFIED_FLAGS`: ``gap``, ``short``, or a unit rule
the service applies per window, ``accel_units``, ``wheel_speed_units``, or
``non_finite_proba``, a NaN or inf among the model's probabilities);
``window_age_s`` is null where no window was built (``short``; the in-process service says
inf, which JSON cannot hold). The readers'
run-level plausibility rules (:func:`terrain.io.plausibility.check_run`) apply to the
request: a certain finding (wheel speeds in km/h, gyro in deg/s, clocks that do not overlap)
refuses it, a stuck channel flags the windows holding it (``stuck:<stream>.<channel>``, as
``terrain predict``) and a likely unit problem flags every window (``warning:<rule>``);
neither drops a window. Rows of a
known stream the model does not use (IMU rows sent to a wheel-only model) are not read, so
not checked: every window says so (``unused:<stream>``). Samples the service still held
when the request ended (a stream stepping far ahead of the others' clock, held until they
catch up; :attr:`~terrain.serving.service.StreamService.held_samples`) reached no decision:
every window says so (``held:<stream>``). Columns that no known stream has (a CSV index, a
misspelt channel, another sensor) are not read: every window names them,
``ignored_columns`` (the first five, as :func:`terrain.errors.listed` writes them, and a
count of the others; empty when none), and counts them, ``n_ignored_columns``.

A window holding a timestamp gap costs the same as any other (the service aligns only its
window's end of the streams' grid, :func:`terrain.io.align.anchored_grid_tail`; the window is
a dropped ``gap`` row), and a request whose time span would make more than
``max_decisions`` decisions is refused before any work, so the cost of a request is bounded
by its rows and the limits, never by the length of a gap in it.

A malformed request raises :class:`ServedInputError`, an
:class:`mlflow.exceptions.MlflowException` whose message is the project's typed message
(:mod:`terrain.errors`, class name first) and which MLflow's scoring server answers with
HTTP 400 and no stack trace; its message cannot be rewritten by the server (which would
otherwise prepend a dump of the request frame).
"""

from __future__ import annotations

import logging
import re
import threading
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from features.windows import WindowConfig
from terrain.control import DesiredSlipConfig
from terrain.errors import (DataFormatError, TerrainError, config_integer, config_positive,
                            config_probability, listed)
from terrain.run import TIME
from terrain.serving.config import KNOWN_STREAMS, StreamConfig, check_hop
from terrain.serving.decisions import decisions_frame, with_run_stuck_flags
from terrain.serving.model import (PIPELINE_ARTIFACT, StreamModel, load_pipeline,
                                   load_stream_model, model_channel_steps_s, model_track_m,
                                   model_vehicle, new_model_directory)
from terrain.serving.replay import replay_run
from terrain.serving.request import (DEFAULT_VEHICLE, parse_request, planned_decisions,
                                     time_span_s)
from terrain.serving.service import UNCLASSIFIED_FLAGS, StreamService
from terrain.serving.smoothing import SmoothingConfig
from terrain.serving.targets import TableTargets

try:  # mlflow is a hard dependency; the guard keeps the module importable for docs tools
    from mlflow.exceptions import MlflowException
    from mlflow.protos.databricks_pb2 import BAD_REQUEST, INTERNAL_ERROR
    from mlflow.pyfunc import PythonModel
except ImportError:  # pragma: no cover
    PythonModel, MlflowException, BAD_REQUEST, INTERNAL_ERROR = object, Exception, 400, 500

#: default limit of the decisions one request may make (its time span / hop_s): 2000 at
#: the 0.5 s hop is 1000 s of stream, and bounds one request's work to seconds (measured
#: by an HTTP fuzz: 0.6-0.7 s wheel-only, 2.9-3.2 s with the IMU at 100 Hz); a live robot
#: sends seconds at a time
MAX_DECISIONS = 2_000
#: requests of more rows than this are long (a bulk log: 10,000 rows are 100 s of a 100 Hz
#: IMU): they are decided one at a time in their own lane, so a robot's short requests,
#: decided one at a time in theirs, do not wait behind them
LONG_REQUEST_ROWS = 10_000
#: requests spanning more seconds of stream than this are long too, whatever their rows: the
#: work is per decision, i.e. per second of stream (a 999 s wheel-only log holds only 6,488
#: rows and took 1.4 s; seven of them kept a 3 s request waiting 9.5 s in the short lane)
LONG_REQUEST_S = 100.0
_log = logging.getLogger(__name__)


class ServedInputError(MlflowException):
    """A request the served model refuses; HTTP 400 (or ``error_code``'s status).

    Its ``message`` is fixed at construction: MLflow's scoring server assigns a new message
    (the request frame followed by the error) to any MlflowException raised by a model, which
    this class ignores, so the answer carries only the project's message.

    Parameters
    ----------
    message : str
        The project's typed message.
    error_code : int
        MLflow error code (:data:`BAD_REQUEST` -> HTTP 400, :data:`INTERNAL_ERROR` -> 500).
    """

    def __init__(self, message: str, error_code: int = BAD_REQUEST) -> None:
        self._fixed = message
        super().__init__(message, error_code=error_code)

    @property
    def message(self) -> str:
        """The project's message (assignments are ignored, see class docstring)."""
        return self._fixed

    @message.setter
    def message(self, value: str) -> None:
        pass


def served_settings(model: StreamModel, hop_s: float = 0.5, dwell_s: float | None = 10.0,
                    min_confidence: float = 0.5, max_rows: int = 200_000,
                    max_decisions: int = MAX_DECISIONS,
                    reset_confidence: float | None = None, reset_windows: int = 2) -> dict:
    """Settings of the served model (stored as its MLflow ``model_config``).

    Parameters
    ----------
    model : StreamModel
        The classifier and its window.
    hop_s : float
        Time between decisions, s; at least one period of the model's clock
        (``1 / rate_hz``): deciding more often gives no new sample to decide on.
    dwell_s : float or None
        Expected time on one terrain of the forward filter, s (> 0; None: no smoothing).
    min_confidence : float
        Smoothed probability below which the table's conservative target is used, in [0, 1].
    max_rows : int
        Largest request, rows (a larger one is refused).
    max_decisions : int
        Most decisions one request may make (its time span over ``hop_s``; a request that
        would make more is refused before any work).
    reset_confidence : float or None
        The forward filter's switch reset (:class:`SmoothingConfig`); None: no reset.
    reset_windows : int
        Consecutive confident windows that reset it.

    Returns
    -------
    dict
        JSON-serialisable settings; ``vehicle`` is the model's vehicle
        (:func:`~terrain.serving.model.model_vehicle`; the readers' default ``husky`` when
        it names none), whose bounds the run-level
        plausibility rules use; ``channel_steps_s`` the training runs' sample step of its
        channels (:func:`~terrain.serving.model.model_channel_steps_s`; None when the model
        records none), against which a stream's first steps are judged; ``track_m`` the
        track width (m) the model's training windows derived ``yaw_rate_wheels`` with
        (:func:`~terrain.serving.model.model_track_m`), with which the served windows derive
        it too.

    Raises
    ------
    ConfigError
        A setting out of its range.
    """
    settings = {"kind": "terrain-stream", "channels": list(model.channels),
                "classes": list(model.classes), "window_s": model.window.window_s,
                "rate_hz": model.window.rate_hz, "hop_s": float(hop_s),
                "dwell_s": None if dwell_s is None else float(dwell_s),
                "reset_confidence": None if reset_confidence is None else float(reset_confidence),
                "reset_windows": int(reset_windows),
                "min_confidence": float(min_confidence), "max_rows": max_rows,
                "max_decisions": max_decisions,
                "vehicle": str(model_vehicle(model.metadata) or DEFAULT_VEHICLE),
                "channel_steps_s": model_channel_steps_s(model.metadata) or None,
                # the served windows derive yaw_rate_wheels as the training windows did (it
                # was left out: a tracked vehicle's model served with the Husky's track)
                "track_m": model_track_m(model.metadata)}
    check_settings(settings)
    # checked whole numbers; a NumPy integer as Python's, for the JSON of model_config
    settings["max_rows"], settings["max_decisions"] = int(max_rows), int(max_decisions)
    return settings


def check_settings(settings: Mapping[str, Any]) -> None:
    """Refuse served-model settings out of their range (see :func:`served_settings`).

    Parameters
    ----------
    settings : Mapping
        ``hop_s``, ``rate_hz``, ``dwell_s``, ``min_confidence``, ``max_rows`` and (optional,
        absent in models wrapped before they existed) ``max_decisions`` and ``track_m``.

    Raises
    ------
    ConfigError
        Naming the setting, its value and its range.
    """
    check_hop(settings["hop_s"], settings["rate_hz"])
    smoothing_of(settings)
    model_channel_steps_s(settings)
    if settings.get("track_m") is not None:
        config_positive("served settings", track_m=settings["track_m"])
    config_probability("served settings", min_confidence=settings["min_confidence"])
    for key in ("max_rows", "max_decisions"):
        # a count: a float (2.7 was taken as 2), text, None, NaN or a boolean is refused here
        # rather than by int() in Python's words
        config_integer(key, settings.get(key, 1), 1)


def smoothing_of(settings: Mapping[str, Any]) -> SmoothingConfig:
    """The forward filter's settings of a served model (``reset_*`` absent in models
    wrapped before the reset existed: no reset).

    Parameters
    ----------
    settings : Mapping
        ``dwell_s`` and, optionally, ``reset_confidence``, ``reset_windows``.

    Returns
    -------
    SmoothingConfig

    Raises
    ------
    ConfigError
        A value out of its range.
    """
    reset = settings.get("reset_confidence")
    return SmoothingConfig(dwell_s=settings.get("dwell_s"),
                           reset_confidence=None if reset is None else float(reset),
                           reset_windows=int(settings.get("reset_windows", 2)))


def _plausibility_flags(frame: pd.DataFrame, window_s: float, checks: Mapping[str, Any],
                        held: Mapping[tuple[str, str], int] | None = None) -> list[str]:
    """Decision flags plus the run-level findings: ``stuck:<stream>.<channel>`` on the
    decisions whose window holds a stuck stretch (:func:`~terrain.serving.decisions.
    stuck_decision_flags`), ``warning:<rule>`` on every window when a rule found a likely
    problem (the service still decided), ``unused:<stream>`` on every window when the
    request held rows of a stream the model does not use (not read, not checked), and
    ``held:<stream>`` on every window when samples of that stream were still held by the
    service when the request ended (``held``: :attr:`StreamService.held_samples`), so that
    no decision saw them."""
    rules = "|".join(sorted({f"warning:{m.group(1)}" for w in checks.get("warnings", ())
                             for m in [re.search(r"rule (\w+)", w)] if m}
                            | {f"unused:{s}" for s in checks.get("unused", {})}
                            | {f"held:{s}" for s, _ in (held or {})}))
    return with_run_stuck_flags(frame, checks.get("stuck", {}), window_s,
                                [rules] * len(frame))[0]


class ServedStreamModel(PythonModel):
    """MLflow pyfunc of the streaming service (see module docstring).

    Settings come from the model's ``model_config`` (:func:`served_settings`), the fitted
    classifier from the ``pipeline`` artifact; the model is logged from code
    (:mod:`terrain.serving.served_entry`), so no Python object is pickled.
    """

    def __init__(self) -> None:
        self.settings: dict = {}
        self.model: StreamModel | None = None
        # one request decided at a time per lane (short, long: is_long): MLflow's
        # server runs each prediction in a thread of its pool, and concurrent CPU-bound
        # requests only contend for the interpreter lock and memory (measured: 8 requests of
        # 999 s at once took 47.6 s against 8 x 3.9 s one after another, at 950 MB;
        # docs/streaming.md, "Served model under load")
        self._lanes = {False: threading.Lock(), True: threading.Lock()}

    def load_context(self, context: Any) -> None:
        """Load the classifier and the settings.

        Parameters
        ----------
        context : mlflow.pyfunc.PythonModelContext
            ``artifacts["pipeline"]`` and ``model_config``.

        Raises
        ------
        ConfigError
            The pipeline artifact is not a fitted classifier, or a setting is out of range
            (so a broken model fails when the server starts, not on every request).
        """
        s = {"max_decisions": MAX_DECISIONS, "vehicle": DEFAULT_VEHICLE,
             **dict(context.model_config)}
        check_settings(s)
        # built whole before any is kept: a load that fails (a broken pipeline file) leaves
        # the model as it was, never new settings over the old classifier
        pipeline = load_pipeline(context.artifacts["pipeline"])
        model = StreamModel(pipeline, tuple(s["channels"]),
                            WindowConfig(window_s=float(s["window_s"]),
                                         rate_hz=float(s["rate_hz"])),
                            tuple(s["classes"]),
                            # the service's per-window wheel_speed_units rule needs
                            # the vehicle (the run-level rules get it in decide)
                            metadata={"vehicle": str(s["vehicle"]),
                                      # the first steps of a stream are judged
                                      # against its training step
                                      "channel_steps_s": s.get("channel_steps_s"),
                                      # the derived wheel channels' track (None: a model
                                      # wrapped before the key, which used the Husky's)
                                      "track_m": s.get("track_m")})
        targets = TableTargets(model.classes,
                               DesiredSlipConfig(min_confidence=s["min_confidence"]))
        # a request makes at most max_decisions decisions, every one in the answer (a
        # dropped one with its reason): the service's skipping of long silent stretches
        # must never apply inside a request
        config = StreamConfig(hop_s=s["hop_s"], min_confidence=s["min_confidence"],
                              smoothing=smoothing_of(s),
                              max_backlog_s=(int(s["max_decisions"]) + 1) * float(s["hop_s"]))
        self.settings, self.model, self.targets, self.config = s, model, targets, config

    def decide(self, frame: pd.DataFrame) -> pd.DataFrame:
        """Decisions for one request (typed project errors propagate).

        Parameters
        ----------
        frame : pandas.DataFrame
            The request (see module docstring).

        Returns
        -------
        pandas.DataFrame
            One row per window (see module docstring); ``window_age_s`` (s) is None (JSON
            null) where no window was built (``short``: its age is infinite);
            ``ignored_columns`` and ``n_ignored_columns`` name and count the request's
            columns that no known stream has (not read).

        Raises
        ------
        DataFormatError
            Besides :func:`parse_request`'s errors: a request whose time span would make
            more than ``max_decisions`` decisions, or one that gave no decision (the service
            still held samples of it when it ended, or its streams do not hold one window
            together: each spans a window, but not the same one).
        """
        service = StreamService(self.model, self.targets, self.config)
        streams = {s: service.streams[s] for s in service.needed_streams}
        window_s = self.model.window.window_s
        run = parse_request(frame, streams, window_s, int(self.settings["max_rows"]),
                            known_streams=self.config.streams,
                            vehicle=str(self.settings["vehicle"]))
        limit, hop = int(self.settings["max_decisions"]), float(self.config.hop_s)
        planned = planned_decisions(run, window_s, hop)
        if planned > limit:
            raise DataFormatError(f"request spanning {time_span_s(run):.6g} s would make "
                                  f"{planned} decisions (one every {hop:g} s), above the limit of "
                                  f"{limit}; send the streams in shorter pieces (a time jump "
                                  "in a stream counts as its length)", "request", TIME)
        decisions = replay_run(service, run, max_chunk=32)
        held = service.held_samples
        if held and not decisions:
            raise DataFormatError(
                "no decision: " + ", ".join(f"{n} sample(s) of stream {s!r} held ({r})"
                                            for (s, r), n in sorted(held.items()))
                + " when the request ended; send the other streams' samples of that time "
                "in the same request", "request", TIME)
        if not decisions:   # no decision came due: an empty answer would give no reason
            spans = ", ".join(f"{s} {float(f[TIME].iloc[0]):.10g}..{float(f[TIME].iloc[-1]):.10g}"
                              " s" for s, f in run.streams.items())
            raise DataFormatError(
                f"no decision: the streams ({spans}) do not hold one window of {window_s:g} s "
                "together (the first decision is due one window after the last stream starts, "
                "and no stream ran on long enough past it); send the streams' samples of the "
                "same time in one request", "request", TIME)
        out = decisions_frame(decisions, self.model.classes)
        out["flags"] = _plausibility_flags(out, window_s, run.meta, held)
        # (a list, not the .str accessor: an answer without decisions has no text dtype)
        out["dropped"] = [not UNCLASSIFIED_FLAGS.isdisjoint(f.split("|")) for f in out["flags"]]
        ignored = run.meta["ignored_columns"]
        out["ignored_columns"] = listed(ignored) if ignored else ""
        out["n_ignored_columns"] = len(ignored)
        out["terrain"] = out["terrain"].fillna("")
        # no window was built (``short``): its age is infinite, which JSON cannot hold
        # (MLflow would write the bare token Infinity): null instead
        age = out["window_age_s"].astype(object)
        out["window_age_s"] = age.where(np.isfinite(out["window_age_s"].to_numpy(float)), None)
        return out

    def predict(self, context: Any, model_input: pd.DataFrame,
                params: dict | None = None) -> pd.DataFrame:
        """MLflow entry: :meth:`decide`, errors mapped to :class:`ServedInputError`.

        Requests are decided one at a time in two lanes, short and long (:func:`is_long`:
        more than :data:`LONG_REQUEST_ROWS` rows or :data:`LONG_REQUEST_S` seconds of
        stream), so at most two run at once and a short one does not wait behind a bulk log.

        Parameters
        ----------
        context : mlflow.pyfunc.PythonModelContext
            Unused (loaded in :meth:`load_context`).
        model_input : pandas.DataFrame
            The request.
        params : dict, optional
            Unused.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        ServedInputError
            400 with the typed message for a malformed request; 500 with a one-line message
            (the traceback goes to the server log only) for an unexpected failure.
        """
        try:
            with self._lanes[is_long(model_input)]:
                return self.decide(model_input)
        except TerrainError as exc:
            raise ServedInputError(f"{type(exc).__name__}: {' '.join(str(exc).split())}"
                                   ) from None
        except Exception as exc:  # the server must answer, never show a traceback
            _log.exception("served model failed")
            raise ServedInputError(f"internal error ({type(exc).__name__}); see the server "
                                   "log", INTERNAL_ERROR) from None


def is_long(model_input: Any) -> bool:
    """Whether a served request takes the long lane: a table of more than
    :data:`LONG_REQUEST_ROWS` rows, or whose timestamps (``t_s``, or the wide format's
    ``<stream>_t_s`` of a known stream, :data:`~terrain.serving.config.KNOWN_STREAMS`; a
    column of another sensor is not read; non-numeric and non-finite cells ignored) span
    more than :data:`LONG_REQUEST_S` seconds. A time column that cannot be read as numbers
    at all (an integer beyond the float range) leaves the request short; the model refuses
    it.

    Parameters
    ----------
    model_input : Any
        The request as MLflow parsed it: a DataFrame, or whatever a malformed body gave (a
        number, a string, None), which is short and refused by :meth:`ServedStreamModel.decide`.

    Returns
    -------
    bool
    """
    if not isinstance(model_input, pd.DataFrame):
        return False
    if len(model_input) > LONG_REQUEST_ROWS:
        return True
    # the columns the model reads: a column of no known stream (``gps_t_s``) is ignored
    read = {TIME, *(f"{s}_{TIME}" for s in KNOWN_STREAMS)}
    times = [c for c in model_input.columns if isinstance(c, str) and c in read]
    if not times:
        return False
    try:
        stamps = np.concatenate([pd.to_numeric(model_input[c], errors="coerce").to_numpy(float)
                                 for c in times])
    except (OverflowError, TypeError, ValueError):  # an integer of 400 digits, a repeated
        return False   # name (a frame, not a column): decide() refuses it in its own words
    stamps = stamps[np.isfinite(stamps)]
    return bool(stamps.size) and float(stamps.max() - stamps.min()) > LONG_REQUEST_S


def save_served_model(path: str | Path, model_dir: str | Path, settings: dict | None = None,
                      pip_requirements: Sequence[str] | None = None) -> Path:
    """Wrap a model written by ``terrain train --model-out`` into the served pyfunc.

    Parameters
    ----------
    path : str or Path
        New MLflow model directory (must not exist or be empty).
    model_dir : str or Path
        Model directory of ``terrain train --model-out`` (its pipeline and metadata are read
        with :func:`terrain.serving.load_stream_model`).
    settings : dict, optional
        :func:`served_settings` (its defaults when omitted).
    pip_requirements : sequence of str, optional
        Pinned requirements of the classifier.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ConfigError
        ``model_dir`` is not a terrain model, or ``path`` exists and is not empty.
    """
    import mlflow.pyfunc

    model = load_stream_model(model_dir)
    settings = settings or served_settings(model)
    path = Path(path)
    root = Path(__file__).resolve().parents[2]
    # no signature, on purpose: a request is either layout (long with ``stream``, or one
    # column per channel) and is checked by parse_request with the project's typed errors,
    # where MLflow's schema enforcement would refuse one layout and answer in its own words.
    # MLflow says at every save that it cannot infer one; that warning is expected here.
    no_signature = _DropRecords("Failed to infer model signature: Type hint")
    pyfunc_log = logging.getLogger("mlflow.pyfunc")
    pyfunc_log.addFilter(no_signature)
    try:
        with new_model_directory(path) as stage:
            mlflow.pyfunc.save_model(
                path=str(stage), python_model=str(Path(__file__).with_name("served_entry.py")),
                model_config=settings,
                artifacts={"pipeline": str(Path(model_dir) / PIPELINE_ARTIFACT)},
                code_paths=[str(root / "terrain"), str(root / "features")],
                pip_requirements=list(pip_requirements or ["numpy", "pandas", "scikit-learn"]),
                metadata={**settings, "source_model": str(Path(model_dir).resolve())})
    finally:
        pyfunc_log.removeFilter(no_signature)
    return path


class _DropRecords(logging.Filter):
    """Drop the log records whose message starts with ``prefix``."""

    def __init__(self, prefix: str) -> None:
        super().__init__()
        self.prefix = prefix

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(self.prefix)
