"""The audit report: a JSON-ready dict and a Markdown page (figures from
:mod:`terrain.audit.figures`).

The Markdown page is rendered from the Jinja2 template ``templates/audit_report.md.j2`` (the
prose); every number in it comes from the JSON report (results, and the settings recorded
under ``settings``).

JSON layout (``format = "terrain-audit/1"``): ``effects`` is a list whose items carry
``name``, ``terrain`` (a class or ``all``), ``group``, ``params`` (the vocabulary names of
:data:`terrain.audit.effects.EFFECT_VOCABULARY`), ``ci95``, ``heldout_gain`` (fraction of
the baseline RMSE removed on held-out runs), ``heldout_gain_ci95``, ``supported``, ``step``,
``details``, ``cause``, ``reason``, ``n_units``, ``n_runs``; ``signals`` gives the error per
signal and terrain of each model; ``residuals_by_manoeuvre``, ``residuals_by_run``, ``lags``
(per run), ``facts`` (model-free statistics), ``supported`` (terrain -> effect names,
``["none"]`` when no effect is supported) complete it.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import jinja2
import numpy as np
import pandas as pd

from terrain.audit.core import POOLED, AuditResult
from terrain.audit.effects import EFFECT_VOCABULARY, GROUP_SIGNALS
from terrain.io.jsonfile import json_ready, replace_text

FORMAT = "terrain-audit/1"
BASELINE = (
    "replay of the simulator's Husky model as is (terrain.sim dynamics on the run's "
    "catalogue terrain, level ground, every named effect off) driven by the run's own "
    "measured wheel speeds; predictions and IMU low-passed at the same cut-off and compared "
    "at the wheel timestamps; IMU signals read on the run's own aligned clock (wheel_lag "
    "track) except for the 'replay_raw' model")
MODELS: Mapping[str, str] = MappingProxyType({
    "ideal": "ideal differential drive (v_R - v_L)/B, yaw rate only",
    "replay_raw": "baseline on raw timestamps (no clock alignment), yaw rate only",
    "replay": "baseline (simulator replay) on the aligned clock",
    "extended": "replay + supported effects, held-out (leave-one-run-out) predictions",
})


def _records(frame: pd.DataFrame) -> list[dict]:
    return [json_ready(r) for r in frame.to_dict(orient="records")]


def signal_table(result: AuditResult) -> pd.DataFrame:
    """Error of each model per signal and terrain (all manoeuvres, runs pooled).

    Parameters
    ----------
    result : AuditResult
        Output of :func:`terrain.audit.run_audit`.

    Returns
    -------
    pandas.DataFrame
        Columns ``signal, terrain, n`` and ``<model>_rmse``, ``<model>_bias``,
        ``<model>_corr`` for each model, plus ``extended_gain`` (fraction of the aligned
        replay's RMSE removed by the extended model).
    """
    r = result.residuals
    if r.empty:
        return pd.DataFrame()
    r = r[(r.run_id == "*") & (r.manoeuvre == "all")]
    rows = []
    for (signal, terrain), g in r.groupby(["signal", "terrain"], sort=False):
        row = {"signal": signal, "terrain": terrain, "n": int(g.n.max())}
        for _, m in g.iterrows():
            for k in ("rmse", "bias", "corr"):
                row[f"{m.model}_{k}"] = m[k]
        if "replay_rmse" in row and "extended_rmse" in row and row["replay_rmse"] > 0:
            row["extended_gain"] = 1.0 - row["extended_rmse"] / row["replay_rmse"]
        rows.append(row)
    return pd.DataFrame(rows)


def to_dict(result: AuditResult, source: Mapping | None = None) -> dict:
    """The JSON report (module docstring).

    Parameters
    ----------
    result : AuditResult
        Output of :func:`terrain.audit.run_audit`.
    source : mapping, optional
        Where the runs came from (``runs_dir`` or ``dataset``), recorded as is.

    Returns
    -------
    dict
        JSON-serialisable.
    """
    effects = [e.as_dict() for e in result.effects()]
    scopes = result.terrains + ([POOLED] if any(e["terrain"] == POOLED for e in effects)
                                else [])
    supported = {t: (result.supported(t) or ["none"]) for t in scopes}
    r = result.residuals
    by_man = r[(r.run_id == "*")] if not r.empty else r
    by_run = r[(r.run_id != "*") & (r.manoeuvre == "all")] if not r.empty else r
    groups = [{"terrain": t, "group": g, "selected": list(res.selected),
               "baseline_rmse": res.baseline_rmse, "final_rmse": res.final_rmse,
               "signals": list(GROUP_SIGNALS[g]), "n_units": len(res.units),
               "segmented": res.segmented, "reference_rmse": res.reference_rmse}
              for (t, g), res in result.groups.items()]
    return json_ready({
        "format": FORMAT,
        "source": dict(source or {}),
        "baseline": BASELINE,
        "models": MODELS,
        "vocabulary": {k: {"group": v.group, "param": v.param, "unit": v.unit}
                       for k, v in EFFECT_VOCABULARY.items()},
        "runs": {"audited": [f.run_id for f in result.frames], "skipped": result.skipped},
        "terrains": result.terrains,
        "supported": supported,
        "effects": effects,
        "groups": groups,
        "signals": _records(signal_table(result)),
        "residuals_by_manoeuvre": _records(by_man.drop(columns=["run_id"])) if len(by_man) else [],
        "residuals_by_run": _records(by_run.drop(columns=["manoeuvre"])) if len(by_run) else [],
        "lags": _records(result.lags) if len(result.lags) else [],
        "facts": result.facts,
        "lateral_friction_sweep": _records(result.sweep) if len(result.sweep) else [],
        "settings": {k: (list(v) if isinstance(v, tuple) else v)
                     for k, v in result.settings.as_params().items()},
        "timings_s": result.timings_s,
    })


def flat_metrics(report: Mapping) -> dict[str, float]:
    """Numbers of a report as flat metric names (for MLflow).

    Parameters
    ----------
    report : mapping
        Output of :func:`to_dict`.

    Returns
    -------
    dict of str to float
        ``rmse_<model>__<signal>__<terrain>`` for the replay and the extended model,
        ``gain__<effect>__<terrain>`` and ``<param>__<effect>__<terrain>`` for supported
        effects, ``n_supported``, ``n_runs`` and ``time_<step>`` (s).
    """
    out: dict[str, float] = {}
    for s in report["signals"]:
        for model in ("replay", "extended"):
            v = s.get(f"{model}_rmse")
            if v is not None:
                out[f"rmse_{model}__{s['signal']}__{s['terrain']}"] = v
    for e in report["effects"]:
        if e["supported"]:
            key = f"{e['name']}__{e['terrain']}"
            out[f"gain__{key}"] = e["heldout_gain"]
            out.update({f"{p}__{key}": v for p, v in e["params"].items() if v is not None})
    out["n_supported"] = sum(bool(e["supported"]) for e in report["effects"])
    out["n_runs"] = len(report["runs"]["audited"])
    out.update({f"time_{k}": v for k, v in report["timings_s"].items()})
    return out


#: a stand-still current bias (measured - replayed) below minus this is reported as a finding, A
STANDSTILL_BIAS_FINDING_A = 2.0
#: how each scoring scope is described in the effects table
SCOPE_TEXT: Mapping[str, str] = MappingProxyType({
    "straight_diff": "scored on right - left in straight driving",
    "active": "scored near turns",
    "turning": "scored on turning samples", "moving": "scored on moving samples"})


def _fmt(v, nd: int = 3) -> str:
    """A number as table text: ``nd`` significant digits, ``-`` for missing or non-finite."""
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "-"
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return f"{float(v):.{nd}g}" if abs(float(v)) >= 1e-3 or v == 0 else f"{float(v):.2e}"


def _md_table(rows: Sequence[Sequence], header: Sequence[str]) -> str:
    """A Markdown pipe table (header, separator, one line per row)."""
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out)


def matching_lateral_friction(sweep: pd.DataFrame) -> str:
    """Lateral friction at which the replay's chi equals the measured one, as text.

    Linear interpolation between the two sweep points that bracket the measured chi; where
    the upper one's replay digs in completely (chi inf), no interpolation: the two
    frictions are given.

    Parameters
    ----------
    sweep : pandas.DataFrame
        One terrain's rows of :func:`terrain.audit.core.lateral_friction_sweep` (columns
        ``lateral_friction``, ``replay_chi``, ``measured_chi``).

    Returns
    -------
    str
        ``~<mu>``; ``between <mu_k> and <mu_k+1>`` when the replay's chi goes from below
        the measured chi to inf between them; ``below <lowest>`` / ``above <highest>``
        when the sweep does not bracket the measured chi (its ends bracket it: a friction
        whose replayed chi equals the measured one is ``~<that mu>``); ``-`` without a
        measured chi or without a replayed chi (no run of the terrain turns inside the
        scored span), or for an empty sweep. Frictions without a replayed chi are left out
        of the bracketing.
    """
    g = sweep.sort_values("lateral_friction")
    if g.empty:
        return "-"
    target = g.measured_chi.iloc[0]
    mu, chi = g.lateral_friction.to_numpy(float), g.replay_chi.to_numpy(float)
    if target is None or not np.isfinite(float(target)) or np.isnan(chi).all():
        return "-"
    # a NaN chi brackets nothing and failed every comparison, down to the "above" fall-through
    mu, chi = mu[~np.isnan(chi)], chi[~np.isnan(chi)]
    hit = np.flatnonzero(chi == float(target))
    if hit.size:        # a friction met exactly (the sweep's only point, or the last before
        return f"~{mu[hit[0]]:.2f}"      # digging in, was 'above' / 'between')
    for k in range(len(mu) - 1):
        if chi[k] <= target <= chi[k + 1] and np.isfinite(chi[k + 1]):
            frac = (target - chi[k]) / max(chi[k + 1] - chi[k], 1e-12)
            return f"~{mu[k] + frac * (mu[k + 1] - mu[k]):.2f}"
        if chi[k] <= target and chi[k + 1] == np.inf:   # digs in at the next friction
            return f"between {mu[k]:.3g} and {mu[k + 1]:.3g}"
    return f"below {mu[0]:.3g}" if target < chi[0] else f"above {mu[-1]:.3g}"


def _segmented_scopes(report: Mapping) -> set[tuple[str, str]]:
    """``(terrain, group)`` of the groups whose units are segments of runs."""
    return {(g["terrain"], g["group"]) for g in report["groups"] if g.get("segmented")}


def _timing_finding(report: Mapping) -> dict | None:
    """Numbers of the timing finding (None without any identifiable lag): ``constant``
    lists the terrains where a constant ``wheel_lag`` is supported across runs (held-out
    units are whole runs), ``constant_one_run`` those where it is supported between
    segments of a single run (nothing is known there about other runs), and
    ``constant_segments`` those where it is supported between segments of two or more runs
    (a held-out segment was fitted on its own run's other segments too: transfer between
    runs is not shown)."""
    lags = [x for x in report["lags"] if x["identifiable"]]
    if not lags:
        return None
    lag_effects = [e for e in report["effects"] if e["name"] == "wheel_lag" and e["supported"]]
    segmented = _segmented_scopes(report)
    drifts = [abs(x["drift_s_per_min"]) for x in lags if x["drift_s_per_min"] is not None]
    return {"n_runs": len(lags),
            "lag_min_s": min(x["lag_min_s"] for x in lags),
            "lag_max_s": max(x["lag_max_s"] for x in lags),
            "median_min_s": min(x["lag_s"] for x in lags),
            "median_max_s": max(x["lag_s"] for x in lags),
            "max_drift_s_per_min": max(drifts) if drifts else None,
            "constant": [e["terrain"] for e in lag_effects if e["n_runs"] >= 2
                         and (e["terrain"], e["group"]) not in segmented],
            "constant_one_run": [e["terrain"] for e in lag_effects if e["n_runs"] < 2],
            "constant_segments": [e["terrain"] for e in lag_effects if e["n_runs"] >= 2
                                  and (e["terrain"], e["group"]) in segmented]}


def _standstill_finding(report: Mapping) -> dict | None:
    """Numbers of the stand-still current finding (None when no terrain's replay bias at
    rest is below ``-STANDSTILL_BIAS_FINDING_A``)."""
    man = pd.DataFrame(report["residuals_by_manoeuvre"])
    if not len(man):
        return None
    stop = man[(man.manoeuvre == "stop") & (man.model == "replay")
               & man.signal.isin(["cur_l", "cur_r"]) & (man.terrain != "all")]
    bad = stop[stop.bias < -STANDSTILL_BIAS_FINDING_A]
    if not len(bad):
        return None
    return {"worst_bias_a": float(bad.bias.min()), "terrains": sorted(set(bad.terrain))}


def _sweep_table(report: Mapping) -> tuple[list[list], list[str]]:
    """Rows and header of the lateral-friction what-if table (empty without a sweep)."""
    sweep = pd.DataFrame(report.get("lateral_friction_sweep") or [])
    if not len(sweep):
        return [], []
    rows = []
    for t, g in sweep.groupby("terrain", sort=False):
        rows.append([t, _fmt(g.measured_chi.iloc[0]), int(g.n_runs.iloc[0]),
                     matching_lateral_friction(g)]
                    + [f"{_fmt(r.lateral_friction)}: {_fmt(r.replay_chi)}"
                       for r in g.itertuples()])
    width = max(len(r) for r in rows)
    rows = [r + [""] * (width - len(r)) for r in rows]
    header = (["terrain", "measured chi", "runs", "mu_lat matching it"]
              + [f"mu_lat: chi ({k + 1})" for k in range(width - 4)])
    return rows, header


def _manoeuvre_rows(report: Mapping) -> list[list] | None:
    """Rows of the residuals-by-manoeuvre table (None without residuals)."""
    man = pd.DataFrame(report["residuals_by_manoeuvre"])
    if not len(man):
        return None
    man = man[man.model.isin(["replay", "extended"]) & (man.manoeuvre != "all")]
    piv = man.pivot_table(index=["signal", "terrain", "manoeuvre"], columns="model",
                          values=["rmse", "bias", "n"], aggfunc="first")
    rows = []
    for (signal, terrain, m), r in piv.iterrows():
        n = r[("n", "replay")]                   # a count: the pivot made it a float
        rows.append([signal, terrain, m, _fmt(int(n) if np.isfinite(n) else None),
                     _fmt(r[("rmse", "replay")]), _fmt(r[("bias", "replay")]),
                     _fmt(r.get(("rmse", "extended"))), _fmt(r.get(("bias", "extended")))])
    return rows


def _environment() -> jinja2.Environment:
    """The template environment: package templates, strict undefined names, the ``do``
    extension, and the filters ``fmt`` (numbers) and ``md_table`` (pipe tables)."""
    env = jinja2.Environment(loader=jinja2.PackageLoader("terrain.audit", "templates"),
                             undefined=jinja2.StrictUndefined, trim_blocks=True,
                             lstrip_blocks=True, keep_trailing_newline=True,
                             autoescape=False, extensions=["jinja2.ext.do"])
    env.filters["fmt"] = _fmt
    env.filters["md_table"] = _md_table
    return env


def to_markdown(report: Mapping, figures: Mapping[str, str] | None = None,
                commands: Sequence[str] = (), title: str = "Simulation audit") -> str:
    """The Markdown report, rendered from ``templates/audit_report.md.j2``.

    Every number in the page comes from ``report`` (results, and the settings it records
    under ``settings``); the template holds the prose.

    Parameters
    ----------
    report : mapping
        Output of :func:`to_dict`.
    figures : mapping of str to str, optional
        Figure key -> relative path of its image (keys of
        :func:`terrain.audit.figures.make_figures`); figures not given are left out.
    commands : sequence of str
        Shell commands that reproduce the report (from the repository root).
    title : str
        Page title.

    Returns
    -------
    str
        Markdown text ending with a newline.

    Raises
    ------
    jinja2.UndefinedError
        ``report`` lacks a field of the :func:`to_dict` layout.
    """
    effects = report["effects"]
    findings = []
    for t in report["supported"]:
        found = [e for e in effects if e["terrain"] == t and e["supported"]]
        found.sort(key=lambda e: (e["group"], e["step"] or 0))
        findings.append((t, found))
    causes = []
    for name, spec in EFFECT_VOCABULARY.items():
        if any(e["name"] == name for e in effects):
            causes.append((name, spec.cause))
        # a supported effect fitted the other way round says so (effects.effect_cause)
        causes += [(f"{name} on {e['terrain']}", e["cause"]) for e in effects
                   if e["name"] == name and e["supported"] and e["cause"] != spec.cause]
    scopes = _segmented_scopes(report)
    segmented = sorted(f"{t} ({g})" for t, g in scopes)
    # segments of two or more runs: a held-out segment is fitted on its own run's others
    segmented_runs = sorted({f"{e['terrain']} ({e['group']})" for e in effects
                             if (e["terrain"], e["group"]) in scopes and e["n_runs"] >= 2})
    sweep_rows, sweep_header = _sweep_table(report)
    return _environment().get_template("audit_report.md.j2").render(
        report=report, settings=report["settings"], figures=dict(figures or {}),
        commands=list(commands), title=title, findings=findings, causes=causes,
        segmented=segmented, segmented_runs=segmented_runs, timing=_timing_finding(report),
        standstill=_standstill_finding(report), scope_text=SCOPE_TEXT,
        sweep_rows=sweep_rows, sweep_header=sweep_header,
        manoeuvre_rows=_manoeuvre_rows(report))


def figures_folder(path: Path) -> Path:
    """The folder of a Markdown report's figures, ``<stem>_figures`` beside it.

    Parameters
    ----------
    path : pathlib.Path
        The Markdown file.

    Returns
    -------
    pathlib.Path
        ``path.parent / f"{path.stem}_figures"``.
    """
    path = Path(path)
    return path.parent / f"{path.stem}_figures"


def write_markdown(path: Path, report: Mapping, figures: Mapping[str, Any],
                   commands: Sequence[str] = (), title: str = "Simulation audit",
                   appendix: str = "") -> None:
    """Write the Markdown report at ``path`` and its figures in ``<stem>_figures/`` beside it
    (:func:`figures_folder`), whole or not at all.

    The page is rendered and every figure saved (in a temporary folder beside ``path``)
    before anything of an earlier report is touched: a failure leaves the earlier page and
    its figures as they were. The figures folder then holds this report's figures only (an
    ``audit_<key>.png`` of an earlier report that this one has not is removed).

    Parameters
    ----------
    path : pathlib.Path
        Markdown file to write (its folder is created).
    report : mapping
        Output of :func:`to_dict`.
    figures : mapping of str to matplotlib.figure.Figure
        Figures by key (:func:`terrain.audit.figures.make_figures`), saved as
        ``audit_<key>.png`` at 90 dpi and linked by relative paths.
    commands : sequence of str
        Shell commands that reproduce the report (from the repository root).
    title : str
        Page title.
    appendix : str, optional
        Markdown appended to the page (e.g. the physics comparison).

    Raises
    ------
    jinja2.UndefinedError, KeyError
        ``report`` lacks a field of the :func:`to_dict` layout (nothing written).
    OSError
        A figure or the page cannot be written (the earlier report left as it was).
    """
    path = Path(path)
    folder = figures_folder(path)
    names = {k: f"audit_{k}.png" for k in figures}
    text = to_markdown(report, {k: f"{folder.name}/{n}" for k, n in names.items()},
                       commands, title) + appendix
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{folder.name}.partial-", dir=path.parent))
    try:
        for key, fig in figures.items():
            fig.savefig(stage / names[key], dpi=90)
        folder.mkdir(exist_ok=True)
        for old in folder.glob("audit_*.png"):    # an earlier report's figure this one lacks
            if old.name not in names.values():
                old.unlink()
        for name in names.values():
            os.replace(stage / name, folder / name)
        replace_text(path, text)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def summary_lines(report: Mapping, timings_s: Mapping[str, float]) -> list[str]:
    """A short text summary of a report for the terminal.

    Parameters
    ----------
    report : mapping
        Output of :func:`to_dict`.
    timings_s : mapping of str to float
        Wall time of each step, s (summed in the first line).

    Returns
    -------
    list of str
        ``audited N runs (...)`` then one line per terrain with its supported effects,
        parameters and held-out gains (``none`` without any); a gain scored on held-out
        segments of runs (a group with too few runs, ``groups[].segmented``) says so,
        with the number of runs cut, as the Markdown report does: it is no run-to-run
        figure.
    """
    runs = report["runs"]
    # a gain between segments of one run read like a leave-one-run-out gain here (only
    # the Markdown said otherwise): one run gave "ICE: icr_expansion (chi=1.48; gain 0.38)"
    segmented = {(g["terrain"], g["group"]) for g in report.get("groups", ())
                 if g.get("segmented")}

    def held_out(e):
        if (e["terrain"], e.get("group")) not in segmented:
            return ""
        n = e.get("n_runs")
        return f" on held-out segments of {n} run{'' if n == 1 else 's'}"
    out = [f"audited {len(runs['audited'])} runs ({', '.join(report['terrains'])}), skipped "
           f"{len(runs['skipped'])}; {sum(timings_s.values()):.1f} s"]
    for terrain in report["supported"]:
        found = [e for e in report["effects"] if e["terrain"] == terrain and e["supported"]]
        text = ", ".join(
            f"{e['name']} ({', '.join(f'{k}={_g(v)}' for k, v in e['params'].items())}"
            f"; gain {e['heldout_gain']:.2f}{held_out(e)})" for e in found)
        out.append(f"  {terrain}: {text or 'none'}")
    return out


def _g(value) -> str:
    """A parameter for printing: ``n/a`` when it could not be estimated (e.g. a dead gyro)."""
    return "n/a" if value is None else f"{value:.3g}"
