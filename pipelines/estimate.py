"""Estimate vehicle states and per-wheel slip of recorded runs (EKF for the run's vehicle).

RUN_DIR is a folder in the run layout (RUN_DIR/<TERRAIN>/{imu,pro,omega,steer,cam}_XX.csv and
meta_XX.json, as measured data and `terrain simulate` write it) or one <TERRAIN> folder of it.
The vehicle comes from meta_XX.json ("vehicle", default husky): agrimaro -> 12-state EKF of
thesis ch. 6.1; husky/tracked -> skid-steer EKF (speed, yaw rate, gyro bias, ICR factor).
With one run the table goes to --out. With several, --run TERRAIN/XX selects one; without
--run one file per run is written next to --out as <stem>_<TERRAIN>_<XX><suffix>.
Columns: t_s, states, std_<state>, slip_1.. with std_slip_1.. (simulator wheel numbering;
AgriMaRo: std_slip_i NaN in the 0.05 m/s dead band, where slip_i is 0 by convention, and a
note counts those samples), innov_<row>, nis, nis_dof. Skid-steer: the common longitudinal
slip is not observable from wheels + IMU; --slip-model picks its source (fused default:
physics + learned model as the EKF's pseudo-measurement; learned falls back to physics without
a model; ekf: none) and a note says so. Without --slip-model-dir the registered model is
looked up and its absence is a note (physics supplies the slip); a --slip-model-dir that
cannot be loaded (missing folder, no MLmodel file, unreadable model) is an error. --gate is a
probability in (0, 1) exclusive; --rate-hz a rate in [1, 10000] Hz, and the grid holds at most
5 million steps. --lag xcorr applies the cross-correlation lag only for a clear peak
(terrain.slip.alignment.gated_lag): a run without one gets no lag and a note, and a last note
counts the runs of each kind. The skid-steer slip filter keeps its forward speed within what
the recent rim speeds allow (braking slip down to -0.3;
terrain.estimation.skid_steer_slip.speed_bounds_m_s); a note counts the steps where it was
held there. With several runs, a run the estimator refuses (a stream it needs missing or
unreadable) is named and skipped, and a last note counts the runs left without a table.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from features.slip_outputs import missing_slip_inputs, slip_model_outputs
from pipelines.arguments import check_derived_output, input_folder, input_path, output_file
from pipelines.slip_model import REGISTERED_SLIP_MODEL, resolve_slip_model
from terrain.errors import ConfigError, DataFormatError, EstimationError
from terrain.estimation.ekf import Gate
from terrain.estimation.runner import MAX_RATE_HZ, MIN_RATE_HZ, check_rate_hz
from terrain.io.jsonfile import whole_file
from terrain.io.measured import read_runs_path
from terrain.io.report import input_report
from terrain.run import TIME
from terrain.slip import LAG_MODES, TUNINGS, estimate_run
from terrain.slip.estimate import (LEARNED_FALLBACK_NOTE, SLIP_MODELS,
                                   estimate_skid_steer_slip_run)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain estimate``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Subparser to fill.
    """
    parser.add_argument("run_dir", type=input_folder, metavar="RUN_DIR",
                        help="folder in the run layout (or a terrain folder of it)")
    parser.add_argument("--out", type=output_file, required=True, help="output CSV file")
    parser.add_argument("--run", default=None, metavar="TERRAIN/XX",
                        help="select one run when RUN_DIR holds several")
    parser.add_argument("--lag", choices=LAG_MODES, default="xcorr",
                        help="encoder lag handling (default: xcorr, estimated from data and "
                             "applied only for a clear cross-correlation peak)")
    parser.add_argument("--tuning", choices=TUNINGS, default=None,
                        help="AgriMaRo EKF tuning: noise-derived (default) or thesis eqs. "
                             "6.9/6.13/6.14")
    parser.add_argument("--gate", type=float, default=None, metavar="P",
                        help="chi-square gate probability per sensor, in (0, 1) exclusive "
                             "(e.g. 0.999); off by default")
    parser.add_argument("--rate-hz", type=float, default=None,
                        help=f"filter rate, Hz, in [{MIN_RATE_HZ:g}, {MAX_RATE_HZ:g}] (default: "
                             "the IMU rate)")
    parser.add_argument("--slip-model", choices=SLIP_MODELS, default=None,
                        help="skid-steer slip source (default fused)")
    # as text: a model URI read as a path lost a slash of its '//' (s3:/bucket/...)
    parser.add_argument("--slip-model-dir", type=input_path, default=None,
                        help="learned slip model (MLflow model dir or model URI; an error "
                             "when it cannot be loaded; default: registered "
                             f"{REGISTERED_SLIP_MODEL}, "
                             "physics with a note when there is none)")


def _load(run_dir: Path, select: str | None):
    # one terrain folder reads that folder only (its siblings are not read or checked)
    runs = read_runs_path(run_dir)
    if select is not None:
        chosen = [r for r in runs if "/".join(r.run_id.split("/")[1:]) == select]
        if not chosen:
            names = ["/".join(r.run_id.split("/")[1:]) for r in runs]
            raise ConfigError(f"no run {select!r} in {run_dir}; runs: {', '.join(names)}")
        runs = chosen
    return runs


def _outputs(args: argparse.Namespace, runs) -> dict[str, Path]:
    """Run id -> its output file: ``--out`` for one run, else one file per run beside it,
    each checked as ``--out`` itself was (before any run is estimated)."""
    if len(runs) == 1:
        return {runs[0].run_id: args.out}
    outs = {}
    for run in runs:
        _, terrain, index = run.run_id.split("/")
        outs[run.run_id] = args.out.with_name(
            f"{args.out.stem}_{terrain}_{index}{args.out.suffix}")
        check_derived_output("--out", outs[run.run_id], [args.run_dir, args.slip_model_dir])
    return outs


def _estimate(run, args: argparse.Namespace, slip_model: str, tuning: str, learned, gate,
              rate_hz):
    """One run's estimate: the AgriMaRo EKF or the skid-steer slip filter."""
    if run.vehicle == "agrimaro":
        return estimate_run(run, lag=args.lag, tuning=tuning, gate=gate, rate_hz=rate_hz)
    outputs = slip_model_outputs(run, learned) if slip_model != "ekf" else None
    missing = (missing_slip_inputs(run) if outputs is None and slip_model != "ekf"
               else None)
    return estimate_skid_steer_slip_run(run, slip_model, outputs=outputs, missing=missing,
                                        lag=args.lag, gate=gate, rate_hz=rate_hz)


def main(args: argparse.Namespace) -> int:
    """Run the estimator on each selected run, write its table and print a summary line.

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
    ConfigError, EstimationError, DataFormatError
        ``--gate`` outside (0, 1), ``--rate-hz`` outside [1 Hz, 10 kHz] (both checked before
        any run is read); a ``--slip-model-dir`` that cannot be loaded
        (:func:`pipelines.slip_model.resolve_slip_model`); ``--run`` names no run of
        RUN_DIR; a run's own file beside ``--out`` (several runs) cannot be written or would
        overwrite an input (:func:`pipelines.arguments.check_derived_output`); the one
        selected run lacks the streams its estimator needs, or, with several runs, every run
        does (a run the estimator refuses among others is named, left without a table and
        counted in a last note; the others are estimated).
    """
    try:
        gate = Gate(args.gate) if args.gate is not None else None
    except ConfigError:     # Gate's message names no option
        raise ConfigError(f"--gate must be a probability in (0, 1) exclusive "
                          f"(e.g. 0.999), got {args.gate:g}") from None
    rate_hz = check_rate_hz(args.rate_hz, "--rate-hz")
    runs = _load(args.run_dir, args.run)
    outs = _outputs(args, runs)
    print(input_report(runs).text())
    # an option for the other vehicle kind than every run's is said, not silently ignored
    skid = any(r.vehicle != "agrimaro" for r in runs)
    agrimaro = any(r.vehicle == "agrimaro" for r in runs)
    if args.slip_model is not None and not skid:
        print(f"note: --slip-model {args.slip_model} not used: no skid-steer run (the AgriMaRo "
              "EKF observes its slip with the camera)")
    if args.lag == "ema" and not agrimaro:
        print("note: --lag ema filters the AgriMaRo camera (thesis ch. 7.2.2) and no run is an "
              "AgriMaRo's: the encoder lag is neither estimated nor compensated (as --lag none)")
    if args.tuning is not None and not agrimaro:
        print(f"note: --tuning {args.tuning} not used: it tunes the AgriMaRo EKF and no run is "
              "an AgriMaRo's")
    slip_model = args.slip_model or "fused"
    tuning = args.tuning or "noise"
    learned = None
    wants_model = slip_model in ("learned", "fused") and skid
    if wants_model:
        learned, where = resolve_slip_model(args.slip_model_dir)
        if learned is None:
            print(f"note: no learned slip model ({where}); physics supplies the slip")
    elif args.slip_model_dir is not None:
        why = (f"--slip-model {slip_model} uses no learned model"
               if slip_model not in ("learned", "fused")
               else "no skid-steer run (the AgriMaRo EKF observes its slip)")
        print(f"note: --slip-model-dir {args.slip_model_dir} not used: {why}")
    lags = {"applied": 0, "not applied": 0, "not estimated": 0}
    refused: dict[str, str] = {}
    for run in runs:
        try:
            est = _estimate(run, args, slip_model, tuning, learned, gate, rate_hz)
        except (EstimationError, DataFormatError) as exc:
            if len(runs) == 1:
                raise
            # one run the estimator refuses does not cost the others their tables
            refused[run.run_id] = str(exc)
            print(f"error: run {run.run_id} not estimated: {exc}")
            continue
        for note in est.notes:
            if note == LEARNED_FALLBACK_NOTE and wants_model and learned is None:
                continue        # said once above, with where the model was looked for
            print(note)
        lags["not estimated" if est.lag is None or not est.lag.estimated
             else "applied" if est.lag.applied else "not applied"] += 1
        out = outs[run.run_id]
        out.parent.mkdir(parents=True, exist_ok=True)
        frame = est.to_frame()
        # the states to 9 digits; the time exactly (an epoch clock needs 10 before the point)
        frame[TIME] = [repr(float(t)) for t in frame[TIME]]
        with whole_file(out) as tmp:    # a failure half-way leaves no half table
            frame.to_csv(tmp, index=False, float_format="%.9g")
        print(f"{est.summary()} -> {out}")
    estimated = len(runs) - len(refused)
    if lags["not applied"] or (args.lag == "xcorr" and lags["not estimated"] and estimated > 1):
        # a cross-correlation lag is applied only for a clear peak (terrain.slip.alignment)
        print(f"note: encoder lag applied on {lags['applied']} of {estimated} runs, not "
              f"applied on {lags['not applied']} (no clear cross-correlation peak), not "
              f"estimated on {lags['not estimated']}")
    if refused:
        listing = "; ".join(f"{run_id} ({why})" for run_id, why in refused.items())
        if not estimated:
            raise EstimationError(f"no run of {args.run_dir} could be estimated: {listing}")
        print(f"note: {len(refused)} of {len(runs)} runs not estimated, no table written for "
              f"them: {listing}")
    return 0
