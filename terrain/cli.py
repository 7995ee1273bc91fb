"""The ``terrain`` command line.

Each subcommand lives in a module of :mod:`pipelines` that exposes

* a module docstring (first line = the subcommand's help),
* ``add_arguments(parser: argparse.ArgumentParser) -> None``,
* ``main(args: argparse.Namespace) -> int``.

This module only dispatches; it is the outermost layer (nothing imports it).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from types import MappingProxyType
from typing import Mapping, Sequence

from terrain.errors import TerrainError

#: subcommand -> pipelines module implementing it
SUBCOMMANDS: Mapping[str, str] = MappingProxyType({
    "cv": "pipelines.cv",
    "train": "pipelines.train",
    "predict": "pipelines.predict",
    "convert": "pipelines.convert",
    "benchmark": "pipelines.benchmark",
    "simulate": "pipelines.simulate",
    "audit": "pipelines.audit",
    "estimate": "pipelines.estimate",
    "validate": "pipelines.validate",
    "slip-table": "pipelines.slip_table",
})


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with one subparser per available pipeline."""
    parser = argparse.ArgumentParser(
        prog="terrain",
        description="Terrain classification, slip estimation and simulation for field robots.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in SUBCOMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name == module_name:
                continue  # pipeline not part of this installation
            raise
        doc = (module.__doc__ or name).strip()
        sp = sub.add_parser(name, help=doc.splitlines()[0], description=doc,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(sp)
        sp.set_defaults(_main=module.main)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``terrain`` command; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._main(args) or 0)
    except TerrainError as exc:
        print(f"terrain {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
