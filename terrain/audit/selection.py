"""Held-out scoring of effects: leave-one-run-out, bootstrap support, forward selection.

Protocol, for one group of signals (``timing``, ``yaw``, ``current``) and one terrain (or all
runs pooled):

1. Cross-validation units are the runs; when a terrain has fewer than ``min_units`` runs with
   the needed signals, each run is cut into contiguous segments that serve as units
   (leave-one-segment-out, reported as such).
2. The baseline (the replay, no effect) is scored on every unit: squared errors summed per
   unit.
3. Forward selection: every effect not yet in the model is added in turn; the extended model
   is fitted on all units but one and scored on the one left out, for every unit. The gain of
   a candidate is the fraction of the baseline RMSE it removes on held-out units, measured on
   the samples where the effect acts (:data:`~terrain.audit.effects.SCOPES`):
   ``(RMSE_before - RMSE_with) / RMSE_baseline`` (RMSE pooled over held-out samples).
4. Support: units (those with samples in the effect's scope) are resampled with
   replacement (``n_bootstrap`` times) and the gain is recomputed from the resampled per-unit
   errors; the effect is supported when the lower end of the 95 % percentile interval is
   above 0 *and* the gain is at least ``min_gain`` *and* its fitted size is not negligible
   (:func:`negligible`) *and* it does not contradict its physics (:func:`unphysical`).
   The best supported candidate joins the model and step 3 repeats; when the best candidate
   is not supported, selection stops and every remaining candidate is reported with its
   increment over the final model and ``supported = false``.
5. Parameters are fitted on all units with the final model (an unsupported effect: final
   model plus that effect); their 95 % intervals come from refitting on units resampled with
   replacement (``n_param_bootstrap`` times; the functional form is kept fixed).

A fold whose training units hold no information on a candidate (e.g. the only run with turns
is held out) predicts with the model without that candidate.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from terrain.audit.effects import (CAUSES, GROUP_MODELS, GROUPS, SCOPES, CurrentParams,
                                   EffectSettings, LagParams, NotIdentifiable, YawParams,
                                   effect_details, effect_params)
from terrain.audit.frames import AuditFrame
from terrain.errors import ConfigError

_DEFAULTS: Mapping[str, type] = MappingProxyType(
    {"timing": LagParams, "yaw": YawParams, "current": CurrentParams})


def json_ready(v: Any, nd: int = 5) -> Any:
    """``v`` with numpy scalars turned into Python ones, floats rounded to ``nd`` decimals,
    non-finite floats to ``None``, recursively through mappings, lists and tuples."""
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return None if not np.isfinite(v) else round(float(v), nd)
    if isinstance(v, Mapping):
        return {str(k): json_ready(x, nd) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [json_ready(x, nd) for x in v]
    return v


@dataclass(frozen=True)
class SelectionSettings:
    """Settings of the held-out scoring.

    Parameters
    ----------
    n_bootstrap : int
        Resamples of held-out units for the gain interval.
    n_param_bootstrap : int
        Resamples of units for the parameter intervals (refits).
    min_gain : float
        Smallest gain (fraction of baseline RMSE) an effect must bring to be supported.
    min_units : int
        Fewest cross-validation units; terrains with fewer runs are cut into segments.
    seed : int
        Seed of the bootstrap generator.
    """

    n_bootstrap: int = 1000
    n_param_bootstrap: int = 200
    min_gain: float = 0.02
    min_units: int = 4
    seed: int = 0

    def __post_init__(self) -> None:
        if self.n_bootstrap < 10 or self.n_param_bootstrap < 0:
            raise ConfigError("n_bootstrap must be >= 10 and n_param_bootstrap >= 0")
        if self.min_units < 2:
            raise ConfigError(f"min_units must be >= 2, got {self.min_units}")


@dataclass(frozen=True)
class EffectResult:
    """One effect scored on one terrain (or ``all``).

    Attributes
    ----------
    name, terrain, group : str
    params : dict
        Vocabulary parameter(s), e.g. ``{"chi": 1.55}`` (empty when not identifiable).
    ci95 : dict
        Parameter name -> ``[low, high]`` bootstrap interval over units.
    heldout_gain : float or None
        Fraction of the baseline RMSE removed on held-out units (increment at the effect's
        step; for unsupported effects, increment over the final model).
    heldout_gain_ci95 : list or None
        Bootstrap interval of the gain.
    supported : bool
    step : int or None
        Order in which the effect joined the model (1 = first), None if not selected.
    details : dict
        Form, secondary parameters, RMSE before/after.
    cause : str
        Plain-language cause.
    reason : str or None
        Why the effect could not be fitted (not identifiable), if so.
    n_units, n_runs : int
        Cross-validation units and distinct runs.
    """

    name: str
    terrain: str
    group: str
    params: dict
    ci95: dict
    heldout_gain: float | None
    heldout_gain_ci95: list | None
    supported: bool
    step: int | None
    details: dict
    cause: str
    reason: str | None
    n_units: int
    n_runs: int

    def as_dict(self) -> dict:
        """JSON-ready dict."""
        return {"name": self.name, "terrain": self.terrain, "group": self.group,
                "params": json_ready(self.params), "ci95": json_ready(self.ci95),
                "heldout_gain": json_ready(self.heldout_gain),
                "heldout_gain_ci95": json_ready(self.heldout_gain_ci95),
                "supported": bool(self.supported), "step": self.step,
                "details": json_ready(self.details), "cause": self.cause, "reason": self.reason,
                "n_units": self.n_units, "n_runs": self.n_runs}


@dataclass(frozen=True)
class GroupResult:
    """Forward selection of one group on one terrain.

    Attributes
    ----------
    group, terrain : str
    selected : tuple of str
        Supported effects in order of selection.
    effects : tuple of EffectResult
        Every effect of the group.
    params : Any
        Final model fitted on all units (YawParams, CurrentParams or LagParams).
    baseline_rmse, final_rmse : float
        Held-out RMSE of the replay and of the final model (pooled over units).
    units : tuple of tuple of AuditFrame
    heldout_params : tuple
        Final-model parameters fitted without each unit (same order as ``units``).
    segmented : bool
        Whether runs were cut into segments to get enough units.
    reference_rmse : dict
        Held-out RMSE of extra reference models (e.g. ``ideal`` kinematics for the yaw rate).
    """

    group: str
    terrain: str
    selected: tuple[str, ...]
    effects: tuple[EffectResult, ...]
    params: Any
    baseline_rmse: float
    final_rmse: float
    units: tuple
    heldout_params: tuple
    segmented: bool
    reference_rmse: dict = field(default_factory=dict)


def negligible(name: str, params, settings: EffectSettings) -> str | None:
    """Why a fitted effect is too small to matter (None if it is not); floors in
    :attr:`EffectSettings.negligible`."""
    floor = dict(settings.negligible).get(name)
    if floor is None:
        return None
    if name == "icr_expansion":
        size = abs(params.chi / params.chi_replay - 1.0) if np.isfinite(params.chi_replay) \
            else np.inf
        text = f"chi {params.chi:.3g} within {100 * floor:.0f} % of the replay's {params.chi_replay:.3g}"
    else:
        size = abs(next(iter(effect_params(name, params).values())))
        text = f"{next(iter(effect_params(name, params)))} = {size:.3g} below {floor}"
    return text if size < floor else None


def unphysical(name: str, params) -> str | None:
    """Why a fitted effect contradicts its physics (None if it does not).

    ``grade_resistance`` must cost current: a slope in either direction adds gravity load to
    the flat-ground replay (seed 003 eq. 10), so ``k_a_per_rad <= 0`` means the pitch
    estimate is correlated with something else (accelerations, vibration) and the effect is
    not supported whatever its gain.
    """
    if name == "grade_resistance" and not params.k_a_per_rad > 0:
        return (f"k_a_per_rad = {params.k_a_per_rad:.3g} <= 0: slopes would lower the "
                "current, which no grade resistance does")
    return None


def _fit_or(fit: Callable, frames: Sequence[AuditFrame], spec: Sequence[str],
            fallback: Sequence[str], settings: EffectSettings, group: str,
            form: str | None = None):
    try:
        return fit(frames, list(spec), settings, form)
    except NotIdentifiable:
        try:
            return fit(frames, list(fallback), settings)
        except NotIdentifiable:
            return _DEFAULTS[group]()


def loro(units: Sequence[Sequence[AuditFrame]], group: str, spec: Sequence[str],
         fallback: Sequence[str], settings: EffectSettings, form: str | None = None) -> list:
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
    form : str, optional
        Functional form forced on the effect that has forms.

    Returns
    -------
    list
        One fitted parameter object per unit (fitted on all the other units).
    """
    fit, _ = GROUP_MODELS[group]
    params = []
    for k in range(len(units)):
        train = [f for j, u in enumerate(units) if j != k for f in u]
        params.append(_fit_or(fit, train, spec, fallback, settings, group, form))
    return params


def unit_errors(units: Sequence[Sequence[AuditFrame]], group: str, params: Sequence,
                scope: str = "all") -> tuple[np.ndarray, np.ndarray]:
    """Squared errors of each unit under its own parameters.

    Parameters
    ----------
    units : sequence of sequence of AuditFrame
    group : str
    params : sequence
        One parameter object per unit (e.g. from :func:`loro`).
    scope : str
        Samples scored (:func:`~terrain.audit.effects.scope_mask`).

    Returns
    -------
    sse : ndarray, shape (n_units,)
    n : ndarray, shape (n_units,)
        Scored samples (both sides count for currents).
    """
    _, sse_fn = GROUP_MODELS[group]
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


def bootstrap_gain(ref: np.ndarray, new: np.ndarray, base: np.ndarray,
                   rng: np.random.Generator, n_boot: int) -> tuple[float, list[float]]:
    """Gain ``(sqrt(sum ref) - sqrt(sum new)) / sqrt(sum base)`` and its 95 % interval.

    Parameters
    ----------
    ref, new, base : ndarray, shape (n_units,)
        Per-unit squared-error sums of the model before, with the candidate, and of the
        baseline (same samples in each).
    rng : numpy.random.Generator
    n_boot : int

    Returns
    -------
    gain : float
    ci95 : list of float
        Percentile interval ``[2.5 %, 97.5 %]`` over unit resamples.
    """
    def gain(r, n, b):
        return (np.sqrt(r) - np.sqrt(n)) / np.sqrt(np.maximum(b, 1e-300))
    point = float(gain(ref.sum(), new.sum(), base.sum()))
    idx = rng.integers(0, len(ref), (n_boot, len(ref)))
    g = gain(ref[idx].sum(axis=1), new[idx].sum(axis=1), base[idx].sum(axis=1))
    return point, [float(np.percentile(g, 2.5)), float(np.percentile(g, 97.5))]


def _param_ci(units, group: str, spec: Sequence[str], name: str, form: str | None,
              settings: EffectSettings, rng: np.random.Generator, n_boot: int) -> dict:
    if n_boot <= 0:
        return {}
    fit, _ = GROUP_MODELS[group]
    draws = []
    for _ in range(n_boot):
        idx = rng.integers(0, len(units), len(units))
        frames = [f for i in idx for f in units[i]]
        try:
            p = fit(frames, list(spec), settings, form)
        except NotIdentifiable:
            continue
        draws.append(effect_params(name, p))
    if len(draws) < max(5, n_boot // 4):
        return {}
    return {k: [float(np.nanpercentile([d[k] for d in draws], 2.5)),
                float(np.nanpercentile([d[k] for d in draws], 97.5))] for k in draws[0]}


def _form_of(name: str, params) -> str | None:
    if name == "turning_resistance":
        return params.form
    if name == "immobilised":
        return params.form
    return None


def select_group(units: Sequence[Sequence[AuditFrame]], group: str, terrain: str,
                 settings: SelectionSettings = SelectionSettings(),
                 effect_settings: EffectSettings = EffectSettings(), segmented: bool = False,
                 references: dict[str, np.ndarray] | None = None) -> GroupResult:
    """Forward selection of the effects of one group (module docstring).

    Parameters
    ----------
    units : sequence of sequence of AuditFrame
        Cross-validation units (at least 2).
    group : str
        ``timing``, ``yaw`` or ``current``.
    terrain : str
        Terrain label or ``all`` (reported).
    settings : SelectionSettings
    effect_settings : EffectSettings
    segmented : bool
        Whether units are segments of runs (reported).
    references : dict, optional
        Name -> per-unit squared-error sums of extra reference models (e.g. ``ideal``
        kinematics for the yaw rate); each effect's details then carry its held-out gain
        relative to them.

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
    rng = np.random.default_rng(settings.seed)
    fit, _ = GROUP_MODELS[group]
    all_frames = [f for u in units for f in u]
    n_runs = len({f.run_id for f in all_frames})
    base_params = [_DEFAULTS[group]() for _ in units]
    base_all, n_all = unit_errors(units, group, base_params)
    ref_params = base_params
    spec: list[str] = []
    steps: dict[str, dict] = {}
    reasons: dict[str, str] = {}
    last: dict[str, dict] = {}
    while True:
        trials = {}
        for c in GROUPS[group]:
            if c in spec or c in reasons:
                continue
            try:
                full = fit(all_frames, spec + [c], effect_settings)
            except NotIdentifiable as exc:
                reasons[c] = str(exc)
                continue
            new_params = loro(units, group, spec + [c], spec, effect_settings)
            scope = SCOPES[c]
            base, n = unit_errors(units, group, base_params, scope)
            ref, _ = unit_errors(units, group, ref_params, scope)
            new, _ = unit_errors(units, group, new_params, scope)
            keep = n > 0                         # units with samples where the effect acts
            if base[keep].sum() <= 0:
                reasons[c] = f"no scored samples in scope {scope!r}"
                continue
            gain, ci = bootstrap_gain(ref[keep], new[keep], base[keep], rng,
                                      settings.n_bootstrap)
            trials[c] = {"params": new_params, "gain": gain, "ci": ci, "scope": scope,
                         "rmse_before": float(np.sqrt(ref.sum() / max(n.sum(), 1))),
                         "rmse_with": float(np.sqrt(new.sum() / max(n.sum(), 1))),
                         "rmse_baseline": float(np.sqrt(base.sum() / max(n.sum(), 1))),
                         "sse_all": unit_errors(units, group, new_params)[0],
                         "unphysical": unphysical(c, full),
                         "negligible": negligible(c, full, effect_settings)}
        if not trials:
            break
        ok = [c for c in trials if not (trials[c]["unphysical"] or trials[c]["negligible"])]
        if not ok:
            last = trials
            break
        best = max(ok, key=lambda c: trials[c]["gain"])
        t = trials[best]
        if t["ci"][0] > 0 and t["gain"] >= settings.min_gain and not t["negligible"]:
            spec.append(best)
            steps[best] = {**t, "step": len(spec)}
            ref_params = t["params"]
            continue
        last = trials
        break
    final_params = _fit_or(fit, all_frames, spec, [], effect_settings, group)
    final_all, _ = unit_errors(units, group, ref_params)
    n_tot = max(int(n_all.sum()), 1)
    results = []
    for name in GROUPS[group]:
        info = steps.get(name) or last.get(name)
        model = spec if name in steps else spec + [name]
        if name in reasons and name not in steps:
            results.append(EffectResult(
                name, terrain, group, {}, {}, None, None, False, None,
                {"scope": SCOPES[name]}, CAUSES[name], reasons[name], len(units), n_runs))
            continue
        params = (final_params if name in steps
                  else _fit_or(fit, all_frames, model, spec, effect_settings, group))
        details = {"scope": SCOPES[name], **effect_details(name, params)}
        for flag in ("unphysical", "negligible"):
            if info is not None and info.get(flag):
                details[flag] = info[flag]
        if info is not None:
            details["heldout_rmse_baseline"] = info["rmse_baseline"]
            details["heldout_rmse_before"] = info["rmse_before"]
            details["heldout_rmse_with"] = info["rmse_with"]
            for rname, rsse in (references or {}).items():
                details[f"heldout_gain_vs_{rname}"] = float(
                    1.0 - np.sqrt(info["sse_all"].sum() / max(rsse.sum(), 1e-300)))
        form = _form_of(name, params)
        ci = _param_ci(units, group, model, name, form, effect_settings, rng,
                       settings.n_param_bootstrap)
        results.append(EffectResult(
            name=name, terrain=terrain, group=group, params=effect_params(name, params),
            ci95=ci, heldout_gain=None if info is None else info["gain"],
            heldout_gain_ci95=None if info is None else info["ci"],
            supported=name in steps, step=steps[name]["step"] if name in steps else None,
            details=details, cause=CAUSES[name], reason=None, n_units=len(units),
            n_runs=n_runs))
    return GroupResult(
        group=group, terrain=terrain, selected=tuple(spec), effects=tuple(results),
        params=final_params, baseline_rmse=float(np.sqrt(base_all.sum() / n_tot)),
        final_rmse=float(np.sqrt(final_all.sum() / n_tot)), units=tuple(tuple(u) for u in units),
        heldout_params=tuple(ref_params), segmented=segmented,
        reference_rmse={k: float(np.sqrt(v.sum() / n_tot)) for k, v in (references or {}).items()})


def unscored_group(group: str, terrain: str, reason: str, n_runs: int) -> GroupResult:
    """A group that could not be scored at all (e.g. no run with an IMU): every effect is
    listed as not supported with ``reason``."""
    effects = tuple(EffectResult(name, terrain, group, {}, {}, None, None, False, None,
                                 {"scope": SCOPES[name]}, CAUSES[name], reason, 0, n_runs)
                    for name in GROUPS[group])
    return GroupResult(group=group, terrain=terrain, selected=(), effects=effects,
                       params=_DEFAULTS[group](), baseline_rmse=float("nan"),
                       final_rmse=float("nan"), units=(), heldout_params=(), segmented=False)


def make_units(frames: Sequence[AuditFrame], min_units: int,
               needs: Callable[[AuditFrame], bool]) -> tuple[list[list[AuditFrame]], bool]:
    """Cross-validation units from frames that have the needed signals.

    Parameters
    ----------
    frames : sequence of AuditFrame
        One per run.
    min_units : int
    needs : callable
        ``needs(frame)`` is True when the frame can be scored.

    Returns
    -------
    units : list of list of AuditFrame
    segmented : bool
        True when runs were cut into segments (too few runs).
    """
    from terrain.audit.frames import split_frame

    usable = [f for f in frames if needs(f)]
    if not usable:
        return [], False
    if len(usable) >= min_units:
        return [[f] for f in usable], False
    parts = int(np.ceil(min_units / len(usable)))
    units = [[p] for f in usable for p in split_frame(f, parts) if needs(p)]
    return units, True
