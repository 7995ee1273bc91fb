"""Gain of one simulator physics version over another on measured runs (v1 vs v2).

Both versions replay every run with no fitted effect (:func:`~terrain.audit.replay.replay_run`
with :attr:`ReplaySettings.physics`), on the same comparison clock
(:func:`~terrain.audit.frames.prepare_frame`, whose lag track is estimated against the
commanded yaw rate or the replayed one, so it is taken from the *reference* version's frame
for both, so that both are scored on the same samples and timing). No fitted effect is
applied. The v2 soil parameters (:mod:`terrain.terramechanics.lateral`) come from published
tables, with the shear moduli, the shear curves' residual ratios and the choice of the snow
row made on the *training* half of the runs of each soil, and the Husky tyre's side-force
factor and the ICE friction on the training half of the ASPHALT, FLOORING and ICE runs
(:data:`TUNED_TERRAINS`, ``benchmarks/sweep_soil_params.py``): the tables over all runs
include those training runs; ``sweep_soil_params.py --heldout-table`` scores the held-out
runs alone.

For each terrain (and ``all`` pooled), each signal (``wz, ax, ay, cur_l, cur_r``, and
``cur`` = both currents) and each manoeuvre (``straight, curve, spin``, ``moving`` = all three,
``stop``), the RMSE of each version, the gain ``1 - RMSE_new / RMSE_ref`` and its 95 %
run-bootstrap interval (runs resampled with replacement within the terrain, and for ``all``
within each terrain, so that every resample keeps the terrain mix of the data:
:func:`~terrain.audit.selection.stratified_resamples`; per-run sums of squared errors, so long
runs weigh by their samples).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np
import pandas as pd

from terrain.audit.frames import (MANOEUVRES, AuditFrame, FrameSettings, check_same_bandwidth,
                                  prepare_frame)
from terrain.audit.replay import ReplaySettings, replay_run
from terrain.audit.selection import (MAX_BOOTSTRAP, MIN_BOOTSTRAP, has_spread, keyed_rng,
                                     stratified_resamples)
from terrain.audit.timing import LagSettings
from terrain.errors import ConfigError, DataFormatError, config_integer
from terrain.run import Run
from terrain.sim.forces import PHYSICS_VERSIONS
from terrain.terramechanics.lateral import SOILS

#: Terrains whose runs were split by :func:`alternate_split` to choose a physics-v2
#: parameter: the soils (:data:`terrain.terramechanics.lateral.SOILS`; BorealTC SANDY_LOAM
#: and SNOW, Vulpi PLOUGHED) and the rigid surfaces the Husky tyre's side-force factor and
#: the ICE friction were chosen on (:data:`terrain.sim.forces.COMBINED_SLIP`).
TUNED_TERRAINS = frozenset(SOILS) | frozenset({"ASPHALT", "FLOORING", "ICE"})
#: signals compared; ``cur`` pools left and right
COMPARED_SIGNALS = ("wz", "ax", "ay", "cur_l", "cur_r", "cur")
#: manoeuvre scopes; ``moving`` pools straight, curve and spin
SCOPES = ("moving", "straight", "curve", "spin", "stop")


@dataclass(frozen=True)
class PhysicsComparisonSettings:
    """What is compared and how the intervals are drawn.

    Parameters
    ----------
    reference : str
        Physics version the gain is measured against (``v1``).
    candidate : str
        Physics version whose gain is measured (``v2``).
    n_bootstrap : int
        Run-bootstrap resamples for the gain intervals (10 to
        :data:`terrain.audit.selection.MAX_BOOTSTRAP`).
    seed : int
        Bootstrap seed (>= 0).

    Raises
    ------
    ConfigError
        ``n_bootstrap`` or ``seed`` not an integer in its range, or a version not in
        :data:`terrain.sim.forces.PHYSICS_VERSIONS`.
    """

    reference: str = "v1"
    candidate: str = "v2"
    n_bootstrap: int = 1000
    seed: int = 0

    def __post_init__(self) -> None:
        unknown = [v for v in (self.reference, self.candidate) if v not in PHYSICS_VERSIONS]
        if unknown:   # every run would be skipped and the table come back empty
            raise ConfigError(f"physics versions must be among {list(PHYSICS_VERSIONS)}, got "
                              f"{unknown}")
        # (seed NaN or n_bootstrap 10.5 passed a range check, then numpy's TypeError)
        config_integer("PhysicsComparisonSettings.n_bootstrap", self.n_bootstrap,
                       MIN_BOOTSTRAP, MAX_BOOTSTRAP)
        config_integer("PhysicsComparisonSettings.seed", self.seed, 0)


def _errors(frame: AuditFrame, other: AuditFrame) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Squared errors of ``other``'s predictions against ``frame``'s measurements, with
    the manoeuvre code of each, per signal (scored samples only)."""
    out = {}
    man = frame.manoeuvre
    if frame.has_imu:
        m = frame.score_imu & np.isfinite(frame.wz)
        out["wz"] = ((frame.wz - other.sim_wz)[m] ** 2, man[m])
        out["ax"] = ((frame.ax - other.sim_ax)[m] ** 2, man[m])
        out["ay"] = ((frame.ay - other.sim_ay)[m] ** 2, man[m])
    m = frame.score_cur
    e_l = (frame.cur[:, 0] - other.sim_cur[:, 0])[m] ** 2
    e_r = (frame.cur[:, 1] - other.sim_cur[:, 1])[m] ** 2
    out["cur_l"] = (e_l, man[m])
    out["cur_r"] = (e_r, man[m])
    out["cur"] = (np.r_[e_l, e_r], np.r_[man[m], man[m]])
    return out


def _sums(errors: dict, scope: str) -> dict[str, tuple[float, int]]:
    """Per-signal sum of squared errors and count within a manoeuvre scope."""
    res = {}
    for sig, (e, man) in errors.items():
        if scope == "moving":
            keep = man != MANOEUVRES.index("stop")
        else:
            keep = man == MANOEUVRES.index(scope)
        res[sig] = (float(np.sum(e[keep])), int(np.count_nonzero(keep)))
    return res


def paired_frames(runs: Sequence[Run], settings: PhysicsComparisonSettings,
                  replay: ReplaySettings = ReplaySettings(),
                  frames: FrameSettings = FrameSettings(), lag: LagSettings = LagSettings()
                  ) -> tuple[list[tuple[AuditFrame, AuditFrame]], dict[str, str]]:
    """Each run on the comparison clock, with the predictions of both versions.

    Parameters
    ----------
    runs : sequence of Run
        Measured skid-steer runs with catalogue terrain labels.
    settings : PhysicsComparisonSettings
        Versions compared.
    replay : ReplaySettings
        Replay settings (its ``physics`` is replaced by each version).
    frames : FrameSettings
        Comparison clock and manoeuvres.
    lag : LagSettings
        Lag-track estimation (done once, on the reference version's replay).

    Returns
    -------
    pairs : list of (AuditFrame, AuditFrame)
        Per run, the reference version's frame and the same frame with the candidate's
        predictions (``sim_*``) on the same samples, timing and lag track.
    skipped : dict
        Run id -> reason (a run the replay or the frame cannot take).

    Raises
    ------
    ConfigError
        ``replay`` and ``frames`` low-pass at different cut-offs
        (:func:`~terrain.audit.frames.check_same_bandwidth`).
    """
    check_same_bandwidth(replay, frames, "paired_frames")
    pairs, skipped = [], {}
    for run in runs:
        try:
            ref = prepare_frame(run, replay_run(run, replace(replay, physics=settings.reference)),
                                frames, lag)
            new_rep = replay_run(run, replace(replay, physics=settings.candidate))
        except (ConfigError, DataFormatError) as exc:
            skipped[run.run_id] = str(exc)
            continue
        pairs.append((ref, replace(
            ref, sim_wz=_on(ref, new_rep.yaw_rate), sim_ax=_on(ref, new_rep.ax),
            sim_ay=_on(ref, new_rep.ay), sim_vx=_on(ref, new_rep.v_x),
            sim_cur=np.column_stack([_on(ref, new_rep.cur[:, 0]),
                                     _on(ref, new_rep.cur[:, 1])]))))
    return pairs, skipped


def per_run_errors(runs: Sequence[Run], settings: PhysicsComparisonSettings,
                   replay: ReplaySettings = ReplaySettings(),
                   frames: FrameSettings = FrameSettings(), lag: LagSettings = LagSettings()
                   ) -> tuple[pd.DataFrame, dict[str, str]]:
    """Per run, signal and manoeuvre scope: sums of squared errors of both versions.

    Parameters
    ----------
    runs : sequence of Run
        Measured skid-steer runs with catalogue terrain labels.
    settings : PhysicsComparisonSettings
        Versions compared.
    replay : ReplaySettings
        Replay settings (its ``physics`` is replaced by each version).
    frames : FrameSettings
        Comparison clock and manoeuvres.
    lag : LagSettings
        Lag-track estimation (done once, on the reference version's replay).

    Returns
    -------
    table : pandas.DataFrame
        Columns ``run_id, terrain, signal, scope, n, sse_ref, sse_new``.
    skipped : dict
        Run id -> reason.
    """
    rows = []
    pairs, skipped = paired_frames(runs, settings, replay, frames, lag)
    for ref, new in pairs:
        e_ref, e_new = _errors(ref, ref), _errors(ref, new)
        for scope in SCOPES:
            s_ref, s_new = _sums(e_ref, scope), _sums(e_new, scope)
            for sig in s_ref:
                rows.append((ref.run_id, ref.terrain, sig, scope, s_ref[sig][1],
                             s_ref[sig][0], s_new[sig][0]))
    cols = ["run_id", "terrain", "signal", "scope", "n", "sse_ref", "sse_new"]
    return pd.DataFrame(rows, columns=cols), skipped


def alternate_split(runs: Sequence[Run]) -> tuple[list[Run], list[Run]]:
    """Training and held-out runs of one terrain, alternating in run-id order.

    The split on which the physics-v2 parameters were chosen (training half) and scored
    (held-out half): ``benchmarks/sweep_soil_params.py``, ``docs/physics_v2.md``.

    Parameters
    ----------
    runs : sequence of Run
        Runs of one terrain.

    Returns
    -------
    train, held : list of Run
        Positions 0, 2, 4, ... and 1, 3, 5, ... of the runs sorted by run id.
    """
    runs = sorted(runs, key=lambda r: r.run_id)
    return runs[0::2], runs[1::2]


def _on(frame: AuditFrame, values: np.ndarray) -> np.ndarray:
    """Replay values (on the wheel clock of the whole run) at the frame's timestamps."""
    return np.asarray(values, dtype=float)[-frame.n:] if len(values) >= frame.n else values


def gain_table(per_run: pd.DataFrame, settings: PhysicsComparisonSettings,
               pooled: str = "all") -> pd.DataFrame:
    """RMSE of both versions and the gain with its run-bootstrap interval.

    Parameters
    ----------
    per_run : pandas.DataFrame
        Output of :func:`per_run_errors`.
    settings : PhysicsComparisonSettings
        Bootstrap size and seed.
    pooled : str
        Name of the all-terrain group.

    Returns
    -------
    pandas.DataFrame
        Columns ``terrain, signal, scope, n_runs, n, rmse_ref, rmse_new, gain, gain_lo,
        gain_hi`` (gain = ``1 - rmse_new / rmse_ref``, NaN where ``rmse_ref`` is 0; the
        interval NaN where one run holds every sample, or one run per terrain in the
        ``pooled`` rows: resampling says nothing there; the ``pooled`` rows resample runs
        within each terrain; runs are resampled in run-id order, each cell from a stream
        of its own (:func:`~terrain.audit.selection.keyed_rng` of the seed, terrain,
        signal and scope), so neither the order in which they are listed nor the other
        cells of the table move the interval). A signal and scope without any sample
        (e.g. ``stop`` on runs that never stop) gets no row; ``n_runs`` counts the runs with
        samples in it.

    Raises
    ------
    DataFormatError
        A run listed more than once for one signal and scope (it counted as several runs,
        its samples several times).
    """
    keys = ["run_id", "signal", "scope"]
    counts = per_run.groupby(keys, sort=False).size()
    if (counts > 1).any():
        (run, sig, scope), k = next((key, k) for key, k in counts.items() if k > 1)
        raise DataFormatError(f"gain_table: run {run} is listed {k} times for signal {sig}, "
                              f"scope {scope}: give one row per run, signal and scope")
    # the resamples draw row positions: in run-id order (stable, each run's rows kept in
    # theirs), the same runs listed in another order get the same interval
    per_run = per_run.sort_values("run_id", kind="stable")
    rows = []
    groups = [(t, per_run[per_run.terrain == t]) for t in sorted(per_run.terrain.unique())]
    groups.append((pooled, per_run))
    for terrain, tab in groups:
        for (sig, scope), sub in tab.groupby(["signal", "scope"], sort=False):
            sub = sub[sub.n > 0]
            if sub.empty:
                continue
            n = sub.n.to_numpy(float)
            a, b = sub.sse_ref.to_numpy(float), sub.sse_new.to_numpy(float)
            r_ref, r_new = np.sqrt(a.sum() / n.sum()), np.sqrt(b.sum() / n.sum())
            # the pooled rows resample runs within each terrain (one stratum elsewhere)
            # each cell its own stream (keyed_rng): its interval does not move with the
            # other cells of the table nor with the order they come in
            rng = keyed_rng(settings.seed, terrain, sig, scope)
            idx = stratified_resamples(sub.terrain.to_numpy(), rng, settings.n_bootstrap)
            ra = np.sqrt(a[idx].sum(1) / n[idx].sum(1))
            rb = np.sqrt(b[idx].sum(1) / n[idx].sum(1))
            g = 1.0 - rb / np.where(ra > 0, ra, np.nan)
            # one run (per terrain, for the pooled rows) has no run-to-run spread to
            # resample: no interval, not a zero-width one
            lo, hi = ((float(np.nanpercentile(g, 2.5)), float(np.nanpercentile(g, 97.5)))
                      if has_spread(sub.terrain.to_numpy()) else (np.nan, np.nan))
            rows.append((terrain, sig, scope, len(sub), int(n.sum()), r_ref, r_new,
                         1.0 - r_new / r_ref if r_ref > 0 else np.nan, lo, hi))
    return pd.DataFrame(rows, columns=["terrain", "signal", "scope", "n_runs", "n", "rmse_ref",
                                       "rmse_new", "gain", "gain_lo", "gain_hi"])


def comparison_markdown(table: pd.DataFrame, meta: dict) -> str:
    """Markdown section of the physics comparison (RMSE of both versions, gain, interval).

    Parameters
    ----------
    table : pandas.DataFrame
        Output of :func:`gain_table`.
    meta : dict
        ``reference`` and ``candidate`` version names, and optionally ``skipped`` (run id ->
        reason, :func:`per_run_errors`), listed under the table.

    Returns
    -------
    str
        The section, ending with a newline.
    """
    ref, new = meta["reference"], meta["candidate"]
    tuned = sorted(TUNED_TERRAINS & set(table.terrain))
    runs = ("All runs; v2 parameters were chosen on the training half of the shipped runs of "
            f"{', '.join(tuned)}: their rows (and `all`) include those training runs "
            "(held-out figures in docs/physics_v2.md)." if tuned else
            "All runs; no v2 parameter was chosen on runs of these terrains.")
    lines = [f"## Physics {new} against {ref} (replay, no fitted effect, all runs)",
             "",
             f"Gain = 1 - RMSE({new}) / RMSE({ref}); 95 % interval: runs resampled with "
             f"replacement within the terrain. {runs}",
             "",
             f"| terrain | signal | manoeuvre | runs | samples | RMSE {ref} | RMSE {new} | "
             "gain [95 % CI] |", "|---|---|---|---|---|---|---|---|"]
    for r in table.itertuples():
        if r.scope == "stop":
            continue
        # a pooled row of several runs, one per terrain, has no interval either
        interval = (f"[{r.gain_lo:+.3f}, {r.gain_hi:+.3f}]" if np.isfinite(r.gain_lo)
                    else "(one run: no interval)" if r.n_runs == 1
                    else "(one run per terrain: no interval)")
        lines.append(f"| {r.terrain} | {r.signal} | {r.scope} | {r.n_runs} | {r.n} | "
                     f"{r.rmse_ref:.3g} | {r.rmse_new:.3g} | {r.gain:+.3f} {interval} |")
    if meta.get("skipped"):
        lines += ["", f"Left out ({len(meta['skipped'])} run(s) a version could not replay): "
                  + "; ".join(f"{k} ({v})" for k, v in meta["skipped"].items()) + "."]
    return "\n".join(lines) + "\n"
