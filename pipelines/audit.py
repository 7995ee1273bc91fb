"""Audit the simulator against measured runs: what it gets wrong, why, and the held-out gain.

Replays each run's own wheel speeds through the simulator's Husky model, compares the
predicted yaw rate, accelerations and motor currents with the measured ones, fits the named
effects (icr_expansion, gyro_bias, wheel_lag, turning_resistance, current_offset,
grade_resistance, immobilised) on training runs and scores them on held-out runs
(leave one run out per terrain, bootstrap support). Input: RUNS_DIR in the measured-run
layout (<TERRAIN>/imu_XX.csv, pro_XX.csv) or --dataset for the shipped copy. Writes the JSON
report (--json), optionally Markdown with figures (--md, figures in <stem>_figures/), and
logs both to MLflow (experiment terrain-audit) unless --no-mlflow.
"""

from __future__ import annotations

import argparse
import json
import shlex
import time
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

from pipelines.arguments import (input_folder, integer_in, output_dir, output_file,
                                 parse_number, positive_number, seed_value)
from terrain.audit import AuditSettings, SelectionSettings, run_audit, to_dict, to_markdown
from terrain.audit.physics import (PhysicsComparisonSettings, comparison_markdown,
                                   gain_table, per_run_errors)
from terrain.audit.replay import (JITTER_ACCEL_M_S2, MAX_CUTOFF_FRACTION, ReplaySettings,
                                  cruise_wheel_acceleration_rms, lowpass_cutoff_hz)
from terrain.audit.core import prepare_frames
from terrain.audit.selection import (MAX_BOOTSTRAP, MAX_PARAM_BOOTSTRAP, MIN_BOOTSTRAP,
                                     MIN_PARAM_BOOTSTRAP)
from terrain.audit.report import figures_folder, flat_metrics, summary_lines, write_markdown
from terrain.io.jsonfile import json_ready, replace_text
from terrain.sim.forces import DEFAULT_PHYSICS, PHYSICS_VERSIONS
from terrain.errors import ConfigError
from terrain.io.measured import read_runs_dir
from terrain.io.report import input_report
from terrain.io.shipped import DATASET_SPECS, load_dataset
from terrain.tracking import tracked_run

EXPERIMENT = "terrain-audit"
#: multipliers of the catalogue lateral friction in the what-if sweep
SWEEP_FACTORS = (0.5, 0.75, 1.0, 1.5, 2.0)
#: option -> default, the selection settings' own defaults
DEFAULTS: Mapping[str, float] = MappingProxyType({
    "bootstrap": SelectionSettings.n_bootstrap,
    "param_bootstrap": SelectionSettings.n_param_bootstrap,
    "min_gain": SelectionSettings.min_gain, "seed": SelectionSettings.seed})


def _min_gain(value: str) -> float:
    """argparse ``type`` of ``--min-gain``: a fraction in [0, 1) (NaN refused), as
    :class:`terrain.audit.selection.SelectionSettings` takes it, named as the option."""
    return parse_number(value, lambda x: 0 <= x < 1, "a fraction of the baseline RMSE in [0, 1)")


def _param_bootstrap(value: str) -> int:
    """argparse ``type`` of ``--param-bootstrap``: 0 or an integer in
    ``MIN_PARAM_BOOTSTRAP..MAX_PARAM_BOOTSTRAP``, as
    :class:`terrain.audit.selection.SelectionSettings` takes it, named as the option (1-4
    resamples never give an interval)."""
    number = integer_in(0, MAX_PARAM_BOOTSTRAP)(value)
    if 0 < number < MIN_PARAM_BOOTSTRAP:
        raise argparse.ArgumentTypeError(
            f"must be 0 (no parameter intervals) or at least {MIN_PARAM_BOOTSTRAP} (an "
            f"interval needs {MIN_PARAM_BOOTSTRAP} refits), got {value}")
    return number


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``terrain audit`` to ``parser``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser.
    """
    parser.add_argument("runs_dir", nargs="?", type=input_folder, default=None,
                        metavar="RUNS_DIR",
                        help="folder in the measured-run layout <TERRAIN>/{imu_XX,pro_XX}.csv")
    parser.add_argument("--dataset", choices=list(DATASET_SPECS), default=None,
                        help="audit a shipped dataset instead of RUNS_DIR")
    parser.add_argument("--json", type=output_file, required=True,
                        help="write the JSON report here")
    parser.add_argument("--md", type=output_file, default=None,
                        help="write the Markdown report here")
    parser.add_argument("--bootstrap", type=integer_in(MIN_BOOTSTRAP, MAX_BOOTSTRAP),
                        default=DEFAULTS["bootstrap"],
                        help="resamples of held-out runs for the gain interval "
                             f"({MIN_BOOTSTRAP}-{MAX_BOOTSTRAP:,})")
    parser.add_argument("--param-bootstrap", type=_param_bootstrap,
                        default=DEFAULTS["param_bootstrap"],
                        help="resamples of runs for the parameter intervals (0: none, or "
                             f"{MIN_PARAM_BOOTSTRAP}-{MAX_PARAM_BOOTSTRAP:,})")
    parser.add_argument("--min-gain", type=_min_gain, default=DEFAULTS["min_gain"],
                        help="smallest held-out gain (fraction of baseline RMSE, in [0, 1)) "
                             "to support")
    parser.add_argument("--seed", type=seed_value, default=DEFAULTS["seed"], help="bootstrap seed")
    parser.add_argument("--no-pooled", action="store_true",
                        help="skip the pooled fit over all terrains (terrain 'all')")
    parser.add_argument("--sweep-lateral-friction", action="store_true",
                        help="also replay each terrain with its catalogue lateral friction "
                             f"scaled by {', '.join(f'{k:g}' for k in SWEEP_FACTORS)} "
                             "(what-if table)")
    parser.add_argument("--physics", choices=list(PHYSICS_VERSIONS), default=DEFAULT_PHYSICS,
                        help="simulator physics replayed (v1: static loads, Coulomb lateral "
                             "friction; v2: load transfer, lateral wheel-soil model)")
    parser.add_argument("--compare-physics", action="store_true",
                        help="also replay every run with v1 and v2 and report the gain of v2 "
                             "per terrain, signal and manoeuvre with run-bootstrap intervals")
    parser.add_argument("--replay-input-lowpass-hz", type=positive_number, default=None,
                        metavar="HZ",
                        help="low-pass the measured wheel speeds at HZ before they drive the "
                             "replay (default: as recorded; for noisy speed records such as "
                             "Vulpi's, see docs/physics_v2.md)")
    parser.add_argument("--no-mlflow", action="store_true", help="do not log to MLflow")
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")


def _portable(path: Path) -> str:
    """``path`` relative to the working directory when it lies below it (a report's
    reproduce line then works from the repository root on any machine), else as given."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _exact(value: float) -> str:
    """``value`` as short as ``:g`` writes it where that reads back the same float, else in
    full (``:g`` keeps 6 significant digits: 2.123456789 read back as 2.12346)."""
    short = f"{value:g}"
    return short if float(short) == value else repr(value)


def _command(args: argparse.Namespace) -> str:
    """The ``terrain audit`` command line that reproduces this run."""
    parts = ["terrain", "audit"]
    parts += [_portable(args.runs_dir)] if args.runs_dir else ["--dataset", args.dataset]
    parts += ["--json", _portable(args.json)] + (["--md", _portable(args.md)] if args.md
                                                 else [])
    for key, default in DEFAULTS.items():
        if getattr(args, key) != default:
            parts += [f"--{key.replace('_', '-')}", str(getattr(args, key))]
    if args.physics != DEFAULT_PHYSICS:
        parts += ["--physics", args.physics]
    parts += ["--compare-physics"] * args.compare_physics
    if args.replay_input_lowpass_hz is not None:
        parts += ["--replay-input-lowpass-hz", _exact(args.replay_input_lowpass_hz)]
    parts += ["--no-pooled"] * args.no_pooled
    parts += ["--sweep-lateral-friction"] * args.sweep_lateral_friction
    return shlex.join(parts)


def main(args: argparse.Namespace) -> int:
    """Run the audit, write the reports, log to MLflow.

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
        Neither or both of ``RUNS_DIR`` and ``--dataset`` given, the figures' folder beside
        ``--md`` cannot be created (:func:`pipelines.arguments.output_dir`) or is the
        ``--json`` file, or a setting out
        of range (:class:`terrain.audit.selection.SelectionSettings`); all before any run is
        read.
    DataFormatError
        No run could be audited (from the readers or :func:`terrain.audit.run_audit`).
    """
    if (args.runs_dir is None) == (args.dataset is None):
        raise ConfigError("give exactly one of RUNS_DIR or --dataset")
    if args.md is not None:     # its figures' folder, before the audit rather than after it
        try:
            output_dir(str(figures_folder(args.md)))
        except argparse.ArgumentTypeError as exc:
            raise ConfigError(f"--md: {exc}") from None
        folder = figures_folder(args.md)
        if folder.resolve() == args.json.resolve():   # the JSON file would block the folder
            raise ConfigError(f"--json {args.json} is the folder of the --md report's figures "
                              f"({folder}): give the JSON file another name")
    settings = AuditSettings(  # before reading: a bad setting fails fast
        replay=ReplaySettings(physics=args.physics,
                              input_cutoff_hz=args.replay_input_lowpass_hz),
        selection=SelectionSettings(n_bootstrap=args.bootstrap,
                                    n_param_bootstrap=args.param_bootstrap,
                                    min_gain=args.min_gain, seed=args.seed),
        pooled=not args.no_pooled,
        sweep_factors=SWEEP_FACTORS if args.sweep_lateral_friction else ())
    progress = not getattr(args, "no_progress", False)
    runs = (read_runs_dir(args.runs_dir, progress=progress) if args.runs_dir
            else load_dataset(args.dataset))
    source = {"runs_dir": str(args.runs_dir)} if args.runs_dir else {"dataset": args.dataset}
    name = args.dataset or args.runs_dir.resolve().name
    if args.no_mlflow:
        _audit(args, runs, settings, source, name, None)
    else:
        # --compare-physics is no audit setting: its v1/v2 replays are said here
        with tracked_run(EXPERIMENT, run_name=name,
                         params={**source, **settings.as_params(),
                                 "compare_physics": args.compare_physics}) as tracked:
            _audit(args, runs, settings, source, name, tracked)
    return 0


def report_json(report: Mapping) -> str:
    """The JSON text of a report; strict JSON, so a non-finite number fails here.

    Parameters
    ----------
    report : mapping
        The report (:func:`terrain.audit.to_dict` and the pipeline's additions, every one
        made JSON-ready: non-finite floats as ``None``).

    Returns
    -------
    str
        Indented JSON ending with a newline.

    Raises
    ------
    ValueError
        A NaN or infinite float left in ``report`` (``NaN`` is not JSON: ``JSON.parse``
        and other strict readers reject the whole file).
    """
    return json.dumps(report, indent=1, allow_nan=False) + "\n"


def _run_with_progress(runs, settings, progress: bool):
    """``run_audit`` with a progress bar over the replay of the runs (the slow step); the
    replay's wall time is measured here (``run_audit`` given the frames would report ~0 s)."""
    if not progress:
        return run_audit(runs, settings)
    from dataclasses import replace

    from tqdm.auto import tqdm

    t0 = time.perf_counter()
    frames, skipped = [], {}
    for run in tqdm(runs, desc="replaying runs", unit="run"):
        f, s = prepare_frames([run], settings)
        frames += f
        skipped.update(s)
    replay_s = time.perf_counter() - t0
    if not frames:  # run_audit raises the error naming every skipped run
        return run_audit(runs, settings)
    result = run_audit(runs, settings, frames=frames, skipped=skipped)
    return replace(result, timings_s={**result.timings_s, "replay_s": replay_s})


def _audit(args, runs, settings, source, name, tracked) -> None:
    """Audit ``runs``, write the reports, log them to ``tracked`` (None: no MLflow)."""
    from terrain.audit import make_figures

    result = _run_with_progress(runs, settings, not getattr(args, "no_progress", False))
    # the runs the audit skipped are skipped in the input report too (it said every run
    # used above "audited N runs, skipped M"), and only the replayed runs are described below
    inputs = input_report(runs, {"skipped_runs": list(result.skipped),
                                 "reasons": dict(result.skipped)})
    print(inputs.text())
    audited = {f.run_id for f in result.frames}
    replayed = [r for r in runs if r.run_id in audited]
    report = to_dict(result, source)
    report["physics"] = settings.replay.physics
    jitter = {r.run_id: round(a, 3) for r in replayed
              if (a := cruise_wheel_acceleration_rms(r)) > JITTER_ACCEL_M_S2}
    report["jittery_wheel_records"] = {
        "threshold_m_s2": JITTER_ACCEL_M_S2, "input_cutoff_hz": settings.replay.input_cutoff_hz,
        "runs": jitter}
    if jitter and settings.replay.input_cutoff_hz is None:
        values = sorted(jitter.values())
        print(f"  note: {len(jitter)} run(s) have a jittery wheel-speed record (rms wheel "
              f"acceleration while cruising {values[0]:.2f}-{values[-1]:.2f} m/s^2, above "
              f"{JITTER_ACCEL_M_S2:g}); the replay drives the motors with it, so their "
              "simulated currents include the rectified jitter. --replay-input-lowpass-hz 2 "
              "smooths it (docs/physics_v2.md)")
    cutoff = settings.replay.input_cutoff_hz
    if cutoff is not None:
        rates = [r.rate_hz("wheels") for r in replayed
                 if "wheels" in r.streams and len(r.streams["wheels"]) > 1]
        clipped = [(rate, used) for rate in rates
                   if (used := lowpass_cutoff_hz(rate, cutoff)) < cutoff]
        if clipped:
            def span(values) -> str:
                low, high = f"{min(values):.3g}", f"{max(values):.3g}"
                return f"{low} Hz" if low == high else f"{low}-{high} Hz"

            used_rates, used_cutoffs = zip(*clipped)
            print(f"  note: --replay-input-lowpass-hz {cutoff:g} is above "
                  f"{MAX_CUTOFF_FRACTION:g} of the wheel rate of {len(clipped)} run(s) "
                  f"({span(used_rates)}): their low-pass is clipped to {MAX_CUTOFF_FRACTION:g} "
                  f"of each run's rate ({span(used_cutoffs)})")
    with_imu = {r.run_id for r in runs if r.has_imu}
    no_imu = sorted(f.run_id for f in result.frames if f.run_id not in with_imu)
    if no_imu:
        print(f"  note: {len(no_imu)} of {len(result.frames)} audited run(s) have no IMU "
              f"stream ({', '.join(no_imu[:5])}{' ...' if len(no_imu) > 5 else ''}): only "
              "their motor currents are compared; the yaw-rate and acceleration checks and "
              "the clock lag use the runs with an IMU")
    comparison = None
    if args.compare_physics:
        cmp_settings = PhysicsComparisonSettings(n_bootstrap=args.bootstrap, seed=args.seed)
        per_run, cmp_skipped = per_run_errors(runs, cmp_settings, settings.replay,
                                              settings.frames, settings.lag)
        comparison = gain_table(per_run, cmp_settings)
        report["physics_comparison"] = {
            "reference": cmp_settings.reference, "candidate": cmp_settings.candidate,
            "records": [json_ready(r) for r in comparison.to_dict(orient="records")],
            "skipped": cmp_skipped}
        if cmp_skipped:
            print(f"  note: {len(cmp_skipped)} run(s) left out of the physics comparison "
                  f"({cmp_settings.reference} vs {cmp_settings.candidate}): "
                  + "; ".join(f"{k} ({v})" for k, v in cmp_skipped.items()))
    if tracked is not None:
        report["mlflow_run_id"] = tracked.run_id
    figures = make_figures(result)
    title, commands = f"Simulation audit: {name}", [_command(args)]
    if args.dataset:
        commands.append(f"# the same runs in the CSV layout give identical results: "
                        f"terrain audit <folder>/{args.dataset} --json ...")
    # every text rendered before any file is written; the JSON report, which other steps
    # read as the audit's result, replaced last and in one step: a failure leaves the
    # earlier JSON (and Markdown, write_markdown) as it was, not a new one beside an old page
    text = report_json(report)
    if args.md:
        appendix = ("\n" + comparison_markdown(comparison, report["physics_comparison"])
                    if comparison is not None else "")
        write_markdown(args.md, report, figures, commands, title, appendix=appendix)
    replace_text(args.json, text)
    if tracked is not None:
        tracked.log_metrics({**flat_metrics(report), **inputs.metrics()})
        tracked.log_table(inputs.table, "input_report.csv")
        tracked.log_dict(report, "audit.json")
        rel = {k: f"figures/audit_{k}.png" for k in figures}
        tracked.log_text(to_markdown(report, rel, commands, title), "audit.md")
        for key, fig in figures.items():
            tracked.log_figure(fig, rel[key])
        for table, fname in ((result.residuals, "residuals.csv"), (result.lags, "lags.csv"),
                             (result.sweep, "lateral_friction_sweep.csv"),
                             (comparison if comparison is not None else result.sweep.iloc[:0],
                              "physics_comparison.csv")):
            if len(table):
                tracked.log_table(table, fname)
    print("\n".join(summary_lines(report, result.timings_s)))
    print(f"  report written to {args.json}" + (f" and {args.md}" if args.md else ""))
