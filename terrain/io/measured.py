"""Reader for the measured-run CSV layout ``<root>/<TERRAIN>/{imu_XX.csv, pro_XX.csv}``.

The layout is the one of the Husky datasets in ``shared/data`` (BorealTC, Vulpi) and of the
files written by ``terrain simulate``:

* ``imu_XX.csv``: ``time, wx, wy, wz, ax, ay, az`` in s, rad/s, m/s^2;
* ``pro_XX.csv``: ``time, curL, curR, velL, velR`` in s, A, m/s (column order varies between
  datasets: columns are always read by name);
* any other ``<stream>_XX.csv`` (simulator extras such as ``truth_XX.csv``): ``time`` first,
  snake_case channel names, SI units; loaded as stream ``<stream>``;
* ``meta_XX.json`` (optional): run metadata, e.g. ``{"vehicle": "husky"}``; a key the
  reader sets itself (``repaired``, ``gaps``, ``files``..., :func:`read_run`) is replaced by
  the reader's value, with a :class:`~terrain.errors.DataWarning` where the file's differs.

Validation rules: every problem raises a subclass of :class:`terrain.errors.DataFormatError`
naming file, column and 1-based file line; the plausibility rules (ranges, units, clocks,
stuck sensors) are those of :mod:`terrain.io.plausibility`. The only
repair is documented in :func:`read_stream_csv`: isolated non-finite samples (at most
``max_repair_run`` consecutive rows in one channel) are linearly interpolated in time and
counted; longer bursts are rejected. Timestamp gaps are never interpolated across: they are
listed in ``Run.meta["gaps"]``, the windowing step drops every window that spans one, and a
non-finite sample next to one is rejected (its repair would interpolate across it).
"""

from __future__ import annotations

import csv
import json
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np
import pandas as pd

from terrain.errors import (ConfigError, DataFormatError, DataWarning, EmptyFileError,
                            EncodingError, ImplausibleValueError, MissingColumnError,
                            NonFiniteError, NonNumericError, OrphanFileError, RaggedRowError,
                            TimestampError, UnreadableFileError, config_flags, config_integer,
                            duplicated, first_items)
from terrain.io.align import check_gap_factor, gap_steps
from terrain.io.jsonfile import json_ready
from terrain.io.plausibility import (CHANNEL_LIMITS, check_accel_units, check_ranges,
                                     check_rate, check_run)
from terrain.run import IMU_CHANNELS, TIME, VEHICLE_NAMES, Run

#: file column -> canonical name, per known file kind
COLUMN_MAPS: Mapping[str, Mapping[str, str]] = MappingProxyType({
    "imu": MappingProxyType({"time": TIME, **{c: c for c in IMU_CHANNELS}}),
    "pro": MappingProxyType({"time": TIME, "velL": "vel_l", "velR": "vel_r", "curL": "cur_l",
                             "curR": "cur_r"}),
})
#: file prefix -> stream name in the Run
STREAM_NAMES: Mapping[str, str] = MappingProxyType({"imu": "imu", "pro": "wheels"})
#: gyro rates above this (rad/s) are beyond a MEMS gyro's 2000 deg/s full scale: the reader's
#: plausibility range of the angular rates (:data:`terrain.io.plausibility.CHANNEL_LIMITS`)
MAX_PLAUSIBLE_RATE_RAD_S = CHANNEL_LIMITS["wz"].limit
#: stream name -> the file kind it is read from, for the names that are not their file's
#: kind (``wheels``, from ``pro_XX.csv``): a ``wheels_XX.csv`` would replace that stream
_TAKEN_STREAM_NAMES: Mapping[str, str] = MappingProxyType(
    {name: kind for kind, name in STREAM_NAMES.items() if name != kind})
#: the ``<kind>`` of a run file ``<kind>_XX.csv`` the readers take (the stream's file prefix)
FILE_KIND_PATTERN = r"[a-z][a-z0-9]*"
_FILE_RE = re.compile(rf"^(?P<kind>{FILE_KIND_PATTERN})_(?P<index>\d+)\.csv$")
_META_RE = re.compile(r"^meta_(?P<index>.+)\.json$")
#: cell texts (stripped, lower case) that stand for a missing or non-finite sample: the words
#: NumPy's fast path reads as non-finite too (C's printf writes -nan), and an empty cell
#: fewest data rows of a stream file: two are needed to know its sample rate
MIN_DATA_ROWS = 2
NON_FINITE_WORDS = ("nan", "-nan", "+nan", "inf", "-inf", "+inf", "infinity", "-infinity",
                    "+infinity", "")


@dataclass
class ReadReport:
    """What a reader repaired or noticed in one file.

    Attributes
    ----------
    path : str
        File read.
    repaired : dict[str, int]
        Channel -> number of non-finite samples repaired by linear interpolation.
    gaps : list[tuple[float, float]]
        ``(t_start_s, t_end_s)`` of each timestamp gap longer than ``gap_factor`` times the
        median sampling interval.
    skipped_lines : dict[str, int]
        ``blank`` and ``comment`` lines skipped.
    ignored_columns : list[str]
        Header columns of an ``imu`` or ``pro`` file that are not among its canonical
        columns, and header columns of any stream file that have no name or are named
        ``t_s`` (the clock is ``time``), in file order:
        present in the file, not read. One with an empty name is ``<unnamed column N>`` (N
        its 1-based position; the last one's name adds ``a trailing comma?``).
    warnings : list[str]
        What the file itself makes likely but not certain (rule ``last_line``: no line
        break after the last line, which may then have been cut off while being written;
        rule ``timestamp_units``: a rate outside the stream's nominal range; rule
        ``accel_units``: an accelerometer that sees no gravity), each naming the file;
        :func:`read_stream_csv` warns them and :func:`read_run` adds them to the run's
        warnings.
    """

    path: str
    repaired: dict[str, int] = field(default_factory=dict)
    gaps: list[tuple[float, float]] = field(default_factory=list)
    skipped_lines: dict[str, int] = field(default_factory=dict)
    ignored_columns: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def _header_format_hint(header: list[str]) -> str:
    # a header that is another CSV dialect: say which, since the readers take one
    joined = ",".join(header)
    for sep, name in (("\t", "tabs"), (";", "semicolons"), ("|", "bars")):
        if sep in joined:
            return f" (the header is separated by {name}; the readers take commas only)"
    if any(len(c) > 1 and c[0] == c[-1] and c[0] in "\"'" for c in header):
        return " (the names are quoted; the readers take them unquoted)"
    if header and header[0].startswith("\ufeff"):
        # utf-8-sig drops one at the file's start only: a second one, or one after a line
        return (" (a byte-order mark leads the header line: the file holds a second one, or "
                "one after the lines above; save it as UTF-8 with one at most, at its start)")
    return ""


def read_stream_csv(path: str | Path, kind: str, *, max_repair_run: int = 2,
                    gap_factor: float = 3.0) -> tuple[pd.DataFrame, ReadReport]:
    """Read and validate one stream file.

    The file is parsed strictly: UTF-8 text (a BOM is allowed), comma separated (a quoted
    data field is read as CSV within its own line; header names unquoted), one header line
    then one data row per line, lines ended by LF, CR LF or a lone CR (as
    the streaming service reads CSV bodies). Blank lines and ``#`` comment lines are
    skipped and counted in the report; the first other line is the header (one of numbers
    is refused: the header is missing or commented out, as ``numpy.savetxt`` writes it);
    every other line must have as many fields as the header. Errors name the 1-based file
    line (what an editor shows).

    Parameters
    ----------
    path : str or Path
        CSV file.
    kind : str
        File prefix (``imu``, ``pro`` or a simulator extra such as ``truth``). ``imu`` and
        ``pro`` require their canonical columns; other kinds only require ``time``.
    max_repair_run : int
        Longest run of consecutive non-finite samples in one channel that is repaired by
        linear interpolation in time between its finite neighbours (counted in the report).
        Longer bursts, non-finite values at the first or last row, and those whose finite
        neighbours lie across a timestamp gap (a step of more than ``gap_factor`` median
        steps) raise :class:`NonFiniteError`. A non-finite sample is an empty cell or one of
        :data:`NON_FINITE_WORDS`; a number beyond the float64 range (``1e400``) is not one:
        it raises :class:`ImplausibleValueError`.
    gap_factor : float
        A timestamp step larger than ``gap_factor`` times the median step is reported as a gap
        (a finite number > 1, :func:`terrain.io.align.check_gap_factor`).

    Returns
    -------
    frame : pandas.DataFrame
        ``t_s`` first, then canonical channel names (SI units), float64 except string columns
        of extra streams (e.g. a per-sample ``terrain`` label).
    report : ReadReport

    Raises
    ------
    UnreadableFileError, EncodingError, EmptyFileError, RaggedRowError, MissingColumnError,
    NonNumericError, NonFiniteError, TimestampError, ImplausibleValueError, UnitError
        All :class:`DataFormatError`, with file, column and file line.
    ConfigError
        ``max_repair_run`` not an integer >= 0, or ``gap_factor`` not a finite number > 1
        (checked before the file is read).
    """
    config_integer("read_stream_csv.max_repair_run", max_repair_run, 0)
    check_gap_factor("read_stream_csv", gap_factor)
    path = Path(path)
    text = read_text(path)
    if "\r" in text:   # CR LF and a lone CR (classic Mac OS) end a line as LF does
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    header, rows, lines, skipped = _split_lines(text, path)
    header_line = skipped.pop("header_line")
    # columns without a name (trailing commas) are told apart by position, not refused
    named = [c for c in header if c]
    if len(set(named)) < len(named):
        dup = duplicated(named)
        raise DataFormatError(f"duplicated column name(s) {dup} in the header", path, dup[0],
                              line=header_line)
    mapping = COLUMN_MAPS.get(kind)
    if mapping is None:
        # extra stream: ``time`` is required and comes first, other columns keep their names;
        # a column without a name (a trailing comma) is not read but reported, as for imu/pro;
        # so is one named t_s, the canonical name of the clock (it took the place of the
        # file's 'time' column without a word)
        mapping = {"time": TIME, **{c: c for c in header if c and c not in ("time", TIME)}}
    missing = [c for c in mapping if c not in header]
    if missing:
        raise MissingColumnError(
            f"missing column(s) {missing}; found {header[:12]}, expected {list(mapping)}"
            f"{_header_format_hint(header)}", path, missing[0], line=header_line)
    report = ReadReport(str(path), skipped_lines=skipped,
                        ignored_columns=[_column_label(header, k) for k, c in enumerate(header)
                                         if c not in mapping])
    if not text.endswith("\n"):
        # a writer interrupted mid-line leaves a partial last value ("-0.0" of "-0.0731")
        # that parses as a number: said, not dropped (many tools end files this way too)
        report.warnings.append(
            f"{path}: rule last_line: no line break after the last line (line "
            f"{text.count(chr(10)) + 1}), so it may have been cut off while the file was "
            "written; kept as read")
    # Python's float() also takes "1_000" and non-ASCII digits: those go the strict path
    plain = text.isascii() and "_" not in text
    numbers = _fast_numbers(rows, header, mapping) if plain else None
    if numbers is not None:
        cells = None
    else:
        cells = np.empty((len(rows), len(header)), dtype=object)
        cells[:] = rows
    out: dict[str, np.ndarray] = {}
    for col, name in mapping.items():
        if numbers is not None:
            out[name] = numbers[:, header.index(col)]
            continue
        text = pd.Series(cells[:, header.index(col)]).str.strip()
        values, bad = parse_cells(text)
        if bad.any():
            if kind not in COLUMN_MAPS and name != TIME and bad.all():
                out[name] = text.to_numpy()  # a string channel of an extra stream
                continue
            idx = np.flatnonzero(bad)
            shown = text.iloc[idx[0]]
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            first = [str(c).strip() for c in rows[int(idx[0])]]
            # (a log saved with a byte-order mark, joined to another: the mark leads its line)
            marked = bool(first) and first[0].startswith("\ufeff")
            if marked:
                first[0] = first[0].lstrip("\ufeff").strip()
            hint = (f"; line {int(lines[idx[0]])} repeats the header (two logs joined into "
                    "one file?" + (", the second with a byte-order mark" if marked else "")
                    + "): cut the file there or delete that line"
                    if first == header else
                    "; a decimal comma? numbers take a decimal point (0.25, not 0,25)"
                    if re.fullmatch(r"[-+]?\d*,\d+(?:[eE][-+]?\d+)?", shown) else "")
            raise NonNumericError(f"{idx.size} non-numeric value(s), first {shown!r} at "
                                  f"{first_items(lines[idx])}{hint}", path, col, int(idx[0]),
                                  int(lines[idx[0]]))
        out[name] = values
    _refuse_overflow(out, mapping, header, rows, lines, path)
    # the clock first (finite, increasing, its gaps): channels are repaired on it
    t = out[TIME]
    _refuse_non_finite_time(t, path, next(c for c, n in mapping.items() if n == TIME), lines,
                            rows)
    is_gap = _check_time(t, path, gap_factor, report, lines)
    for col, name in mapping.items():
        if name != TIME and out[name].dtype != object:
            out[name] = _repair_non_finite(out[name], t, is_gap, path, col, max_repair_run,
                                           report, name, lines)
    frame = pd.DataFrame(out)
    check_stream(frame, kind, path, mapping, lines, report.warnings)
    for msg in report.warnings:
        warnings.warn(msg, DataWarning, stacklevel=2)
    return frame, report


def check_stream(frame: pd.DataFrame, kind: str, path, mapping: Mapping[str, str],
                 lines: np.ndarray | None, found: list[str]) -> None:
    """The plausibility rules of one stream file (:mod:`terrain.io.plausibility`), as
    :func:`read_stream_csv` applies them to what it read, and
    :func:`terrain.io.writer.write_run` to what it would write.

    Parameters
    ----------
    frame : pandas.DataFrame
        ``(n_rows, n_columns)`` the stream as read: ``t_s`` first, canonical channel names,
        SI units (float64 numbers).
    kind : str
        File prefix (``imu``, ``pro`` or an extra stream's).
    path : str or Path
        The file (for the messages).
    mapping : Mapping[str, str]
        Column name in the file -> canonical name (the messages name the file's column).
    lines : numpy.ndarray or None
        ``(n_rows,)`` 1-based file line of each row (for the messages).
    found : list of str
        Where the findings go (rules ``timestamp_units``, ``accel_units``: a rate outside
        the nominal range, a dead accelerometer); the caller warns them or not.

    Raises
    ------
    UnitError
        Timestamps certainly not in s (:func:`~terrain.io.plausibility.check_rate`), an
        accelerometer in g (:func:`~terrain.io.plausibility.check_accel_units`).
    ImplausibleValueError
        A value outside its channel's range (:func:`~terrain.io.plausibility.check_ranges`).
    """
    check_rate(frame[TIME].to_numpy(), STREAM_NAMES.get(kind, kind), path, found=found)
    check_ranges(frame, path, mapping, lines)
    if kind == "imu":
        # a file in g is refused, a dead sensor warned
        check_accel_units(frame, path, found=found)


def parse_cells(text: pd.Series) -> tuple[np.ndarray, np.ndarray]:
    """The readers' number rule for the stripped cells of one column (strict path).

    Parameters
    ----------
    text : pandas.Series
        ``(n,)`` cell texts, stripped.

    Returns
    -------
    values : numpy.ndarray
        ``(n,)`` float64, NaN where a cell is not a number or is a non-finite word
        (:data:`NON_FINITE_WORDS`, an empty cell included).
    is_text : numpy.ndarray
        ``(n,)`` bool: neither a number nor a non-finite word (a column of such cells only
        is an extra stream's text channel; one among numbers a
        :class:`~terrain.errors.NonNumericError`).
    """
    # pandas' parser reads a number led by "+" one unit in the last place off (1 in 8 of
    # them: "+1.4718714553235301"); without its sign it reads float()'s value
    values = pd.to_numeric(text.str.replace(r"^\+(?=[0-9.])", "", regex=True),
                           errors="coerce").to_numpy(dtype=float)
    # the words NumPy's fast path reads as non-finite too (C's printf writes -nan)
    is_nan_word = text.str.lower().isin(NON_FINITE_WORDS).to_numpy()
    return values, np.isnan(values) & ~is_nan_word


def _column_label(header: list[str], k: int) -> str:
    """The name of header column ``k`` for the report: a column without one (a trailing
    comma on every line, header included) is named by its position, since an empty name
    read as nothing ("ignored 1 column(s) not read by the readers ()")."""
    if header[k]:
        return header[k]
    last = "; a trailing comma?" if k == len(header) - 1 else ""
    return f"<unnamed column {k + 1}{last}>"


def _fast_numbers(rows: list[list[str]], header: list[str],
                  mapping: Mapping[str, str]) -> np.ndarray | None:
    """All cells as float64 when every column is read and every cell is a number (the usual
    case); None otherwise: the slower per-column path then names the bad cell."""
    if set(header) != set(mapping) or not rows:
        return None
    try:
        return np.array(rows, dtype=np.float64)
    except ValueError:
        return None


def read_text(path: Path) -> str:
    """A file as UTF-8 text (a byte-order mark dropped), every way of failing typed.

    Parameters
    ----------
    path : Path
        File to read.

    Returns
    -------
    str
        Its text.

    Raises
    ------
    UnreadableFileError
        A directory, a FIFO/socket/device, a dangling symlink or symlink loop, no permission.
    EncodingError
        Bytes that are not UTF-8; names the first one's byte offset and line.
    """
    if path.exists() and not path.is_file() and not path.is_dir():
        raise UnreadableFileError("is not a regular file (a FIFO, socket or device?)", path)
    try:
        data = path.read_bytes()
    except IsADirectoryError:
        raise UnreadableFileError("is a directory, expected a file", path) from None
    except FileNotFoundError:
        raise UnreadableFileError("file not found (a dangling symlink?)", path) from None
    except OSError as exc:  # ELOOP (symlink loop), EACCES...
        raise UnreadableFileError(f"cannot be read: {exc.strerror or exc}", path) from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        head = data[:exc.start]   # lines end in LF, CR LF or a lone CR
        line = head.count(b"\n") + head.count(b"\r") - head.count(b"\r\n") + 1
        utf16 = data.startswith((b"\xff\xfe", b"\xfe\xff"))
        raise EncodingError(f"undecodable byte 0x{data[exc.start]:02x} at byte offset "
                            f"{exc.start}; expected UTF-8 text"
                            + (" (the file starts with a UTF-16 byte-order mark, as Windows "
                               "PowerShell writes: save it as UTF-8)" if utf16 else ""), path,
                            line=line) from None


def text_place(text: str, pos: int) -> tuple[int, int]:
    """1-based line and column of a character of a text, lines ended as the readers end them.

    A line ends with LF, CR LF or a lone CR (:func:`read_stream_csv`, :func:`read_text`),
    as an editor shows it; :class:`json.JSONDecodeError` counts LF only, so a JSON file
    with lone CR line ends was named at line 1 and a column far beyond its lines.

    Parameters
    ----------
    text : str
        The text (as :func:`read_text` returns it: line ends kept).
    pos : int
        0-based index of the character (e.g. :attr:`json.JSONDecodeError.pos`).

    Returns
    -------
    line : int
        1-based line holding the character.
    column : int
        1-based position of the character in its line.
    """
    head = text[:pos]
    if head.endswith("\r") and text[pos:pos + 1] == "\n":
        head = head[:-1]    # the LF of a CR LF: the CR ends the same line
    line = head.count("\n") + head.count("\r") - head.count("\r\n") + 1
    start = max(head.rfind("\n"), head.rfind("\r")) + 1
    return line, pos - start + 1


def _split_lines(text: str, path: Path) -> tuple[list[str], list[list[str]], np.ndarray, dict]:
    """Header fields, data rows (fields), their 1-based file lines, skipped-line counts."""
    raw = text.split("\n")
    unended = bool(raw) and raw[-1] != ""   # no line break after the last line
    if not unended:
        raw.pop()  # the newline that ends the last line
    skipped = {"blank": 0, "comment": 0}
    header, rows, lines = None, [], []
    for i, line in enumerate(raw):
        stripped = line.strip()
        if not stripped:
            skipped["blank"] += 1
            continue
        if stripped.startswith("#"):
            skipped["comment"] += 1
            continue
        if header is None:
            header = [c.strip() for c in line.split(",")]
            skipped["header_line"] = i + 1
            continue
        rows.append(line)
        lines.append(i + 1)
    if header is None:
        n = skipped["blank"] + skipped["comment"]
        if not n:
            raise EmptyFileError("file is empty", path)
        # lines, but only comment and blank ones: "empty" would send the user to a file
        # that is not
        lines_were = f"{n} lines were" if n > 1 else "1 line was"
        raise EmptyFileError(f"no header line: its {lines_were} all skipped "
                             f"({skipped['comment']} comment, {skipped['blank']} blank)", path)
    _refuse_numeric_header(header, raw, skipped["header_line"], path)
    if not rows:
        trailing = next((k for k, c in enumerate(reversed(header)) if c), len(header))
        if trailing:   # the header line shows the trailing-comma problem: say so
            raise EmptyFileError(f"file has a header but no data rows; the header ends in "
                                 f"{trailing} unnamed column(s) (a trailing comma?)", path,
                                 line=skipped["header_line"])
        raise EmptyFileError("file has a header but no data rows", path,
                             line=skipped["header_line"])
    lines = np.asarray(lines)
    # a quoted field (``"1,5"``) is parsed as CSV within its own line only: an unbalanced
    # quote never swallows the following lines, it makes its line ragged
    cells = [r.split(",") if '"' not in r else next(csv.reader([r])) for r in rows]
    n_fields = np.fromiter((len(c) for c in cells), dtype=int, count=len(cells))
    ragged = np.flatnonzero(n_fields != len(header))
    if ragged.size:
        k = int(ragged[0])
        # (the file's last line, not merely its last data row: a comment may follow it)
        hint = _ragged_hint(header, rows[k], int(lines[k]), int(n_fields[k]),
                            unended and int(lines[k]) == len(raw))
        raise RaggedRowError(f"{ragged.size} of {len(rows)} data rows have a field count "
                             f"other than the header's {len(header)} (first: {n_fields[k]} "
                             f"fields) at {first_items(lines[ragged])}{hint}", path,
                             row=k, line=int(lines[k]))
    if len(rows) < MIN_DATA_ROWS:
        raise EmptyFileError(f"file has a single data row; at least {MIN_DATA_ROWS} are "
                             "needed to know the sample rate", path, line=int(lines[0]))
    return header, cells, lines, skipped


def _ragged_hint(header: list[str], row: str, line: int, n_fields: int,
                 cut_off: bool) -> str:
    """The likely cause of the first row whose field count is not the header's, for the
    message ("" when none is recognised); ``cut_off``: it is the last line and has no line
    break after it."""
    if len(header) == 1:
        dialect = _header_format_hint(header)
        if dialect:
            return dialect
    if "\x00" in row:
        return ("; the line holds NUL bytes: the end of a file that was never written (a "
                "power loss while logging?)")
    if cut_off:
        return ("; it is the last line and has no line break: cut off while the file was "
                "written (a logger stopped)?")
    if row.rstrip().endswith(","):
        return "; a trailing comma?"
    if row.count('"') % 2:
        return "; an unbalanced quote?"
    if not header[-1] and n_fields < len(header):
        return f"; the header ends in a comma, line {line} does not: a trailing comma?"
    return ""


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _refuse_numeric_header(header: list[str], raw: list[str], header_line: int,
                           path: Path) -> None:
    """A first line (not blank, not a comment) of numbers is a data row: the file has no
    header line, or has it commented out (``numpy.savetxt`` writes ``# time,wx,...``). Read
    as the header, its values were named as columns: "duplicated column name(s)
    ['0.1968503937007874']" when two were equal."""
    named = [c for c in header if c]
    if not named or not all(_is_number(c) for c in named):
        return
    hint = ""
    for k in range(header_line - 2, -1, -1):    # the comment line just above, if any
        text = raw[k].strip()
        if not text:
            continue
        if text.startswith("#"):
            names = [c.strip() for c in text.lstrip("#").split(",")]
            if len(names) == len(header) and not any(_is_number(c) for c in names if c):
                hint = (f"; line {k + 1} ({text[:60]!r}) looks like the header commented "
                        "out: remove its '#'")
        break
    shown = ",".join(header)
    shown = shown if len(shown) <= 60 else shown[:57] + "..."
    raise MissingColumnError(f"no header line: the first line that is not blank or a comment "
                             f"holds numbers ({shown!r}), not column names{hint}", path,
                             line=header_line)


def _refuse_overflow(out: dict[str, np.ndarray], mapping: Mapping[str, str],
                     header: list[str], rows: list[list[str]], lines: np.ndarray,
                     path: Path) -> None:
    """A number beyond float64's range (``1e400``) parses as inf; it is a value, not a
    missing sample, so it is refused (ImplausibleValueError naming the first) rather than
    repaired as a non-finite cell."""
    for col, name in mapping.items():
        values = out[name]
        if values.dtype == object:
            continue
        j = header.index(col)
        idx = [i for i in np.flatnonzero(np.isinf(values))
               if rows[i][j].strip().lower() not in NON_FINITE_WORDS]
        if idx:
            raise ImplausibleValueError(
                f"{len(idx)} number(s) beyond the float64 range (+-1.8e308), first "
                f"{rows[idx[0]][j].strip()[:40]!r} at {first_items(lines[idx])}: not a "
                "plausible measurement", path, col, int(idx[0]), int(lines[idx[0]]))


def _refuse_non_finite_time(t: np.ndarray, path: Path, col: str, lines: np.ndarray,
                            rows: list[list[str]]) -> None:
    """A non-finite timestamp is never repaired (NonFiniteError naming the first); a row
    of empty cells only (``,,,,``: a spreadsheet's emptied rows) is said to be one."""
    idx = np.flatnonzero(~np.isfinite(t))
    if idx.size:
        empty = [i for i in idx if not any(c.strip() for c in rows[i])]
        hint = (f"; {len(empty)} of them a line of empty cells only (a spreadsheet's emptied "
                "rows?): delete such lines" if empty else "")
        raise NonFiniteError(f"{idx.size} non-finite timestamp(s) at {first_items(lines[idx])}"
                             f"{hint}", path, col, int(idx[0]), int(lines[idx[0]]))


def _repair_non_finite(values: np.ndarray, t: np.ndarray, is_gap: np.ndarray, path: Path,
                       col: str, max_run: int, report: ReadReport, name: str,
                       lines: np.ndarray) -> np.ndarray:
    """Isolated non-finite samples of one channel, interpolated linearly in time between
    their finite neighbours; a burst, a run at the file's edge or one next to a timestamp gap
    (``is_gap``, :func:`_check_time`) is refused."""
    finite = np.isfinite(values)
    if finite.all():
        return values
    idx = np.flatnonzero(~finite)
    # runs of consecutive non-finite rows
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]]
    for s, e in zip(starts, ends):
        if e - s + 1 > max_run:
            raise NonFiniteError(f"burst of {e - s + 1} non-finite values (more than "
                                 f"{max_run} are not repaired)", path, col, int(s),
                                 int(lines[s]))
        if s == 0 or e == len(values) - 1:
            raise NonFiniteError("non-finite value at the edge of the file cannot be "
                                 "interpolated", path, col, int(s), int(lines[s]))
        # steps s-1 -> s ... e -> e+1: the neighbours the repair interpolates between
        if is_gap[s - 1:e + 1].any():
            k = s - 1 + int(np.flatnonzero(is_gap[s - 1:e + 1])[0])
            raise NonFiniteError(f"non-finite value next to a timestamp gap ({t[k]:.10g} -> "
                                 f"{t[k + 1]:.10g} s) cannot be interpolated: gaps are never "
                                 "interpolated across", path, col, int(s), int(lines[s]))
    good = np.flatnonzero(finite)
    repaired = values.copy()
    repaired[idx] = np.interp(t[idx], t[good], values[good])
    report.repaired[name] = int(idx.size)
    return repaired


def _check_time(t: np.ndarray, path: Path, gap_factor: float, report: ReadReport,
                lines: np.ndarray) -> np.ndarray:
    """Refuse timestamps that do not increase strictly; list the gaps in ``report``.

    Returns
    -------
    numpy.ndarray
        ``(n - 1,)`` bool: whether each step is a gap (over ``gap_factor`` x the median,
        :func:`terrain.io.align.gap_steps`).
    """
    dt = np.diff(t)
    if dt.size and (dt <= 0).any():
        bad = np.flatnonzero(dt <= 0) + 1
        row = int(bad[0])
        what = "duplicated" if dt[row - 1] == 0 else "decreasing"
        raise TimestampError(f"{what} timestamp {float(t[row])!r} after {float(t[row - 1])!r} "
                             f"({bad.size} such row(s), at {first_items(lines[bad])}); "
                             "timestamps must increase strictly", path, "time", row,
                             int(lines[row]))
    gaps = gap_steps(dt, float(np.median(dt)), gap_factor) if dt.size else np.zeros(0, bool)
    for i in np.flatnonzero(gaps):
        report.gaps.append((float(t[i]), float(t[i + 1])))
    return gaps


#: Compression suffixes of a run file that the readers do not open (named in the error).
_COMPRESSED = (".gz", ".bz2", ".xz", ".zip", ".zst")


def _near_miss(name: str) -> str | None:
    """Why ``name`` looks like a run file but is not read, or None."""
    lower = name.lower()
    plain = next((lower[:-len(z)] for z in _COMPRESSED if lower.endswith(z)), None)
    if plain is not None and (_FILE_RE.match(plain) or _META_RE.match(plain)):
        return f"compressed run files are not read: decompress it to {name[:len(plain)]}"
    if lower != name and (_FILE_RE.match(lower) or _META_RE.match(lower)):
        return f"run file names are lower case: rename it to {lower}"
    # imu-00.csv, 'imu 00.csv', ' pro_00.csv ': the readers take '_' between stream and
    # index, and no space around the name; such a file was left out without a word
    spaced = re.sub(r"[-\s]+", "_", lower.strip())
    if spaced != lower and (_FILE_RE.match(spaced) or _META_RE.match(spaced)):
        return (f"run file names join the stream and the index with '_' and hold no space: "
                f"rename it to {spaced}")
    return None


def is_run_file_name(name: str) -> bool:
    """Whether a file named ``name`` in a terrain folder is one the readers take or refuse
    as a run file (``imu_XX.csv``, ``meta_XX.json``; ``IMU_04.csv``, ``imu_04.csv.gz``).

    Parameters
    ----------
    name : str
        A file name, without its folder.

    Returns
    -------
    bool
        True for a run file's name (:func:`folder_run_files` reads or refuses such a file).
    """
    return bool(_FILE_RE.match(name) or _META_RE.match(name) or _near_miss(name))


def folder_run_files(folder: str | Path) -> dict[str, dict[str, Path]]:
    """Index the run files directly inside one folder.

    Parameters
    ----------
    folder : str or pathlib.Path
        A terrain folder (``imu_XX.csv``, ``pro_XX.csv``, optional ``meta_XX.json``).

    Returns
    -------
    dict
        ``index -> {kind: path}``; empty when the folder holds no run file.

    Raises
    ------
    DataFormatError
        A file named like a run file that the readers would not read (upper case,
        compressed, ``-`` or spaces for ``_`` (``imu-00.csv``), spaces around the name,
        ``meta_XX.csv``, or ``wheels_XX.csv``: the wheel stream is read from
        ``pro_XX.csv``), naming the file: it would otherwise be left out silently (an IMU
        file named ``IMU_04.csv`` made its run wheel-only) or replace a stream of its run
        (``wheels_XX.csv`` took the place of ``pro_XX.csv``).
    """
    runs: dict[str, dict[str, Path]] = {}
    for f in sorted(Path(folder).iterdir()):
        meta = _META_RE.match(f.name)
        if meta:
            runs.setdefault(meta["index"], {})["meta"] = f
            continue
        m = _FILE_RE.match(f.name)
        if m and m["kind"] == "meta":
            # taken for the run's metadata, it was shadowed by meta_XX.json without a word
            raise DataFormatError("file named like a run file is not read (a run's metadata "
                                  f"is meta_{m['index']}.json; a stream cannot be named "
                                  "meta)", f)
        if m and m["kind"] in _TAKEN_STREAM_NAMES:
            # read as a stream of the name of another file's stream, it replaced that
            # stream without a word (wheels_XX.csv the wheel stream of pro_XX.csv)
            kind = _TAKEN_STREAM_NAMES[m["kind"]]
            raise DataFormatError("file named like a run file is not read (stream "
                                  f"{m['kind']!r} of a run is read from {kind}_"
                                  f"{m['index']}.csv; a stream cannot be named "
                                  f"{m['kind']})", f)
        if m:
            runs.setdefault(m["index"], {})[m["kind"]] = f
            continue
        why = _near_miss(f.name)
        if why:
            raise DataFormatError(f"file named like a run file is not read ({why})", f)
    return runs


def list_run_files(root: str | Path) -> dict[tuple[str, str], dict[str, Path]]:
    """Index the stream files under ``root``.

    Parameters
    ----------
    root : str or pathlib.Path
        Runs folder holding one sub-folder per terrain (``<root>/<TERRAIN>/imu_XX.csv``,
        ``pro_XX.csv``, optional ``meta_XX.json``), e.g. ``data/borealtc``.

    Returns
    -------
    dict
        ``(TERRAIN, index) -> {kind: path}`` for every ``<kind>_<index>.csv`` and
        ``meta_<index>.json`` found in the terrain folders of ``root``.

    Raises
    ------
    DataFormatError
        If ``root`` is not a directory or holds no run file in its terrain folders, holds
        run files at its top level beside terrain folders with runs (one of the two would
        be left out), or a file named like a run file that is not read
        (:func:`folder_run_files`).
    """
    root = Path(root)
    if not root.is_dir():
        raise DataFormatError("runs folder is a file: give the folder that holds the terrain "
                              "folders" if root.exists() else "runs folder does not exist",
                              root)
    runs = {(folder.name, index): files
            for folder in sorted(p for p in root.iterdir() if p.is_dir())
            for index, files in folder_run_files(folder).items()}
    top = folder_run_files(root)
    if top and runs:
        raise _mixed_layout(root, top, {folder for folder, _ in runs})
    if not runs:
        hint = (": its run files lie at its top level; give the folder that holds it (its "
                "name is the terrain label) or move them into a <TERRAIN> folder") if top else ""
        raise DataFormatError(f"no run files (<TERRAIN>/imu_XX.csv, pro_XX.csv) found{hint}",
                              root)
    return runs


def _mixed_layout(root: Path, top: dict, folders) -> DataFormatError:
    """The error for run files at the top of ``root`` beside terrain folders with runs."""
    names = sorted(p.name for files in top.values() for p in files.values())
    return DataFormatError(f"holds run files itself ({first_items(names, word='file')}) and "
                           f"terrain folders with runs ({', '.join(sorted(folders))}): one "
                           "of the two would be left out; move the top-level files into "
                           "their terrain folder", root)


def known_vehicle(vehicle) -> bool:
    """Whether the ``vehicle`` of a run's metadata is one the readers take (the rule of
    :func:`read_run` and of :func:`terrain.io.writer.write_run`).

    Parameters
    ----------
    vehicle : object
        The value of the ``vehicle`` key of ``meta_XX.json``.

    Returns
    -------
    bool
        True for text naming one of :data:`terrain.run.VEHICLE_NAMES` in any case
        (``Husky``); False otherwise (``None``, a number, ``"husky "``).
    """
    return isinstance(vehicle, str) and vehicle.lower() in VEHICLE_NAMES


def read_run(files: dict[str, Path], run_id: str, dataset: str, terrain: str | None,
             **reader_options) -> Run:
    """Read the files of one run into a :class:`Run`.

    Parameters
    ----------
    files : dict
        ``kind -> path`` as produced by :func:`list_run_files` (``pro`` is required).
    run_id : str
        Unique id of the run, ``<dataset>/<TERRAIN>/<index>`` for measured runs.
    dataset : str
        Dataset name (``borealtc``, ``vulpi`` or the runs folder's name).
    terrain : str or None
        Terrain class label of the whole run (upper case); ``None`` for unlabelled runs.
    **reader_options
        Passed to :func:`read_stream_csv`.

    Returns
    -------
    Run
        The run with one stream per file (``pro`` -> wheel stream, ``imu`` -> IMU stream,
        ``t_s`` first, SI units); its ``meta`` holds ``meta_XX.json`` plus the repair, gap and
        skipped-line counts of the readers, and ``warnings``: the files' own findings
        (``file_warnings``, :attr:`ReadReport.warnings`) then those of the run's checks.
        The keys the reader sets (``repaired``, ``gaps``, ``skipped_lines``,
        ``ignored_columns``, ``file_warnings``, ``stuck``, ``unused_s``, ``warnings``,
        ``files``) replace those of ``meta_XX.json``; ``vehicle`` is kept as the file gives
        it (the run's :attr:`~terrain.run.Run.vehicle` is its lower case).

    Raises
    ------
    OrphanFileError
        If the run has stream files but no ``pro`` (wheel) file.
    DataFormatError
        If ``meta_XX.json`` is not valid JSON or not a JSON object, or its ``vehicle`` is
        not one of :data:`terrain.run.VEHICLE_NAMES` (names the file), or a
        stream file is malformed (raised by :func:`read_stream_csv`).

    Warns
    -----
    DataWarning
        A key of ``meta_XX.json`` that the reader sets itself, whose value in the file
        differs from the reader's (rule ``meta_keys``): names the file, the key and the
        value replaced (kept in ``file_warnings`` and ``warnings`` too). A value equal to
        the reader's, and the ``files`` that :func:`terrain.io.writer.write_run` records
        (the run's file names), replace nothing and are not warned.
    """
    if "pro" not in files:
        other = next(iter(p for k, p in files.items() if k != "meta"), files.get("meta"))
        raise OrphanFileError("run has no wheel file pro_XX.csv beside it", other)
    meta: dict = {}
    if "meta" in files:
        text = read_text(files["meta"])
        try:
            meta = json.loads(text)
        except json.JSONDecodeError as exc:
            line, column = text_place(text, exc.pos)    # (a lone CR ends a line too)
            raise DataFormatError(f"invalid JSON: {exc.msg}, column {column}",
                                  files["meta"], line=line) from None
        if not isinstance(meta, dict):
            raise DataFormatError("run metadata must be a JSON object", files["meta"])
    vehicle = meta.get("vehicle", "husky")
    if not known_vehicle(vehicle):
        # an unknown vehicle would also switch off the vehicle's plausibility rules
        raise DataFormatError(f"key 'vehicle': unknown vehicle {vehicle!r}; valid: "
                              f"{', '.join(VEHICLE_NAMES)} (leave the key out for the "
                              "Husky)", files["meta"])
    vehicle = vehicle.lower()
    streams: dict[str, pd.DataFrame] = {}
    repaired: dict[str, int] = {}
    gaps: dict[str, list] = {}
    skipped: dict[str, int] = {}
    ignored: dict[str, list[str]] = {}
    file_warnings: list[str] = []
    for kind, path in sorted(files.items()):
        if kind == "meta":
            continue
        frame, report = read_stream_csv(path, kind, **reader_options)
        name = STREAM_NAMES.get(kind, kind)
        streams[name] = frame
        repaired.update({f"{name}.{c}": n for c, n in report.repaired.items()})
        skipped.update({f"{name}.{k}": n for k, n in report.skipped_lines.items() if n})
        if report.ignored_columns:
            ignored[name] = report.ignored_columns
        file_warnings += report.warnings
        if report.gaps:
            gaps[name] = report.gaps
    checks = check_run(run_id, streams, vehicle,
                       {STREAM_NAMES.get(k, k): str(p) for k, p in files.items()},
                       columns={STREAM_NAMES[k]: COLUMN_MAPS[k] for k in files
                                if k in COLUMN_MAPS})
    checks["warnings"] = file_warnings + checks["warnings"]
    found = {"repaired": repaired, "gaps": gaps, "skipped_lines": skipped,
             "ignored_columns": ignored, "file_warnings": list(file_warnings), **checks,
             "files": {k: str(p) for k, p in files.items()}}
    # a key of meta_XX.json that the reader sets itself was replaced without a word
    replaced = _replaced_meta_keys(meta, found, files)
    for msg in replaced:
        warnings.warn(msg, DataWarning, stacklevel=2)
    found["file_warnings"] += replaced
    found["warnings"] = found["warnings"] + replaced
    return Run(run_id=run_id, dataset=dataset, terrain=terrain, streams=streams,
               vehicle=vehicle, source=str(files["pro"].parent), meta={**meta, **found})


def _replaced_meta_keys(meta: dict, found: dict, files: dict[str, Path]) -> list[str]:
    """A finding for each key of ``meta_XX.json`` that :func:`read_run` sets itself
    (``found``: ``repaired``, ``gaps``, ``files``...) and whose value in the file differs
    from the reader's, which replaces it. A value equal to the reader's (as JSON) loses
    nothing, nor does the ``files`` that :func:`terrain.io.writer.write_run` records: the
    names of the run's stream files."""
    out = []
    names = {k: Path(p).name for k, p in files.items() if k != "meta"}
    for key in sorted(set(meta) & set(found)):
        if meta[key] == json_ready(found[key], None) or (key == "files" and meta[key] == names):
            continue
        shown = repr(meta[key])
        shown = shown if len(shown) <= 80 else shown[:77] + "..."
        out.append(f"{files['meta']}: rule meta_keys: key {key!r} of the run's metadata is "
                   f"set by the reader (what it read, repaired and found); the file's value "
                   f"{shown} is replaced and not kept: rename the key")
    return out


def folder_text(name: str) -> str:
    """A folder name as text that every later step can hold (a run id, a label).

    A name that is not UTF-8 on disk (``sim\\xff``) comes from the file system with lone
    surrogates (Python's ``surrogateescape``), which pandas' text columns, MLflow and CSV
    files cannot encode: such bytes are written as ``\\xff`` escapes, every other
    character is kept.

    Parameters
    ----------
    name : str
        Folder name as :class:`pathlib.Path` gives it.

    Returns
    -------
    str
        The name, its undecodable bytes as backslash escapes.
    """
    return name.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def read_folder_run(run_dir: str | Path, index: str | None = None) -> Run:
    """Read one run of one terrain folder (``terrain stream``'s RUN_DIR).

    Parameters
    ----------
    run_dir : str or pathlib.Path
        A terrain folder of the measured-run layout (``imu_XX.csv``, ``pro_XX.csv``,
        optional ``meta_XX.json``); its name is the terrain label, its parent's the
        dataset's.
    index : str, optional
        Run index ``XX``; may be left out when the folder holds one run.

    Returns
    -------
    Run
        Run id ``<TERRAIN>/<index>``, labelled with the folder's name in upper case.

    Raises
    ------
    ConfigError
        ``run_dir`` is not a folder, holds no run files (the message names its terrain
        folders that do, when it is a runs folder), holds several runs and ``index`` is not
        given, or lacks the run ``index`` (the message lists those it holds).
    DataFormatError, OrphanFileError
        As :func:`folder_run_files` and :func:`read_run` (a file that cannot be read).
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ConfigError(f"run folder {run_dir} does not exist or is not a folder")
    folder = run_dir.resolve()
    # errors name the folder as given, unless it has no name of its own (".")
    shown = folder if run_dir.name in ("", ".", "..") else run_dir
    runs = folder_run_files(shown)
    if not runs:
        # a runs folder one level up (<root>/<TERRAIN>/...): name its terrain folders
        inner = sorted(d.name for d in folder.iterdir() if d.is_dir() and folder_run_files(d))
        hint = (f"; its terrain folder(s) {', '.join(inner)} do: pass one of them, e.g. "
                f"{shown / inner[0]}" if inner else "")
        raise ConfigError(f"{shown} holds no run files (imu_XX.csv, pro_XX.csv){hint}")
    if index is None:
        if len(runs) > 1:
            raise ConfigError(f"{shown} holds runs {sorted(runs)}: choose one with --index")
        index = next(iter(runs))
    if index not in runs:
        raise ConfigError(f"no run {index!r} in {shown}; available: {sorted(runs)}")
    name = folder_text(folder.name)
    return read_run(runs[index], f"{name}/{index}", folder_text(folder.parent.name),
                    name.upper())


def read_runs_path(path: str | Path, *, labelled: bool = True, progress: bool = False,
                   **reader_options) -> list[Run]:
    """Read the runs of a runs folder, or of one terrain folder of it.

    Parameters
    ----------
    path : str or Path
        A folder in the layout ``<path>/<TERRAIN>/<kind>_XX.csv``, or one ``<TERRAIN>``
        folder (holding the CSV files itself).
    labelled : bool
        See :func:`read_runs_dir`.
    progress : bool
        Show a progress bar over runs.
    **reader_options
        Passed to :func:`read_stream_csv`.

    Returns
    -------
    list of Run
        Run ids ``<folder>/<TERRAIN>/<index>``, ``<folder>`` the runs folder's name.

    Raises
    ------
    DataFormatError
        If ``path`` is not a folder, holds no run file, holds run files itself beside
        terrain folders with runs, or a file named like a run file that is not read (in
        the folders read: a terrain folder's sibling folders are not looked at).
    ConfigError
        ``labelled`` or ``progress`` not True or False (the text ``"no"`` was read as on).
    """
    config_flags("read_runs_path", labelled=labelled, progress=progress)
    path = Path(path)
    if path.name in ("", ".", ".."):     # "." has no name and "." as parent
        path = path.resolve()
    root, only = path, None
    if path.is_dir() and folder_run_files(path):
        sub = {d.name for d in path.iterdir() if d.is_dir() and folder_run_files(d)}
        if sub:
            raise _mixed_layout(path, folder_run_files(path), sub)
        root, only = path.parent, path.name
    try:
        name = folder_text(root.resolve().name)
    except (OSError, RuntimeError) as exc:  # a symbolic link loop: RuntimeError before 3.13
        raise DataFormatError(f"not a folder of runs: {exc}", path=str(path)) from None
    return read_runs_dir(root, name, labelled=labelled, progress=progress, only=only,
                         **reader_options)


def read_runs_dir(root: str | Path, dataset: str | None = None, *,
                  labelled: bool = True, progress: bool = False, only: str | None = None,
                  **reader_options) -> list[Run]:
    """Read every run under ``root`` (layout ``<root>/<TERRAIN>/<kind>_XX.csv``).

    Parameters
    ----------
    root : str or Path
        Folder holding one sub-folder per terrain class.
    dataset : str, optional
        Dataset name for the run ids; defaults to the folder name of ``root``.
    labelled : bool
        If True the terrain folder name is the label; if False runs are unlabelled
        (``terrain=None``, as for prediction).
    progress : bool
        Show a progress bar (tqdm, on stderr) over runs.
    only : str, optional
        Read the runs of this terrain folder only: only that folder is indexed
        (:func:`folder_run_files`), so a badly named file in another folder of ``root``
        does not stop it (the name of a folder of ``root``, case included).
    **reader_options
        Passed to :func:`read_stream_csv`.

    Returns
    -------
    list of Run
        Sorted by run id, ``<dataset>/<TERRAIN>/<index>``.

    Raises
    ------
    DataFormatError
        As :func:`list_run_files` (with ``only``: ``root`` holds no such folder, the
        folder holds no run file, or a file named like a run file that is not read), or a
        file that cannot be read (:func:`read_run`).
    ConfigError
        ``labelled`` or ``progress`` not True or False (the text ``"no"`` labelled the runs),
        or ``only`` not a folder name (text without a path separator or NUL, not empty,
        ``.`` or ``..``).
    """
    config_flags("read_runs_dir", labelled=labelled, progress=progress)
    root = Path(root)
    dataset = dataset or folder_text(root.resolve().name)
    runs = []
    if only is None:
        found = list_run_files(root)
    else:
        if not isinstance(only, str) or only in ("", ".", "..") or "\0" in only or (
                Path(only).name != only):
            # ('ASPHALT/' read its run as '<root>/ASPHALT//00' labelled 'ASPHALT/', ''
            # the root itself, '../x' a folder outside it)
            raise ConfigError(f"read_runs_dir.only names one terrain folder of root (its "
                              f"name, without a path separator), got {only!r}")
        if not (root / only).is_dir():     # (a bare FileNotFoundError)
            folders = sorted(folder_text(d.name) for d in root.iterdir()
                             if d.is_dir()) if root.is_dir() else []
            raise DataFormatError(f"no terrain folder {only!r} in the runs folder (its "
                                  f"folders: {folders})", root)
        found = {(only, index): files
                 for index, files in folder_run_files(root / only).items()}
        if not found:
            raise DataFormatError("no run files (imu_XX.csv, pro_XX.csv) found", root / only)
    # sorted by the run id given, as read_shipped sorts them: sorted by (folder, index), a
    # folder 'SAND' came before 'SAND-WET' though 'SAND-WET/00' < 'SAND/00' ('-' < '/')
    items = sorted(((f"{dataset}/{folder_text(folder)}/{index}", folder_text(folder), files)
                    for (folder, index), files in found.items()), key=lambda item: item[0])
    if progress:
        from tqdm.auto import tqdm
        items = tqdm(items, desc="reading runs", unit="run")
    for run_id, folder, files in items:
        runs.append(read_run(files, run_id, dataset, folder.upper() if labelled else None,
                             **reader_options))
    return runs
