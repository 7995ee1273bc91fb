"""Print the desired-slip table: target slip per terrain class for traction, braking, steady.

Every class the terrain classifier can emit (the measured classes of data/manifest.json and
the thesis's TILES, GRASS, GRAVEL) gets targets computed from its traction-slip curve in the
terrain catalogue (terrain.control.desired_slip); the last row, UNKNOWN, is the conservative
fallback for unknown, low-confidence or stale terrain decisions. CSV on stdout with columns
terrain, target_slip_traction, target_slip_braking, target_slip_steady, source, method;
--json prints the same rows (and the rules' settings) as JSON.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

from pathlib import Path

from terrain.control.desired_slip import build_slip_table, classifier_classes
from terrain.errors import ConfigError, DataFormatError
from terrain.io.shipped import default_data_dir, read_manifest
from terrain.terramechanics.catalogue import get_terrain


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain slip-table``: ``--json`` and ``--data-dir``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    parser.add_argument("--json", action="store_true", help="print JSON instead of CSV")
    parser.add_argument("--data-dir", default=None,
                        help="shipped data folder whose manifest lists the measured classes "
                             "(default: data/, or TERRAIN_DATA_DIR)")


def _kind(value) -> str:
    """JSON name of a parsed value's type, for messages."""
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean",
            int: "a number", float: "a number", type(None): "null"}.get(type(value),
                                                                      type(value).__name__)


def measured_terrains(manifest, path: str | Path) -> list[str]:
    """Terrain classes of the measured datasets of a manifest, its structure checked.

    The manifest must be a JSON object whose ``datasets`` object maps each dataset (at least
    one) to an object whose ``terrains`` is a non-empty list of catalogue terrain names.

    Parameters
    ----------
    manifest : object
        Parsed ``manifest.json`` (:func:`terrain.io.shipped.read_manifest`).
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
        A structure other than the one above, or an unknown terrain name; names the file
        and the offending key (e.g. ``datasets.vulpi.terrains[2]``).
    """
    if not isinstance(manifest, dict):
        raise DataFormatError(f"manifest must be a JSON object with a 'datasets' key, got "
                              f"{_kind(manifest)}", path)
    datasets = manifest.get("datasets")
    if "datasets" not in manifest:
        raise DataFormatError(f"manifest key 'datasets' is missing (found keys: "
                              f"{', '.join(map(str, list(manifest)[:8])) or 'none'})", path)
    if not isinstance(datasets, dict):
        raise DataFormatError(f"manifest key 'datasets' must be an object of datasets, got "
                              f"{_kind(datasets)}", path)
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
            try:
                get_terrain(t)
            except ConfigError as exc:
                raise DataFormatError(f"manifest key '{key}.terrains[{i}]': {exc}",
                                      path) from None
        measured.extend(terrains)
    return measured


def main(args: argparse.Namespace) -> int:
    """Compute the per-class slip table and print it.

    The classes are the classifier's classes for the terrains of the manifest of
    ``args.data_dir`` (:func:`terrain.control.desired_slip.build_slip_table`); printed as CSV
    (4 decimals) or, with ``args.json``, as JSON with the table's config.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        Exit status, 0.

    Raises
    ------
    DataFormatError
        The manifest is missing, unreadable or badly structured (:func:`measured_terrains`).
    """
    manifest = read_manifest(args.data_dir)
    path = Path(args.data_dir or default_data_dir()) / "manifest.json"
    measured = measured_terrains(manifest, path)
    table = build_slip_table(classifier_classes(measured))
    frame = table.frame()
    if args.json:
        print(json.dumps({"config": dataclasses.asdict(table.config),
                          "rows": frame.to_dict(orient="records")}, indent=1))
    else:
        frame.to_csv(sys.stdout, index=False, float_format="%.4f", lineterminator="\n")
    return 0
