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

from pipelines.arguments import (add_smoothing, input_folder, model_folder, output_file,
                                 positive_number, probability, smoothing_from_args)
from terrain.control import DesiredSlipConfig
from terrain.io.jsonfile import whole_file
from terrain.io.measured import read_folder_run
from terrain.serving import StreamConfig, StreamService, TableTargets, load_stream_model
from terrain.serving.model import imu_rate_note, other_vehicle_note
from terrain.serving.replay import replay_recorded


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain stream``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser to which the options are added (modified in place).
    """
    parser.add_argument("--model", type=model_folder, required=True,
                        help="model directory (terrain train --model-out)")
    parser.add_argument("run_dir", type=input_folder, metavar="RUN_DIR",
                        help="terrain folder holding the run's imu_XX.csv / pro_XX.csv")
    parser.add_argument("--index", default=None, help="run index XX when RUN_DIR holds several")
    parser.add_argument("--out", type=output_file, required=True, help="decisions CSV to write")
    parser.add_argument("--hop-s", type=positive_number, default=0.5,
                        help="time between decisions, s")
    add_smoothing(parser)
    parser.add_argument("--min-confidence", type=probability,
                        default=DesiredSlipConfig().min_confidence,
                        help="smoothed probability below which the fallback target is used "
                             "(default: the desired-slip table's, %(default)s)")


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
        When a smoothing option is out of range
        (:func:`pipelines.arguments.smoothing_from_args`, checked before the model is
        loaded), the model cannot be loaded, ``args.run_dir`` is not a folder, holds no run
        files, holds several runs and ``--index`` is not given, lacks the run ``--index``
        (:func:`~terrain.io.measured.read_folder_run`), or lacks a stream the model needs.
    DataFormatError
        When the run gives no decision (:meth:`~terrain.serving.replay.RunReplay.check`):
        its streams overlap for less than one window, or the service's per-sample rules
        refused the samples it needed.
    """
    smoothing = smoothing_from_args(args)   # the options' own checks, before any reading
    model = load_stream_model(args.model)
    run = read_folder_run(args.run_dir, args.index)
    config = StreamConfig(hop_s=args.hop_s, min_confidence=args.min_confidence,
                          smoothing=smoothing)
    targets = TableTargets(model.classes, DesiredSlipConfig(min_confidence=args.min_confidence))
    replay = replay_recorded(StreamService(model, targets, config), run)
    print(replay.input_report().text())
    for note in (other_vehicle_note(model.metadata, run.vehicle, run.run_id),
                 imu_rate_note(model.channels, model.window.rate_hz, run)):
        if note:
            print(note)
    replay.check(args.run_dir)
    with whole_file(args.out) as tmp:  # a failure half-way leaves no half file
        replay.frame.to_csv(tmp, index=False)
    print(replay.summary(args.out))
    return 0
