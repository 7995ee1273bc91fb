"""The streaming service as one MLflow pyfunc: raw logged streams in, decisions out.

:class:`ServedStreamModel` bundles the fitted window classifier (the ``pipeline.joblib`` of
a model written by ``terrain train --model-out``), its windowing, the smoothing settings and
the desired-slip table (:class:`~terrain.serving.targets.TableTargets`). Each request is
replayed through a fresh :class:`~terrain.serving.service.StreamService` (samples in
timestamp order, streams interleaved), so the served answer is exactly what the in-process
service would have decided on the same samples; nothing is resampled by the client.

Request (a pandas frame, e.g. the ``dataframe_split`` JSON of ``mlflow models serve``), either

* **long**: one row per sample, ``stream`` (``imu`` / ``wheels``), ``t_s`` (s, the stream's
  own clock) and the channels (SI units; a channel of another stream may be empty), or
* **wide**: per-stream time columns ``<stream>_t_s`` next to that stream's channels; a
  shorter stream leaves its trailing cells empty.

Answer: one row per window, ``t_s, terrain, confidence, proba_<CLASS>...,
target_slip_traction, target_slip_braking, target_slip_steady, window_age_s, flags,
dropped``; ``dropped`` is true for a window that was not classified, and its reason is in
``flags`` (``gap``, ``short``, ``stale``...). The readers' run-level plausibility rules
(:func:`terrain.io.plausibility.check_run`) apply to the request: a certain finding (wheel
speeds in km/h, gyro in deg/s, clocks that do not overlap) refuses it, a stuck channel flags
the windows holding it (``stuck:<stream>.<channel>``, as ``terrain predict``) and a likely
unit problem flags every window (``warning:<rule>``); neither drops a window. Rows of a
known stream the model does not use (IMU rows sent to a wheel-only model) are not read, so
not checked: every window says so (``unused:<stream>``).

A window holding a timestamp gap costs the same as any other (the service aligns only its
window's end of the streams' grid, :func:`terrain.io.align.overlap_grid_tail`; the window is
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
import math
import re
from numbers import Real
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from features.windows import WindowConfig
from terrain.control import DesiredSlipConfig
from terrain.errors import (ConfigError, DataFormatError, ImplausibleValueError,
                            MissingColumnError, NonFiniteError, NonNumericError, TerrainError,
                            TimestampError, duplicated, first_items)
from terrain.io.plausibility import (NOMINAL_RATE_HZ, check_accel_units, check_ranges,
                                     check_rate, check_run, implied_rate_hz)
from terrain.run import TIME, Run
from terrain.serving.config import KNOWN_STREAMS, StreamConfig, check_hop
from terrain.serving.decisions import decisions_frame, with_run_stuck_flags
from terrain.serving.model import (PIPELINE_ARTIFACT, StreamModel, load_pipeline,
                                   load_stream_model)
from terrain.serving.replay import replay_run
from terrain.serving.rules import MAX_PLAUSIBLE_TIME_S
from terrain.serving.service import StreamService
from terrain.serving.smoothing import SmoothingConfig
from terrain.serving.targets import TableTargets

try:  # mlflow is a hard dependency; the guard keeps the module importable for docs tools
    from mlflow.exceptions import MlflowException
    from mlflow.protos.databricks_pb2 import BAD_REQUEST, INTERNAL_ERROR
    from mlflow.pyfunc import PythonModel
except ImportError:  # pragma: no cover
    PythonModel, MlflowException, BAD_REQUEST, INTERNAL_ERROR = object, Exception, 400, 500

STREAM = "stream"
#: consecutive non-finite samples of one channel the readers repair (longer: refused)
MAX_REPAIR_RUN = 2
#: flags of a window that was not classified
DROP_FLAGS = ("gap", "short")
#: default limit of the decisions one request may make (its time span / hop_s): 2000 at
#: the 0.5 s hop is 1000 s of stream, and keeps one request's work near 1 s (about 0.2 ms
#: per decision inside a timestamp gap, 0.6 ms on dense samples, measured with
#: ``benchmarks/bench_served_load.py``'s machine); a live robot sends seconds at a time
MAX_DECISIONS = 2_000
#: vehicle whose datasheet bounds the run-level rules use when the model names none (the
#: readers' default: the measured data is all Clearpath Husky)
DEFAULT_VEHICLE = "husky"
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
        JSON-serialisable settings; ``vehicle`` is the model metadata's vehicle (the
        readers' default ``husky`` when it names none), whose bounds the run-level
        plausibility rules use.

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
                "min_confidence": float(min_confidence), "max_rows": int(max_rows),
                "max_decisions": int(max_decisions),
                "vehicle": str(model.metadata.get("vehicle") or DEFAULT_VEHICLE)}
    check_settings(settings)
    return settings


def check_settings(settings: Mapping[str, Any]) -> None:
    """Refuse served-model settings out of their range (see :func:`served_settings`).

    Parameters
    ----------
    settings : Mapping
        ``hop_s``, ``rate_hz``, ``dwell_s``, ``min_confidence``, ``max_rows`` and (optional,
        absent in models wrapped before it existed) ``max_decisions``.

    Raises
    ------
    ConfigError
        Naming the setting, its value and its range.
    """
    check_hop(settings["hop_s"], settings["rate_hz"])
    smoothing_of(settings)
    conf = float(settings["min_confidence"])
    if not 0.0 <= conf <= 1.0:
        raise ConfigError(f"min_confidence must be in [0, 1], got {conf:g}")
    for key in ("max_rows", "max_decisions"):
        if key in settings and not int(settings[key]) > 0:
            raise ConfigError(f"{key} must be a positive number, got {settings[key]}")


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


def _numeric(frame: pd.DataFrame, col: str, rows: np.ndarray, where: str) -> np.ndarray:
    """Column ``col`` at ``rows`` as float; a typed error naming the first bad row.

    Text (``NonNumericError``), a boolean (``NonNumericError``: JSON ``true`` is not 1.0)
    and a number beyond the float range (``ImplausibleValueError``, e.g. an integer of 400
    digits) are refused; empty cells are NaN.
    """
    raw = frame[col].to_numpy()[rows]
    if raw.dtype.kind in "iuf":
        return raw.astype(float)
    if raw.size == 0:
        return np.zeros(0)
    if raw.dtype.kind == "b":
        is_bool = np.ones(raw.size, dtype=bool)
    elif raw.dtype.kind != "O":  # dates, durations, complex numbers (e.g. from Parquet)
        raise NonNumericError(f"{raw.dtype} value {_short(raw[0])} where a number is "
                              "expected", where, col, int(rows[0]))
    else:
        is_bool = np.fromiter((isinstance(x, (bool, np.bool_)) for x in raw), bool, raw.size)
    if is_bool.any():
        i = int(np.flatnonzero(is_bool)[0])
        raise NonNumericError(f"boolean value {bool(raw[i])} where a number is expected "
                              f"({int(is_bool.sum())} such value(s))", where, col,
                              int(rows[i]))
    try:
        values = pd.to_numeric(pd.Series(raw), errors="coerce").to_numpy(dtype=float)
    except (OverflowError, TypeError, ValueError):  # a cell pandas cannot even coerce
        values = np.array([_to_float(x, where, col, int(r)) for x, r in zip(raw, rows)])
    bad = np.flatnonzero(np.isnan(values) & pd.notna(pd.Series(raw)).to_numpy())
    if bad.size:
        raise NonNumericError(f"non-numeric value {_short(raw[bad[0]])} ({bad.size} such "
                              "value(s))", where, col, int(rows[bad[0]]))
    return values


def _to_float(x: Any, where: str, col: str, row: int) -> float:
    """One cell as float: NaN for text or an object (refused by the caller), an error for
    a number beyond the float range."""
    if isinstance(x, Real):
        try:
            return float(x)
        except OverflowError:
            size = (f": an integer of about {int(x.bit_length() * math.log10(2)) + 1} digits"
                    if isinstance(x, int) else "")
            raise ImplausibleValueError(
                f"number beyond the float range (|x| < {np.finfo(float).max:.4g}){size}",
                where, col, row) from None
    if isinstance(x, str):
        try:
            return float(x)
        except ValueError:
            return float("nan")
    return float("nan")


def _short(value: Any, limit: int = 40) -> str:
    """A cell as a message shows it, cut to ``limit`` characters: ``repr`` of the plain
    Python value (a NumPy scalar or array as the number, text or list it holds; a date or
    duration as its ISO text), never a NumPy type name."""
    if isinstance(value, (np.datetime64, np.timedelta64)):
        text = str(value)
    elif isinstance(value, (np.generic, np.ndarray)):
        text = repr(value.tolist())
    else:
        text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _check_stream(stream: str, t: np.ndarray, v: np.ndarray, channels: Sequence[str],
                  rows: np.ndarray, window_s: float, where: str) -> None:
    """The readers' rules on one stream of a request (time, rate, length, NaN bursts)."""
    if not np.isfinite(t).all():
        i = int(np.flatnonzero(~np.isfinite(t))[0])
        raise NonFiniteError(f"non-finite timestamp in stream {stream!r}", where, TIME,
                             int(rows[i]))
    dt = np.diff(t)
    if (dt <= 0).any():
        i = int(np.flatnonzero(dt <= 0)[0]) + 1
        what = "duplicated" if dt[i - 1] == 0 else "decreasing"
        raise TimestampError(f"stream {stream!r}: {what} timestamp {float(t[i])!r} after "
                             f"{float(t[i - 1])!r}; timestamps must increase strictly (send each "
                             "stream in time order)", where, TIME, int(rows[i]))
    beyond = np.flatnonzero(np.abs(t) > MAX_PLAUSIBLE_TIME_S)
    if beyond.size:
        # the service's rule plausible_time would refuse every such sample one by one and
        # the answer would hold no decision and no reason
        raise TimestampError(f"stream {stream!r}: {beyond.size} timestamp(s) beyond "
                             f"{MAX_PLAUSIBLE_TIME_S:g} s, the first {float(t[beyond[0]])!r} "
                             "(a clock in ms or ns since an epoch?); send seconds, e.g. since "
                             "the start of the log", where, TIME, int(rows[beyond[0]]))
    check_rate(t, stream, where)
    if t.size >= 2 and stream in NOMINAL_RATE_HZ:
        lo, hi = NOMINAL_RATE_HZ[stream]
        rate = implied_rate_hz(t)   # as printed: 1 ms float steps are 1000 Hz, in range
        if not lo <= rate <= hi:
            raise DataFormatError(f"stream {stream!r}: median step implies {rate:.4g} Hz, "
                                  f"outside its nominal {lo:g}-{hi:g} Hz (timestamps in s?)",
                                  where, TIME)
    span = float(t[-1] - t[0]) if t.size else 0.0
    if span < window_s:
        shown = f"{span:.3g}"
        if float(shown) >= window_s:  # 1.9999999 s would read "spans 2 s ... needs 2 s"
            shown = f"{span:.10g}"
        raise DataFormatError(f"stream {stream!r} too short: it spans {shown} s over "
                              f"{t.size} sample(s); one window needs {window_s:g} s", where,
                              TIME)
    for j, col in enumerate(channels):
        bad = ~np.isfinite(v[:, j])
        if not bad.any():
            continue
        idx = np.flatnonzero(bad)
        starts = np.r_[idx[0], idx[1:][np.diff(idx) > 1]]
        ends = np.r_[idx[:-1][np.diff(idx) > 1], idx[-1]]
        longest = int(np.argmax(ends - starts))
        if ends[longest] - starts[longest] + 1 > MAX_REPAIR_RUN:
            raise NonFiniteError(f"stream {stream!r}: burst of "
                                 f"{ends[longest] - starts[longest] + 1} non-finite values "
                                 f"(more than {MAX_REPAIR_RUN} are not repaired)", where, col,
                                 int(rows[starts[longest]]))
        if bad[0] or bad[-1]:  # as the readers: only a sample between two finite ones
            i = 0 if bad[0] else len(bad) - 1
            raise NonFiniteError(f"stream {stream!r}: non-finite value in its "
                                 f"{'first' if i == 0 else 'last'} sample; only samples "
                                 "between two finite ones are repaired (the window grid "
                                 "starts at the first sample)", where, col, int(rows[i]))


def parse_request(frame: pd.DataFrame, streams: Mapping[str, Sequence[str]],
                  window_s: float, max_rows: int, where: str = "request",
                  known_streams: Sequence[str] = tuple(KNOWN_STREAMS),
                  vehicle: str = DEFAULT_VEHICLE) -> Run:
    """Validate a request frame (long or wide, see module docstring) into a :class:`Run`.

    In the long format every row's ``stream`` must be one of ``known_streams``: a row of an
    unknown stream (``gps``, an empty cell, a number, or a typo such as ``wheel``) refuses
    the whole request, naming the unknown values and the known ones. A typo would otherwise
    lose that stream's samples without a word (the service ignores streams it does not
    know), and the answer could only report it as fewer decisions. Rows of a known stream
    that the model does not need (IMU rows sent to a wheel-only model) are not read, as the
    in-process service ignores them; ``meta["unused"]`` counts them per stream, and the
    served answer flags every window ``unused:<stream>``.

    Parameters
    ----------
    frame : pandas.DataFrame
        The request.
    streams : Mapping[str, sequence of str]
        Stream name -> channels the model needs from it.
    window_s : float
        Window length, s (each stream must span at least this).
    max_rows : int
        Largest accepted request, rows.
    where : str
        Name of the input in messages.
    known_streams : sequence of str
        Stream names a long-format request may hold.
    vehicle : str
        Vehicle whose bounds the run-level rules of
        :func:`terrain.io.plausibility.check_run` use.

    Returns
    -------
    Run
        One frame per needed stream (``t_s`` + channels), in the request's time order;
        ``meta`` holds the run-level findings (``stuck``, ``warnings``) of
        :func:`~terrain.io.plausibility.check_run` and ``unused`` (stream -> rows of a
        known stream the model does not need).

    Raises
    ------
    DataFormatError
        Too many rows, a column name that is not text or appears twice, an unknown stream
        name, a stream that is too short or at an implausible rate.
    MissingColumnError
        A needed stream or channel is absent.
    NonNumericError
        A value that is not a number (text, a boolean).
    TimestampError
        Unsorted or duplicated timestamps within a stream, or a timestamp beyond
        :data:`terrain.serving.rules.MAX_PLAUSIBLE_TIME_S` (the service's own bound).
    NonFiniteError
        A non-finite timestamp, a burst of non-finite values, or a non-finite value in a
        stream's first or last sample.
    ImplausibleValueError, UnitError, ClockError
        A value beyond its channel's plausibility range or the float range; timestamps in
        ms, wheel speeds in km/h, a gyro in deg/s or an accelerometer in g (certain
        findings of the readers' rules); streams whose clocks do not overlap.
    """
    if not isinstance(frame, pd.DataFrame):
        raise DataFormatError(
            f"expected a table of samples, got {type(frame).__name__} (MLflow's 'inputs' "
            "and 'instances' tensor formats are not taken: send JSON as {\"dataframe_split\": "
            "{\"columns\": [...], \"data\": [[...], ...]}}, or CSV or Parquet)", where)
    if len(frame) > max_rows:
        raise DataFormatError(f"request of {len(frame)} rows exceeds the limit of {max_rows}; "
                              "send the streams in shorter pieces", where)
    labels = list(frame.columns)
    odd = [c for c in labels if not isinstance(c, str)]
    if odd:
        raise DataFormatError(f"column names must be text, got {_short(odd[0])}", where)
    dup = duplicated(labels)
    if dup:  # a repeated channel would shift the channels after it
        raise DataFormatError(f"duplicated column name(s) {dup}; send each column once",
                              where, dup[0])
    long = STREAM in frame.columns
    if long:
        _check_stream_names(frame[STREAM].to_numpy(), known_streams, where)
    out = {}
    for stream, channels in streams.items():
        tcol = TIME if long else f"{stream}_{TIME}"
        need = [tcol, *channels]
        missing = [c for c in need if c not in frame.columns]
        if long and STREAM not in missing and not (frame[STREAM] == stream).any():
            missing = [f"{STREAM}={stream}"]
        if missing:
            form = ("long format: stream, t_s, channels" if long else
                    "wide format: <stream>_t_s next to each stream's channels, or add a "
                    "'stream' column for the long format")
            raise MissingColumnError(f"the model needs stream {stream!r} with {need}; "
                                     f"missing {missing} ({form})", where, missing[0])
        rows = (np.flatnonzero((frame[STREAM] == stream).to_numpy()) if long
                else np.flatnonzero(pd.notna(frame[tcol]).to_numpy()))
        t = _numeric(frame, tcol, rows, where)
        v = np.column_stack([_numeric(frame, c, rows, where) for c in channels])
        _check_stream(stream, t, v, channels, rows, window_s, where)
        part = pd.DataFrame({TIME: t, **{c: v[:, j] for j, c in enumerate(channels)}})
        check_ranges(part, where, {c: c for c in channels})
        if {"ax", "ay", "az"} <= set(channels):
            check_accel_units(part, where)  # a stream in g is refused, as a file in g
        out[stream] = part
    # the readers' run-level rules (units, clocks, stuck sensors); certain findings raise
    checks = check_run(where, out, vehicle, {s: where for s in out})
    checks["unused"] = _unused_rows(frame, long,
                                    [s for s in known_streams if s not in streams])
    return Run("request", "request", None, out, vehicle=vehicle, source=where, meta=checks)


def _unused_rows(frame: pd.DataFrame, long: bool, others: Sequence[str]) -> dict[str, int]:
    """Rows of each known stream the model does not need (``others``) that the request holds
    (long format: rows of that ``stream``; wide: non-empty cells of its ``<stream>_t_s``);
    those rows are not read, so not checked either, and the answer says so."""
    counts = {}
    for stream in others:
        if long:
            n = int((frame[STREAM] == stream).sum())
        else:
            tcol = f"{stream}_{TIME}"
            n = int(pd.notna(frame[tcol]).sum()) if tcol in frame.columns else 0
        if n:
            counts[stream] = n
    return counts


def _check_stream_names(names: np.ndarray, known: Sequence[str], where: str) -> None:
    """Refuse rows whose ``stream`` is not a known stream name (see :func:`parse_request`)."""
    known_set = set(known)
    ok = np.fromiter((isinstance(x, str) and x in known_set for x in names), bool,
                     names.size)
    if ok.all():
        return
    bad = np.flatnonzero(~ok)
    values: list[str] = []
    for x in names[bad]:
        text = ("empty" if x is None or (isinstance(x, float) and math.isnan(x))
                else f"{type(x).__name__} {_short(x, 30)}"
                if isinstance(x, (list, tuple, dict, np.ndarray)) else _short(x, 30))
        if text not in values:
            values.append(text)
    raise DataFormatError(
        f"unknown stream {', '.join(values[:5])}"
        + (f" and {len(values) - 5} more" if len(values) > 5 else "")
        + f" in {bad.size} row(s), {first_items(bad, word='data row')} (0-based); the known "
        f"streams are {', '.join(repr(k) for k in known)} (a misspelt stream would lose its "
        "samples)", where, STREAM, int(bad[0]))


def planned_decisions(run: Run, window_s: float, hop_s: float) -> int:
    """Most decisions the service can make on ``run`` (one per ``hop_s`` of its time span).

    The first decision is due one window after the streams start, the last at the newest
    sample; this bounds the work of a request before any is done.

    Parameters
    ----------
    run : Run
        Validated request (non-empty streams).
    window_s : float
        Window length, s.
    hop_s : float
        Time between decisions, s.

    Returns
    -------
    int
        An upper bound of the number of decisions (0 when the span is shorter than a
        window).
    """
    span = _time_span_s(run) - window_s
    return int(math.floor(span / hop_s)) + 1 if span >= 0 else 0


def _time_span_s(run: Run) -> float:
    """From the first sample of any stream of ``run`` to the last of any, s."""
    return (max(float(f[TIME].iloc[-1]) for f in run.streams.values())
            - min(float(f[TIME].iloc[0]) for f in run.streams.values()))


def _plausibility_flags(frame: pd.DataFrame, window_s: float,
                        checks: Mapping[str, Any]) -> list[str]:
    """Decision flags plus the run-level findings: ``stuck:<stream>.<channel>`` on the
    decisions whose window holds a stuck stretch (:func:`~terrain.serving.decisions.
    stuck_decision_flags`), ``warning:<rule>`` on every window when a rule found a likely
    problem (the service still decided), ``unused:<stream>`` on every window when the
    request held rows of a stream the model does not use (not read, not checked)."""
    rules = "|".join(sorted({f"warning:{m.group(1)}" for w in checks.get("warnings", ())
                             for m in [re.search(r"rule (\w+)", w)] if m}
                            | {f"unused:{s}" for s in checks.get("unused", {})}))
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
        self.settings = s
        pipeline = load_pipeline(context.artifacts["pipeline"])
        self.model = StreamModel(pipeline, tuple(s["channels"]),
                                 WindowConfig(window_s=float(s["window_s"]),
                                              rate_hz=float(s["rate_hz"])),
                                 tuple(s["classes"]))
        self.targets = TableTargets(self.model.classes,
                                    DesiredSlipConfig(min_confidence=s["min_confidence"]))
        # a request makes at most max_decisions decisions, every one in the answer (a
        # dropped one with its reason): the service's skipping of long silent stretches
        # must never apply inside a request
        self.config = StreamConfig(hop_s=s["hop_s"], min_confidence=s["min_confidence"],
                                   smoothing=smoothing_of(s),
                                   max_backlog_s=(int(s["max_decisions"]) + 1)
                                   * float(s["hop_s"]))

    def decide(self, frame: pd.DataFrame) -> pd.DataFrame:
        """Decisions for one request (typed project errors propagate).

        Parameters
        ----------
        frame : pandas.DataFrame
            The request (see module docstring).

        Returns
        -------
        pandas.DataFrame
            One row per window (see module docstring).

        Raises
        ------
        DataFormatError
            Besides :func:`parse_request`'s errors: a request whose time span would make
            more than ``max_decisions`` decisions.
        """
        service = StreamService(self.model, self.targets, self.config)
        streams = {s: service.streams[s] for s in service.needed_streams}
        window_s = self.model.window.window_s
        run = parse_request(frame, streams, window_s, int(self.settings["max_rows"]),
                            known_streams=tuple(self.config.streams),
                            vehicle=str(self.settings["vehicle"]))
        limit, hop = int(self.settings["max_decisions"]), float(self.config.hop_s)
        planned = planned_decisions(run, window_s, hop)
        if planned > limit:
            raise DataFormatError(f"request spanning {_time_span_s(run):.6g} s would make "
                                  f"{planned} decisions (one every {hop:g} s), above the limit of "
                                  f"{limit}; send the streams in shorter pieces (a time jump "
                                  "in a stream counts as its length)", "request", TIME)
        out = decisions_frame(replay_run(service, run, max_chunk=32), self.model.classes)
        out["flags"] = _plausibility_flags(out, window_s, run.meta)
        # (a list, not the .str accessor: an answer without decisions has no text dtype)
        out["dropped"] = [any(x in DROP_FLAGS for x in f.split("|")) for f in out["flags"]]
        out["terrain"] = out["terrain"].fillna("")
        return out

    def predict(self, context: Any, model_input: pd.DataFrame,
                params: dict | None = None) -> pd.DataFrame:
        """MLflow entry: :meth:`decide`, errors mapped to :class:`ServedInputError`.

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
            return self.decide(model_input)
        except TerrainError as exc:
            raise ServedInputError(f"{type(exc).__name__}: {' '.join(str(exc).split())}"
                                   ) from None
        except Exception as exc:  # the server must answer, never show a traceback
            _log.exception("served model failed")
            raise ServedInputError(f"internal error ({type(exc).__name__}); see the server "
                                   "log", INTERNAL_ERROR) from None


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
    if path.exists() and any(path.iterdir()):
        raise ConfigError(f"model directory {path} exists and is not empty")
    if path.exists():
        path.rmdir()
    root = Path(__file__).resolve().parents[2]
    mlflow.pyfunc.save_model(
        path=str(path), python_model=str(Path(__file__).with_name("served_entry.py")),
        model_config=settings,
        artifacts={"pipeline": str(Path(model_dir) / PIPELINE_ARTIFACT)},
        code_paths=[str(root / "terrain"), str(root / "features")],
        pip_requirements=list(pip_requirements or ["numpy", "pandas", "scikit-learn"]),
        metadata={**settings, "source_model": str(Path(model_dir).resolve())})
    return path
