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
from collections import Counter
from pathlib import Path

import pandas as pd

from pipelines.arguments import add_smoothing, output_file, smoothing_from_args
from terrain.errors import ConfigError, DataFormatError
from terrain.io.measured import folder_run_files, read_run
from terrain.io.report import input_report
from terrain.control import DesiredSlipConfig
from terrain.run import TIME
from terrain.serving import (StreamConfig, StreamService, TableTargets,
                             decisions_frame, load_stream_model, replay_run)
from terrain.serving.decisions import join_flags, stuck_decision_flags, without_stuck


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
    parser.add_argument("--out", type=output_file, required=True, help="decisions CSV to write")
    parser.add_argument("--hop-s", type=float, default=0.5, help="time between decisions, s")
    add_smoothing(parser)
    parser.add_argument("--min-confidence", type=float, default=0.5,
                        help="smoothed probability below which the fallback target is used")


def _run_files(run_dir: Path, index: str | None) -> tuple[str, dict]:
    """Index and files of the chosen run of ``run_dir``; errors and file paths keep
    ``run_dir`` as the user gave it."""
    if not run_dir.is_dir():
        raise ConfigError(f"run folder {run_dir} does not exist or is not a folder")
    if run_dir.name in ("", ".", ".."):  # no name of its own in the path as given
        run_dir = run_dir.resolve()
    runs = folder_run_files(run_dir)
    if not runs:
        raise ConfigError(f"{run_dir} holds no run files (imu_XX.csv, pro_XX.csv)")
    if index is None and len(runs) > 1:
        raise ConfigError(f"{run_dir} holds runs {sorted(runs)}: choose one with --index")
    index = index or next(iter(runs))
    if index not in runs:
        raise ConfigError(f"no run {index!r} in {run_dir}; available: {sorted(runs)}")
    return index, runs[index]


def _overlap_s(streams: list[pd.DataFrame]) -> float:
    """Time span covered by every one of ``streams``, s (0 when they do not overlap)."""
    if not all(len(f) for f in streams):
        return 0.0
    starts = [float(f[TIME].iloc[0]) for f in streams]
    ends = [float(f[TIME].iloc[-1]) for f in streams]
    return max(0.0, min(ends) - max(starts))


def main(args: argparse.Namespace) -> int:
    """Read the run, replay it, write and summarise the decisions.

    Prints what the readers repaired and found (the input report of ``terrain predict``),
    then one line: decisions, flags by kind, output file.

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
        When the model cannot be loaded, ``args.run_dir`` is not a folder, holds no run
        files, holds several runs and ``--index`` is not given, lacks the run ``--index``,
        or lacks a stream the model needs.
    DataFormatError
        When the run gives no decision: its streams overlap for less than one window, or
        the service's per-sample rules refused the samples it needed (the message counts
        them per stream and reason).
    """
    model = load_stream_model(args.model)
    index, files = _run_files(args.run_dir, args.index)
    folder = args.run_dir.resolve()
    run = read_run(files, f"{folder.name}/{index}", folder.parent.name, folder.name.upper())
    config = StreamConfig(hop_s=args.hop_s, min_confidence=args.min_confidence,
                          smoothing=smoothing_from_args(args))
    targets = TableTargets(model.classes, DesiredSlipConfig(min_confidence=args.min_confidence))
    service = StreamService(model, targets, config)
    missing = [s for s in service.needed_streams if s not in run.streams]
    if missing:
        raise ConfigError(f"the model needs stream(s) {missing}, absent from run {run.run_id}")
    frame = decisions_frame(replay_run(service, run), model.classes)
    window_s = model.window.window_s
    stuck = stuck_decision_flags(frame, dict(run.meta.get("stuck", {})), window_s)
    frame["flags"] = join_flags(without_stuck(frame["flags"]), stuck)
    n_stuck = int((stuck != "").sum())
    span = _overlap_s([run.streams[s] for s in service.needed_streams])
    # a run whose needed streams share less than one window is refused even where the
    # service emitted (flagged) decisions from the longer stream alone
    short = [run.run_id] if span < window_s else []
    counts = {"per_run": {} if short else {run.run_id: {
        "windows": len(frame), "dropped_gap": 0, "dropped_unsteady": 0}},
        "too_short_runs": short}
    print(input_report([run], counts, window_s, {run.run_id: n_stuck}).text())
    if short:
        raise DataFormatError(f"no decision from run {run.run_id}: its streams "
                              f"{list(service.needed_streams)} overlap for {span:.2f} s, "
                              f"shorter than the model's {window_s:g} s window", args.run_dir)
    if not len(frame):
        refused = ", ".join(f"{n} of stream {s} ({r})"
                            for (s, r), n in sorted(service.refused_samples.items()))
        raise DataFormatError(f"no decision from run {run.run_id}: its streams "
                              f"{list(service.needed_streams)} overlap for {span:.2f} s "
                              f"(window {window_s:g} s), but the service's input rules left "
                              f"too few samples; refused: {refused or 'none'}", args.run_dir)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    frame.to_csv(args.out, index=False)
    kinds = Counter(k.split(":")[0] for f in frame["flags"] if f for k in f.split("|"))
    flagged = int((frame["flags"] != "").sum())
    detail = f" ({', '.join(f'{k} {n}' for k, n in sorted(kinds.items()))})" if kinds else ""
    skipped = (f"; {service.skipped_decisions} skipped in silent stretches (no sample of "
               f"any stream for over {config.max_backlog_s:g} s)"
               if service.skipped_decisions else "")
    held = service.held_samples
    if held:
        skipped += "; " + ", ".join(f"{n} samples of stream {s} still held at the end "
                                    f"({r}: their clock not yet told)"
                                    for (s, r), n in sorted(held.items()))
    print(f"{run.run_id}: {len(frame)} decisions every {args.hop_s} s from streams "
          f"{list(service.needed_streams)}; {flagged} flagged{detail}{skipped}; written to "
          f"{args.out}")
    if len(frame) and run.terrain in model.classes:
        acc = float((frame["terrain"] == run.terrain).mean())
        print(f"  decided {run.terrain} (the folder's label) in {acc:.3f} of the decisions")
    return 0
