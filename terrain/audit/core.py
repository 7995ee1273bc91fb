"""The audit: replay measured runs, compare, attribute residuals to named effects, score them.

:func:`run_audit` chains the steps of :mod:`terrain.audit`:

1. :func:`~terrain.audit.replay.replay_run` for every run (the simulator's Husky model as is,
   driven by the run's own wheel speeds), :func:`~terrain.audit.frames.prepare_frame` (the
   comparison clock, the run's own lag track, manoeuvres, pitch);
2. for every terrain and for all runs pooled (``all``), forward selection of the ``timing``,
   ``yaw`` and ``current`` effects with leave-one-run-out gains and bootstrap support
   (:func:`~terrain.audit.selection.select_group`);
3. residual statistics (RMSE, bias, correlation) per signal, run, terrain and manoeuvre for
   the ideal kinematics (yaw rate only), the replay on raw timestamps (yaw rate only), the
   replay on the aligned clock and the extended model (held-out predictions);
4. measured facts that need no model (currents spinning vs driving straight, right-minus-left
   current while driving straight, per-run lags).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from collections.abc import Iterable
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from terrain.audit.effects import (EffectSettings, YawParams, effect_params,
                                   predict_current, predict_yaw)
from terrain.audit.frames import (CURVE, MANOEUVRES, SPIN, STRAIGHT, AuditFrame,
                                  FrameSettings, check_same_bandwidth, prepare_frame)
from terrain.audit.replay import ReplaySettings, replay_run, require_replayable
from terrain.audit.selection import (EffectResult, GroupResult, SelectionSettings, loro,
                                     make_units, select_group, unit_errors, unscored_group)
from terrain.audit.timing import LagSettings
from terrain.errors import (ConfigError, DataFormatError, config_flags, config_positive,
                            duplicated, indexed)
from terrain.run import Run
from terrain.vehicles import get_vehicle, skid_steer_forward
from terrain.vehicles.icr import icr_expansion_factor

SIGNALS = ("wz", "ax", "ay", "cur_l", "cur_r")
POOLED = "all"

CONSTANT_SPREAD_TOL = 1e-9
"""Standard deviation (signal unit: rad/s, m/s^2, A) at or below which a series counts as
constant and its correlation is undefined (NaN).

A replay that does not excite a signal (the body acceleration of a spin in place) is zero
up to floating-point noise of about 1e-19; a Pearson correlation with that noise is a
number between -1 and 1 that changes with the last bits of the integrator. 1e-9 is six
orders below any sensor resolution of the shipped data (IMU about 1e-3)."""


@dataclass(frozen=True)
class AuditSettings:
    """Everything that parametrises an audit (see each part's docstring).

    Parameters
    ----------
    replay : ReplaySettings
        How runs are replayed through the simulator.
    frames : FrameSettings
        Comparison clock, manoeuvre classes, scored samples.
    lag : LagSettings
        Window-by-window estimation of the wheel stream's clock offset.
    effects : EffectSettings
        Constants of the effect models and their negligible sizes.
    selection : SelectionSettings
        Held-out scoring and bootstrap.
    pooled : bool
        Also fit every run pooled (terrain ``all``) when there are several terrains.
    sweep_factors : tuple of float
        Multipliers of the catalogue lateral friction for the what-if replays
        (:func:`lateral_friction_sweep`), each finite, >= 0 and given once; empty: no sweep.

    Raises
    ------
    ConfigError
        ``sweep_factors`` not a sequence (one number, text), a sweep factor that is not a
        finite number >= 0 or is given twice, or a replay output cut-off
        (``replay.output_cutoff_hz``) other than the IMU's (``frames.imu_cutoff_hz``).
    """

    replay: ReplaySettings = field(default_factory=ReplaySettings)
    frames: FrameSettings = field(default_factory=FrameSettings)
    lag: LagSettings = field(default_factory=LagSettings)
    effects: EffectSettings = field(default_factory=EffectSettings)
    selection: SelectionSettings = field(default_factory=SelectionSettings)
    pooled: bool = True
    sweep_factors: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        """Refuse a sweep factor that is not a finite number >= 0, and a ``pooled`` that is
        not a boolean, before the audit runs.

        Raises
        ------
        ConfigError
            ``sweep_factors`` one number or text instead of a sequence, a factor NaN,
            infinite, negative or not a number, ``pooled`` not ``True`` or
            ``False`` (the text ``"no"`` of a config file fitted the pooled terrain), or
            the replay's predictions and the IMU low-passed at different cut-offs (the
            report says they share one: a replay at 0.5 Hz against a gyro at 2 Hz put the
            gyro's 0.5-2 Hz band in the replay's yaw-rate error).
        """
        _check_factors("AuditSettings.sweep_factors", self.sweep_factors)
        config_flags("AuditSettings", pooled=self.pooled)
        check_same_bandwidth(self.replay, self.frames, "AuditSettings")

    def as_params(self) -> dict[str, object]:
        """Flat ``section.name -> value`` mapping (for MLflow parameters and the report).

        Returns
        -------
        dict
            ``replay.*``, ``frames.*``, ``lag.*``, ``effects.*``, ``selection.*`` (tuples
            joined by commas), ``pooled``, ``sweep_factors``.
        """
        out = {}
        for section in ("replay", "frames", "lag", "effects", "selection"):
            for k, v in asdict(getattr(self, section)).items():
                if isinstance(v, tuple):
                    v = ",".join(f"{a[0]}={a[1]}" if isinstance(a, tuple) else str(a)
                                 for a in v)
                out[f"{section}.{k}"] = v
        out["pooled"] = self.pooled
        out["sweep_factors"] = ",".join(map(str, self.sweep_factors))
        return out


@dataclass(frozen=True)
class AuditResult:
    """Outcome of :func:`run_audit`.

    Attributes
    ----------
    settings : AuditSettings
        Settings the audit ran with.
    frames : tuple of AuditFrame
        One per audited run, in run-id order.
    skipped : dict
        Run id -> why it was not audited, in run-id order.
    groups : dict
        ``(terrain, group) -> GroupResult`` (terrain ``all`` = pooled).
    residuals : pandas.DataFrame
        Columns ``signal, model, terrain, run_id, manoeuvre, n, rmse, bias, corr``;
        ``run_id == "*"`` rows pool the terrain, ``manoeuvre == "all"`` rows pool manoeuvres.
    lags : pandas.DataFrame
        Per-run lag summary (:meth:`~terrain.audit.timing.LagTrack.summary`) and windows.
    facts : dict
        Terrain -> measured statistics that need no model.
    timings_s : dict
        Wall time of each step, s.
    sweep : pandas.DataFrame
        What-if replays with scaled catalogue lateral friction (empty unless
        ``settings.sweep_factors``) of the audited runs (those of :attr:`frames`), see
        :func:`lateral_friction_sweep`.
    """

    settings: AuditSettings
    frames: tuple[AuditFrame, ...]
    skipped: Mapping[str, str]
    groups: Mapping[tuple[str, str], GroupResult]
    residuals: pd.DataFrame
    lags: pd.DataFrame
    facts: Mapping[str, Mapping[str, Any]]
    timings_s: Mapping[str, float]
    sweep: pd.DataFrame = field(default_factory=pd.DataFrame)

    @property
    def terrains(self) -> list[str]:
        """Terrains audited (without ``all``), sorted."""
        return sorted({f.terrain for f in self.frames})

    def effects(self) -> list[EffectResult]:
        """Every effect result, terrain by terrain.

        Returns
        -------
        list of EffectResult
            In the order of :attr:`groups`, each group's effects in vocabulary order.
        """
        return [e for g in self.groups.values() for e in g.effects]

    def supported(self, terrain: str) -> list[str]:
        """Supported effect names on one terrain.

        Parameters
        ----------
        terrain : str
            Terrain class or ``all``.

        Returns
        -------
        list of str
            Names of the supported effects (empty when none, or terrain not audited).
        """
        return [e.name for e in self.effects() if e.terrain == terrain and e.supported]

    def effect(self, name: str, terrain: str) -> EffectResult:
        """The result of one effect on one terrain.

        Parameters
        ----------
        name : str
            Effect name.
        terrain : str
            Terrain class or ``all``.

        Returns
        -------
        EffectResult

        Raises
        ------
        KeyError
            Effect or terrain not audited.
        """
        for e in self.effects():
            if e.name == name and e.terrain == terrain:
                return e
        raise KeyError(f"{name} on {terrain}")


def _check_factors(owner: str, factors: Sequence[float]) -> None:
    """Lateral-friction multipliers must be finite and >= 0: NaN stopped the replay with a
    bare ValueError, and a negative factor replayed a friction that pushes the tyre along its
    own slip; one number (or text) in place of the sequence was a bare TypeError (or read
    letter by letter)."""
    if isinstance(factors, (str, bytes)) or not isinstance(factors, Iterable):
        raise ConfigError(f"{owner}: the factors must be a sequence of numbers such as "
                          f"(0.5, 1.0, 2.0), got {factors!r}")
    config_positive(owner, allow_zero=True, **indexed("factors", factors))
    twice = duplicated([float(f) for f in factors])
    if twice:   # the same friction replayed twice: identical rows of the what-if table
        raise ConfigError(f"{owner}: factor(s) {twice} given twice; give each once")


def _replay_and_frame(run: Run, settings: AuditSettings):
    """The catalogue replay of one run and its audit frame (the one recipe of
    :func:`prepare_frames` and of the lateral-friction sweep's measured-chi samples);
    raises as :func:`replay_run` and :func:`prepare_frame`."""
    rep = replay_run(run, settings.replay)
    return rep, prepare_frame(run, rep, settings.frames, settings.lag)


def prepare_frames(runs: Sequence[Run], settings: AuditSettings = AuditSettings()
                   ) -> tuple[list[AuditFrame], dict[str, str]]:
    """Replay every run and put it on the comparison clock.

    Parameters
    ----------
    runs : sequence of Run
        Measured runs (``wheels`` stream, ``imu`` optional) with a catalogue terrain label.
    settings : AuditSettings
        Its ``replay``, ``frames`` and ``lag`` parts are used.

    Returns
    -------
    frames : list of AuditFrame
    skipped : dict
        Run id -> reason (no wheel stream, unknown terrain, not a skid-steer, no sample to
        score...).
    """
    frames, skipped = [], {}
    for run in runs:
        try:
            rep, frame = _replay_and_frame(run, settings)
        except (ConfigError, DataFormatError) as exc:
            skipped[run.run_id] = str(exc)
            continue
        if not (frame.score_cur.any() or frame.score_imu.any()):
            # every sample within the scored edges of the run's ends or in a gap
            skipped[run.run_id] = (f"no sample to score: {run.duration_s:.1f} s long, and "
                                   f"the first and last {settings.frames.edge_s:g} s of a "
                                   "run and its timestamp gaps are not scored")
            continue
        frames.append(frame)
    return frames, skipped


def _stats(meas: np.ndarray, pred: np.ndarray) -> tuple[int, float, float, float]:
    """Sample count, RMSE, bias (measured - predicted) and Pearson correlation.

    The correlation is NaN with fewer than three samples or when either series is constant
    to :data:`CONSTANT_SPREAD_TOL`.
    """
    r = meas - pred
    n = int(len(r))
    if n == 0:
        return 0, float("nan"), float("nan"), float("nan")
    corr = float("nan")
    if n > 2 and np.std(meas) > CONSTANT_SPREAD_TOL and np.std(pred) > CONSTANT_SPREAD_TOL:
        corr = float(np.corrcoef(meas, pred)[0, 1])
    return n, float(np.sqrt(np.mean(r * r))), float(np.mean(r)), corr


def _samples(result_groups: dict, terrain: str, frames: Sequence[AuditFrame]) -> pd.DataFrame:
    """Long table of scored samples with every model's prediction for one terrain scope."""
    rows = []
    yaw = result_groups.get((terrain, "yaw"))
    cur = result_groups.get((terrain, "current"))
    yaw_pred: dict[tuple[str, float], np.ndarray] = {}
    if yaw is not None:
        for unit, params in zip(yaw.units, yaw.heldout_params):
            for f in unit:
                yaw_pred[(f.group, f.t_s[0])] = (f, predict_yaw(f, params), params.bias_rad_s)
    cur_pred = {}
    if cur is not None:
        for unit, params in zip(cur.units, cur.heldout_params):
            for f in unit:
                cur_pred[(f.group, f.t_s[0])] = (f, predict_current(f, params))
    for f, wz_ext, bias in yaw_pred.values():
        m = f.score_imu
        mobile = wz_ext - bias
        ay_ext = f.sim_ay + (mobile - f.sim_wz) * f.sim_vx
        base = {"run_id": f.run_id, "terrain": f.terrain,
                "manoeuvre": np.asarray(MANOEUVRES)[f.manoeuvre[m]]}
        rows.append(pd.DataFrame({**base, "signal": "wz", "measured": f.wz[m],
                                  "ideal": f.commanded_yaw_rate[m], "replay_raw": f.sim_wz[m],
                                  "measured_raw": f.wz_at_lag(0.0)[m],
                                  "replay": f.sim_wz[m], "extended": wz_ext[m]}))
        rows.append(pd.DataFrame({**base, "signal": "ax", "measured": f.ax[m],
                                  "replay": f.sim_ax[m], "extended": f.sim_ax[m]}))
        rows.append(pd.DataFrame({**base, "signal": "ay", "measured": f.ay[m],
                                  "replay": f.sim_ay[m], "extended": ay_ext[m]}))
    for f, c_ext in cur_pred.values():
        m = f.score_cur
        base = {"run_id": f.run_id, "terrain": f.terrain,
                "manoeuvre": np.asarray(MANOEUVRES)[f.manoeuvre[m]]}
        for j, s in enumerate(("cur_l", "cur_r")):
            rows.append(pd.DataFrame({**base, "signal": s, "measured": f.cur[m, j],
                                      "replay": f.sim_cur[m, j], "extended": c_ext[m, j]}))
    if not rows:
        return pd.DataFrame(columns=["run_id", "terrain", "manoeuvre", "signal", "measured"])
    return pd.concat(rows, ignore_index=True)


def residual_statistics(samples: pd.DataFrame, scope: str) -> pd.DataFrame:
    """RMSE, bias (measured - predicted) and correlation per signal, model, run, manoeuvre.

    Parameters
    ----------
    samples : pandas.DataFrame
        Output of the sample table (columns ``run_id, terrain, manoeuvre, signal,
        measured`` and one column per model).
    scope : str
        Terrain label written in the ``terrain`` column (``all`` for the pooled scope).

    Returns
    -------
    pandas.DataFrame
        Columns ``signal, model, terrain, run_id, manoeuvre, n, rmse, bias, corr``.
    """
    out = []
    models = [c for c in ("ideal", "replay_raw", "replay", "extended") if c in samples]
    for signal, s in samples.groupby("signal", sort=False):
        for model in models:
            if s[model].isna().all():
                continue
            meas_col = "measured_raw" if model == "replay_raw" else "measured"
            keys = [("*", "all", s)]
            keys += [(rid, "all", g) for rid, g in s.groupby("run_id", sort=True)]
            keys += [("*", man, g) for man, g in s.groupby("manoeuvre", sort=True)]
            for rid, man, g in keys:
                ok = g[model].notna() & g[meas_col].notna()
                n, rmse, bias, corr = _stats(g.loc[ok, meas_col].to_numpy(),
                                             g.loc[ok, model].to_numpy())
                out.append({"signal": signal, "model": model, "terrain": scope,
                            "run_id": rid, "manoeuvre": man, "n": n, "rmse": rmse,
                            "bias": bias, "corr": corr})
    return pd.DataFrame(out)


def measured_facts(frames: Sequence[AuditFrame]) -> dict:
    """Statistics of the measured data that need no model, for one set of runs.

    Parameters
    ----------
    frames : sequence of AuditFrame
        The runs (their scored samples are used).

    Returns
    -------
    dict
        ``current_straight_a``, ``current_spin_a``, ``current_curve_a`` (mean current per
        side), ``spin_to_straight_current_ratio``, ``straight_right_minus_left_a`` and the
        mean ``|wz|`` of those straight samples (rad/s), ``chi_pooled``
        (:func:`terrain.vehicles.icr.icr_expansion_factor` of the aligned gyro and
        ``(v_R - v_L) / B`` over turning samples; None with 10 samples or fewer or a robot
        that does not turn), lag range over runs (s), run counts.
    """
    cur, man, dcur, wz_st, x_t, wz_t = [], [], [], [], [], []
    for f in frames:
        m = f.score_cur
        cur.append(f.cur[m].mean(axis=1))
        man.append(f.manoeuvre[m])
        dcur.append((f.cur[m, 1] - f.cur[m, 0])[f.manoeuvre[m] == STRAIGHT])
        if f.has_imu:
            mi = f.score_imu
            wz_st.append(np.abs(f.wz[mi][f.manoeuvre[mi] == STRAIGHT]))
            turn = np.isin(f.manoeuvre[mi], (CURVE, SPIN))
            x_t.append(f.commanded_yaw_rate[mi][turn])
            wz_t.append(f.wz[mi][turn])
    cur = np.concatenate(cur) if cur else np.empty(0)
    man = np.concatenate(man) if man else np.empty(0, dtype=int)

    def mean(a):
        return float(np.mean(a)) if len(a) else None
    straight = mean(cur[man == STRAIGHT])
    spin = mean(cur[man == SPIN])
    out = {"current_straight_a": straight, "current_spin_a": spin,
           "current_curve_a": mean(cur[man == CURVE]),
           "spin_to_straight_current_ratio": (spin / straight if spin is not None and straight
                                              else None),
           "n_straight": int(np.sum(man == STRAIGHT)), "n_spin": int(np.sum(man == SPIN))}
    d = np.concatenate(dcur) if dcur else np.empty(0)
    out["straight_right_minus_left_a"] = mean(d)
    w = np.concatenate(wz_st) if wz_st else np.empty(0)
    out["straight_mean_abs_wz_rad_s"] = mean(w)
    xt = np.concatenate(x_t) if x_t else np.empty(0)
    wt = np.concatenate(wz_t) if wz_t else np.empty(0)
    chi = icr_expansion_factor(wt, xt) if len(xt) > 10 else float("inf")
    out["chi_pooled"] = chi if np.isfinite(chi) else None
    lags = [f.lag.summary() for f in frames if f.has_imu]
    ident = [s for s in lags if s["identifiable"]]
    out["lag_min_s"] = min((s["lag_min_s"] for s in ident), default=None)
    out["lag_max_s"] = max((s["lag_max_s"] for s in ident), default=None)
    out["runs_with_identifiable_lag"] = len(ident)
    out["runs_with_imu"] = len(lags)
    out["runs"] = len({f.run_id for f in frames})
    return out


def lag_table(frames: Sequence[AuditFrame]) -> pd.DataFrame:
    """Per-run lag summary with the window lags as text.

    Parameters
    ----------
    frames : sequence of AuditFrame
        Audited runs (those without IMU are left out).

    Returns
    -------
    pandas.DataFrame
        One row per run with IMU: ``run_id, terrain`` and the columns of
        :meth:`~terrain.audit.timing.LagTrack.summary` (s, s/min), ``windows`` as
        ``centre:lag;...``.
    """
    rows = []
    for f in frames:
        if not f.has_imu:
            continue
        s = f.lag.summary()
        s.update(run_id=f.run_id, terrain=f.terrain,
                 windows=";".join(f"{c:.1f}:{l:+.3f}" for c, l in
                                  zip(f.lag.centres_s, f.lag.lags_s)))
        rows.append(s)
    cols = ["run_id", "terrain", "lag_s", "lag_start_s", "lag_end_s", "lag_min_s",
            "lag_max_s", "drift_s_per_min", "n_windows_used", "n_windows", "identifiable",
            "windows"]
    return pd.DataFrame(rows, columns=cols)


def _turning_forms(group: GroupResult, settings: AuditSettings) -> dict:
    """Held-out RMSE (A) of the current model with each turning form forced (NaN where the
    units hold no turning sample: nothing to score, not a perfect fit)."""
    spec = list(group.selected)
    if "turning_resistance" not in spec:
        spec.append("turning_resistance")
    out = {}
    for form in ("coulomb", "proportional"):
        params = loro(group.units, "current", spec,
                      [x for x in spec if x != "turning_resistance"], settings.effects,
                      form=form)
        s, n = unit_errors(group.units, "current", params, "turning")
        out[f"heldout_rmse_turning_{form}"] = (float(np.sqrt(s.sum() / n.sum()))
                                               if n.sum() > 0 else float("nan"))
    return out


def _unscored_reason(frames: Sequence[AuditFrame], group: str,
                     needs: Callable[[AuditFrame], bool]) -> str:
    """Why a group got fewer than 2 cross-validation units: no run with the samples it
    scores, or runs too short to cut into 2 scorable segments (each named with its scored
    sample count and the time they span)."""
    what = "current" if group == "current" else "IMU"
    usable = [f for f in frames if needs(f)]
    if not usable:
        return f"no run with {what} samples to score"
    spans = []
    for f in usable:
        t = f.t_s[f.score_cur if group == "current" else f.score_imu]
        spans.append(f"{f.run_id} ({t.size} {what} samples scored over "
                     f"{t[-1] - t[0]:.1f} s)")
    return (f"{len(usable)} run(s) too short to cut into 2 scorable segments: "
            + "; ".join(spans))


def _require_unique_ids(run_ids: Sequence[str]) -> None:
    """Refuse runs that share a run id (the second one's samples replaced the first one's
    in the sample table, and the per-run rows of both merged)."""
    counts = pd.Series(run_ids, dtype=object).value_counts(sort=False)
    dup = counts[counts > 1]
    if len(dup):
        raise ConfigError("run ids must be unique, got " + ", ".join(
            f"{k} ({v} runs)" for k, v in dup.items()))


def run_audit(runs: Sequence[Run], settings: AuditSettings = AuditSettings(),
              frames: Sequence[AuditFrame] | None = None,
              skipped: Mapping[str, str] | None = None) -> AuditResult:
    """Audit the simulator against measured runs (module docstring).

    Parameters
    ----------
    runs : sequence of Run
        Measured runs (``wheels`` stream, ``imu`` optional), labelled with a catalogue
        terrain; runs that cannot be replayed are skipped and listed.
    settings : AuditSettings
        Every setting of the audit.
    frames : sequence of AuditFrame, optional
        Already prepared frames (skips the replay; ``runs`` then serve the lateral-friction
        sweep only, those with a frame).
    skipped : mapping of str to str, optional
        With ``frames``: the runs their preparation skipped, run id -> reason (listed in
        the result in run-id order, as the skipped runs of a replay here are).

    Returns
    -------
    AuditResult

    Raises
    ------
    DataFormatError
        No run could be audited.
    ConfigError
        Two runs (frames given or not) or two given frames share a run id: every per-run
        table, the skipped list, the sweep and the sample table are keyed by it; or
        ``skipped`` given without ``frames``.
    """
    timings = {}
    t0 = time.perf_counter()
    if skipped is not None and frames is None:
        raise ConfigError("run_audit: skipped is the list of the runs the given frames' "
                          "preparation skipped; give frames with it")
    skipped = dict(skipped or {})
    # given frames too: the runs serve the sweep, each replayed under its id
    _require_unique_ids([r.run_id for r in runs])
    if frames is None:
        frames, skipped = prepare_frames(runs, settings)
    frames = list(frames)
    _require_unique_ids([f.run_id for f in frames])
    # in run-id order (as read_runs_dir lists them): the audited-run list, the lag table and
    # the figures drawn over the frames do not depend on the order the runs were given in
    frames = sorted(frames, key=lambda f: f.run_id)
    skipped = dict(sorted(skipped.items()))
    timings["replay_s"] = time.perf_counter() - t0
    if not frames:
        raise DataFormatError("no run could be audited: " + "; ".join(
            f"{k}: {v}" for k, v in skipped.items()) if skipped else "no runs given")
    t1 = time.perf_counter()
    scopes = sorted({f.terrain for f in frames})
    if settings.pooled and len(scopes) > 1:
        scopes.append(POOLED)
    groups: dict[tuple[str, str], GroupResult] = {}
    stats, facts = [], {}
    min_units = settings.selection.min_units
    for scope in scopes:
        fs = [f for f in frames if scope == POOLED or f.terrain == scope]
        facts[scope] = measured_facts(fs)
        for group in ("timing", "yaw", "current"):
            if group == "current":
                def needs(f):
                    return bool(f.score_cur.any())
            else:
                def needs(f):
                    return bool(f.has_imu and f.score_imu.any())
            units, segmented = make_units(fs, min_units, needs, settings.lag,
                                          settings.frames)
            if len(units) < 2:
                groups[(scope, group)] = unscored_group(
                    group, scope, _unscored_reason(fs, group, needs), len(fs))
                continue
            # ideal differential drive: wz = (v_R - v_L) / B (seed 000 eq. 2)
            refs = ({"ideal": YawParams(kinematic=True, inverse_chi=1.0)} if group == "yaw"
                    else None)
            res = select_group(units, group, scope, settings.selection, settings.effects,
                               segmented, refs)
            if group == "current":
                forms = _turning_forms(res, settings)
                res = _with_details(res, "turning_resistance", forms)
            groups[(scope, group)] = res
        stats.append(residual_statistics(_samples(groups, scope, fs), scope))
    timings["selection_s"] = time.perf_counter() - t1
    residuals = pd.concat(stats, ignore_index=True) if stats else pd.DataFrame()
    sweep = pd.DataFrame()
    # the runs audited only: the replayed chi is set against their measured chi_pooled
    audited = {f.run_id for f in frames}
    swept = [r for r in runs if r.run_id in audited]
    if settings.sweep_factors and swept:
        t2 = time.perf_counter()
        sweep = pd.concat([lateral_friction_sweep(swept, t, settings.sweep_factors, settings,
                                                  facts[t].get("chi_pooled"))
                           for t in scopes if t != POOLED], ignore_index=True)
        timings["sweep_s"] = time.perf_counter() - t2
    return AuditResult(settings=settings, frames=tuple(frames), skipped=skipped, groups=groups,
                       residuals=residuals, lags=lag_table(frames), facts=facts,
                       timings_s=timings, sweep=sweep)


def lateral_friction_sweep(runs: Sequence[Run], terrain: str, factors: Sequence[float],
                           settings: AuditSettings = AuditSettings(),
                           measured_chi: float | None = None) -> pd.DataFrame:
    """What-if: the replay's own ICR expansion when the catalogue lateral friction is scaled.

    The simulator produces yaw-rate scrub only through its contact model (lateral friction
    against traction, :mod:`terrain.sim.dynamics`). Replaying the runs of ``terrain`` that
    turn, with ``lateral_friction`` multiplied by each factor, tells whether a catalogue
    value reproduces the measured chi or whether the kinematic ``icr_expansion`` is needed.

    Parameters
    ----------
    runs : sequence of Run
        Runs of any terrain; those of ``terrain`` with an IMU and at least 20 turning wheel
        samples are replayed (a run's label names the catalogue terrain in any case, as for
        :func:`~terrain.audit.replay.replay_run`: ``asphalt`` is an ``ASPHALT`` run).
    terrain : str
        Catalogue terrain (any case; the table's ``terrain`` is the catalogue's name).
    factors : sequence of float
        Multipliers of the catalogue lateral friction (finite, >= 0).
    settings : AuditSettings
        Its ``replay`` and ``frames`` parts are used.
    measured_chi : float, optional
        Copied into the table for comparison.

    Returns
    -------
    pandas.DataFrame
        Columns ``terrain, factor, lateral_friction, replay_chi, measured_chi, n_runs``;
        ``replay_chi`` is :func:`terrain.vehicles.icr.icr_expansion_factor` of the replayed
        yaw rate and ``(v_R - v_L) / B`` over the samples the measured chi is taken on
        (``chi_pooled`` of :func:`measured_facts`): the curve and spin samples scored
        against the IMU in each chosen run's audit frame (:func:`prepare_frames`; inf when
        the replayed robot does not turn; NaN when no run of ``terrain`` turns, or none on
        such a sample). ``attrs["skipped"]``: run id ->
        why a run of ``terrain`` with an IMU could not be replayed or framed
        (:func:`~terrain.audit.replay.require_replayable`; left out, as the audit skips it).

    Raises
    ------
    ConfigError
        ``terrain`` is not in the catalogue, ``factors`` not a sequence (one number, text),
        or a factor is not a finite number >= 0 or is given twice.
    """
    from dataclasses import replace

    _check_factors("lateral_friction_sweep", factors)

    from terrain.terramechanics.catalogue import get_terrain

    base = get_terrain(terrain)
    chosen, skipped = [], {}
    for run in runs:
        # the catalogue's name, as the replay reads the label (a folder 'asphalt/' gives
        # 'asphalt', the frames and run_audit's scopes 'ASPHALT'): compared as text, no run
        # was chosen and the table read replay_chi NaN, n_runs 0
        if (_catalogue_name(run.terrain) != base.name or not run.has_imu
                or "wheels" not in run.streams):
            continue
        try:                # a run the audit skips (listed there) would stop the sweep
            require_replayable(run, base)
        except (ConfigError, DataFormatError) as exc:
            skipped[run.run_id] = str(exc)
            continue
        w = run.streams["wheels"]
        _, x = skid_steer_forward(w["vel_l"].to_numpy(), w["vel_r"].to_numpy(),
                                  get_vehicle(run.vehicle).track_m)
        if np.sum(np.abs(x) >= settings.frames.turn_rad_s) >= 20:
            # the samples of the measured chi (measured_facts' chi_pooled): the curve and
            # spin samples scored against the IMU in the run's audit frame (the catalogue
            # replay, as prepare_frames makes it); the turning samples of the wheel
            # record's scored span counted stopped samples and samples outside the IMU
            # record on the replayed side only
            try:
                rep, frame = _replay_and_frame(run, settings)
            except (ConfigError, DataFormatError) as exc:
                skipped[run.run_id] = str(exc)
                continue
            m = frame.score_imu & np.isin(frame.manoeuvre, (CURVE, SPIN))
            chosen.append((run, rep, m, frame.commanded_yaw_rate[m]))
    rows = []
    for factor in factors:
        ter = replace(base, lateral_friction=float(base.lateral_friction * factor))
        commanded, replayed = [np.empty(0)], [np.empty(0)]
        for run, rep, m, x in chosen:
            if ter != base:
                rep = replay_run(run, settings.replay, terrain=ter)
            commanded.append(x)
            replayed.append(rep.yaw_rate[m])
        commanded, replayed = np.concatenate(commanded), np.concatenate(replayed)
        chi = icr_expansion_factor(replayed, commanded) if commanded.size else np.nan
        rows.append({"terrain": base.name, "factor": float(factor),
                     "lateral_friction": ter.lateral_friction, "replay_chi": chi,
                     "measured_chi": measured_chi, "n_runs": len(chosen)})
    out = pd.DataFrame(rows)
    out.attrs["skipped"] = skipped
    return out


def _catalogue_name(label: object) -> str | None:
    """A run's terrain label as the catalogue names it (:func:`get_terrain` reads any case);
    None for no label or one the catalogue does not know."""
    from terrain.terramechanics.catalogue import get_terrain

    if label is None:
        return None
    try:
        return get_terrain(str(label)).name
    except ConfigError:
        return None


def _with_details(group: GroupResult, name: str, extra: dict) -> GroupResult:
    """``group`` with ``extra`` added to the details of effect ``name``."""
    from dataclasses import replace

    effects = tuple(replace(e, details={**e.details, **extra}) if e.name == name else e
                    for e in group.effects)
    return replace(group, effects=effects)


__all__ = ["AuditSettings", "AuditResult", "run_audit", "prepare_frames", "measured_facts",
           "lateral_friction_sweep",
           "residual_statistics", "lag_table", "effect_params", "SIGNALS", "POOLED"]
