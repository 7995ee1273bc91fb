"""Probe: how much of the replay's current error comes from noise in its wheel-speed input.

The audit replays a measured run by imposing its wheel-speed record on the simulated motors
(:func:`terrain.audit.replay.replay_run`). Where that record is noisy (Vulpi: 15 Hz,
step-to-step std about 0.2 m/s while cruising at 0.5 m/s), the replayed motors follow the
noise as real speed changes; every fluctuation costs inertia and braking torque, and the
reported current is a magnitude, so the noise does not average out even though the
predictions are low-passed afterwards. This probe low-passes the wheel-speed *input*
(``ReplaySettings(input_cutoff_hz=...)``, zero-phase 4th-order Butterworth) at each cut-off
and prints the motor-current RMSE (both sides, moving samples on the
audit's comparison clock, no fitted effect) per terrain and physics version
(``terrain audit --replay-input-lowpass-hz`` runs the whole audit that way; its default is
the record as measured).

Run::

    python benchmarks/replay_input_lowpass.py --dataset vulpi --cutoffs-hz 2 1
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from pipelines.arguments import DistinctValues, positive_number
from terrain.audit.frames import MANOEUVRES, prepare_frame
from terrain.audit.replay import ReplaySettings, replay_run
from terrain.io.shipped import load_dataset


def current_errors(dataset: str, cutoffs_hz: list[float]) -> pd.DataFrame:
    """Squared current errors per run, input cut-off and physics version.

    Parameters
    ----------
    dataset : str
        Shipped dataset (``borealtc`` or ``vulpi``).
    cutoffs_hz : list of float
        Cut-offs of the input low-pass, Hz; 0 means the record as measured.

    Returns
    -------
    pandas.DataFrame
        ``terrain, run, cutoff_hz, physics, sse, n`` (sum of squared current errors, A^2,
        over both sides of the moving samples, and their number).
    """
    rows = []
    for run in load_dataset(dataset):
        wheels = run.streams.get("wheels")
        if wheels is None or len(wheels) < 20:
            continue
        for fc in cutoffs_hz:
            for physics in ("v1", "v2"):
                settings = ReplaySettings(physics=physics, input_cutoff_hz=fc or None)
                f = prepare_frame(run, replay_run(run, settings))
                m = f.score_imu & (f.manoeuvre != MANOEUVRES.index("stop"))
                e = (f.cur[m] - f.sim_cur[m]) ** 2
                rows.append((run.terrain, run.run_id, fc, physics, float(e.sum()), e.size))
    return pd.DataFrame(rows, columns=["terrain", "run", "cutoff_hz", "physics", "sse", "n"])


def main() -> int:
    """Print the current RMSE per terrain, cut-off and physics version; returns 0."""
    ap = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default="vulpi", choices=["borealtc", "vulpi"])
    ap.add_argument("--cutoffs-hz", type=positive_number, nargs="+", action=DistinctValues,
                    default=[2.0, 1.0],
                    help="input low-pass cut-offs, Hz (the record as measured is always "
                         "included)")
    args = ap.parse_args()
    df = current_errors(args.dataset, [0.0] + [c for c in args.cutoffs_hz if c > 0])
    for keys, label in ((["terrain", "cutoff_hz", "physics"], "per terrain"),
                        (["cutoff_hz", "physics"], "all runs")):
        g = df.groupby(keys)[["sse", "n"]].sum()
        rmse = np.sqrt(g.sse / g.n).unstack("physics").round(2)
        print(f"motor-current RMSE (A), {label}; cutoff_hz 0 = wheel speeds as recorded")
        print(rmse.to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
