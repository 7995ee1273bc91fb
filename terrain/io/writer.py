"""Write a :class:`~terrain.run.Run` in the measured-data layout (what the reader reads back).

``DIR/<TERRAIN>/<stream>_XX.csv`` and ``DIR/<TERRAIN>/meta_XX.json``, ``XX`` the next free
two-digit index in that folder. ``<TERRAIN>`` is the run's terrain (``MIXED`` when a simulated
path crosses several; per-sample labels are in ``truth_XX.csv``).

Converting a run's canonical streams back to the file dialect is the inverse of
:data:`terrain.io.measured.COLUMN_MAPS` / :data:`~terrain.io.measured.STREAM_NAMES`: stream
``wheels`` becomes file ``pro`` (``time, curL, curR, velL, velR`` in the frame's column order),
``t_s`` becomes ``time`` in every file, other columns keep their names. Numbers are written with
``%.9g`` (9 significant digits: :func:`terrain.io.measured.read_runs_dir` reads back each value
to within 5e-9 of it, relative), except in a file whose timestamps ``%.9g`` would not keep
strictly increasing (an epoch clock, ~1.7e9 s, becomes whole seconds) or would move by more
than a hundredth of its median step (:data:`MAX_CLOCK_SHIFT_STEPS`): that file is written
with every float in full (Python's shortest exact form), so it reads back exactly.
"""

from __future__ import annotations

import json
import math
import numbers
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from terrain.errors import (ConfigError, DataFormatError, DataWarning, config_integer,
                            duplicated, missing_cell, real_number)
from terrain.io.align import first_non_number
from terrain.io.jsonfile import json_ready
from terrain.io.measured import (COLUMN_MAPS, FILE_KIND_PATTERN, MIN_DATA_ROWS, STREAM_NAMES,
                                 check_stream, known_vehicle, parse_cells)
from terrain.io.plausibility import check_run
from terrain.run import TIME, VEHICLE_NAMES, Run

#: Number format of the written CSV files (see the module's note on timestamps).
FLOAT_FORMAT = "%.9g"


#: Largest shift of a timestamp by :data:`FLOAT_FORMAT`, in median time steps of its
#: file, beyond which the file is written in full: a clock 1e6 s from 0 (a robot's seconds
#: since boot after 12 days) keeps two decimals, and a 15 Hz clock read back up to 7.5 % of
#: a step off, its steps alternating 0.06 and 0.07 s; a clock from 0 moves by at most 5e-9
#: of its value (a 100 Hz one by under a hundredth of a step for 5.5 hours at least).
MAX_CLOCK_SHIFT_STEPS = 0.01


def float_format(time_s) -> str | None:
    """The number format of a stream file: :data:`FLOAT_FORMAT`, unless it would not keep
    the file's timestamps strictly increasing, or would move one by more than
    :data:`MAX_CLOCK_SHIFT_STEPS` median time steps.

    Parameters
    ----------
    time_s : array_like
        ``(n,)`` the file's timestamps, s.

    Returns
    -------
    str or None
        :data:`FLOAT_FORMAT`, or None (pandas then writes every float in full, exactly)
        where two timestamps that increase would be written equal or out of order, e.g. an
        epoch clock at 100 Hz (1700000000.01 s is ``1.7e+09``), or where one would be
        written more than :data:`MAX_CLOCK_SHIFT_STEPS` median steps off (a 15 Hz clock
        at 1e6 s).
    """
    t = np.asarray(time_s, dtype=float)
    written = np.char.mod(FLOAT_FORMAT, t).astype(float)
    keeps = np.diff(written) > 0
    if (np.diff(t) > 0)[~keeps].any():
        return None
    if t.size >= 2:
        shift = np.abs(written - t)
        # (NaN timestamps, which the writer refuses, compare False: no shift)
        if (shift > MAX_CLOCK_SHIFT_STEPS * float(np.median(np.diff(t)))).any():
            return None
    return FLOAT_FORMAT


def file_kind(stream: str) -> str:
    """File prefix of a run stream (``wheels`` -> ``pro``; other names unchanged).

    Parameters
    ----------
    stream : str
        Stream name in the :class:`~terrain.run.Run`.

    Returns
    -------
    str
        The ``<kind>`` of ``<kind>_XX.csv``.
    """
    for kind, name in STREAM_NAMES.items():
        if name == stream:
            return kind
    return stream


def to_file_frames(run: Run) -> dict[str, pd.DataFrame]:
    """A run's streams renamed to the measured-file dialect.

    Parameters
    ----------
    run : Run
        Run with canonical streams (``t_s`` first).

    Returns
    -------
    dict
        File kind (``imu``, ``pro``, ``truth``...) -> frame with the file's column names, in
        the order of ``run.streams``.

    Raises
    ------
    ConfigError
        Two streams that go to one file (``wheels`` and ``pro``: the second overwrote the
        first), or a stream with two columns of one file name (a channel ``time`` beside
        ``t_s``, ``velL`` beside ``vel_l``: the readers refuse the file).
    """
    frames: dict[str, pd.DataFrame] = {}
    for name, frame in run.streams.items():
        kind = file_kind(name)
        if kind in frames:
            other = next(n for n in run.streams if n != name and file_kind(n) == kind)
            raise ConfigError(f"run {run.run_id}: streams {other!r} and {name!r} would both "
                              f"be written to {kind}_XX.csv; rename one")
        mapping = COLUMN_MAPS.get(kind, {"time": TIME})
        inverse = {canonical: column for column, canonical in mapping.items()}
        frames[kind] = frame.rename(columns=inverse)
        twice = duplicated(list(frames[kind].columns))
        if twice:   # (a channel 'time' beside t_s: a header the readers refuse)
            raise ConfigError(f"stream {name!r} of run {run.run_id} has columns that its "
                              f"file names alike: {twice}; rename them")
    return frames


def used_indexes(folder: str | Path) -> set[int]:
    """Run indexes ``XX`` of the ``*_XX.*`` files of ``folder``.

    Parameters
    ----------
    folder : str or Path
        Terrain folder (need not exist).

    Returns
    -------
    set of int

    Raises
    ------
    ConfigError
        ``folder`` exists and is not a folder (a file of that name: the run's files cannot
        go in it).
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        # (terrain simulate simulated first, then mkdir failed with a bare "File exists")
        raise ConfigError(f"{folder} is a file, not a terrain folder: a run's files are "
                          f"written into a folder of that name; remove the file or write "
                          f"to another output folder")
    used = set()
    if folder.is_dir():
        for p in folder.iterdir():
            stem = p.stem
            # (isdecimal: "²".isdigit() is True, and int("²") a bare ValueError)
            if "_" in stem and stem.rsplit("_", 1)[1].isdecimal():
                used.add(int(stem.rsplit("_", 1)[1]))
    return used


def next_index(folder: str | Path) -> int:
    """Smallest index ``XX`` not used by any ``*_XX.*`` file of ``folder``.

    Parameters
    ----------
    folder : str or Path
        Terrain folder (need not exist).

    Returns
    -------
    int
        >= 0.

    Raises
    ------
    ConfigError
        ``folder`` exists and is not a folder (:func:`used_indexes`).
    """
    used = used_indexes(folder)
    i = 0
    while i in used:
        i += 1
    return i


def free_index(folder: str | Path) -> int:
    """:func:`next_index` of ``folder``, refused when the two-digit layout has none left.

    Parameters
    ----------
    folder : str or Path
        Terrain folder (need not exist).

    Returns
    -------
    int
        The index the next run written there gets, 0-99.

    Raises
    ------
    ConfigError
        The folder already holds runs 00-99, or it exists and is not a folder.
    """
    idx = next_index(folder)
    if idx > 99:
        raise ConfigError(f"{folder} already holds runs 00-99: the layout numbers a terrain "
                          f"folder's runs with two digits; write to another folder")
    return idx


def _text_read_back(cell) -> bool:
    """Whether a cell of a text channel reads back as written: the readers keep a channel
    as text only when every cell is text by their rule (:func:`parse_cells`: no number, no
    non-finite word, none empty), strip every cell and take one line per row; a cell
    Python's ``float`` reads as a number (``1_0``, other scripts' digits) is refused too."""
    if not isinstance(cell, str) or cell != cell.strip() or "\n" in cell or "\r" in cell:
        return False
    try:
        float(cell)
    except ValueError:
        return bool(parse_cells(pd.Series([cell]))[1][0])
    return False


def _unwritable_cell(cells: pd.Series):
    """The row of the first cell of a column that is neither a real number, text nor
    missing (a date, a duration, a complex number, bytes, a period, a Python boolean among
    objects), or None: the file would hold its text (``2020-01-01 00:00:00``, ``(1+2j)``, ``b'a'``,
    ``True``), which the readers give back as a text channel of other values."""
    if cells.dtype.kind in "cmM":
        return 0
    if cells.dtype.kind != "O" or isinstance(cells.dtype, pd.StringDtype):
        return None
    return next((k for k, c in enumerate(cells) if not _written_as_is(c)), None)


def _written_as_is(cell) -> bool:
    """Whether a cell of an object column is text, a real number (not a boolean) or
    missing (:func:`_missing_numbers` and the text rule judge those)."""
    return isinstance(cell, str) or missing_cell(cell) or real_number(cell)


def _refuse_unreadable_text(run: Run, frames: dict[str, pd.DataFrame]) -> None:
    """ConfigError for a text channel that the readers would refuse or change (a line
    break, a number or an empty cell among text, spaces around a label), or a boolean
    channel (read back as text)."""
    for (kind, frame), name in zip(frames.items(), run.streams):
        for column in frame.columns:
            cells = frame[column]
            if cells.dtype.kind == "b" or str(cells.dtype) == "boolean":
                # to_csv writes True/False, which the readers take as a text channel
                raise ConfigError(
                    f"stream {name!r} of run {run.run_id}: column {column!r} holds booleans, "
                    f"which {kind}_XX.csv would read back as the text 'True'/'False'; write "
                    "them as numbers (0/1)")
            row = _unwritable_cell(cells)
            if row is not None:
                other = cells.iloc[row]
                raise ConfigError(
                    f"stream {name!r} of run {run.run_id}: column {column!r} holds "
                    f"{other!r} ({type(other).__name__}) at row {row}, which {kind}_XX.csv "
                    "would hold as its text and read back as a text channel; write numbers "
                    "(times and durations in seconds, a complex value as two real columns) "
                    "or text labels")
            if cells.dtype.kind in "iuf" or not any(isinstance(c, str) for c in cells):
                continue
            bad = next((k for k, c in enumerate(cells) if not _text_read_back(c)), None)
            if bad is not None:
                raise ConfigError(
                    f"stream {name!r} of run {run.run_id}: text column {column!r} holds "
                    f"{cells.iloc[bad]!r} at row {bad}, which {kind}_XX.csv would not read "
                    "back as written (a text channel's cells are one-line labels without "
                    "spaces around them, none a number, empty or a non-finite word)")


def _name_read_back(name, first: bool) -> bool:
    """Whether a column name reads back as written: the readers split the header line on
    commas without unquoting, strip every name, end a line at LF or CR, skip a line led by
    ``#`` and drop a leading byte-order mark; a name that is not text comes back as text
    (``0`` as ``'0'``) and an empty one is not read."""
    if not isinstance(name, str) or not name or name != name.strip():
        return False
    if any(c in name for c in ',"\r\n'):
        return False
    return not (first and name.startswith(("#", "\ufeff")))


def _refuse_unreadable_names(run: Run, frames: dict[str, pd.DataFrame]) -> None:
    """ConfigError for a column whose name the readers would not give back as written
    (:func:`_name_read_back`), or a column of an ``imu``/``pro`` file that is not among the
    file's canonical columns (the readers leave it out, an ignored column)."""
    for (kind, frame), name in zip(frames.items(), run.streams):
        for k, column in enumerate(frame.columns):
            if not _name_read_back(column, k == 0):
                raise ConfigError(
                    f"stream {name!r} of run {run.run_id}: column name {column!r} would not "
                    f"be read back as written from {kind}_XX.csv (a name is non-empty text "
                    "without spaces around it, a comma, a quote or a line break); rename it")
            if kind in COLUMN_MAPS and column not in COLUMN_MAPS[kind]:
                raise ConfigError(
                    f"stream {name!r} of run {run.run_id}: column {column!r} would be written "
                    f"to {kind}_XX.csv but never read back (the readers take its columns "
                    f"{list(COLUMN_MAPS[kind])} only); put it in a stream of its own")


def _refuse_unreadable_time(run: Run) -> None:
    """ConfigError for a stream whose timestamps the readers refuse: one that is not finite
    (never repaired) or one that does not increase strictly (the readers' rule,
    ``_check_time``)."""
    for name, frame in run.streams.items():
        if TIME not in frame:
            continue
        row = first_non_number(frame[TIME])
        if row is not None:     # (text: float()'s bare ValueError; a date: its text)
            cell = frame[TIME].iloc[row]
            raise ConfigError(
                f"stream {name!r} of run {run.run_id}: timestamp {cell!r} "
                f"({type(cell).__name__}) at row {row} is not a number: t_s holds seconds, "
                f"which the readers read from the time column of {file_kind(name)}_XX.csv")
        bad = _missing_numbers(frame[TIME])
        if bad.size:
            raise ConfigError(
                f"stream {name!r} of run {run.run_id}: {bad.size} non-finite timestamp(s), "
                f"the first {_cell_text(frame[TIME].iloc[bad[0]])} at row {bad[0]}; the "
                f"readers never repair a timestamp and would refuse {file_kind(name)}_XX.csv")
        t = frame[TIME].to_numpy(dtype=float)
        back = np.flatnonzero(np.diff(t) <= 0) + 1
        if back.size:
            row = int(back[0])
            what = "duplicated" if t[row] == t[row - 1] else "decreasing"
            raise ConfigError(
                f"stream {name!r} of run {run.run_id}: {what} timestamp {t[row]!r} after "
                f"{t[row - 1]!r} at row {row} ({back.size} such row(s)); the readers take "
                f"timestamps that increase strictly and would refuse "
                f"{file_kind(name)}_XX.csv: sort the stream or drop the repeats")


def _refuse_missing_columns(run: Run, frames: dict[str, pd.DataFrame]) -> None:
    """ConfigError for a stream whose file would lack a column the readers require: ``time``
    (the stream's ``t_s``) in every file, and the canonical columns of ``imu_XX.csv`` and
    ``pro_XX.csv`` (:data:`terrain.io.measured.COLUMN_MAPS`)."""
    for (kind, frame), name in zip(frames.items(), run.streams):
        mapping = COLUMN_MAPS.get(kind, {"time": TIME})
        missing = [column for column in mapping if column not in frame.columns]
        if missing:
            raise ConfigError(
                f"stream {name!r} of run {run.run_id} lacks the column(s) {missing} of "
                f"{kind}_XX.csv (channels {[mapping[c] for c in missing]}), which the "
                "readers require: they would refuse the file")


def _missing_numbers(cells: pd.Series) -> np.ndarray:
    """Rows of a numeric column that the file would hold as a missing or non-finite cell:
    NaN, inf, pandas' ``NA`` of a nullable column (``Int64``, ``Float64``: ``float()`` of it
    was a bare TypeError) and, in an object column without text (a text column is
    :func:`_refuse_unreadable_text`'s), a missing cell (``None``, ``NaT``...) or a non-finite
    number (written as an empty cell or ``inf``, which the readers interpolate or refuse).
    Other columns: none."""
    if cells.dtype.kind in "iuf":
        values = cells.to_numpy(dtype=float, na_value=np.nan)
        return np.flatnonzero(~np.isfinite(values))
    if cells.dtype.kind != "O" or any(isinstance(c, str) for c in cells):
        return np.zeros(0, dtype=int)
    # (math.isinf of a np.timedelta64, a NumPy integer, was a bare TypeError)
    infinite = [real_number(c) and math.isinf(c) for c in cells]
    return np.flatnonzero(cells.isna().to_numpy() | np.array(infinite, dtype=bool))


def _cell_text(cell) -> str:
    """A missing or non-finite cell for a message: a number as Python's float writes it
    (``nan``, ``inf``), anything else as its ``repr`` (``None``, ``<NA>``)."""
    return repr(float(cell)) if isinstance(cell, numbers.Real) else repr(cell)


def _refuse_non_finite_values(run: Run) -> None:
    """ConfigError for a NaN or infinite sample of a numeric channel: the readers give no
    such value back (an isolated one is interpolated and counted as a repair, one at the
    file's edge or in a burst makes them refuse the file)."""
    for name, frame in run.streams.items():
        for column in frame.columns:
            if column == TIME:
                continue
            bad = _missing_numbers(frame[column])
            if bad.size:
                raise ConfigError(
                    f"stream {name!r} of run {run.run_id}: column {column!r} holds "
                    f"{bad.size} non-finite value(s), the first "
                    f"{_cell_text(frame[column].iloc[bad[0]])} at row {bad[0]}; the readers "
                    f"never give one back (an isolated one is interpolated, one at the edge "
                    f"or in a burst makes them refuse {file_kind(name)}_XX.csv): write "
                    "finite values")


def _file_format(frame: pd.DataFrame) -> str | None:
    """The number format of one file frame (``time`` its clock): :func:`float_format`."""
    return float_format(frame["time"]) if "time" in frame else FLOAT_FORMAT


def _formatted(frame: pd.DataFrame, fmt: str | None) -> pd.DataFrame:
    """A file frame with each float column as the text its file holds: ``fmt % value``
    (pandas' rule for ``to_csv(float_format=fmt)``; NaN, which the writer refuses before,
    as pandas' empty cell), so that the numbers are formatted once, for the file and for
    :func:`_as_read` (pandas formatted them again, the longest cost of a long run's
    write). ``fmt`` None: the frame as it is (pandas writes every float in full).

    Parameters
    ----------
    frame : pandas.DataFrame
        ``(n_rows, n_columns)`` one file's frame (:func:`to_file_frames`).
    fmt : str or None
        The file's number format (:func:`_file_format`).

    Returns
    -------
    pandas.DataFrame
        Same shape, columns and index; float columns as ``object`` columns of text, the
        others as they are.
    """
    if fmt is None:
        return frame
    out = {}
    for c in frame.columns:
        cells = frame[c]
        if cells.dtype.kind != "f":
            out[c] = cells
            continue
        values = cells.to_numpy(dtype=float, na_value=np.nan)
        text = np.array([fmt % v for v in values.tolist()], dtype=object)
        text[np.isnan(values)] = ""
        out[c] = pd.Series(text, index=frame.index, dtype=object)
    return pd.DataFrame(out, index=frame.index)


def _as_read(frame: pd.DataFrame, written: pd.DataFrame) -> pd.DataFrame:
    """A stream as the readers give it back from its file (``written``, its
    :func:`_formatted` frame): its float columns as their written text reads (written in
    full: exactly), its other numeric columns as float64, its text columns as they are
    (the writer's other checks refused every other cell)."""
    out = {}
    for c, w in zip(frame.columns, written.columns):
        cells = frame[c]
        if cells.dtype.kind == "O" and any(isinstance(v, str) for v in cells):
            out[c] = cells.to_numpy()
            continue
        if cells.dtype.kind == "f" and written[w].dtype.kind == "O":
            text = written[w].to_numpy(dtype=object)
            values = np.full(text.shape, np.nan)
            filled = text != ""
            values[filled] = text[filled].astype(float)     # float() of each text
        else:
            values = cells.to_numpy(dtype=float, na_value=np.nan)
        out[c] = values
    return pd.DataFrame(out)


def _refuse_implausible(run: Run, frames: dict[str, pd.DataFrame],
                        paths: dict[str, Path], written: dict[str, pd.DataFrame]) -> None:
    """ConfigError for a run that the readers' plausibility rules refuse (an IMU in a z-down
    frame, an accelerometer in g, a value out of its channel's range, clocks that do not
    overlap...): the readers' own rules (:func:`terrain.io.measured.check_stream` per file,
    :func:`terrain.io.plausibility.check_run` on the run) applied to the streams as they
    would be read back from ``paths`` (``frames`` written there as ``written``, their
    :func:`_formatted` frames),
    the message the readers' (their error chained). Their findings (a stuck sensor) are
    left to the readers, who warn them on every read."""
    streams = {}
    try:
        for kind, (name, frame) in zip(frames, run.streams.items()):
            streams[name] = _as_read(frame, written[kind])
            mapping = COLUMN_MAPS.get(kind) or {
                "time": TIME, **{c: c for c in frame.columns if c != TIME}}
            # (the header is line 1 of the file, row k its line k + 2)
            check_stream(streams[name], kind, paths[kind], mapping,
                         np.arange(len(frame)) + 2, found=[])
        check_run(run.run_id, streams, run.vehicle.lower(),
                  {name: str(paths[file_kind(name)]) for name in run.streams},
                  columns={STREAM_NAMES[k]: COLUMN_MAPS[k] for k in paths if k in COLUMN_MAPS},
                  warn=False)
    except DataFormatError as exc:
        raise ConfigError(f"run {run.run_id} would be written to files that the readers "
                          f"refuse: {exc}") from exc


def _same_vehicle(value, vehicle: str) -> bool:
    """Whether a meta ``vehicle`` value names ``vehicle`` (text, in any case: the readers
    lower-case it)."""
    return isinstance(value, str) and value.lower() == vehicle.lower()


def _json_default(value):
    """A meta value JSON cannot hold: an array as its list (NaN as null), else its text
    (``str`` of an array cut it to ``[0 1 2 ... 1997 1998 1999]`` past 1000 values)."""
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist(), None)
    return str(value)


def write_run(run: Run, out_dir: str | Path, index: int | None = None) -> dict[str, Path]:
    """Write every stream of a run and its metadata in the measured-data layout.

    Parameters
    ----------
    run : Run
        Run to write (e.g. from :func:`terrain.sim.simulate`); its ``meta`` is written as
        standard JSON by :func:`terrain.io.jsonfile.json_ready` (NumPy scalars as numbers
        and booleans, NaN and inf as ``null``, tuples and arrays as lists); other values
        that JSON cannot hold are written with ``str``.
    out_dir : str or Path
        Root folder; the run goes to ``out_dir / <TERRAIN>`` (``run.terrain``, ``UNLABELLED``
        when it has none).
    index : int, optional
        Run index (default: the next free one).

    Returns
    -------
    dict
        File kind (and ``meta``) -> written path.

    Raises
    ------
    ConfigError
        The run's vehicle is not one of :data:`terrain.run.VEHICLE_NAMES` (in any case;
        the readers refuse its ``meta_XX.json``), the run has no ``wheels`` stream (the
        readers refuse a run without
        ``pro_XX.csv``), index not an integer in [0, 99] (a boolean, a float or text
        included) or already
        used by a file of the folder (any
        ``*_XX.*``, measured runs have no ``meta_XX.json``), no free index left (default
        ``index``: the folder holds runs 00-99), a stream name the readers
        would not read back (``meta`` included, and ``pro``: ``pro_XX.csv`` is read back as
        ``wheels``) or two streams that go to one file
        (:func:`to_file_frames`), a stream without ``t_s`` or an ``imu`` or ``wheels``
        stream without one of its canonical channels (a file the readers refuse), a
        terrain that is not a folder name (``A/B``, ``..``, a NUL character), not UTF-8
        text (a lone surrogate such as ``'\\udcff'``) or
        not in upper case (the readers upper-case the folder name: ``snow`` is read back as
        ``SNOW``), a stream of fewer than :data:`~terrain.io.measured.MIN_DATA_ROWS` (2)
        rows (a file the readers refuse), a column name the readers would not give back
        as written (not text, empty, spaces around it, a comma, a quote or a line break:
        ``' x'`` came back as ``'x'``, ``'a"b'`` as ``'"a""b"'``), a column of the ``imu``
        or ``wheels`` stream other than its file's canonical ones (never read back), or a
        text column the readers would refuse or change (a cell with a line break or spaces
        around it, a number, an empty or non-finite cell among text), a column of values
        that are neither real numbers nor text (dates, durations, complex numbers, bytes,
        Python booleans among objects: written as their text, read back as a text channel
        of other values), or timestamps the readers refuse (not numbers: text, dates,
        durations; not finite, or not increasing strictly: a duplicated or decreasing one),
        or a NaN or infinite value of a numeric channel (pandas' ``NA`` of a nullable
        column and ``None`` among numbers included: the readers interpolate an isolated one
        and refuse one at the file's edge or in a burst), or streams that the readers'
        plausibility rules (:mod:`terrain.io.plausibility`) refuse: an IMU in a z-down frame,
        an accelerometer in g, timestamps certainly not in s, a value outside its channel's
        range, clocks that do not overlap, a gyro in deg/s, wheel sides swapped, wheel
        speeds in km/h (the message holds the readers' own, naming the file to be written,
        column and line; their error is chained as ``__cause__``); nothing is written then.
    OSError
        A file could not be written (a full disk, no permission); as on any failure while
        writing (``KeyboardInterrupt`` included), no file of the run is left: each is
        written under a temporary name (``.<file>.writing``) and renamed into place,
        ``pro_XX.csv`` (by which the readers find a run) last.

    Warns
    -----
    DataWarning
        The run's ``meta`` has a ``vehicle`` other than the run's
        :attr:`~terrain.run.Run.vehicle` (in any case; rule ``meta_keys``, as
        :func:`terrain.io.measured.read_run` warns a key it replaces): ``meta_XX.json`` gets
        the run's vehicle, by which the readers read the run back, and the meta's value is
        not kept; the message names the file, the run, the key and both values. A
        ``vehicle`` that names the run's vehicle in another case is written as the run's,
        without a word (the readers lower-case it).
    """
    terrain = str(run.terrain or "UNLABELLED")
    if terrain in (".", "..") or any(sep in terrain for sep in "/\\\0"):
        # 'A/B' wrote a folder the readers never look in (they take <root>/<TERRAIN>/); a
        # NUL character made Path.mkdir a bare "ValueError: embedded null byte"
        raise ConfigError(f"terrain {terrain!r} is not a folder name: the run would be "
                          f"written where the readers never look")
    if not terrain.isascii() and any("\ud800" <= c <= "\udfff" for c in terrain):
        # '\udcff' became the folder b'\xff', read back as the label '\\XFF'; '\ud800'
        # was a bare UnicodeEncodeError
        raise ConfigError(f"terrain {terrain!r} is not UTF-8 text (a lone surrogate, as "
                          f"Python gives a folder name that is not UTF-8 on disk): the "
                          f"readers would not read it back; give the label as text")
    if terrain != terrain.upper():
        # the readers take the label from the folder name, upper-cased: 'snow' came back SNOW
        raise ConfigError(f"terrain {terrain!r} would be read back as {terrain.upper()!r} "
                          f"(the readers upper-case the folder name); give the label in "
                          f"upper case")
    if not known_vehicle(run.vehicle):
        # its files were written, then refused by every reader ("unknown vehicle"), which
        # stopped the reading of every run of the folder
        raise ConfigError(f"run {run.run_id}: vehicle {run.vehicle!r} would be written to "
                          f"meta_XX.json, which the readers refuse; valid: "
                          f"{', '.join(VEHICLE_NAMES)}")
    frames = to_file_frames(run)
    # the readers take <kind>_XX.csv with that kind only, as the stream STREAM_NAMES gives
    # it (pro_XX.csv: 'wheels', so a stream named 'pro' came back as 'wheels'); meta_XX is
    # the metadata
    odd = [name for name in run.streams
           if not re.fullmatch(FILE_KIND_PATTERN, file_kind(name)) or name == "meta"
           or STREAM_NAMES.get(file_kind(name), name) != name]
    if odd:
        raise ConfigError(f"stream names {odd} would be written but never read back: a "
                          f"stream name is lower-case letters and digits, starting with a "
                          f"letter, and not 'meta' (meta_XX.json holds the run's metadata) "
                          f"nor 'pro' (pro_XX.csv is read back as the stream 'wheels')")
    wheels = STREAM_NAMES["pro"]
    if wheels not in run.streams:
        # its files were written, then refused by every reader (OrphanFileError), which
        # stopped the reading of every run of the folder
        raise ConfigError(f"run {run.run_id} has no {wheels!r} stream: the readers read a run "
                          f"from its pro_XX.csv (streams given: {list(run.streams)})")
    _refuse_missing_columns(run, frames)
    short = next(((n, len(f)) for n, f in run.streams.items() if len(f) < MIN_DATA_ROWS), None)
    if short is not None:   # (a header and one row, or none: a file the readers refuse)
        raise ConfigError(f"stream {short[0]!r} of run {run.run_id} has {short[1]} row(s): "
                          f"the readers need at least {MIN_DATA_ROWS} to know its sample "
                          f"rate and would refuse {file_kind(short[0])}_XX.csv; leave the "
                          "stream out")
    _refuse_unreadable_time(run)
    _refuse_non_finite_values(run)
    _refuse_unreadable_names(run, frames)
    _refuse_unreadable_text(run, frames)
    folder = Path(out_dir) / terrain
    if index is not None:    # (True was run 01, 2.7 run 02, "x" int()'s bare ValueError)
        config_integer("write_run.index", index, 0, 99)
    idx = free_index(folder) if index is None else int(index)
    if idx in used_indexes(folder):     # any *_XX.* file, as next_index counts them
        raise ConfigError(f"run index {idx:02d} already used in {folder}")
    paths = {kind: folder / f"{kind}_{idx:02d}.csv" for kind in frames}
    # every number formatted once: for the file and for the readers' rules
    formats = {kind: _file_format(frame) for kind, frame in frames.items()}
    written = {kind: _formatted(frame, formats[kind]) for kind, frame in frames.items()}
    # (an IMU in a z-down frame was written, then refused by every reader)
    _refuse_implausible(run, frames, paths, written)
    paths["meta"] = folder / f"meta_{idx:02d}.json"
    folder.mkdir(parents=True, exist_ok=True)      # after the checks: nothing written then
    meta = dict(run.meta)
    # read back as the run's vehicle: not the default, nor a stale "vehicle" of its meta
    # (which was replaced without a word, where the readers warn a key they replace)
    if "vehicle" in meta and not _same_vehicle(meta["vehicle"], run.vehicle):
        warnings.warn(f"{paths['meta']}: rule meta_keys: key 'vehicle' of the metadata of run "
                      f"{run.run_id} is {meta['vehicle']!r:.60}, the run's vehicle "
                      f"{run.vehicle!r}: the file gets the run's (the readers read the run "
                      "back as that vehicle) and the metadata's value is not kept",
                      DataWarning, stacklevel=2)
    meta["vehicle"] = run.vehicle
    meta["index"] = f"{idx:02d}"
    meta["files"] = {k: p.name for k, p in paths.items() if k != "meta"}
    # every file goes to a temporary name that the readers skip, then into place, pro_XX.csv
    # (by which the readers find a run) last: imu_00.csv and pro_00.csv left by a failure
    # at truth_00.csv or meta_00.json (a full disk, an interrupt) were read as a complete
    # measured run of the default vehicle
    staged = {kind: path.with_name(f".{path.name}.writing") for kind, path in paths.items()}
    placed: list[Path] = []
    try:
        for kind, frame in written.items():
            frame.to_csv(staged[kind], index=False, float_format=formats[kind])
        # numpy scalars as JSON numbers and booleans (default=str wrote np.int64(3) as "3"),
        # NaN and inf as null (the bare token NaN is not JSON): terrain.io.jsonfile's rule
        staged["meta"].write_text(json.dumps(json_ready(meta, None), indent=2,
                                             default=_json_default, allow_nan=False))
        for kind in sorted(paths, key=lambda k: k == "pro"):
            staged[kind].replace(paths[kind])
            placed.append(paths[kind])
    except BaseException:
        for path in placed:     # new files (the index was free): the run's, none older
            path.unlink(missing_ok=True)
        raise
    finally:
        for tmp in staged.values():
            tmp.unlink(missing_ok=True)
    return paths
