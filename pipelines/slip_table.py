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

from pipelines.arguments import input_path
from terrain.control.desired_slip import build_slip_table, classifier_classes
from terrain.errors import ConfigError, DataFormatError
from terrain.io.shipped import default_data_dir, manifest_terrains, read_manifest
from terrain.terramechanics.catalogue import get_terrain


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain slip-table``: ``--json`` and ``--data-dir``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    parser.add_argument("--json", action="store_true", help="print JSON instead of CSV")
    parser.add_argument("--data-dir", type=input_path, default=None,
                        help="shipped data folder whose manifest lists the measured classes "
                             "(default: data/, or TERRAIN_DATA_DIR)")


def measured_terrains(manifest, path: str | Path) -> list[str]:
    """Terrain classes of a manifest's measured datasets, each a catalogue terrain.

    Parameters
    ----------
    manifest : object
        Parsed ``manifest.json`` (:func:`terrain.io.shipped.read_manifest`).
    path : str or Path
        The manifest file (for the messages).

    Returns
    -------
    list of str
        :func:`terrain.io.shipped.manifest_terrains`, in manifest order.

    Raises
    ------
    DataFormatError
        A badly structured manifest (:func:`~terrain.io.shipped.manifest_terrains`) or a
        terrain the catalogue does not know; names the file and the key.
    """
    names = manifest_terrains(manifest, path)
    for key, entry in manifest["datasets"].items():
        for i, t in enumerate(entry["terrains"]):
            try:
                get_terrain(t)
            except ConfigError as exc:
                raise DataFormatError(f"manifest key 'datasets.{key}.terrains[{i}]': {exc}",
                                      path) from None
    return names


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
