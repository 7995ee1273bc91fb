"""Reader for the measured-run CSV layout ``<root>/<TERRAIN>/{imu_XX.csv, pro_XX.csv}``.

The layout is the one of the Husky datasets in ``shared/data`` (BorealTC, Vulpi) and of the
files written by ``terrain simulate``:

* ``imu_XX.csv``: ``time, wx, wy, wz, ax, ay, az`` in s, rad/s, m/s^2;
* ``pro_XX.csv``: ``time, curL, curR, velL, velR`` in s, A, m/s (column order varies between
  datasets: columns are always read by name);
* any other ``<stream>_XX.csv`` (simulator extras such as ``truth_XX.csv``): ``time`` first,
  snake_case channel names, SI units; loaded as stream ``<stream>``;
* ``meta_XX.json`` (optional): run metadata, e.g. ``{"vehicle": "husky"}``.

Validation rules (``DESIGN.md``, "Bad input"): every problem raises a subclass of
:class:`terrain.errors.DataFormatError` naming file, column and 0-based data row. The only
repair is documented in :func:`read_stream_csv`: isolated non-finite samples (at most
``max_repair_run`` consecutive rows in one channel) are linearly interpolated and counted;
longer bursts are rejected. Timestamp gaps are never interpolated across: they are listed in
``Run.meta["gaps"]`` and the windowing step drops every window that spans one.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np
import pandas as pd

from terrain.errors import (DataFormatError, EmptyFileError, MissingColumnError,
                            NonFiniteError, NonNumericError, OrphanFileError, TimestampError)
from terrain.run import IMU_CHANNELS, TIME, Run

#: file column -> canonical name, per known file kind
COLUMN_MAPS: Mapping[str, Mapping[str, str]] = MappingProxyType({
    "imu": MappingProxyType({"time": TIME, **{c: c for c in IMU_CHANNELS}}),
    "pro": MappingProxyType({"time": TIME, "velL": "vel_l", "velR": "vel_r", "curL": "cur_l",
                             "curR": "cur_r"}),
})
#: file prefix -> stream name in the Run
STREAM_NAMES: Mapping[str, str] = MappingProxyType({"imu": "imu", "pro": "wheels"})
#: gyro rates above this (rad/s) are taken for deg/s (2000 deg/s = 34.9 rad/s, a full-scale
#: MEMS gyro range; no ground robot turns that fast)
MAX_PLAUSIBLE_RATE_RAD_S = 35.0
_FILE_RE = re.compile(r"^(?P<kind>[a-z][a-z0-9]*)_(?P<index>\d+)\.csv$")


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
    """

    path: str
    repaired: dict[str, int] = field(default_factory=dict)
    gaps: list[tuple[float, float]] = field(default_factory=list)


def read_stream_csv(path: str | Path, kind: str, *, max_repair_run: int = 2,
                    gap_factor: float = 3.0) -> tuple[pd.DataFrame, ReadReport]:
    """Read and validate one stream file.

    Parameters
    ----------
    path : str or Path
        CSV file.
    kind : str
        File prefix (``imu``, ``pro`` or a simulator extra such as ``truth``). ``imu`` and
        ``pro`` require their canonical columns; other kinds only require ``time``.
    max_repair_run : int
        Longest run of consecutive non-finite samples in one channel that is repaired by
        linear interpolation between its finite neighbours (counted in the report). Longer
        bursts, and non-finite values at the first or last row, raise :class:`NonFiniteError`.
    gap_factor : float
        A timestamp step larger than ``gap_factor`` times the median step is reported as a gap.

    Returns
    -------
    frame : pandas.DataFrame
        ``t_s`` first, then canonical channel names (SI units), float64 except string columns
        of extra streams (e.g. a per-sample ``terrain`` label).
    report : ReadReport

    Raises
    ------
    EmptyFileError, MissingColumnError, NonNumericError, NonFiniteError, TimestampError,
    DataFormatError
        With file, column and 0-based data row.
    """
    path = Path(path)
    try:
        raw = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise EmptyFileError("file is empty", path) from None
    except pd.errors.ParserError as exc:
        raise DataFormatError(f"not a valid CSV file: {exc}", path) from None
    if raw.empty:
        raise EmptyFileError("file has a header but no data rows", path)
    raw.columns = [c.strip() for c in raw.columns]
    mapping = COLUMN_MAPS.get(kind)
    if mapping is None:
        # extra stream: ``time`` is required and comes first, other columns keep their names
        mapping = {"time": TIME, **{c: c for c in raw.columns if c != "time"}}
    missing = [c for c in mapping if c not in raw.columns]
    if missing:
        raise MissingColumnError(
            f"missing column(s) {missing}; found {list(raw.columns)}, expected {list(mapping)}",
            path, missing[0])
    report = ReadReport(str(path))
    out: dict[str, np.ndarray] = {}
    for col, name in mapping.items():
        text = raw[col].str.strip()
        values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
        is_nan_word = text.str.lower().isin(["nan", "inf", "-inf", "+inf", "infinity", ""])
        bad = np.isnan(values) & ~is_nan_word.to_numpy()
        if bad.any():
            if kind not in COLUMN_MAPS and name != TIME and bad.all():
                out[name] = text.to_numpy()  # a string channel of an extra stream
                continue
            row = int(np.flatnonzero(bad)[0])
            raise NonNumericError(f"non-numeric value {raw[col].iloc[row]!r}", path, col, row)
        values = _repair_non_finite(values, path, col, max_repair_run, report, name)
        out[name] = values
    frame = pd.DataFrame(out)
    _check_time(frame[TIME].to_numpy(), path, gap_factor, report)
    if kind == "imu":
        _check_imu_units(frame, path)
    return frame, report


def _repair_non_finite(values: np.ndarray, path: Path, col: str, max_run: int,
                       report: ReadReport, name: str) -> np.ndarray:
    finite = np.isfinite(values)
    if finite.all():
        return values
    idx = np.flatnonzero(~finite)
    if name == TIME:
        raise NonFiniteError("non-finite timestamp", path, col, int(idx[0]))
    # runs of consecutive non-finite rows
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]]
    for s, e in zip(starts, ends):
        if e - s + 1 > max_run:
            raise NonFiniteError(f"burst of {e - s + 1} non-finite values (more than "
                                 f"{max_run} are not repaired)", path, col, int(s))
        if s == 0 or e == len(values) - 1:
            raise NonFiniteError("non-finite value at the edge of the file cannot be "
                                 "interpolated", path, col, int(s))
    good = np.flatnonzero(finite)
    repaired = values.copy()
    repaired[idx] = np.interp(idx, good, values[good])
    report.repaired[name] = int(idx.size)
    return repaired


def _check_time(t: np.ndarray, path: Path, gap_factor: float, report: ReadReport) -> None:
    dt = np.diff(t)
    if dt.size and (dt <= 0).any():
        row = int(np.flatnonzero(dt <= 0)[0]) + 1
        what = "duplicated" if dt[row - 1] == 0 else "decreasing"
        raise TimestampError(f"{what} timestamp {t[row]!r} after {t[row - 1]!r}; "
                             "timestamps must increase strictly", path, "time", row)
    if dt.size:
        step = float(np.median(dt))
        for i in np.flatnonzero(dt > gap_factor * step):
            report.gaps.append((float(t[i]), float(t[i + 1])))


def _check_imu_units(frame: pd.DataFrame, path: Path) -> None:
    for c in ("wx", "wy", "wz"):
        big = np.abs(frame[c].to_numpy()) > MAX_PLAUSIBLE_RATE_RAD_S
        if big.any():
            raise DataFormatError(f"angular rate above {MAX_PLAUSIBLE_RATE_RAD_S} rad/s; the "
                                  "file looks like deg/s, expected rad/s", path, c,
                                  int(np.flatnonzero(big)[0]))
    norm = np.linalg.norm(frame[["ax", "ay", "az"]].to_numpy(), axis=1)
    if np.median(norm) < 3.0:
        raise DataFormatError(f"median specific force {np.median(norm):.2f} is far below "
                              "9.81 m/s^2; the file looks like units of g, expected m/s^2",
                              path, "az")


def list_run_files(root: str | Path) -> dict[tuple[str, str], dict[str, Path]]:
    """Index the stream files under ``root``.

    Returns
    -------
    dict
        ``(TERRAIN, index) -> {kind: path}`` for every ``<kind>_<index>.csv`` and
        ``meta_<index>.json`` found in the terrain folders of ``root``.

    Raises
    ------
    DataFormatError
        If ``root`` is not a directory or holds no run file.
    """
    root = Path(root)
    if not root.is_dir():
        raise DataFormatError("runs folder does not exist", root)
    runs: dict[tuple[str, str], dict[str, Path]] = {}
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        for f in sorted(folder.iterdir()):
            if f.suffix == ".json" and f.name.startswith("meta_"):
                runs.setdefault((folder.name, f.stem[5:]), {})["meta"] = f
                continue
            m = _FILE_RE.match(f.name)
            if m:
                runs.setdefault((folder.name, m["index"]), {})[m["kind"]] = f
    if not runs:
        raise DataFormatError("no run files (<TERRAIN>/imu_XX.csv, pro_XX.csv) found", root)
    return runs


def read_run(files: dict[str, Path], run_id: str, dataset: str, terrain: str | None,
             **reader_options) -> Run:
    """Read the files of one run into a :class:`Run`.

    Parameters
    ----------
    files : dict
        ``kind -> path`` as produced by :func:`list_run_files` (``pro`` is required).
    run_id, dataset, terrain : str
        Metadata of the run.
    **reader_options
        Passed to :func:`read_stream_csv`.

    Raises
    ------
    OrphanFileError
        If the run has stream files but no ``pro`` (wheel) file.
    """
    if "pro" not in files:
        other = next(iter(p for k, p in files.items() if k != "meta"), None)
        raise OrphanFileError("run has no wheel file pro_XX.csv beside it", other)
    meta: dict = {}
    if "meta" in files:
        try:
            meta = json.loads(files["meta"].read_text())
        except json.JSONDecodeError as exc:
            raise DataFormatError(f"invalid JSON: {exc}", files["meta"]) from None
        if not isinstance(meta, dict):
            raise DataFormatError("run metadata must be a JSON object", files["meta"])
    streams: dict[str, pd.DataFrame] = {}
    repaired: dict[str, int] = {}
    gaps: dict[str, list] = {}
    for kind, path in sorted(files.items()):
        if kind == "meta":
            continue
        frame, report = read_stream_csv(path, kind, **reader_options)
        name = STREAM_NAMES.get(kind, kind)
        streams[name] = frame
        repaired.update({f"{name}.{c}": n for c, n in report.repaired.items()})
        if report.gaps:
            gaps[name] = report.gaps
    return Run(run_id=run_id, dataset=dataset, terrain=terrain, streams=streams,
               vehicle=str(meta.get("vehicle", "husky")), source=str(files["pro"].parent),
               meta={**meta, "repaired": repaired, "gaps": gaps,
                     "files": {k: str(p) for k, p in files.items()}})


def read_runs_dir(root: str | Path, dataset: str | None = None, *,
                  labelled: bool = True, **reader_options) -> list[Run]:
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
    **reader_options
        Passed to :func:`read_stream_csv`.

    Returns
    -------
    list of Run
        Sorted by run id, ``<dataset>/<TERRAIN>/<index>``.
    """
    root = Path(root)
    dataset = dataset or root.resolve().name
    runs = []
    for (folder, index), files in sorted(list_run_files(root).items()):
        runs.append(read_run(files, f"{dataset}/{folder}/{index}", dataset,
                             folder.upper() if labelled else None, **reader_options))
    return runs

