"""A served request, validated: raw logged streams in a table -> a :class:`~terrain.run.Run`.

The served model (:mod:`terrain.serving.served`) takes a pandas frame (e.g. the
``dataframe_split`` JSON of ``mlflow models serve``), either

* **long**: one row per sample, ``stream`` (``imu`` / ``wheels``), ``t_s`` (s, the stream's
  own clock) and the channels (SI units; a channel of another stream may be empty), or
* **wide**: per-stream time columns ``<stream>_t_s`` next to that stream's channels; a
  shorter stream leaves its trailing cells empty.

:func:`parse_request` applies the readers' rules to it (numbers only, strictly increasing
time, a plausible rate, a stream long enough for a window, at most ``MAX_REPAIR_RUN``
consecutive non-finite values, the plausibility ranges and the run-level rules of
:func:`terrain.io.plausibility.check_run`) and refuses it with the project's typed error
(:mod:`terrain.errors`) naming the column and row; :func:`planned_decisions` bounds the work
the request would cost before any is done.
"""

from __future__ import annotations

import datetime
import math
import warnings
from numbers import Real
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from terrain.errors import (DataFormatError, DataWarning, ImplausibleValueError,
                            MissingColumnError, NonFiniteError, NonNumericError, TimestampError,
                            duplicated, first_items, listed)
from terrain.io.measured import NON_FINITE_WORDS
from terrain.io.plausibility import (NOMINAL_RATE_HZ, check_accel_units, check_ranges,
                                     check_rate, check_run, implied_rate_hz)
from terrain.run import TIME, Run
from terrain.serving.config import KNOWN_STREAMS
from terrain.serving.rules import MAX_PLAUSIBLE_TIME_S

#: column of a long-format request naming each row's stream
STREAM = "stream"
#: consecutive non-finite samples of one channel the readers repair (longer: refused)
MAX_REPAIR_RUN = 2
#: cell types that are times, not numbers: pandas's ``to_numeric`` reads a column of them
#: as ns, us or years since an epoch (pandas's Timestamp and Timedelta subclass these)
_TIME_TYPES = (datetime.date, datetime.time, datetime.timedelta, np.datetime64,
               np.timedelta64, pd.Period)
#: vehicle whose datasheet bounds the run-level rules use when the model names none (the
#: readers' default: the measured data is all Clearpath Husky)
DEFAULT_VEHICLE = "husky"


def numeric_column(frame: pd.DataFrame, col: str, rows: np.ndarray, where: str) -> np.ndarray:
    """Column ``col`` at ``rows`` as float; a typed error naming the first bad row.

    The served models' one reading of a request's numbers (this module's requests and the
    aligned-samples pyfunc, :func:`terrain.serving.pyfunc.predict_windows`).

    Parameters
    ----------
    frame : pandas.DataFrame
        The request's table.
    col : str
        The column to read.
    rows : numpy.ndarray
        ``(n,)`` 0-based row positions to read (the rows named in an error).
    where : str
        What the table is, for the error (e.g. ``"model input"``).

    Returns
    -------
    numpy.ndarray
        ``(n,)`` float values; empty cells NaN. Text holding a number (``"0.5"``, a JSON
        string too) is read as that number, as the readers read a CSV cell: a CSV body is
        text, and a CSV column holding one non-numeric cell reaches the model as a column
        of text (the in-process :meth:`~terrain.serving.service.StreamService.push`, whose
        callers hold typed arrays, refuses text); ``"nan"``, ``"inf"`` and the readers'
        other :data:`~terrain.io.measured.NON_FINITE_WORDS` are a non-finite sample.

    Raises
    ------
    NonNumericError
        Text that is no number (``"abc"``), a boolean (JSON ``true`` is not
        1.0), a date, a duration or a complex number (of any dtype: a tz-aware or period
        column, or such values held as objects).
    ImplausibleValueError
        A number beyond the float range (e.g. an integer of 400 digits, or the text
        ``"1e400"``).
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
    # a tz-aware or period column (e.g. from Parquet) reads as one of objects
    is_time = np.fromiter((isinstance(x, _TIME_TYPES) for x in raw), bool, raw.size)
    if is_time.any():
        i = int(np.flatnonzero(is_time)[0])
        raise NonNumericError(f"{type(raw[i]).__name__} value {_short(raw[i])} where a number "
                              f"is expected ({int(is_time.sum())} such value(s))", where, col,
                              int(rows[i]))
    try:
        values = pd.to_numeric(pd.Series(raw), errors="coerce").to_numpy(dtype=float)
    except (OverflowError, TypeError, ValueError):  # a cell pandas cannot even coerce
        values = np.array([_to_float(x, where, col, int(r)) for x, r in zip(raw, rows)])
    # text beyond the float range ("1e400", 400 digits) reads as inf: a value, not a missing
    # sample, refused as the readers refuse it (_refuse_overflow); "inf" itself is one
    over = [i for i in np.flatnonzero(np.isinf(values)) if isinstance(raw[i], str)
            and raw[i].strip().lower() not in NON_FINITE_WORDS]
    if over:
        raise ImplausibleValueError(f"number {_short(raw[over[0]])} beyond the float range "
                                    f"(|x| < {np.finfo(float).max:.4g}; {len(over)} such "
                                    "value(s))", where, col, int(rows[over[0]]))
    # text the readers read as a missing sample ("nan", "", NON_FINITE_WORDS) is one here too
    not_word = np.fromiter((not isinstance(x, str) or x.strip().lower() not in NON_FINITE_WORDS
                            for x in raw), bool, raw.size)
    bad = np.flatnonzero(np.isnan(values) & pd.notna(pd.Series(raw)).to_numpy() & not_word)
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
                  rows: np.ndarray, window_s: float, where: str, tcol: str = TIME) -> None:
    """The readers' rules on one stream of a request (time, rate, length, NaN bursts);
    ``tcol``: the request's time column of the stream, named in the errors (the wide
    format's ``<stream>_t_s``)."""
    if not np.isfinite(t).all():
        i = int(np.flatnonzero(~np.isfinite(t))[0])
        raise NonFiniteError(f"non-finite timestamp in stream {stream!r}", where, tcol,
                             int(rows[i]))
    beyond = np.flatnonzero(np.abs(t) > MAX_PLAUSIBLE_TIME_S)
    if beyond.size:
        # the service's rule plausible_time would refuse every such sample one by one and
        # the answer would hold no decision and no reason; checked before the order, which
        # such stamps lose as floats (integer ns 1 apart near 1e18 read as duplicated)
        raise TimestampError(f"stream {stream!r}: {beyond.size} timestamp(s) beyond "
                             f"{MAX_PLAUSIBLE_TIME_S:g} s, the first {float(t[beyond[0]])!r} "
                             "(a clock in ms or ns since an epoch?); send seconds, e.g. since "
                             "the start of the log", where, tcol, int(rows[beyond[0]]))
    dt = np.diff(t)
    if (dt <= 0).any():
        i = int(np.flatnonzero(dt <= 0)[0]) + 1
        what = "duplicated" if dt[i - 1] == 0 else "decreasing"
        raise TimestampError(f"stream {stream!r}: {what} timestamp {float(t[i])!r} after "
                             f"{float(t[i - 1])!r}; timestamps must increase strictly (send each "
                             "stream in time order)", where, tcol, int(rows[i]))
    check_rate(t, stream, where, tcol)
    if t.size >= 2 and stream in NOMINAL_RATE_HZ:
        lo, hi = NOMINAL_RATE_HZ[stream]
        rate = implied_rate_hz(t)   # as printed: 1 ms float steps are 1000 Hz, in range
        if not lo <= rate <= hi:
            raise DataFormatError(f"stream {stream!r}: median step implies {rate:.4g} Hz, "
                                  f"outside its nominal {lo:g}-{hi:g} Hz (timestamps in s?)",
                                  where, tcol)
    # long enough where the service's first decision, due one window after the first
    # sample (t[0] + window_s, as its clock computes it), is not after the last sample: the
    # span t[-1] - t[0] of a stream the service decides on fell short of one window on most
    # clocks (2.3 - 0.3 is 1.9999999999999998)
    if not t.size or t[0] + window_s > t[-1]:
        span = float(t[-1] - t[0]) if t.size else 0.0
        # 1.9999999 s would read "spans 2 s ... needs 2 s"
        shown = next((text for text in (f"{span:.3g}", f"{span:.10g}")
                      if float(text) < window_s), repr(span))
        raise DataFormatError(f"stream {stream!r} too short: it spans {shown} s over "
                              f"{t.size} sample(s); one window needs {window_s:g} s", where,
                              tcol)
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


def _wide_rows(frame: pd.DataFrame, stream: str, tcol: str, channels: Sequence[str],
               where: str) -> np.ndarray:
    """Rows of ``stream`` in a wide request: those whose ``tcol`` cell is not empty.

    Only a shorter stream's trailing cells may be empty: an empty stamp before a stamped
    row, or next to a value in one of ``channels``, is a non-finite timestamp (refused as
    the long format refuses it), never a row skipped without a word.

    Raises
    ------
    NonFiniteError
        Naming ``tcol``, the first such row (0-based) and their count.
    """
    stamped = pd.notna(frame[tcol]).to_numpy()
    rows = np.flatnonzero(stamped)
    holds_value = frame[list(channels)].notna().to_numpy().any(axis=1)
    before_last = np.arange(len(frame)) < (rows[-1] if rows.size else 0)
    bad = np.flatnonzero(~stamped & (holds_value | before_last))
    if bad.size:
        why = ("holds values of the stream's channels" if holds_value[bad[0]] else
               "comes before a stamped row")
        raise NonFiniteError(f"non-finite timestamp in stream {stream!r}: {tcol} is empty "
                             f"in a row that {why} ({bad.size} such row(s), "
                             f"{first_items(bad, word='data row')}); only a shorter stream's "
                             "trailing cells may be empty", where, tcol, int(bad[0]))
    return rows


def parse_request(frame: pd.DataFrame, streams: Mapping[str, Sequence[str]],
                  window_s: float, max_rows: int, where: str = "request",
                  known_streams: Mapping[str, Sequence[str]] = KNOWN_STREAMS,
                  vehicle: str = DEFAULT_VEHICLE) -> Run:
    """Validate a request frame (long or wide, see module docstring) into a :class:`Run`.

    In the long format every row's ``stream`` must be one of ``known_streams``: a row of an
    unknown stream (``gps``, an empty cell, a number, or a typo such as ``wheel``) refuses
    the whole request, naming the unknown values and the known ones. A typo would otherwise
    lose that stream's samples without a word (the service ignores streams it does not
    know), and the answer could only report it as fewer decisions. Rows of a known stream
    that the model does not need (IMU rows sent to a wheel-only model) are not read, as the
    in-process service ignores them; ``meta["unused"]`` counts them per stream, and the
    served answer flags every window ``unused:<stream>``. Columns that are neither
    ``stream``, a time column nor a channel of a known stream (a CSV index, a misspelt
    channel, another sensor) are not read either; ``meta["ignored_columns"]`` names them
    and the served answer says so on every window.

    Parameters
    ----------
    frame : pandas.DataFrame
        The request.
    streams : Mapping[str, sequence of str]
        Stream name -> channels the model needs from it.
    window_s : float
        Window length, s: each stream must span at least this, its last sample not before
        its first plus ``window_s`` (computed so, as the service's clock computes its first
        decision; the span ``t[-1] - t[0]`` may round below it: 2.3 - 0.3 is
        1.9999999999999998).
    max_rows : int
        Largest accepted request, rows.
    where : str
        Name of the input in messages.
    known_streams : Mapping[str, sequence of str]
        Streams a long-format request may hold, stream -> its channels (their time columns
        and channels, with those of ``streams``, are not ignored columns).
    vehicle : str
        Vehicle whose bounds the run-level rules of
        :func:`terrain.io.plausibility.check_run` use.

    Returns
    -------
    Run
        One frame per needed stream (``t_s`` + channels), in the request's time order;
        ``meta`` holds the run-level findings (``stuck``, ``warnings``) of
        :func:`~terrain.io.plausibility.check_run`, the ``warnings`` led by the dead-sensor
        finding of :func:`~terrain.io.plausibility.check_accel_units` (an accelerometer
        that sees no gravity; also warned as a :class:`~terrain.errors.DataWarning`), and
        ``unused`` (stream -> rows of a known stream the model does not need) and
        ``ignored_columns`` (the request's columns that no known stream has, in request
        order).

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
        A non-finite timestamp (in the wide format also an empty ``<stream>_t_s`` cell
        before the stream's last stamped row or beside a value of its channels), a burst
        of non-finite values, or a non-finite value in a stream's first or last sample.
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
    out, accel = {}, []
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
            near = _near_names(labels, missing if long else [*missing, STREAM])
            raise MissingColumnError(f"the model needs stream {stream!r} with {need}; "
                                     f"missing {missing} ({form}){near}", where, missing[0])
        rows = (np.flatnonzero((frame[STREAM] == stream).to_numpy()) if long
                else _wide_rows(frame, stream, tcol, channels, where))
        t = numeric_column(frame, tcol, rows, where)
        v = np.column_stack([numeric_column(frame, c, rows, where) for c in channels])
        _check_stream(stream, t, v, channels, rows, window_s, where, tcol)
        part = pd.DataFrame({TIME: t, **{c: v[:, j] for j, c in enumerate(channels)}})
        # finite values only: an isolated inf is a non-finite sample as a NaN is (the
        # service flags it non_finite; a burst was refused above), not a value out of range
        check_ranges(part.where(np.isfinite(part)), where, {c: c for c in channels},
                     rows=rows)
        if {"ax", "ay", "az"} <= set(channels):
            # a stream in g is refused, as a file in g; a dead one is a likely finding,
            # kept with check_run's (the answer flags it warning:accel_units on every window:
            # it went to the server's log only)
            found: list[str] = []
            check_accel_units(part, where, found)
            for message in found:
                warnings.warn(message, DataWarning, stacklevel=2)
            accel += found
        out[stream] = part
    # the readers' run-level rules (units, clocks, stuck sensors); certain findings raise
    checks = check_run(where, out, vehicle, {s: where for s in out}, time_column=TIME)
    checks["warnings"] = [*accel, *checks["warnings"]]
    checks["unused"] = _unused_rows(frame, long,
                                    [s for s in known_streams if s not in streams])
    checks["ignored_columns"] = _ignored_columns(labels, long, (known_streams, streams))
    return Run("request", "request", None, out, vehicle=vehicle, source=where, meta=checks)


def _near_names(labels: Sequence[str], names: Sequence[str]) -> str:
    """``; the request has [...] (spaces or case differ)`` naming the request's columns that
    are one of ``names`` but for spaces around it or its case (a CSV written ``stream, t_s``
    has the column ``' t_s'``, which pandas keeps as written), or ``""`` when none is."""
    wanted = {name.lower() for name in names}
    near = [c for c in labels if c.strip().lower() in wanted and c not in names]
    return f"; the request has {listed(near)} (spaces or case differ)" if near else ""


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


def _ignored_columns(labels: Sequence[str], long: bool,
                     stream_maps: Sequence[Mapping[str, Sequence[str]]]) -> list[str]:
    """The request's columns that no stream of ``stream_maps`` (stream -> channels) has
    (``stream`` and ``t_s`` in the long format, ``<stream>_t_s`` in the wide one, and the
    streams' channels), in request order: not read, and named in the answer rather than
    dropped without a word."""
    read = {STREAM, TIME} if long else set()
    for stream_map in stream_maps:
        for stream, channels in stream_map.items():
            read.update(channels)
            if not long:
                read.add(f"{stream}_{TIME}")
    return [c for c in labels if c not in read]


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
    first, last = _time_bounds_s(run)
    # the decision times as the service's clock computes them (the first window's end plus
    # a whole number of hops) against the newest sample: the floor of the span alone
    # planned one fewer where the span's rounding fell short (4.1 - 0.1 = 3.9999999999999996)
    origin = first + window_s
    if origin > last:
        return 0
    hops = int(math.floor((last - origin) / hop_s))
    while origin + (hops + 1) * hop_s <= last:
        hops += 1
    while hops > 0 and origin + hops * hop_s > last:
        hops -= 1
    return hops + 1


def time_span_s(run: Run) -> float:
    """From the first sample of any stream of ``run`` to the last of any.

    Parameters
    ----------
    run : Run
        Validated request (non-empty streams).

    Returns
    -------
    float
        Time span, s.
    """
    first, last = _time_bounds_s(run)
    return last - first


def _time_bounds_s(run: Run) -> tuple[float, float]:
    """The first sample time of any stream of ``run`` and the last of any, s."""
    return (min(float(f[TIME].iloc[0]) for f in run.streams.values()),
            max(float(f[TIME].iloc[-1]) for f in run.streams.values()))
