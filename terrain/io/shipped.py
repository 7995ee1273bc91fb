"""The compact format of the runs shipped in ``data/``, its manifest and its converter.

Layout (one folder per dataset)::

    data/manifest.json              source, license, citation, rates, checksums, runs
    data/<dataset>/imu.parquet      run_id, t_s, wx, wy, wz, ax, ay, az   (SI units)
    data/<dataset>/wheels.parquet   run_id, t_s, vel_l, vel_r, cur_l, cur_r (SI units)

Parquet (zstd) keeps the original float64 values bit for bit, so the converter
:func:`convert_dataset` is loss-free: reading the CSV layout or the shipped copy gives equal
:class:`~terrain.run.Run` objects (tested). The manifest records the SHA-256 of every source
CSV and of every shipped file; :func:`verify_manifest` checks the latter.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np
import pandas as pd

from terrain.errors import (ConfigError, DataFormatError, DataWarning, MissingColumnError,
                            NonFiniteError, NonNumericError, TimestampError)
from terrain.io.measured import folder_text, list_run_files, read_run, read_text, text_place
from terrain.io.plausibility import check_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run, times_out_of_order

#: Citation and license of each dataset (from ``shared/data/README.md``).
DATASET_INFO: Mapping[str, Mapping[str, str]] = MappingProxyType({
    "borealtc": MappingProxyType({
        "license": "CC0 1.0",
        "citation": ("D. LaRocque, W. Guimont-Martin, D.-A. Duclos, P. Giguere, F. Pomerleau, "
                     "\"Proprioception Is All You Need: Terrain Classification for Boreal "
                     "Forests\", IROS 2024 (arXiv 2403.16877)"),
        "source": "public repository norlab-ulaval/BorealTC, folder data/borealtc",
        "robot": "Clearpath Husky A200",
    }),
    "vulpi": MappingProxyType({
        "license": "as redistributed in norlab-ulaval/BorealTC (data/vulpi)",
        "citation": ("F. Vulpi, A. Milella, R. Marani, G. Reina, \"Recurrent and convolutional "
                     "neural networks for deep terrain classification by autonomous robots\", "
                     "Journal of Terramechanics 96 (2021) 119-131"),
        "source": ("converted from the authors' MATLAB files to CSV and redistributed in the "
                   "public repository norlab-ulaval/BorealTC, folder data/vulpi"),
        "robot": "Clearpath Husky A200",
    }),
})
DATASETS = tuple(DATASET_INFO)
#: Vehicle (:data:`terrain.vehicles.VEHICLE_NAMES`) that recorded each shipped dataset: both
#: are the Clearpath Husky A200 of :data:`DATASET_INFO` ``robot``.
DATASET_VEHICLE: Mapping[str, str] = MappingProxyType({"borealtc": "husky", "vulpi": "husky"})
STREAM_FILES: Mapping[str, str] = MappingProxyType({"imu": "imu.parquet",
                                                   "wheels": "wheels.parquet"})
RUN_ID = "run_id"
#: keys of a run's ``meta_XX.json`` that the shipped format does not need to keep: the
#: vehicle (checked against :data:`DATASET_VEHICLE`), and the index and file names that
#: :func:`terrain.io.writer.write_run` records (the run id and the files say them)
_META_KEPT = frozenset({"vehicle", "index", "files"})
#: Columns of each shipped stream file besides ``run_id`` (what ``terrain convert`` writes).
STREAM_COLUMNS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "imu": (TIME, *IMU_CHANNELS), "wheels": (TIME, *WHEEL_CHANNELS)})


def default_data_dir() -> Path:
    """The shipped ``data/`` folder (``TERRAIN_DATA_DIR`` overrides it).

    Returns
    -------
    pathlib.Path
        ``$TERRAIN_DATA_DIR`` when set, else the repository's ``data/`` folder.
    """
    env = os.environ.get("TERRAIN_DATA_DIR")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / "data"


def sha256(path: str | Path) -> str:
    """SHA-256 hex digest of a file.

    Parameters
    ----------
    path : str or pathlib.Path
        File to hash (read in 1 MiB chunks).

    Returns
    -------
    str
        64-character lower-case hexadecimal digest.
    """
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def convert_dataset(src: str | Path, dataset: str, data_dir: str | Path) -> dict:
    """Convert one dataset from the CSV layout to the shipped format.

    Parameters
    ----------
    src : str or Path
        Folder in the measured-run layout (``<src>/<TERRAIN>/{imu_XX,pro_XX}.csv``).
    dataset : str
        Dataset name (key of :data:`DATASET_INFO`).
    data_dir : str or Path
        Output ``data/`` folder; writes ``<data_dir>/<dataset>/*.parquet``.

    Returns
    -------
    dict
        The manifest entry of the dataset (also merged into ``<data_dir>/manifest.json``);
        run ids ``<dataset>/<TERRAIN folder>/<index>``, a folder name that is not UTF-8
        with its bytes as ``\\xff`` escapes (:func:`terrain.io.measured.folder_text`).

    Raises
    ------
    ConfigError
        Unknown dataset name; a run whose ``meta_XX.json`` names another vehicle than the
        dataset's (:data:`DATASET_VEHICLE`).
    DataFormatError
        Any reader error in the source files; an existing ``<data_dir>/manifest.json``
        that does not parse (its line and column named) or is not a JSON object whose
        ``datasets``, if present, is an object. The manifest is checked before anything
        is written, and the Parquet files are written under temporary names and swapped in
        with the manifest, a stream file of an earlier conversion that this one does not
        write (no run has that stream now) removed with them, the files replaced set aside
        until all are in place: a failed conversion (a rename refused or interrupted
        included) leaves ``data_dir`` as it was.

    Warns
    -----
    DataWarning
        The IMU rate of the converted runs is more than 10 % from the dataset's native rate
        (:data:`DATASET_SPECS`), at which its windows are aligned; stream files other than
        the IMU and wheel ones (``truth``, the AgriMaRo's ``cam``, ``steer``...) that the
        shipped format leaves out, counted per kind; keys of the runs' ``meta_XX.json``
        that it leaves out (all but ``vehicle``, ``index`` and ``files``), counted per key.
    """
    if dataset not in DATASET_INFO:
        raise ConfigError(f"unknown dataset {dataset!r}; valid: {list(DATASET_INFO)}")
    src, out = Path(src), Path(data_dir) / dataset
    manifest_path = Path(data_dir) / "manifest.json"
    # read before anything is written: new Parquet files beside a manifest that cannot take
    # their checksums would leave the dataset unreadable
    manifest = _manifest_to_update(manifest_path)
    frames: dict[str, list[pd.DataFrame]] = {s: [] for s in STREAM_FILES}
    runs_info = []
    left_out: dict[str, int] = {}
    meta_left_out: dict[str, int] = {}
    for (folder, index), files in sorted(list_run_files(src).items()):
        # a folder name that is not UTF-8 (its bytes as lone surrogates) as the CSV readers
        # name it: the Parquet file cannot hold lone surrogates (a bare UnicodeEncodeError)
        folder = folder_text(folder)
        run_id = f"{dataset}/{folder}/{index}"
        run = read_run(files, run_id, dataset, folder.upper())
        if run.vehicle != DATASET_VEHICLE[dataset]:
            raise ConfigError(f"run {folder}/{index} of {src} was recorded by vehicle "
                              f"{run.vehicle!r} (its meta_{index}.json); dataset {dataset!r} "
                              f"is the {DATASET_VEHICLE[dataset]}'s, and its models, rules "
                              "and notes assume that robot")
        for name in run.streams:
            if name not in STREAM_FILES:
                left_out[name] = left_out.get(name, 0) + 1
        if "meta" in files:     # (valid: read_run parsed it)
            for key in json.loads(read_text(files["meta"])):
                if key not in _META_KEPT:
                    meta_left_out[key] = meta_left_out.get(key, 0) + 1
        for name in STREAM_FILES:
            if name in run.streams:
                frames[name].append(run.streams[name].assign(**{RUN_ID: run_id}))
        runs_info.append({
            "run_id": run_id, "terrain": run.terrain, "has_imu": run.has_imu,
            "duration_s": round(run.duration_s, 3),
            "samples": {k: len(v) for k, v in run.streams.items()},
            "repaired": dict(run.meta["repaired"]), "gaps": run.meta["gaps"],
            "source_files": {p.name: sha256(p) for k, p in files.items()},
            # what the reader skipped or ignored in the CSV files, and what the files made
            # likely (kept when there is any: the shipped runs report it as the CSV runs did)
            **{key: dict(run.meta[key]) for key in ("skipped_lines", "ignored_columns")
               if run.meta.get(key)},
            **({"file_warnings": list(run.meta["file_warnings"])}
               if run.meta.get("file_warnings") else {}),
        })
    tables: dict[str, pd.DataFrame] = {}
    rates = {}
    for name, parts in frames.items():
        if not parts:  # e.g. a dataset with no IMU recording at all: no file for it
            continue
        table = pd.concat(parts, ignore_index=True)
        table = table[[RUN_ID] + [c for c in table.columns if c != RUN_ID]]
        table[RUN_ID] = table[RUN_ID].astype("category")
        tables[STREAM_FILES[name]] = table
        dt = table.groupby(RUN_ID, observed=True)[TIME].diff().median()
        rates[name] = round(float(1.0 / dt), 3)
    if left_out:
        kinds = ", ".join(f"{k} ({n} run(s))" for k, n in sorted(left_out.items()))
        warnings.warn(f"{src}: stream file(s) left out, the shipped format keeps the IMU and "
                      f"wheel streams only: {kinds}", DataWarning, stacklevel=2)
    if meta_left_out:
        keys = ", ".join(f"{k} ({n} run(s))" for k, n in sorted(meta_left_out.items()))
        warnings.warn(f"{src}: run metadata key(s) left out, the shipped format keeps no "
                      f"meta_XX.json (the vehicle is the dataset's): {keys}", DataWarning,
                      stacklevel=2)
    native = DATASET_SPECS[dataset].rate_hz
    # (a difference against a tenth of the rate: 110 / 100 - 1 is 0.10000000000000009, so
    # an IMU exactly 10 % above the rate was named and one 10 % below it not)
    if "imu" in rates and abs(rates["imu"] - native) > native / 10.0:
        # every window of this dataset is cut on its native clock: a 100 Hz IMU converted
        # as vulpi (50 Hz) loses its 25-50 Hz band without a word otherwise
        warnings.warn(f"{src}: the IMU runs at {rates['imu']:g} Hz, dataset {dataset!r} at "
                      f"{native:g} Hz: its windows will be aligned at {native:g} Hz (the "
                      "IMU resampled); convert the runs under the dataset they come from",
                      DataWarning, stacklevel=2)
    # every file is written under a temporary name and swapped in, the manifest last, once
    # all are written: a failure leaves the old files and their checksums
    pending: dict[Path, Path] = {}    # temporary file -> the file it replaces
    try:
        out.mkdir(parents=True, exist_ok=True)
        shipped = {}
        for file_name, table in tables.items():
            tmp = out / f".{file_name}.converting"
            pending[tmp] = out / file_name
            table.to_parquet(tmp, compression="zstd", index=False)
            shipped[f"{dataset}/{file_name}"] = sha256(tmp)
        entry = {**DATASET_INFO[dataset], "sampling_rates_hz": rates,
                 "terrains": sorted({r["terrain"] for r in runs_info}),
                 "runs_without_imu": [r["run_id"] for r in runs_info if not r["has_imu"]],
                 "files": shipped, "runs": runs_info}
        manifest.setdefault("datasets", {})[dataset] = entry
        manifest["format"] = __doc__.strip().splitlines()[0]
        tmp = manifest_path.with_name(f".{manifest_path.name}.converting")
        pending[tmp] = manifest_path
        tmp.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
        # a stream file of an earlier conversion that this one does not write (its runs have
        # no IMU file now): left, unlisted, it made every read of the dataset fail
        stale = [out / f for f in sorted(set(STREAM_FILES.values()) - set(tables))]
        _swap_in(pending, stale)
    finally:
        for tmp in pending:               # left only when the conversion failed
            tmp.unlink(missing_ok=True)
    return entry


def _swap_in(pending: Mapping[Path, Path], stale: list[Path]) -> None:
    """Rename each temporary file of ``pending`` onto the file it replaces and remove the
    ``stale`` files, all or none: the files replaced or removed are first set aside
    (``.<name>.previous``) and put back when a rename fails or is interrupted (new Parquet
    files swapped in under the earlier manifest, whose checksums then refused every read
    of the dataset, were left otherwise); once all are in place they are deleted."""
    aside: dict[Path, Path] = {}      # file replaced or removed -> its earlier copy
    placed: list[Path] = []
    try:
        for path in [*pending.values(), *stale]:
            if path.exists():
                copy = path.with_name(f".{path.name}.previous")
                os.replace(path, copy)
                aside[path] = copy
        for tmp, path in pending.items():
            os.replace(tmp, path)
            placed.append(path)
    except BaseException:
        for path in placed:
            path.unlink(missing_ok=True)
        for path, copy in aside.items():
            os.replace(copy, path)
        raise
    for copy in aside.values():
        copy.unlink(missing_ok=True)


def _manifest_to_update(path: Path) -> dict:
    """The manifest :func:`convert_dataset` merges its entry into, checked first.

    Parameters
    ----------
    path : Path
        ``<data_dir>/manifest.json``; need not exist.

    Returns
    -------
    dict
        The parsed manifest (empty when there is none).

    Raises
    ------
    DataFormatError
        It does not parse (line and column named), or is not a JSON object whose
        ``datasets``, if present, is an object; nothing has been written then.
    """
    if not path.exists():
        return {}
    hint = "fix it or move it away (nothing was converted)"
    manifest = _parse_manifest(path, hint)
    _check_manifest_object(manifest, path, f"; {hint}")
    return manifest


def read_manifest(data_dir: str | Path | None = None) -> dict:
    """Load ``data/manifest.json``.

    Parameters
    ----------
    data_dir : str or pathlib.Path, optional
        Shipped data folder; defaults to :func:`default_data_dir`.

    Returns
    -------
    dict
        The manifest; its ``datasets`` maps each dataset to an entry whose ``files`` maps
        relative paths to SHA-256 digests.

    Raises
    ------
    DataFormatError
        If the manifest is missing, or unreadable (not UTF-8 JSON), or ``data_dir`` is a
        file (``--data-dir data/manifest.json``); names the file.
    """
    folder = Path(data_dir or default_data_dir())
    if folder.is_file():    # its "manifest.json" below it was reported missing
        raise DataFormatError("data folder is a file: give the folder that holds "
                              "manifest.json", folder)
    path = folder / "manifest.json"
    if not path.exists():
        raise DataFormatError("manifest not found; regenerate data/ with `terrain convert`",
                              path)
    return _parse_manifest(path, "regenerate data/ with `terrain convert`")


def _parse_manifest(path: Path, hint: str):
    """Parse a manifest file, a failure named with its line and column and ``hint``."""
    try:
        text = read_text(path)
        return json.loads(text)
    except DataFormatError as exc:  # not UTF-8 (byte offset and line), not a file
        raise type(exc)(f"unreadable manifest: {exc.message}; {hint}", path,
                        line=exc.line) from None
    except json.JSONDecodeError as exc:  # where the parser stopped: line and column
        line, column = text_place(text, exc.pos)    # (a lone CR ends a line too)
        raise DataFormatError(f"unreadable manifest (invalid JSON: {exc.msg}, column "
                              f"{column}); {hint}", path, line=line) from None
    except (ValueError, OSError) as exc:  # UnicodeDecodeError included
        raise DataFormatError(f"unreadable manifest ({type(exc).__name__}); {hint}",
                              path) from None


def _check_manifest_object(manifest, path: str | Path, suffix: str = "") -> None:
    """Refuse a parsed manifest that is not a JSON object, or whose ``datasets``, where
    present, is not an object (DataFormatError naming ``path``; ``suffix`` ends the
    message)."""
    if not isinstance(manifest, dict):
        raise DataFormatError(f"manifest must be a JSON object with a 'datasets' key, got "
                              f"{_kind(manifest)}{suffix}", path)
    if not isinstance(manifest.get("datasets", {}), dict):
        raise DataFormatError(f"manifest key 'datasets' must be an object of datasets, got "
                              f"{_kind(manifest['datasets'])}{suffix}", path)


def _kind(value) -> str:
    """JSON name of a parsed value's type, for messages."""
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean",
            int: "a number", float: "a number", type(None): "null"}.get(type(value),
                                                                        type(value).__name__)


def manifest_terrains(manifest, path: str | Path) -> list[str]:
    """Terrain class names of the measured datasets of a manifest, its structure checked.

    The manifest must be a JSON object whose ``datasets`` object maps each dataset (at least
    one) to an object whose ``terrains`` is a non-empty list of terrain names (non-empty
    strings; whether the catalogue knows them is the caller's check).

    Parameters
    ----------
    manifest : object
        Parsed ``manifest.json`` (:func:`read_manifest`).
    path : str or Path
        The manifest file (for the messages).

    Returns
    -------
    list of str
        The terrain names of every dataset, in manifest order (a class of two datasets
        appears twice).

    Raises
    ------
    DataFormatError
        A structure other than the one above; names the file and the offending key (e.g.
        ``datasets.vulpi.terrains[2]``).
    """
    _check_manifest_object(manifest, path)
    if "datasets" not in manifest:
        raise DataFormatError(f"manifest key 'datasets' is missing (found keys: "
                              f"{', '.join(map(str, list(manifest)[:8])) or 'none'})", path)
    datasets = manifest["datasets"]
    if not datasets:
        raise DataFormatError("manifest key 'datasets' lists no dataset", path)
    measured: list[str] = []
    for name, entry in datasets.items():
        key = f"datasets.{name}"
        if not isinstance(entry, dict):
            raise DataFormatError(f"manifest key {key!r} must be an object, got "
                                  f"{_kind(entry)}", path)
        if "terrains" not in entry:
            raise DataFormatError(f"manifest key '{key}.terrains' is missing (the dataset's "
                                  "terrain classes)", path)
        terrains = entry["terrains"]
        if not isinstance(terrains, list):
            raise DataFormatError(f"manifest key '{key}.terrains' must be a list of terrain "
                                  f"names, got {_kind(terrains)} {terrains!r}"[:300], path)
        if not terrains:
            raise DataFormatError(f"manifest key '{key}.terrains' is an empty list", path)
        for i, t in enumerate(terrains):
            if not isinstance(t, str) or not t.strip():
                raise DataFormatError(f"manifest key '{key}.terrains[{i}]' must be a terrain "
                                      f"name, got {t!r}", path)
        measured.extend(terrains)
    return measured


def verify_manifest(data_dir: str | Path | None = None) -> list[str]:
    """Check the SHA-256 of every shipped file against the manifest.

    Parameters
    ----------
    data_dir : str or pathlib.Path, optional
        Shipped data folder; defaults to :func:`default_data_dir`. Errors of
        :func:`read_manifest` propagate.

    Returns
    -------
    list of str
        Relative paths whose checksum differs or that are missing, and shipped stream files
        (:data:`STREAM_FILES`) that exist but are not listed (empty when all match).

    Raises
    ------
    DataFormatError
        A manifest of another structure (:func:`dataset_entry`), naming the key.
    """
    data_dir = Path(data_dir or default_data_dir())
    path = data_dir / "manifest.json"
    manifest = read_manifest(data_dir)
    manifest_terrains(manifest, path)   # 'datasets': an object of dataset objects
    bad = []
    for dataset in manifest["datasets"]:
        entry = dataset_entry(manifest, dataset, path)
        for rel, digest in entry["files"].items():
            p = data_dir / rel
            if not p.exists() or sha256(p) != digest:
                bad.append(rel)
        bad += [f"{dataset}/{f}" for f in STREAM_FILES.values()
                if _unlisted_stream_file(data_dir, dataset, entry, f)]
    return bad


def _unlisted_stream_file(data_dir: Path, dataset: str, entry: dict, file_name: str) -> bool:
    """Whether the shipped stream file ``<data_dir>/<dataset>/<file_name>`` exists but the
    dataset's manifest ``entry`` does not list it in ``files`` (its runs would be read
    without that stream)."""
    return (f"{dataset}/{file_name}" not in entry["files"]
            and (data_dir / dataset / file_name).exists())


def _fail(key: str, expected: str, value, path: str | Path) -> DataFormatError:
    """A manifest error naming the key, what it must be and what it holds."""
    return DataFormatError(f"manifest key '{key}' must be {expected}, got {_kind(value)} "
                           f"{value!r}"[:300], path)


def _is_time_pair(value) -> bool:
    """Whether a parsed JSON value is a ``[t_start_s, t_end_s]`` pair of numbers."""
    return (isinstance(value, list) and len(value) == 2
            and all(isinstance(t, (int, float)) and not isinstance(t, bool) for t in value))


def dataset_entry(manifest, dataset: str, path: str | Path) -> dict:
    """One dataset's manifest entry, its structure checked for :func:`read_shipped`.

    Beyond :func:`manifest_terrains`: ``files`` maps relative paths to SHA-256 hex digests,
    ``source`` is a string, ``runs_without_imu``, where present, a list of run ids, and
    ``runs`` is a non-empty list of objects, each with a unique ``run_id``, a ``terrain`` of
    the entry's ``terrains``, ``repaired`` (an object of counts), ``gaps`` (an object of
    lists of ``[t_start_s, t_end_s]`` pairs) and, where present, a boolean ``has_imu``,
    ``samples`` and ``skipped_lines`` (objects of counts), ``ignored_columns`` (an object
    of lists of column names), a number ``duration_s`` and a list of strings
    ``file_warnings``, as :func:`convert_dataset` writes them.

    Parameters
    ----------
    manifest : object
        Parsed ``manifest.json`` (:func:`read_manifest`).
    dataset : str
        Dataset name.
    path : str or Path
        The manifest file (for the messages).

    Returns
    -------
    dict
        The entry.

    Raises
    ------
    DataFormatError
        The dataset is not in the manifest, or its entry has another structure; names the
        file and the offending key (e.g. ``datasets.vulpi.runs[3].terrain``).
    """
    manifest_terrains(manifest, path)
    entry = manifest["datasets"].get(dataset)
    if entry is None:
        raise DataFormatError(f"dataset {dataset!r} not in manifest (key 'datasets')", path)
    key = f"datasets.{dataset}"
    for name, kind in (("files", dict), ("source", str), ("runs", list)):
        if name not in entry:
            raise DataFormatError(f"manifest key '{key}.{name}' is missing", path)
        if not isinstance(entry[name], kind) or not entry[name]:
            raise _fail(f"{key}.{name}", {dict: "a non-empty object", str: "a string",
                                          list: "a non-empty list"}[kind], entry[name], path)
    for rel, digest in entry["files"].items():
        if not (isinstance(digest, str) and len(digest) == 64
                and all(c in "0123456789abcdef" for c in digest)):
            raise _fail(f"{key}.files.{rel}", "a SHA-256 hex digest", digest, path)
    without = entry.get("runs_without_imu", [])
    if not isinstance(without, list) or not all(isinstance(r, str) for r in without):
        raise _fail(f"{key}.runs_without_imu", "a list of run ids", without, path)
    seen: set[str] = set()
    for i, info in enumerate(entry["runs"]):
        k = f"{key}.runs[{i}]"
        if not isinstance(info, dict):
            raise _fail(k, "an object", info, path)
        for name in ("run_id", "terrain", "repaired", "gaps"):
            if name not in info:
                raise DataFormatError(f"manifest key '{k}.{name}' is missing", path)
        rid = info["run_id"]
        if not isinstance(rid, str) or not rid:
            raise _fail(f"{k}.run_id", "a run id", rid, path)
        if not isinstance(info.get("has_imu", False), bool):
            raise _fail(f"{k}.has_imu", "a boolean", info["has_imu"], path)
        if rid in seen:
            raise DataFormatError(f"manifest key '{k}.run_id': run {rid!r} is listed twice",
                                  path)
        seen.add(rid)
        if info["terrain"] not in entry["terrains"]:
            raise _fail(f"{k}.terrain", f"one of '{key}.terrains' {entry['terrains']}",
                        info["terrain"], path)
        repaired = info["repaired"]
        if not isinstance(repaired, dict) or not all(
                isinstance(n, int) and not isinstance(n, bool) and n >= 0
                for n in repaired.values()):
            raise _fail(f"{k}.repaired", "an object of counts", repaired, path)
        gaps = info["gaps"]
        if not isinstance(gaps, dict) or not all(
                isinstance(v, list) and all(map(_is_time_pair, v)) for v in gaps.values()):
            raise _fail(f"{k}.gaps", "an object of lists of [t_start_s, t_end_s] pairs",
                        gaps, path)
        for name in ("samples", "skipped_lines"):
            counts = info.get(name, {})
            if not isinstance(counts, dict) or not all(
                    isinstance(n, int) and not isinstance(n, bool) and n >= 0
                    for n in counts.values()):
                raise _fail(f"{k}.{name}", "an object of counts", counts, path)
        ignored = info.get("ignored_columns", {})
        if not isinstance(ignored, dict) or not all(
                isinstance(v, list) and all(isinstance(c, str) for c in v)
                for v in ignored.values()):
            raise _fail(f"{k}.ignored_columns", "an object of lists of column names",
                        ignored, path)
        duration = info.get("duration_s", 0.0)
        if not isinstance(duration, (int, float)) or isinstance(duration, bool):
            raise _fail(f"{k}.duration_s", "a number of seconds", duration, path)
        found = info.get("file_warnings", [])
        if not isinstance(found, list) or not all(isinstance(w, str) for w in found):
            raise _fail(f"{k}.file_warnings", "a list of messages", found, path)
    return entry


def _check_table(table: pd.DataFrame, stream: str, path: Path) -> None:
    """The columns of a shipped stream file: ``run_id`` and :data:`STREAM_COLUMNS`, numeric.

    The SHA-256 of the manifest guards the values; this guards a file and manifest both
    edited by hand (every later step indexes these columns and does arithmetic on them)."""
    for column in (RUN_ID, *STREAM_COLUMNS[stream]):
        if column not in table.columns:
            raise MissingColumnError(f"shipped {stream} file lacks column {column!r} (has "
                                     f"{[str(c) for c in table.columns]}); regenerate data/ "
                                     "with `terrain convert`", path, column)
        if column != RUN_ID and not pd.api.types.is_float_dtype(table[column]) \
                and not pd.api.types.is_integer_dtype(table[column]):
            raise NonNumericError(f"shipped {stream} column holds {table[column].dtype} "
                                  "values, not numbers; regenerate data/ with `terrain "
                                  "convert`", path, column)


def _check_run_rows(frame: pd.DataFrame, run_id: str, path: Path,
                    rows: np.ndarray | None = None) -> None:
    """The rules of the CSV reader that ``terrain convert`` applied, rechecked per run:
    strictly increasing, finite timestamps and finite values (no repair here). The error
    names the run's row in its message and the file's row (``rows``: the 0-based row of
    the file of each of the run's rows; default: the run's own) as its ``row``."""
    rows = np.arange(len(frame)) if rows is None else np.asarray(rows)
    t = frame[TIME].to_numpy(dtype=float)
    out_of_order = times_out_of_order(t)
    if out_of_order.size:
        row = int(out_of_order[0])
        raise TimestampError(f"run {run_id}: timestamps must increase strictly and be "
                             f"finite, got {float(t[row])!r} after {float(t[row - 1])!r} at "
                             f"row {row} of the run"
                             if row else f"run {run_id}: timestamp {float(t[row])!r} is not "
                             "finite at row 0 of the run", path, TIME,
                             int(rows[row]))
    values = frame.drop(columns=TIME).to_numpy(dtype=float)
    bad = np.argwhere(~np.isfinite(values))
    if len(bad):
        row, col = (int(i) for i in bad[0])
        raise NonFiniteError(f"run {run_id}: {len(bad)} non-finite value(s), the first "
                             f"{float(values[row, col])!r} at row {row} of the run; the "
                             "shipped files hold only repaired, finite values: regenerate "
                             "data/ with `terrain convert`", path,
                             str(frame.columns.drop(TIME)[col]), int(rows[row]))


def _check_run_counts(run: Run, info: dict, key: str, path: Path) -> None:
    """A run's manifest ``samples`` (rows per shipped stream) and ``duration_s``
    (:attr:`Run.duration_s`, 3 decimals, as :func:`convert_dataset` writes it) against the
    run read, where present: DataFormatError naming the key. ``samples`` of a stream the
    shipped format leaves out (``truth``...) have no rows to compare with."""
    samples = info.get("samples")
    if samples is not None:
        rows = {name: len(frame) for name, frame in run.streams.items()}
        for name in STREAM_FILES:
            if samples.get(name) != rows.get(name):
                said = f"{name} {samples[name]}" if name in samples else f"no {name}"
                held = f"holds {rows[name]} rows" if name in rows else "holds no row"
                raise DataFormatError(f"key '{key}.samples' says {said} but "
                                      f"{STREAM_FILES[name]} {held} of run {run.run_id!r}; "
                                      "regenerate data/ with `terrain convert`", path)
    if "duration_s" in info and round(run.duration_s, 3) != info["duration_s"]:
        raise DataFormatError(f"key '{key}.duration_s' says {info['duration_s']:g} s but "
                              f"its rows span {run.duration_s:.3f} s; regenerate data/ with "
                              "`terrain convert`", path)


def read_shipped(dataset: str, data_dir: str | Path | None = None) -> list[Run]:
    """Read one shipped dataset.

    Parameters
    ----------
    dataset : str
        ``borealtc`` or ``vulpi``.
    data_dir : str or Path, optional
        Defaults to :func:`default_data_dir`.

    Returns
    -------
    list of Run
        Sorted by run id; runs without an IMU recording have only a ``wheels`` stream. Each
        run's ``meta`` holds what the CSV readers repaired, skipped, ignored and found
        (``file_warnings``) when the run was converted, and ``warnings``: those findings
        then the plausibility checks' (:func:`~terrain.io.plausibility.check_run`).

    Raises
    ------
    ConfigError
        Unknown dataset.
    DataFormatError
        A missing or unreadable file, a file whose SHA-256 differs from the manifest's
        (edited after `terrain convert` wrote it), a stream file that exists but that the
        manifest's ``files`` does not list (its runs would silently lack that stream), a
        manifest entry of another structure (:func:`dataset_entry`), a run's ``terrain``
        other than the terrain folder of its id (``<dataset>/<TERRAIN>/<index>``, as
        :func:`convert_dataset` writes it), runs of a file and of
        the manifest that differ (run ids; a run's ``has_imu`` and the entry's
        ``runs_without_imu`` against the IMU rows the files hold; a run's ``samples`` and
        ``duration_s`` against its rows), a missing
        or non-numeric column, timestamps that do not increase strictly or a non-finite
        value (subclasses :class:`~terrain.errors.MissingColumnError`,
        :class:`~terrain.errors.NonNumericError`, :class:`~terrain.errors.TimestampError`,
        :class:`~terrain.errors.NonFiniteError`); names the file and the manifest key or
        column, with the run, the row of the run and the row of the file (both 0-based).

    Warns
    -----
    DataWarning
        Each finding of a run's files kept from its conversion, and those of the
        plausibility checks.
    """
    if dataset not in DATASET_INFO:
        raise ConfigError(f"unknown dataset {dataset!r}; valid: {list(DATASET_INFO)}")
    data_dir = Path(data_dir or default_data_dir())
    manifest_path = data_dir / "manifest.json"
    entry = dataset_entry(read_manifest(data_dir), dataset, manifest_path)
    tables = {}
    for name, fname in STREAM_FILES.items():
        path = data_dir / dataset / fname
        rel = f"{dataset}/{fname}"
        if _unlisted_stream_file(data_dir, dataset, entry, fname):
            # left out, every run of the dataset would be read without this stream
            raise DataFormatError(
                f"key 'datasets.{dataset}.files' does not list {rel}, which exists "
                f"({path}): its runs would be read without their {name} stream; "
                "regenerate data/ with `terrain convert`", manifest_path)
        if rel not in entry["files"]:
            continue  # no run of the dataset has this stream
        if not path.exists():
            raise DataFormatError("shipped file missing", path)
        # read once: the bytes hashed are the bytes parsed (and the file is read only once)
        content = path.read_bytes()
        if hashlib.sha256(content).hexdigest() != entry["files"][rel]:
            # the values were checked when `terrain convert` wrote the file; a changed file
            # would skip every rule of the CSV reader
            raise DataFormatError(f"contents differ from their SHA-256 in {manifest_path} "
                                  f"(key 'datasets.{dataset}.files.{rel}'): shipped files are "
                                  "written only by `terrain convert`, which checks every "
                                  "value; regenerate data/ with it", path)
        try:
            table = pd.read_parquet(io.BytesIO(content))
        except (OSError, ValueError) as exc:  # pyarrow's errors derive from these
            raise DataFormatError(f"unreadable Parquet file ({type(exc).__name__}: "
                                  f"{str(exc)[:120]}); regenerate data/ with `terrain convert`",
                                  path) from None
        _check_table(table, name, path)
        groups = table.groupby(RUN_ID, observed=True, sort=False)
        tables[name] = {str(k): g.drop(columns=RUN_ID).reset_index(drop=True)
                        for k, g in groups}
        file_rows = {str(k): v for k, v in groups.indices.items()}
        for rid, frame in tables[name].items():
            _check_run_rows(frame, rid, path, file_rows[rid])
    listed = {info["run_id"] for info in entry["runs"]}
    for name, table in tables.items():
        extra = sorted(set(table) - listed)
        if extra:
            raise DataFormatError(f"{len(extra)} run(s) not listed in {manifest_path} "
                                  f"(key 'datasets.{dataset}.runs'): {extra[:5]}",
                                  data_dir / dataset / STREAM_FILES[name], RUN_ID)
    runs = []
    # sorted by run id, as returned; ``i`` stays the manifest's index (its keys in messages)
    for i, info in sorted(enumerate(entry["runs"]), key=lambda item: item[1]["run_id"]):
        rid = info["run_id"]
        streams = {n: t[rid] for n, t in tables.items() if rid in t}
        if "wheels" not in streams:
            raise DataFormatError(f"run {rid!r} of key 'datasets.{dataset}.runs' has no rows "
                                  f"in {STREAM_FILES['wheels']}", manifest_path)
        folder = rid.split("/")
        if len(folder) == 3 and folder[1].upper() != info["terrain"]:
            # the label is the manifest's: one edited to another class was read as it
            raise DataFormatError(f"key 'datasets.{dataset}.runs[{i}].terrain' is "
                                  f"{info['terrain']!r} but run {rid!r} lies in terrain "
                                  f"folder {folder[1]!r}; regenerate data/ with `terrain "
                                  "convert`", manifest_path)
        if "has_imu" in info and info["has_imu"] != ("imu" in streams):
            raise DataFormatError(
                f"key 'datasets.{dataset}.runs[{i}].has_imu' is "
                f"{json.dumps(info['has_imu'])} but {STREAM_FILES['imu']} holds "
                f"{'rows' if 'imu' in streams else 'no row'} of run {rid!r}; regenerate data/ "
                "with `terrain convert`", manifest_path)
        # the same plausibility rules as the CSV reader (ranges were checked on conversion)
        # the CSV files' own findings, made when they were converted (warned again, as
        # reading the CSV files warns them)
        file_warnings = list(info.get("file_warnings", []))
        for msg in file_warnings:
            warnings.warn(msg, DataWarning, stacklevel=2)
        checks = check_run(rid, streams, DATASET_VEHICLE[dataset],
                           {n: f"{data_dir / dataset / STREAM_FILES[n]} run {rid}"
                            for n in streams})
        checks["warnings"] = file_warnings + checks["warnings"]
        runs.append(Run(run_id=rid, dataset=dataset, terrain=info["terrain"], streams=streams,
                        vehicle=DATASET_VEHICLE[dataset],
                        source=f"{data_dir / dataset} ({entry['source']})",
                        meta={"repaired": info["repaired"],
                              # JSON has no tuples: restore the reader's (t_start_s, t_end_s)
                              "gaps": {k: [tuple(g) for g in v]
                                       for k, v in info["gaps"].items()},
                              "skipped_lines": dict(info.get("skipped_lines", {})),
                              "ignored_columns": dict(info.get("ignored_columns", {})),
                              "file_warnings": file_warnings, **checks}))
        _check_run_counts(runs[-1], info, f"datasets.{dataset}.runs[{i}]", manifest_path)
    if "runs_without_imu" in entry:
        without = {r.run_id for r in runs if "imu" not in r.streams}
        listed_without = set(entry["runs_without_imu"])
        extra, missing = sorted(listed_without - without), sorted(without - listed_without)
        wrong = ([f"lists {extra[:5]}, which are not runs without rows"] if extra else []) + \
            ([f"omits {missing[:5]}, which have none"] if missing else [])
        if wrong:
            raise DataFormatError(f"key 'datasets.{dataset}.runs_without_imu' "
                                  f"{' and '.join(wrong)} in {STREAM_FILES['imu']}; "
                                  "regenerate data/ with `terrain convert`", manifest_path)
    return runs


@dataclass(frozen=True)
class DatasetSpec:
    """A named training set: which shipped datasets it pools, and its aligned clock rate.

    ``rate_hz`` is the native IMU rate (100 Hz BorealTC, 50 Hz Vulpi; ``combined`` uses
    100 Hz, Vulpi's IMU being interpolated, so BorealTC keeps its vibration band up to 50 Hz).

    Parameters
    ----------
    name : str
        Name of the training set (``borealtc``, ``vulpi``, ``combined``).
    parts : tuple of str
        Shipped datasets it pools, each read by :func:`read_shipped`.
    rate_hz : float
        Common clock rate the streams are aligned to, Hz.
    """

    name: str
    parts: tuple[str, ...]
    rate_hz: float


DATASET_SPECS: Mapping[str, DatasetSpec] = MappingProxyType({
    "borealtc": DatasetSpec("borealtc", ("borealtc",), 100.0),
    "vulpi": DatasetSpec("vulpi", ("vulpi",), 50.0),
    "combined": DatasetSpec("combined", ("borealtc", "vulpi"), 100.0),
})


def dataset_vehicle(name: str) -> str | None:
    """The vehicle that recorded a training set of :data:`DATASET_SPECS`.

    Parameters
    ----------
    name : str
        ``borealtc``, ``vulpi`` or ``combined``.

    Returns
    -------
    str or None
        The one vehicle of its shipped parts (:data:`DATASET_VEHICLE`); None for a name
        that is not a training set, or one whose parts were recorded by different vehicles.
    """
    spec = DATASET_SPECS.get(str(name))
    vehicles = {DATASET_VEHICLE.get(part) for part in spec.parts} if spec else set()
    return vehicles.pop() if len(vehicles) == 1 else None


def load_dataset(name: str, data_dir: str | Path | None = None) -> list[Run]:
    """Load ``borealtc``, ``vulpi`` or ``combined`` (both pooled, 9 classes).

    Parameters
    ----------
    name : str
        Key of :data:`DATASET_SPECS`.
    data_dir : str or pathlib.Path, optional
        Shipped data folder; defaults to :func:`default_data_dir`.

    Returns
    -------
    list of Run
        The runs of every part of the spec, in part order, each sorted by run id.

    Raises
    ------
    ConfigError
        Unknown name (the message lists the valid ones).
    DataFormatError
        Missing or corrupt shipped file (raised by :func:`read_shipped`).
    """
    spec = DATASET_SPECS.get(name)
    if spec is None:
        raise ConfigError(f"unknown dataset {name!r}; valid: {list(DATASET_SPECS)}")
    return [run for part in spec.parts for run in read_shipped(part, data_dir)]


def runs_equal(a: Run, b: Run) -> bool:
    """Whether two runs have the same id, label and bit-identical streams.

    Parameters
    ----------
    a, b : Run
        Runs to compare (e.g. a CSV-read run and its shipped Parquet round trip).

    Returns
    -------
    bool
        True when run id, terrain, stream names, column names and all values match exactly
        (:func:`numpy.array_equal`, so a stream holding NaN never compares equal).
    """
    if (a.run_id, a.terrain) != (b.run_id, b.terrain) or set(a.streams) != set(b.streams):
        return False
    return all(list(a.streams[k].columns) == list(b.streams[k].columns)
               and np.array_equal(a.streams[k].to_numpy(), b.streams[k].to_numpy())
               for k in a.streams)
