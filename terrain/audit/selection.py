"""Held-out scoring of effects: leave-one-run-out, bootstrap support, forward selection.

Protocol, for one group of signals (``timing``, ``yaw``, ``current``) and one terrain (or all
runs pooled):

1. Cross-validation units are the runs; when a terrain has fewer than ``min_units`` runs with
   the needed signals, each run is cut into contiguous segments that serve as units
   (leave-one-segment-out, reported as such; each segment carries the lag estimated on its
   own span, :func:`~terrain.audit.frames.split_frame`). Intervals over the segments of a
   single run say nothing about run-to-run spread; the report labels them so.
2. The baseline (the replay, no effect) is scored on every unit: squared errors summed per
   unit.
3. Forward selection: every effect not yet in the model is added in turn; the extended model
   is fitted on all units but one and scored on the one left out, for every unit. The gain of
   a candidate is the fraction of the baseline RMSE it removes on held-out units, measured on
   the samples where the effect acts (:attr:`~terrain.audit.effects.EffectSpec.scope`):
   ``(RMSE_before - RMSE_with) / RMSE_baseline`` (RMSE pooled over held-out samples).
4. Support: units (those with samples in the effect's scope) are resampled with
   replacement (``n_bootstrap`` times; with all runs pooled, within each terrain, so that
   every resample keeps the terrain mix of the data: :func:`stratified_resamples`) and the
   gain is recomputed from the resampled per-unit errors; the effect is supported when the
   lower end of the 95 % percentile interval is above 0 (no interval, hence no support,
   when every terrain holds a single such unit: :func:`has_spread`) *and* the gain is at least
   ``min_gain`` *and* its fitted size is not negligible (:func:`negligible`) *and* it does
   not contradict its physics (:func:`unphysical`).
   The supported candidate with the largest gain joins the model and step 3 repeats (a
   larger gain that misses the rule, e.g. a noisy one whose interval reaches 0, does not
   stop a supported one from joining); when no candidate is supported, selection stops and
   every remaining candidate is reported with its increment over the final model and
   ``supported = false``.
5. Parameters are fitted on all units with the final model (an unsupported effect: final
   model plus that effect); their 95 % intervals come from refitting on units resampled with
   replacement (``n_param_bootstrap`` times, within each terrain as in step 4; the functional
   form is kept fixed).

A fold whose training units hold no information on a candidate (e.g. the only run with turns
is held out) predicts with the model without that candidate.
"""

from __future__ import annotations

import hashlib
import numbers
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from terrain.audit.effects import (EFFECT_VOCABULARY, GROUP_MODELS, GROUPS, CurrentParams,
                                   EffectSettings, LagParams, NotIdentifiable, YawParams,
                                   effect_cause, effect_details, effect_params)
from terrain.audit.frames import AuditFrame, FrameSettings, split_frame
from terrain.audit.timing import LagSettings
from terrain.errors import ConfigError, config_integer
from terrain.io.jsonfile import json_ready

#: fitted model of one group
GroupParams = LagParams | YawParams | CurrentParams
#: cross-validation units: each a list of frames (one run, or one segment of a run)
Units = Sequence[Sequence[AuditFrame]]


#: Most bootstrap resamples of a gain interval: 100 times the default, far past where the
#: interval's bounds stop moving; more only fills memory (resamples x units indices).
MAX_BOOTSTRAP = 100_000
#: Fewest bootstrap resamples of a gain interval.
MIN_BOOTSTRAP = 10
#: Most parameter-interval resamples: each one refits every effect.
MAX_PARAM_BOOTSTRAP = 10_000
#: Fewest successful refits a parameter interval is given from (and a quarter of the
#: resamples asked for, when more): fewer resamples than this (but some) never give one.
MIN_PARAM_BOOTSTRAP = 5


@dataclass(frozen=True)
class SelectionSettings:
    """Settings of the held-out scoring.

    Parameters
    ----------
    n_bootstrap : int
        Resamples of held-out units for the gain interval.
    n_param_bootstrap : int
        Resamples of units for the parameter intervals (refits): 0 (no intervals) or at
        least :data:`MIN_PARAM_BOOTSTRAP`.
    min_gain : float
        Smallest gain (fraction of baseline RMSE) an effect must bring to be supported.
    min_units : int
        Fewest cross-validation units; terrains with fewer runs are cut into segments.
    seed : int
        Seed of the bootstrap generator.

    Raises
    ------
    ConfigError
        ``n_bootstrap`` not an integer in ``MIN_BOOTSTRAP..MAX_BOOTSTRAP``,
        ``n_param_bootstrap`` not one in ``0..MAX_PARAM_BOOTSTRAP`` or one below
        :data:`MIN_PARAM_BOOTSTRAP` but 0 (1-4 resamples never gave an interval),
        ``min_units`` not one
        >= 2, ``seed`` not one >= 0 (:func:`~terrain.errors.config_integer`: a boolean or a
        float such as 10.5 or NaN is no count), or ``min_gain`` not a number in [0, 1).
    """

    n_bootstrap: int = 1000
    n_param_bootstrap: int = 200
    min_gain: float = 0.02
    min_units: int = 4
    seed: int = 0

    def __post_init__(self) -> None:
        # (10.5 resamples or a NaN seed passed range checks, then numpy's TypeError at the
        # first bootstrap draw; min_units inf an OverflowError cutting runs into segments)
        config_integer("SelectionSettings.n_bootstrap", self.n_bootstrap, MIN_BOOTSTRAP,
                       MAX_BOOTSTRAP)
        config_integer("SelectionSettings.n_param_bootstrap", self.n_param_bootstrap, 0,
                       MAX_PARAM_BOOTSTRAP)
        if 0 < self.n_param_bootstrap < MIN_PARAM_BOOTSTRAP:
            raise ConfigError(
                f"SelectionSettings.n_param_bootstrap must be 0 (no parameter intervals) or "
                f"at least {MIN_PARAM_BOOTSTRAP} (an interval needs {MIN_PARAM_BOOTSTRAP} "
                f"refits), got {self.n_param_bootstrap!r}")
        config_integer("SelectionSettings.min_units", self.min_units, 2)
        config_integer("SelectionSettings.seed", self.seed, 0)
        if not (isinstance(self.min_gain, numbers.Real) and not isinstance(self.min_gain, bool)
                and 0.0 <= self.min_gain < 1.0):  # NaN included: it would support no effect
            raise ConfigError(f"min_gain must be in [0, 1) (a fraction of the baseline "
                              f"RMSE), got {self.min_gain!r}")


@dataclass(frozen=True, kw_only=True)
class EffectResult:
    """One effect scored on one terrain (or ``all``). Keyword construction only.

    Parameters
    ----------
    name : str
        Effect (a key of :data:`~terrain.audit.effects.EFFECT_VOCABULARY`).
    terrain : str
        Terrain class, or ``all`` for every run pooled.
    group : str
        ``timing``, ``yaw`` or ``current``.
    params : mapping of str to float
        Vocabulary parameter, e.g. ``{"chi": 1.55}`` (empty when not identifiable), in the
        unit of :attr:`~terrain.audit.effects.EffectSpec.unit`.
    ci95 : mapping of str to (float, float)
        Parameter name -> ``(low, high)`` bootstrap interval over units (empty when too few
        resamples could be fitted to a finite parameter).
    heldout_gain : float or None
        Fraction of the baseline RMSE removed on held-out units (increment at the effect's
        step; for unsupported effects, increment over the final model); None when the effect
        was not scored.
    heldout_gain_ci95 : (float, float) or None
        Bootstrap interval of the gain (None also when every terrain holds a single unit in
        the effect's scope: ``details["no_gain_interval"]``).
    supported : bool
        Whether the effect joined the model.
    step : int or None
        Order in which the effect joined the model (1 = first), None if not selected.
    details : mapping
        ``scope``, the effect's secondary quantities
        (:func:`~terrain.audit.effects.effect_details`), ``unphysical`` / ``negligible``
        when a rule rejected it, held-out RMSE before / with it / of the baseline and its gain
        against reference models (``heldout_gain_vs_<reference>``), all on its scope.
    cause : str
        Plain-language cause (:attr:`~terrain.audit.effects.EffectSpec.cause`).
    reason : str or None
        Why the effect could not be fitted or scored, if so.
    n_units : int
        Cross-validation units.
    n_runs : int
        Distinct runs in them.
    """

    name: str
    terrain: str
    group: str
    params: Mapping[str, float] = field(default_factory=dict)
    ci95: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    heldout_gain: float | None = None
    heldout_gain_ci95: tuple[float, float] | None = None
    supported: bool = False
    step: int | None = None
    details: Mapping[str, Any] = field(default_factory=dict)
    cause: str = ""
    reason: str | None = None
    n_units: int = 0
    n_runs: int = 0

    def as_dict(self) -> dict:
        """The result as the report's ``effects`` item.

        Returns
        -------
        dict
            JSON-ready (:func:`json_ready`), keys = the field names above.
        """
        return {"name": self.name, "terrain": self.terrain, "group": self.group,
                "params": json_ready(self.params), "ci95": json_ready(self.ci95),
                "heldout_gain": json_ready(self.heldout_gain),
                "heldout_gain_ci95": json_ready(self.heldout_gain_ci95),
                "supported": bool(self.supported), "step": self.step,
                "details": json_ready(self.details), "cause": self.cause, "reason": self.reason,
                "n_units": self.n_units, "n_runs": self.n_runs}


@dataclass(frozen=True, kw_only=True)
class GroupResult:
    """Forward selection of one group on one terrain.

    Parameters
    ----------
    group : str
        ``timing``, ``yaw`` or ``current``.
    terrain : str
        Terrain class or ``all``.
    selected : tuple of str
        Supported effects in order of selection.
    effects : tuple of EffectResult
        Every effect of the group, in vocabulary order.
    params : LagParams or YawParams or CurrentParams
        Final model fitted on all units.
    baseline_rmse : float
        Held-out RMSE of the replay (pooled over units; rad/s or A).
    final_rmse : float
        Held-out RMSE of the final model (pooled over units; rad/s or A).
    units : tuple of tuple of AuditFrame
        Cross-validation units, in run-id order (a run's segments by start time).
    heldout_params : tuple
        Final-model parameters fitted without each unit (same order as ``units``).
    segmented : bool
        Whether runs were cut into segments to get enough units.
    reference_rmse : mapping of str to float
        Held-out RMSE of extra reference models (e.g. ``ideal`` kinematics for the yaw rate).
    """

    group: str
    terrain: str
    selected: tuple[str, ...]
    effects: tuple[EffectResult, ...]
    params: GroupParams
    baseline_rmse: float
    final_rmse: float
    units: tuple[tuple[AuditFrame, ...], ...]
    heldout_params: tuple[GroupParams, ...]
    segmented: bool
    reference_rmse: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True)
class Trial:
    """One candidate effect scored against the current model on held-out units.

    Parameters
    ----------
    name : str
        Candidate effect.
    scope : str
        Samples it is scored on (:attr:`~terrain.audit.effects.EffectSpec.scope`).
    heldout_params : tuple
        Parameters of the model with the candidate, fitted without each unit.
    gain : float
        ``(RMSE_before - RMSE_with) / RMSE_baseline`` on held-out units in ``scope``.
    gain_ci95 : (float, float)
        Bootstrap interval of the gain over units.
    rmse_baseline, rmse_before, rmse_with : float
        Held-out RMSE in ``scope`` of the replay, of the model before and of the model with the
        candidate (rad/s or A).
    unphysical : str or None
        Why the fitted effect contradicts its physics (:func:`unphysical`).
    negligible : str or None
        Why the fitted effect is too small to matter (:func:`negligible`).
    """

    name: str
    scope: str
    heldout_params: tuple[GroupParams, ...]
    gain: float
    gain_ci95: tuple[float, float]
    rmse_baseline: float
    rmse_before: float
    rmse_with: float
    unphysical: str | None
    negligible: str | None

    @property
    def admissible(self) -> bool:
        """Neither unphysical nor negligible."""
        return not (self.unphysical or self.negligible)


@dataclass(frozen=True, kw_only=True)
class SelectionPath:
    """What forward selection did in one group.

    Parameters
    ----------
    accepted : tuple of Trial
        Trials of the effects that joined the model, in order (step = index + 1).
    final_round : mapping of str to Trial
        Trials of the round that ended the selection (every remaining candidate's increment
        over the final model); empty when every scorable effect was accepted.
    not_identifiable : mapping of str to str
        Effect -> why it could not be fitted or scored.
    heldout_params : tuple
        Final-model parameters fitted without each unit.
    """

    accepted: tuple[Trial, ...]
    final_round: Mapping[str, Trial]
    not_identifiable: Mapping[str, str]
    heldout_params: tuple[GroupParams, ...]

    @property
    def selected(self) -> tuple[str, ...]:
        """Names of the accepted effects, in order."""
        return tuple(t.name for t in self.accepted)

    def step(self, name: str) -> int | None:
        """Step at which an effect joined the model.

        Parameters
        ----------
        name : str
            Effect name.

        Returns
        -------
        int or None
            1 = first; None if it did not join.
        """
        return self.selected.index(name) + 1 if name in self.selected else None

    def trial(self, name: str) -> Trial | None:
        """The trial that describes an effect.

        Parameters
        ----------
        name : str
            Effect name.

        Returns
        -------
        Trial or None
            Its accepted step, else its trial in the final round, else None (never scored).
        """
        for t in self.accepted:
            if t.name == name:
                return t
        return self.final_round.get(name)


def negligible(name: str, params: GroupParams, settings: EffectSettings) -> str | None:
    """Why a fitted effect is too small to matter.

    Parameters
    ----------
    name : str
        Effect.
    params : LagParams or YawParams or CurrentParams
        Fitted model of its group.
    settings : EffectSettings
        Floors in :attr:`~terrain.audit.effects.EffectSettings.negligible`.

    Returns
    -------
    str or None
        The reason, or None when the effect is above its floor (or has none).
    """
    floor = dict(settings.negligible).get(name)
    if floor is None:
        return None
    if name == "icr_expansion":
        size = abs(params.chi / params.chi_replay - 1.0) if np.isfinite(params.chi_replay) \
            else np.inf
        text = (f"chi {params.chi:.3g} within {100 * floor:.0f} % of the replay's "
                f"{params.chi_replay:.3g}")
    else:
        size = abs(next(iter(effect_params(name, params).values())))
        text = f"{next(iter(effect_params(name, params)))} = {size:.3g} below {floor}"
    return text if size < floor else None


def unphysical(name: str, params: GroupParams) -> str | None:
    """Why a fitted effect contradicts its physics.

    ``grade_resistance`` must cost current: a slope in either direction adds gravity load to
    the flat-ground replay (seed 003 eq. 10), so ``k_a_per_rad <= 0`` means the pitch
    estimate is correlated with something else (accelerations, vibration) and the effect is
    not supported whatever its gain. ``icr_expansion`` must turn the robot the way its
    wheels command: a ``chi`` that is NaN or <= 0 (a gyro mounted upside down fits ``chi < 0``,
    a dead one ``chi = NaN``) describes a sensor, not a wider track; and tyre scrub only moves
    the sides' ICRs outward, so ``chi < 1`` (the robot turning faster than ideal differential
    drive, seed 000 eqs. 2-3: a wrong wheel radius or track width, or a gyro scale error) is
    no ICR expansion either (the simulator plants ``chi`` in [1, 20]). For the same reason
    ``immobilised`` with the kinematic mobile model must not turn its mobile samples faster
    than ideal differential drive (``chi_mobile < 1``): its gain would be the correction of
    that error, credited to digging in.

    Parameters
    ----------
    name : str
        Effect.
    params : LagParams or YawParams or CurrentParams
        Fitted model of its group.

    Returns
    -------
    str or None
        The reason, or None when the effect does not contradict its physics.
    """
    if name == "grade_resistance" and not params.k_a_per_rad > 0:
        return (f"k_a_per_rad = {params.k_a_per_rad:.3g} <= 0: slopes would lower the "
                "current, which no grade resistance does")
    if name == "icr_expansion" and not params.chi > 0:
        return (f"chi = {params.chi:.3g} not > 0: the gyro turns against the wheels' "
                "command (or not at all), which no ICR expansion does")
    if name == "icr_expansion" and params.chi < 1.0:
        return (f"chi = {params.chi:.3g} < 1: the robot turns faster than ideal differential "
                "drive, which no ICR expansion does (wheel radius, track width or gyro scale)")
    if name == "immobilised" and params.kinematic and params.chi < 1.0:
        return (f"mobile chi = {params.chi:.3g} < 1: the robot turns faster than ideal "
                "differential drive when it moves (wheel radius, track width or gyro scale), "
                "which digging in does not explain")
    return None


def _fit_or(frames: Sequence[AuditFrame], group: str, spec: Sequence[str],
            fallback: Sequence[str], settings: EffectSettings,
            form: str | None = None) -> GroupParams:
    """Fit ``spec``; where the data cannot identify it, ``fallback``; else no effect."""
    model = GROUP_MODELS[group]
    try:
        return model.fit(frames, list(spec), settings, form)
    except NotIdentifiable:
        try:
            return model.fit(frames, list(fallback), settings)
        except NotIdentifiable:
            return model.no_effect()


def loro(units: Units, group: str, spec: Sequence[str], fallback: Sequence[str],
         settings: EffectSettings, form: str | None = None) -> list[GroupParams]:
    """Parameters of the model ``spec`` fitted without each unit in turn.

    Parameters
    ----------
    units : sequence of sequence of AuditFrame
        Cross-validation units.
    group : str
        ``timing``, ``yaw`` or ``current``.
    spec : sequence of str
        Effects in the model.
    fallback : sequence of str
        Model used in a fold whose training units cannot identify ``spec``.
    settings : EffectSettings
        Constants of the effect models.
    form : str, optional
        Functional form forced on the effect that has forms.

    Returns
    -------
    list
        One fitted parameter object per unit (fitted on all the other units).
    """
    params = []
    for k in range(len(units)):
        train = [f for j, u in enumerate(units) if j != k for f in u]
        params.append(_fit_or(train, group, spec, fallback, settings, form))
    return params


def unit_errors(units: Units, group: str, params: Sequence[GroupParams],
                scope: str = "all") -> tuple[np.ndarray, np.ndarray]:
    """Squared errors of each unit under its own parameters.

    Parameters
    ----------
    units : sequence of sequence of AuditFrame
        Cross-validation units.
    group : str
        ``timing``, ``yaw`` or ``current``.
    params : sequence
        One parameter object per unit (e.g. from :func:`loro`).
    scope : str
        Samples scored (:func:`~terrain.audit.effects.scope_mask`, or ``straight_diff``).

    Returns
    -------
    sse : ndarray, shape (n_units,)
        Sum of squared errors per unit, (rad/s)^2 or A^2.
    n : ndarray, shape (n_units,)
        Scored samples (both sides count for currents).
    """
    sse_fn = GROUP_MODELS[group].sse
    out_s, out_n = [], []
    for unit, p in zip(units, params):
        s = n = 0
        for f in unit:
            a, b = sse_fn(f, p, scope)
            s += a
            n += b
        out_s.append(s)
        out_n.append(n)
    return np.asarray(out_s, dtype=float), np.asarray(out_n)


def keyed_rng(seed: int, *key: object) -> np.random.Generator:
    """A generator of its own for one draw of a table, from the seed and the draw's name.

    A table whose cells draw from one generator in the order they come gives each cell
    resamples that depend on which cells came before it (another signal in the table, the
    rows listed in another order, more resamples elsewhere move an interval). Each cell
    draws here from a stream of its own: numpy's :class:`~numpy.random.SeedSequence` of
    ``seed`` and a SHA-256 digest of the key's text (stable across processes, unlike the
    salted :func:`hash` of a string).

    Parameters
    ----------
    seed : int
        The table's seed (>= 0).
    *key : object
        The cell's name (e.g. terrain, signal, scope); each part is written with
        :func:`repr`, so ``("a", "b")`` and ``("a b",)`` are different cells.

    Returns
    -------
    numpy.random.Generator
        The same stream for the same seed and key, in any process.
    """
    digest = hashlib.sha256(repr(tuple(key)).encode()).digest()
    words = [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 16, 4)]
    return np.random.default_rng(np.random.SeedSequence([int(seed), *words]))


def stratified_resamples(strata: np.ndarray, rng: np.random.Generator, n_boot: int
                         ) -> np.ndarray:
    """Bootstrap resamples of units drawn with replacement within each stratum.

    A figure pooled over terrains is the terrain mix of the data: resampling units across
    terrains would give every resample its own mix, and the interval would measure the mix
    as much as the run-to-run spread. Each stratum keeps its count in every resample.

    Parameters
    ----------
    strata : ndarray, shape (n_units,)
        Stratum of each unit (its terrain).
    rng : numpy.random.Generator
        Draws the resamples.
    n_boot : int
        Number of resamples.

    Returns
    -------
    ndarray of int, shape (n_boot, n_units)
        Unit indices; the positions of a stratum's units hold draws among those units
        (strata drawn in sorted order). With one stratum, exactly
        ``rng.integers(0, n_units, (n_boot, n_units))``.
    """
    strata = np.asarray(strata)
    labels = np.unique(strata)
    if len(labels) <= 1:
        return rng.integers(0, len(strata), (n_boot, len(strata)))
    idx = np.empty((n_boot, len(strata)), dtype=np.int64)
    for label in labels:
        members = np.flatnonzero(strata == label)
        idx[:, members] = members[rng.integers(0, len(members), (n_boot, len(members)))]
    return idx


def has_spread(strata: np.ndarray) -> bool:
    """Whether resampling within strata can vary: some stratum holds two or more units.

    With one unit per stratum every resample of :func:`stratified_resamples` draws the same
    units, and a percentile interval over them is the point estimate itself: a certainty
    there is no unit-to-unit information for.

    Parameters
    ----------
    strata : ndarray, shape (n_units,)
        Stratum of each unit (its terrain).

    Returns
    -------
    bool
    """
    _, counts = np.unique(np.asarray(strata), return_counts=True)
    return bool(counts.size and counts.max() >= 2)


def _unit_key(unit: Sequence[AuditFrame]) -> tuple:
    """Sort key of a cross-validation unit: run id and start time of each of its frames."""
    return tuple((f.run_id, float(f.t_s[0])) for f in unit)


def _strata(units: Units) -> np.ndarray:
    """Terrain of each unit (every frame of a unit comes from one run), shape (n_units,)."""
    return np.asarray([unit[0].terrain for unit in units])


def bootstrap_gain(ref: np.ndarray, new: np.ndarray, base: np.ndarray,
                   rng: np.random.Generator, n_boot: int,
                   strata: np.ndarray | None = None) -> tuple[float, list[float]]:
    """Gain ``(sqrt(sum ref) - sqrt(sum new)) / sqrt(sum base)`` and its 95 % interval.

    Parameters
    ----------
    ref : ndarray, shape (n_units,)
        Per-unit squared-error sums of the model before the candidate.
    new : ndarray, shape (n_units,)
        The same with the candidate.
    base : ndarray, shape (n_units,)
        The same of the baseline (same samples in each).
    rng : numpy.random.Generator
        Draws the unit resamples.
    n_boot : int
        Number of resamples.
    strata : ndarray, shape (n_units,), optional
        Terrain of each unit: units are resampled within each terrain
        (:func:`stratified_resamples`); default one stratum.

    Returns
    -------
    gain : float
        Point estimate (fraction of the baseline RMSE).
    ci95 : list of float
        Percentile interval ``[2.5 %, 97.5 %]`` over unit resamples; ``[nan, nan]`` when
        every stratum holds a single unit (:func:`has_spread`: no interval, so the effect
        cannot be supported on it).
    """
    def gain(r, n, b):
        return (np.sqrt(r) - np.sqrt(n)) / np.sqrt(np.maximum(b, 1e-300))
    point = float(gain(ref.sum(), new.sum(), base.sum()))
    strata = np.zeros(len(ref)) if strata is None else strata
    if not has_spread(strata):
        return point, [float("nan"), float("nan")]
    idx = stratified_resamples(strata, rng, n_boot)
    g = gain(ref[idx].sum(axis=1), new[idx].sum(axis=1), base[idx].sum(axis=1))
    return point, [float(np.percentile(g, 2.5)), float(np.percentile(g, 97.5))]


def _param_ci(units: Units, group: str, spec: Sequence[str], name: str, form: str | None,
              settings: EffectSettings, rng: np.random.Generator,
              n_boot: int) -> dict[str, tuple[float, float]]:
    """Bootstrap interval of the parameter of ``name`` refitted on units resampled within
    each terrain (:func:`stratified_resamples`). A refit that fails (not identifiable) or
    gives a parameter that is not finite is no draw; fewer than
    ``max(MIN_PARAM_BOOTSTRAP, n_boot // 4)`` draws give no interval (empty)."""
    if n_boot <= 0:
        return {}
    fit = GROUP_MODELS[group].fit
    strata = _strata(units)
    draws = []
    for _ in range(n_boot):
        idx = stratified_resamples(strata, rng, 1)[0]
        frames = [f for i in idx for f in units[i]]
        try:
            p = fit(frames, list(spec), settings, form)
        except NotIdentifiable:
            continue
        values = effect_params(name, p)
        if np.all(np.isfinite(list(values.values()))):
            draws.append(values)
    if len(draws) < max(MIN_PARAM_BOOTSTRAP, n_boot // 4):
        return {}
    return {k: (float(np.percentile([d[k] for d in draws], 2.5)),
                float(np.percentile([d[k] for d in draws], 97.5))) for k in draws[0]}


def _form_of(name: str, params: GroupParams) -> str | None:
    """The functional form of an effect that has forms (kept fixed in its refits)."""
    if name in ("turning_resistance", "immobilised"):
        return params.form
    return None


def score_candidate(units: Units, group: str, spec: Sequence[str], name: str,
                    before: Sequence[GroupParams], effect_settings: EffectSettings,
                    rng: np.random.Generator, n_bootstrap: int) -> Trial:
    """Score one candidate added to the model ``spec`` on held-out units.

    Parameters
    ----------
    units : sequence of sequence of AuditFrame
        Cross-validation units.
    group : str
        ``timing``, ``yaw`` or ``current``.
    spec : sequence of str
        Effects already in the model.
    name : str
        Candidate effect.
    before : sequence
        Held-out parameters of the model ``spec`` (one per unit).
    effect_settings : EffectSettings
        Constants of the effect models.
    rng : numpy.random.Generator
        Draws the bootstrap resamples of the gain.
    n_bootstrap : int
        Number of resamples.

    Returns
    -------
    Trial

    Raises
    ------
    NotIdentifiable
        The data cannot identify the candidate, no unit has samples in its scope, or the
        replay has no error there (nothing to remove: no gain can be measured).
    """
    model = GROUP_MODELS[group]
    full = model.fit([f for u in units for f in u], list(spec) + [name], effect_settings)
    with_params = loro(units, group, list(spec) + [name], spec, effect_settings)
    scope = EFFECT_VOCABULARY[name].scope
    base, n = unit_errors(units, group, [model.no_effect() for _ in units], scope)
    ref, _ = unit_errors(units, group, before, scope)
    new, _ = unit_errors(units, group, with_params, scope)
    keep = n > 0                                 # units with samples where the effect acts
    if not keep.any():
        raise NotIdentifiable(f"no scored samples in scope {scope!r}")
    if base[keep].sum() <= 0:                    # (was reported as "no scored samples")
        raise NotIdentifiable(f"the replay has no error in scope {scope!r} on its "
                              f"{int(n.sum())} scored samples: nothing to remove")
    gain, ci = bootstrap_gain(ref[keep], new[keep], base[keep], rng, n_bootstrap,
                              _strata(units)[keep])
    n_all = max(n.sum(), 1)
    return Trial(name=name, scope=scope, heldout_params=tuple(with_params), gain=gain,
                 gain_ci95=(ci[0], ci[1]),
                 rmse_baseline=float(np.sqrt(base.sum() / n_all)),
                 rmse_before=float(np.sqrt(ref.sum() / n_all)),
                 rmse_with=float(np.sqrt(new.sum() / n_all)),
                 unphysical=unphysical(name, full),
                 negligible=negligible(name, full, effect_settings))


def is_supported(trial: Trial, settings: SelectionSettings) -> bool:
    """Whether a trial's effect joins the model.

    Parameters
    ----------
    trial : Trial
        A candidate of a round.
    settings : SelectionSettings
        ``min_gain``.

    Returns
    -------
    bool
        The lower end of the gain's 95 % interval is above 0, the gain is at least
        ``min_gain`` and the effect is neither unphysical nor negligible.
    """
    return trial.gain_ci95[0] > 0 and trial.gain >= settings.min_gain and trial.admissible


def forward_selection(units: Units, group: str, settings: SelectionSettings,
                      effect_settings: EffectSettings,
                      rng: np.random.Generator) -> SelectionPath:
    """Forward selection of the effects of one group (module docstring, steps 2-4).

    Each round scores every remaining candidate (:func:`score_candidate`); among those
    that are supported (:func:`is_supported`), the one with the largest gain joins the
    model; when none is supported the selection ends. Every round accepts one effect or
    ends, so there are at most as many rounds as effects in the group.

    Parameters
    ----------
    units : sequence of sequence of AuditFrame
        Cross-validation units.
    group : str
        ``timing``, ``yaw`` or ``current``.
    settings : SelectionSettings
        Bootstrap size and ``min_gain``.
    effect_settings : EffectSettings
        Constants of the effect models.
    rng : numpy.random.Generator
        Draws the bootstrap resamples.

    Returns
    -------
    SelectionPath
    """
    no_effect = tuple(GROUP_MODELS[group].no_effect() for _ in units)
    accepted: list[Trial] = []
    reasons: dict[str, str] = {}
    before = no_effect
    final_round: dict[str, Trial] = {}
    for _ in GROUPS[group]:
        spec = [t.name for t in accepted]
        trials: dict[str, Trial] = {}
        for name in GROUPS[group]:
            if name in spec or name in reasons:
                continue
            try:
                trials[name] = score_candidate(units, group, spec, name, before,
                                               effect_settings, rng, settings.n_bootstrap)
            except NotIdentifiable as exc:
                reasons[name] = str(exc)
        supported = [t for t in trials.values() if is_supported(t, settings)]
        if not supported:
            final_round = trials
            break
        best = max(supported, key=lambda t: t.gain)
        accepted.append(best)
        before = best.heldout_params
    return SelectionPath(accepted=tuple(accepted), final_round=final_round,
                         not_identifiable=reasons, heldout_params=tuple(before))


def effect_result(name: str, terrain: str, group: str, units: Units, path: SelectionPath,
                  final_params: GroupParams, effect_settings: EffectSettings,
                  rng: np.random.Generator, n_param_bootstrap: int,
                  references: Mapping[str, GroupParams] | None = None) -> EffectResult:
    """The reported result of one effect after forward selection (module docstring, step 5).

    Parameters
    ----------
    name : str
        Effect of ``group``.
    terrain : str
        Terrain label or ``all`` (reported).
    group : str
        ``timing``, ``yaw`` or ``current``.
    units : sequence of sequence of AuditFrame
        Cross-validation units.
    path : SelectionPath
        What forward selection did.
    final_params : LagParams or YawParams or CurrentParams
        Final model fitted on all units.
    effect_settings : EffectSettings
        Constants of the effect models.
    rng : numpy.random.Generator
        Draws the unit resamples of the parameter interval.
    n_param_bootstrap : int
        Number of resamples.
    references : mapping of str to parameters, optional
        Reference name -> a fixed model of ``group`` (e.g. ``ideal`` kinematics for the yaw
        rate); the effect's held-out gain against it, ``heldout_gain_vs_<name>``, is
        ``1 - RMSE_with / RMSE_reference`` on the effect's scope (the samples its
        ``heldout_gain`` is scored on).

    Returns
    -------
    EffectResult
    """
    spec = EFFECT_VOCABULARY[name]
    n_runs = len({f.run_id for u in units for f in u})
    supported = name in path.selected
    if name in path.not_identifiable and not supported:
        return EffectResult(name=name, terrain=terrain, group=group,
                            details={"scope": spec.scope}, cause=spec.cause,
                            reason=path.not_identifiable[name], n_units=len(units),
                            n_runs=n_runs)
    model = list(path.selected) if supported else list(path.selected) + [name]
    params = (final_params if supported
              else _fit_or([f for u in units for f in u], group, model, path.selected,
                           effect_settings))
    trial = path.trial(name)
    details = {"scope": spec.scope, **effect_details(name, params)}
    interval = None if trial is None else trial.gain_ci95
    if interval is not None and not np.all(np.isfinite(interval)):
        interval = None
        details["no_gain_interval"] = ("one unit per terrain in scope: resampling within "
                                       "terrains cannot vary")
    if trial is not None:
        for flag in ("unphysical", "negligible"):
            if getattr(trial, flag):
                details[flag] = getattr(trial, flag)
        details["heldout_rmse_baseline"] = trial.rmse_baseline
        details["heldout_rmse_before"] = trial.rmse_before
        details["heldout_rmse_with"] = trial.rmse_with
        for rname, rparams in (references or {}).items():
            # on the trial's own samples: its rmse_with is scored on the effect's scope
            rsse, rn = unit_errors(units, group, [rparams] * len(units), spec.scope)
            rmse_ref = float(np.sqrt(rsse.sum() / max(rn.sum(), 1)))
            details[f"heldout_gain_vs_{rname}"] = float(
                1.0 - trial.rmse_with / max(rmse_ref, 1e-300))
    ci = _param_ci(units, group, model, name, _form_of(name, params), effect_settings, rng,
                   n_param_bootstrap)
    return EffectResult(
        name=name, terrain=terrain, group=group, params=effect_params(name, params), ci95=ci,
        heldout_gain=None if trial is None else trial.gain,
        heldout_gain_ci95=interval,
        supported=supported, step=path.step(name), details=details,
        cause=effect_cause(name, params), n_units=len(units), n_runs=n_runs)


def select_group(units: Units, group: str, terrain: str,
                 settings: SelectionSettings = SelectionSettings(),
                 effect_settings: EffectSettings = EffectSettings(), segmented: bool = False,
                 references: Mapping[str, GroupParams] | None = None) -> GroupResult:
    """Forward selection of the effects of one group, and every effect's result.

    Parameters
    ----------
    units : sequence of sequence of AuditFrame
        Cross-validation units (at least 2); scored in run-id order (a run's segments by
        start time), so that the bootstrap intervals do not depend on their order here.
    group : str
        ``timing``, ``yaw`` or ``current``.
    terrain : str
        Terrain label or ``all`` (reported).
    settings : SelectionSettings
        Bootstrap sizes, ``min_gain``, seed.
    effect_settings : EffectSettings
        Constants of the effect models.
    segmented : bool
        Whether units are segments of runs (reported).
    references : mapping of str to parameters, optional
        Name -> a fixed model of ``group`` (e.g. ``ideal`` kinematics for the yaw rate,
        ``YawParams(kinematic=True, inverse_chi=1.0)``): its RMSE over all scored samples is
        reported (``reference_rmse``) and each effect's details carry its held-out gain
        relative to it on the effect's scope (:func:`effect_result`).

    Returns
    -------
    GroupResult

    Raises
    ------
    ConfigError
        Unknown group or fewer than 2 units.
    """
    if group not in GROUPS:
        raise ConfigError(f"unknown group {group!r}; valid: {list(GROUPS)}")
    if len(units) < 2:
        raise ConfigError(f"need at least 2 cross-validation units, got {len(units)}")
    # the bootstraps draw unit positions: in run-id order (segments of a run by their start),
    # the same runs listed in another order (a caller's own list) get the same intervals
    units = sorted(units, key=_unit_key)
    # separate streams: the gain resamples of the selection (the seed's own generator), and
    # each effect's parameter refits (keyed_rng; one stream drawn for both, n_bootstrap
    # moved every parameter interval)
    rng = np.random.default_rng(settings.seed)
    all_frames = [f for u in units for f in u]
    base_all, n_all = unit_errors(units, group, [GROUP_MODELS[group].no_effect()
                                                 for _ in units])
    path = forward_selection(units, group, settings, effect_settings, rng)
    final_params = _fit_or(all_frames, group, path.selected, [], effect_settings)
    final_all, _ = unit_errors(units, group, path.heldout_params)
    n_tot = max(int(n_all.sum()), 1)
    results = tuple(effect_result(name, terrain, group, units, path, final_params,
                                  effect_settings, keyed_rng(settings.seed, "param", name),
                                  settings.n_param_bootstrap, references)
                    for name in GROUPS[group])
    return GroupResult(
        group=group, terrain=terrain, selected=path.selected, effects=results,
        params=final_params, baseline_rmse=float(np.sqrt(base_all.sum() / n_tot)),
        final_rmse=float(np.sqrt(final_all.sum() / n_tot)),
        units=tuple(tuple(u) for u in units), heldout_params=path.heldout_params,
        segmented=segmented,
        reference_rmse={k: float(np.sqrt(unit_errors(units, group, [v] * len(units))[0].sum()
                                         / n_tot)) for k, v in (references or {}).items()})


def unscored_group(group: str, terrain: str, reason: str, n_runs: int) -> GroupResult:
    """A group that could not be scored at all (e.g. no run with an IMU).

    Parameters
    ----------
    group : str
        ``timing``, ``yaw`` or ``current``.
    terrain : str
        Terrain label or ``all``.
    reason : str
        Why (reported for every effect of the group).
    n_runs : int
        Runs of the terrain.

    Returns
    -------
    GroupResult
        Every effect listed as not supported with ``reason``.
    """
    effects = tuple(EffectResult(name=name, terrain=terrain, group=group,
                                 details={"scope": EFFECT_VOCABULARY[name].scope},
                                 cause=EFFECT_VOCABULARY[name].cause, reason=reason,
                                 n_units=0, n_runs=n_runs)
                    for name in GROUPS[group])
    return GroupResult(group=group, terrain=terrain, selected=(), effects=effects,
                       params=GROUP_MODELS[group].no_effect(), baseline_rmse=float("nan"),
                       final_rmse=float("nan"), units=(), heldout_params=(), segmented=False)


def make_units(frames: Sequence[AuditFrame], min_units: int,
               needs: Callable[[AuditFrame], bool],
               lag_settings: LagSettings = LagSettings(),
               frame_settings: FrameSettings = FrameSettings()
               ) -> tuple[list[list[AuditFrame]], bool]:
    """Cross-validation units from frames that have the needed signals.

    Parameters
    ----------
    frames : sequence of AuditFrame
        One per run.
    min_units : int
        Fewest units wanted; with fewer usable runs each run is cut into
        ``ceil(min_units / n_runs)`` contiguous segments.
    needs : callable
        ``needs(frame)`` is True when the frame can be scored.
    lag_settings : LagSettings
        Lag estimation of each segment (:func:`~terrain.audit.frames.split_frame`: a
        segment carries its own lag, not its run's).
    frame_settings : FrameSettings
        Filters and scored edges each segment is aligned with (the runs' own).

    Returns
    -------
    units : list of list of AuditFrame
        One unit per usable run, or per usable segment.
    segmented : bool
        True when runs were cut into segments (too few runs).
    """
    usable = [f for f in frames if needs(f)]
    if not usable:
        return [], False
    if len(usable) >= min_units:
        return [[f] for f in usable], False
    parts = int(np.ceil(min_units / len(usable)))
    units = [[p] for f in usable for p in split_frame(f, parts, lag_settings, frame_settings)
             if needs(p)]
    return units, True
