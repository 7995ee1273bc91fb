"""Replay a recorded run as a live stream through the streaming terrain service.

RUN_DIR is one terrain folder of the measured-run layout (``imu_XX.csv``, ``pro_XX.csv``;
``--index`` picks the run when it holds several). Samples are fed in timestamp order, the
streams interleaved, one by one; the decisions (``t_s, terrain, confidence,
proba_<CLASS>..., target_slip_traction, target_slip_braking, target_slip_steady,
window_age_s, flags``) are written to --out as CSV. Slip targets come from the desired-slip
table (:mod:`terrain.control.desired_slip`, its conservative entry below --min-confidence or
on stale input).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from terrain.errors import ConfigError
from terrain.io.measured import list_run_files, read_run
from terrain.control import DesiredSlipConfig
from terrain.serving import (SmoothingConfig, StreamConfig, StreamService, TableTargets,
                             decisions_frame, load_stream_model, replay_run)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain stream``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser to which the options are added (modified in place).
    """
    parser.add_argument("--model", type=Path, required=True,
                        help="model directory (terrain train --model-out)")
    parser.add_argument("run_dir", type=Path, metavar="RUN_DIR",
                        help="terrain folder holding the run's imu_XX.csv / pro_XX.csv")
    parser.add_argument("--index", default=None, help="run index XX when RUN_DIR holds several")
    parser.add_argument("--out", type=Path, required=True, help="decisions CSV to write")
    parser.add_argument("--hop-s", type=float, default=0.5, help="time between decisions, s")
    parser.add_argument("--dwell-s", type=float, default=10.0,
                        help="expected time on one terrain of the forward filter, s "
                             "(0 disables smoothing)")
    parser.add_argument("--min-confidence", type=float, default=0.5,
                        help="smoothed probability below which the fallback target is used")


def main(args: argparse.Namespace) -> int:
    """Read the run, replay it, write and summarise the decisions.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of :func:`add_arguments`.

    Returns
    -------
    int
        Exit status, 0 on success.

    Raises
    ------
    ConfigError
        When ``args.run_dir`` holds no run files, holds several runs and ``--index`` is not
        given, lacks the run ``--index``, or lacks a stream the model needs.
    """
    run_dir = args.run_dir.resolve()
    runs = {idx: files for (folder, idx), files in list_run_files(run_dir.parent).items()
            if folder == run_dir.name}
    if not runs:
        raise ConfigError(f"{run_dir} holds no run files (imu_XX.csv, pro_XX.csv)")
    if args.index is None and len(runs) > 1:
        raise ConfigError(f"{run_dir} holds runs {sorted(runs)}: choose one with --index")
    index = args.index or next(iter(runs))
    if index not in runs:
        raise ConfigError(f"no run {index!r} in {run_dir}; available: {sorted(runs)}")
    run = read_run(runs[index], f"{run_dir.name}/{index}", run_dir.parent.name,
                   run_dir.name.upper())
    model = load_stream_model(args.model)
    config = StreamConfig(hop_s=args.hop_s, min_confidence=args.min_confidence,
                          smoothing=SmoothingConfig(dwell_s=args.dwell_s or None))
    targets = TableTargets(model.classes, DesiredSlipConfig(min_confidence=args.min_confidence))
    service = StreamService(model, targets, config)
    missing = [s for s in service.needed_streams if s not in run.streams]
    if missing:
        raise ConfigError(f"the model needs stream(s) {missing}, absent from run {run.run_id}")
    frame = decisions_frame(replay_run(service, run), model.classes)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    frame.to_csv(args.out, index=False)
    flagged = int((frame["flags"] != "").sum())
    print(f"{run.run_id}: {len(frame)} decisions every {args.hop_s} s from streams "
          f"{list(service.needed_streams)}; {flagged} flagged; written to {args.out}")
    if len(frame) and run.terrain in model.classes:
        acc = float((frame["terrain"] == run.terrain).mean())
        print(f"  decided {run.terrain} (the folder's label) in {acc:.3f} of the decisions")
    return 0
