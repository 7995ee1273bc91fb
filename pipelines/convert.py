"""Regenerate data/ (Parquet + manifest) from runs in the original CSV layout.

Example: terrain convert ../shared/data/borealtc --dataset borealtc --data-dir data
"""

from __future__ import annotations

import argparse

from pipelines.arguments import input_folder, output_dir
from terrain.io.report import input_report
from terrain.io.shipped import DATASETS, convert_dataset, default_data_dir, read_shipped


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain convert``: source folder ``<TERRAIN>/{imu_XX,pro_XX}.csv``,
    ``--dataset`` name and ``--data-dir`` output folder.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    parser.add_argument("src", type=input_folder, metavar="CSV_DIR",
                        help="folder in the layout <TERRAIN>/{imu_XX,pro_XX}.csv")
    parser.add_argument("--dataset", required=True, choices=DATASETS)
    parser.add_argument("--data-dir", type=output_dir, default=None,
                        help="output data/ folder (default: the project's data/, or "
                             "TERRAIN_DATA_DIR when set, the folder the other commands read)")


def main(args: argparse.Namespace) -> int:
    """Convert a raw dataset folder to the shipped parquet layout and print a one-line summary
    (runs, terrains, sampling rates in Hz, runs without IMU).

    Bad input raises the project errors of :func:`terrain.io.shipped.convert_dataset`
    (``ConfigError`` for an unknown dataset, ``DataFormatError`` for a bad source file),
    which the CLI entry point reports to the user.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        Exit status, 0.
    """
    data_dir = args.data_dir or default_data_dir()
    entry = convert_dataset(args.src, args.dataset, data_dir)
    print(input_report(read_shipped(args.dataset, data_dir)).text())
    print(f"{args.dataset}: {len(entry['runs'])} runs, terrains {entry['terrains']}, "
          f"rates {entry['sampling_rates_hz']} Hz, without IMU: {entry['runs_without_imu']}")
    return 0
