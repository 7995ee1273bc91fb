"""Reproduce the validation reports: docs/estimation_validation.md or docs/sim_validation.md.

terrain validate estimation   every table of docs/estimation_validation.md (about 75 s)
terrain validate sim          the tables of docs/sim_validation.md (about 35 s)
With --out FILE, each report also draws its figure beside FILE (<FILE stem>_slip_tracking.png,
<FILE stem>_straight_line.png).
The checks with tolerances are tests (tests/estimation, tests/slip, tests/sim); the simulator
speed is benchmarks/bench_sim.py. Tables are printed as Markdown (--out also writes them).
"""

from __future__ import annotations

import argparse
import importlib
import time
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np
import pandas as pd

from pipelines.arguments import check_derived_output, output_file
from terrain.io.jsonfile import staged_outputs

#: report name -> module with ``sections(quick)`` (read-only; imported when run, so that
#: building the ``terrain`` parser stays light)
REPORTS: Mapping[str, str] = MappingProxyType({
    "estimation": "pipelines.validation.estimation_tables",
    "sim": "pipelines.validation.sim_tables"})


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain validate``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    parser.add_argument("report", choices=sorted(REPORTS), help="which report")
    parser.add_argument("--quick", action="store_true",
                        help="fewer seeds / shorter runs (smoke run, not the published figures)")
    parser.add_argument("--out", type=output_file, default=None,
                        help="also write the Markdown here, and the report's figure beside "
                             "it (<stem>_slip_tracking.png or <stem>_straight_line.png)")


def to_markdown(table: pd.DataFrame, digits: int = 4) -> str:
    """A DataFrame as a Markdown table (floats with ``digits`` significant digits).

    Parameters
    ----------
    table : pandas.DataFrame
        Table to format.
    digits : int
        Significant digits of floats.

    Returns
    -------
    str
        Header, rule and one line per row; a missing float reads ``nan``, an infinite one
        ``inf`` or ``-inf``.
    """
    def fmt(v) -> str:
        if isinstance(v, (float, np.floating)):
            return "nan" if np.isnan(v) else f"{v:.{digits}g}"
        return str(v)
    head = "| " + " | ".join(map(str, table.columns)) + " |"
    rule = "|" + "|".join("---" for _ in table.columns) + "|"
    body = ["| " + " | ".join(fmt(v) for v in row) + " |"
            for row in table.itertuples(index=False)]
    return "\n".join([head, rule, *body])


def main(args: argparse.Namespace) -> int:
    """Compute every table of the chosen report and print it as Markdown.

    Each table is printed with the seconds it took; ``--out`` writes the tables without
    those times, so that the same tables give the same file.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        0.

    Raises
    ------
    ConfigError
        With ``--out``, a figure file beside it (``<stem>_<name>.png``) cannot be written
        (checked before any table is computed, as ``--out`` itself is).
    OSError
        With ``--out``, the Markdown or a figure could not be written (a full disk): as on
        any failure of a figure, the files of an earlier run are left as they were.
    """
    if args.out is not None:
        from pipelines.validation.figures import figure_paths
        for path in figure_paths(args.report, args.out).values():
            check_derived_output("--out", path, [])
    text = []
    report = importlib.import_module(REPORTS[args.report])
    for title, table_fn in report.sections(args.quick):
        start = time.perf_counter()
        block = f"### {title}\n\n{to_markdown(table_fn())}\n"
        # the computing time is printed, not written: the same tables give the same file
        print(f"{block}\n({time.perf_counter() - start:.1f} s)\n", flush=True)
        text.append(block)
    if args.out is not None:
        for path in _write_report(args.report, args.out, "\n".join(text), args.quick):
            print(f"figure: {path}", flush=True)
    return 0


def _write_report(report: str, out: Path, text: str, quick: bool) -> list[Path]:
    """Write the Markdown ``text`` to ``out`` and draw the report's figures beside it, all
    in a staging folder beside it (:func:`terrain.io.jsonfile.staged_outputs`) and moved
    into place once every one is written, the Markdown last: a failure (a figure that cannot
    be drawn, a full disk, an interrupt) leaves the files of an earlier run as they were,
    not new tables beside its figure or a cut file, and no temporary file. Returns the
    figure files."""
    from pipelines.validation.figures import figure_paths, figures  # matplotlib: with --out
    with staged_outputs(out.parent, (), last=(out.name,)) as stage:
        (stage / out.name).write_text(text)
        figures(report, stage / out.name, quick)
    return list(figure_paths(report, out).values())
