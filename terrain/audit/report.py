"""The audit report: a JSON-ready dict and a Markdown page (figures from
:mod:`terrain.audit.figures`).

JSON layout (``format = "terrain-audit/1"``): ``effects`` is a list whose items carry ``name``,
``terrain`` (a class or ``all``), ``group``, ``params`` (the vocabulary names of
:data:`terrain.audit.effects.EFFECT_VOCABULARY`), ``ci95``, ``heldout_gain`` (fraction of the baseline
RMSE removed on held-out runs), ``heldout_gain_ci95``, ``supported``, ``step``, ``details``,
``cause``, ``reason``, ``n_units``, ``n_runs``; ``signals`` gives the error per signal and
terrain of each model; ``residuals_by_manoeuvre``, ``residuals_by_run``, ``lags`` (per run),
``facts`` (model-free statistics), ``supported`` (terrain -> effect names, ``["none"]`` when
no effect is supported) complete it.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from terrain.audit.core import POOLED, AuditResult
from terrain.audit.effects import EFFECT_VOCABULARY, GROUP_SIGNALS
from terrain.audit.selection import json_ready

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

    ``rmse_<model>__<signal>__<terrain>`` for the replay and the extended model,
    ``gain__<effect>__<terrain>`` and ``<param>__<effect>__<terrain>`` for supported effects,
    ``n_supported``, ``n_runs`` and ``time_<step>``.
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


def _fmt(v, nd: int = 3) -> str:
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "-"
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return f"{float(v):.{nd}g}" if abs(float(v)) >= 1e-3 or v == 0 else f"{float(v):.2e}"


def _table(header: Sequence[str], rows: Sequence[Sequence]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out)


def _param_text(e: Mapping) -> str:
    parts = []
    for k, v in (e.get("params") or {}).items():
        ci = (e.get("ci95") or {}).get(k)
        parts.append(f"{k} = {_fmt(v)}" + (f" [{_fmt(ci[0])}, {_fmt(ci[1])}]" if ci else ""))
    return ", ".join(parts) or "-"


def _gain_text(e: Mapping) -> str:
    g = e.get("heldout_gain")
    if g is None:
        return "-"
    ci = e.get("heldout_gain_ci95")
    return f"{g:.3f}" + (f" [{ci[0]:.3f}, {ci[1]:.3f}]" if ci else "")


def _detail_text(e: Mapping) -> str:
    d = e.get("details") or {}
    keep = []
    if d.get("form"):
        keep.append(f"form {d['form']}")
    if e["name"] == "immobilised" and d.get("chi_mobile") is not None:
        keep.append(f"mobile model {d.get('mobile_model')} (chi {_fmt(d['chi_mobile'])})")
        if d.get("threshold_rad_s") is not None:
            fr = d.get("fractions") or [None, None]
            keep.append(f"digs in above |x| = {_fmt(d['threshold_rad_s'])} rad/s "
                        f"(immobile {_fmt(fr[0], 2)} below, {_fmt(fr[1], 2)} above)")
    if e["name"] == "turning_resistance":
        for form in ("coulomb", "proportional"):
            v = d.get(f"heldout_rmse_turning_{form}")
            if v is not None:
                keep.append(f"held-out turning RMSE {form} {_fmt(v)} A")
    if e["name"] == "icr_expansion" and d.get("heldout_gain_vs_ideal") is not None:
        keep.append(f"gain vs ideal drive {d['heldout_gain_vs_ideal']:.2f}")
    scope_text = {"straight_diff": "scored on right - left in straight driving",
                  "active": "scored near turns",
                  "turning": "scored on turning samples", "moving": "scored on moving samples"}
    if d.get("scope") in scope_text:
        keep.append(scope_text[d["scope"]])
    if e["name"] == "current_offset" and d.get("common_a") is not None:
        keep.append(f"left {_fmt(d['offset_left_a'])} A, right {_fmt(d['offset_right_a'])} A")
    if d.get("unphysical"):
        keep.append(f"rejected: {d['unphysical']}")
    if d.get("negligible"):
        keep.append(f"negligible: {d['negligible']}")
    if e.get("reason"):
        keep.append(f"not identifiable: {e['reason']}")
    return "; ".join(keep)


def _sentence(e: Mapping) -> str:
    p = e["params"]
    name = e["name"]
    g = e["heldout_gain"]
    if name == "icr_expansion":
        return (f"the robot turns {p['chi']:.2f} times slower than ideal differential drive "
                f"(chi = {p['chi']:.2f}); fitting chi removes {100 * g:.0f} % of the replay's "
                f"yaw-rate error in turns on held-out runs")
    if name == "immobilised":
        d = e["details"]
        extra = ""
        if d.get("threshold_rad_s") is not None:
            extra = (f"; it digs in mostly when the wheels command more than "
                     f"{d['threshold_rad_s']:.2f} rad/s")
        return (f"the robot is immobilised (digs in) during {100 * p['fraction']:.0f} % of "
                f"its turning time while the wheels keep spinning; mobile turns have chi "
                f"{d.get('chi_mobile', float('nan')):.2f}{extra}; this removes "
                f"{100 * g:.0f} % of the replay's yaw-rate error in turns on held-out runs")
    if name == "current_offset":
        return (f"driving straight, the right motor reads {p['offset_a']:.2f} A more than the "
                f"left (held-out gain {100 * g:.0f} % on straight samples)")
    if name == "turning_resistance":
        d = e["details"]
        word = "more" if p["k_a"] > 0 else "less"
        return (f"turning costs {abs(p['k_a']):.2f} A per side {word} than simulated at the "
                f"reference turn ({d.get('form')} form; held-out gain {100 * g:.0f} % on "
                f"turning samples)")
    if name == "grade_resistance":
        return (f"current grows by {p['k_a_per_rad']:.1f} A per rad of pitch (held-out gain "
                f"{100 * g:.0f} %)")
    if name == "gyro_bias":
        return f"the gyro is offset by {p['bias_rad_s']:.4f} rad/s (held-out gain {100 * g:.0f} %)"
    if name == "wheel_lag":
        return (f"the wheel stream is {p['lag_s']:.2f} s late on every run (held-out gain "
                f"{100 * g:.0f} %)")
    return name


def _general_findings(report: Mapping) -> list[str]:
    """Findings across terrains: timing, stand-still currents."""
    out = []
    lags = [x for x in report["lags"] if x["identifiable"]]
    if lags:
        lag_effects = [e for e in report["effects"] if e["name"] == "wheel_lag"]
        constant = [e["terrain"] for e in lag_effects if e["supported"]]
        drifts = [abs(x["drift_s_per_min"]) for x in lags if x["drift_s_per_min"] is not None]
        text = (f"- **Timing**: in the {len(lags)} runs where it is identifiable, the wheel "
                f"stream is offset from the IMU by {min(x['lag_min_s'] for x in lags):+.2f} "
                f"to {max(x['lag_max_s'] for x in lags):+.2f} s (per-run medians "
                f"{min(x['lag_s'] for x in lags):+.2f} to {max(x['lag_s'] for x in lags):+.2f}"
                " s)")
        if drifts:
            text += f", drifting by up to {max(drifts):.2f} s per minute within a run"
        text += ("; a constant lag transfers between runs on " + ", ".join(constant)
                 if constant else "; no constant lag transfers from run to run "
                 "(`wheel_lag` is not supported as a constant), so every comparison uses the "
                 "run's own lag track")
        out.append(text + ".")
    man = pd.DataFrame(report["residuals_by_manoeuvre"])
    if len(man):
        stop = man[(man.manoeuvre == "stop") & (man.model == "replay")
                   & man.signal.isin(["cur_l", "cur_r"]) & (man.terrain != "all")]
        bad = stop[stop.bias < -2.0]
        if len(bad):
            worst = bad.loc[bad.bias.idxmin()]
            out.append(
                f"- **Stand-still currents**: with both wheels at rest the replay predicts "
                f"far more current than the robot draws (bias down to {worst.bias:.1f} A, on "
                f"{', '.join(sorted(set(bad.terrain)))}). An earlier cause, contact "
                "chatter when a wheel is held at exactly zero speed while the body still "
                "moves (biases down to -11 A), was removed by the simulator's low-speed slip "
                "regularisation (`terrain.sim.dynamics.SLIP_SPEED_FLOOR_M_S`); the cause of "
                "what remains is not established. No effect of the vocabulary covers it; the "
                "current effects are scored on moving samples.")
    return out


def matching_lateral_friction(sweep: pd.DataFrame) -> str:
    """Lateral friction at which the replay's chi equals the measured one, as text.

    Linear interpolation between the two sweep points that bracket the measured chi;
    ``below <lowest>`` / ``above <highest>`` when the sweep does not bracket it, ``-``
    without a measured chi.
    """
    g = sweep.sort_values("lateral_friction")
    target = g.measured_chi.iloc[0]
    if target is None or not np.isfinite(float(target)):
        return "-"
    mu, chi = g.lateral_friction.to_numpy(float), g.replay_chi.to_numpy(float)
    for k in range(len(mu) - 1):
        if chi[k] <= target <= chi[k + 1] and np.isfinite(chi[k + 1]):
            frac = (target - chi[k]) / max(chi[k + 1] - chi[k], 1e-12)
            return f"~{mu[k] + frac * (mu[k + 1] - mu[k]):.2f}"
    return f"below {mu[0]:.3g}" if target < chi[0] else f"above {mu[-1]:.3g}"


def to_markdown(report: Mapping, figures: Mapping[str, str] | None = None,
                commands: Sequence[str] = (), title: str = "Simulation audit") -> str:
    """The Markdown report.

    Parameters
    ----------
    report : mapping
        Output of :func:`to_dict`.
    figures : mapping, optional
        Figure key -> relative path of its image (keys of
        :func:`terrain.audit.figures.make_figures`).
    commands : sequence of str
        Shell commands that reproduce the report.
    title : str

    Returns
    -------
    str
    """
    figures = dict(figures or {})
    effects = report["effects"]
    lines = [f"# {title}", ""]
    runs = report["runs"]
    lines += [f"Audited runs: {len(runs['audited'])} ({', '.join(report['terrains'])})"
              + (f"; skipped {len(runs['skipped'])}: " + "; ".join(
                  f"{k} ({v})" for k, v in runs["skipped"].items()) if runs["skipped"] else "")
              + ".", ""]
    if report.get("source"):
        lines += ["Source: " + ", ".join(f"{k} `{v}`" for k, v in report["source"].items()), ""]
    if commands:
        lines += ["Reproduce:", "", "```", *commands, "```", ""]
    lines += ["**Baseline**: " + report["baseline"] + ".", "",
              "**Method**: each effect is fitted on training runs and scored on held-out runs "
              "(leave one run out within a terrain; `all` pools every run). Its held-out gain "
              "is the fraction of the baseline RMSE it removes, measured on the samples where "
              "it acts. An effect is **supported** when the 95 % bootstrap interval of that "
              "gain (runs resampled with replacement) lies above 0 and the gain is at least "
              f"{report['settings'].get('selection.min_gain')}, its size is above a "
              "practical floor and its parameter does not contradict its physics. Effects join the model one at a time, best first "
              "(forward selection). Parameter intervals are bootstrap intervals over runs.", ""]
    seg = sorted({f"{g['terrain']} ({g['group']})" for g in report["groups"]
                  if g.get("segmented")})
    if seg:
        lines += ["Too few runs for leave-one-run-out in " + ", ".join(seg) + ": their runs "
                  "were cut into contiguous segments, left out one at a time.", ""]

    lines += ["## Findings", ""]
    for t, names in report["supported"].items():
        found = [e for e in effects if e["terrain"] == t and e["supported"]]
        found.sort(key=lambda e: (e["group"], e["step"] or 0))
        if not found:
            lines.append(f"- **{t}**: none of the effects is supported.")
            continue
        lines.append(f"- **{t}**: " + "; ".join(_sentence(e) for e in found) + ".")
    lines += _general_findings(report)
    lines.append("")

    sig = pd.DataFrame(report["signals"])
    if len(sig):
        lines += ["## Error per signal and terrain", "",
                  "RMSE (rad/s, m/s^2, A), bias = mean(measured - predicted), correlation. "
                  "`ideal` is ideal differential drive (yaw rate only); `raw` is the replay "
                  "without clock alignment.", ""]
        rows = []
        for _, s in sig.iterrows():
            rows.append([s.signal, s.terrain, _fmt(s.get("ideal_rmse")),
                         _fmt(s.get("replay_raw_rmse")), _fmt(s.get("replay_rmse")),
                         _fmt(s.get("replay_bias")), _fmt(s.get("replay_corr")),
                         _fmt(s.get("extended_rmse")), _fmt(s.get("extended_corr")),
                         _fmt(s.get("extended_gain"), 2)])
        lines += [_table(["signal", "terrain", "ideal RMSE", "replay RMSE (raw)",
                          "replay RMSE", "replay bias", "replay corr", "extended RMSE",
                          "extended corr", "gain"], rows), ""]
        if "rmse" in figures:
            lines += [f"![RMSE of the replay and of the extended model]({figures['rmse']})", ""]

    lines += ["## Effects", "",
              "Every effect of the vocabulary on every terrain: parameters with 95 % "
              "intervals, held-out gain with its interval, support.", ""]
    rows = []
    for e in effects:
        rows.append([e["terrain"], e["name"], _param_text(e), _gain_text(e),
                     "**yes**" if e["supported"] else "no", _detail_text(e)])
    lines += [_table(["terrain", "effect", "parameters [95 % CI]", "held-out gain [95 % CI]",
                      "supported", "details"], rows), ""]
    lines += ["Causes (plain language):", ""]
    for name in EFFECT_VOCABULARY:
        cause = next((e["cause"] for e in effects if e["name"] == name), None)
        if cause:
            lines.append(f"- `{name}`: {cause}")
    lines.append("")

    lines += ["## Yaw rate", ""]
    if "yaw" in figures:
        lines += [f"![Gyro yaw rate against the commanded (v_R - v_L)/B]({figures['yaw']})", ""]
    facts = report["facts"]
    rows = [[t, _fmt(f.get("chi_pooled")), _fmt(f.get("straight_mean_abs_wz_rad_s"))]
            for t, f in facts.items()]
    lines += [_table(["terrain", "chi (least squares, all turning samples)",
                      "mean abs wz driving straight (rad/s)"], rows), ""]
    if "example" in figures:
        lines += [f"![One run: measured, replayed and extended signals]({figures['example']})",
                  ""]

    lines += ["## Timing (`wheel_lag`)", "",
              "Lag of the wheel stream behind the IMU, per run (positive = wheel data late), "
              "estimated in 30 s windows. Runs without any window where the commanded yaw "
              "rate varies and the gyro follows it are left out.", ""]
    lag_rows = [[x["run_id"], _fmt(x["lag_s"]), _fmt(x["lag_start_s"]), _fmt(x["lag_end_s"]),
                 f"{_fmt(x['lag_min_s'])} .. {_fmt(x['lag_max_s'])}",
                 _fmt(x["drift_s_per_min"]), f"{x['n_windows_used']}/{x['n_windows']}"]
                for x in report["lags"] if x["identifiable"]]
    n_not = sum(1 for x in report["lags"] if not x["identifiable"])
    if lag_rows:
        lines += [_table(["run", "median lag (s)", "first window (s)", "last window (s)",
                          "range (s)", "drift (s/min)", "windows used"], lag_rows), ""]
    lines += [f"{n_not} run(s) with IMU have no identifiable lag.", ""]
    if "lags" in figures:
        lines += [f"![Lag of the wheel stream over time, per run]({figures['lags']})", ""]

    lines += ["## Motor currents", ""]
    rows = [[t, _fmt(f.get("current_straight_a")), _fmt(f.get("current_curve_a")),
             _fmt(f.get("current_spin_a")), _fmt(f.get("spin_to_straight_current_ratio"), 2),
             _fmt(f.get("straight_right_minus_left_a"))] for t, f in facts.items()]
    lines += ["Measured mean current per side (A), model-free:", "",
              _table(["terrain", "straight", "curve", "spin", "spin / straight",
                      "right - left, straight"], rows), ""]
    if "currents" in figures:
        lines += [f"![Mean current per side against the commanded turn rate]"
                  f"({figures['currents']})", ""]

    sweep = pd.DataFrame(report.get("lateral_friction_sweep") or [])
    if len(sweep):
        lines += ["## What-if: catalogue lateral friction", "",
                  "The replayed robot's own chi (least squares of (v_R - v_L)/B on the replayed "
                  "yaw rate over turning samples) when the catalogue `lateral_friction` of the "
                  "terrain is scaled; `inf` = the replayed robot digs in completely.", ""]
        rows = []
        for t, g in sweep.groupby("terrain", sort=False):
            rows.append([t, _fmt(g.measured_chi.iloc[0]), int(g.n_runs.iloc[0]),
                         matching_lateral_friction(g)]
                        + [f"{_fmt(r.lateral_friction)}: {_fmt(r.replay_chi)}"
                           for r in g.itertuples()])
        width = max(len(r) for r in rows)
        rows = [r + [""] * (width - len(r)) for r in rows]
        lines += [_table(["terrain", "measured chi", "runs", "mu_lat matching it"]
                         + [f"mu_lat: chi ({k + 1})" for k in range(width - 4)], rows), ""]

    man = pd.DataFrame(report["residuals_by_manoeuvre"])
    if len(man):
        lines += ["## Residuals by manoeuvre", "",
                  "RMSE and bias (measured - predicted) of the replay and of the extended "
                  "model per manoeuvre (stop, straight, curve = turning while moving, spin = "
                  "turning in place).", ""]
        man = man[man.model.isin(["replay", "extended"]) & (man.manoeuvre != "all")]
        piv = man.pivot_table(index=["signal", "terrain", "manoeuvre"], columns="model",
                              values=["rmse", "bias", "n"], aggfunc="first")
        rows = []
        for (signal, terrain, m), r in piv.iterrows():
            rows.append([signal, terrain, m, _fmt(r[("n", "replay")]),
                         _fmt(r[("rmse", "replay")]), _fmt(r[("bias", "replay")]),
                         _fmt(r.get(("rmse", "extended"))), _fmt(r.get(("bias", "extended")))])
        lines += [_table(["signal", "terrain", "manoeuvre", "n", "replay RMSE", "replay bias",
                          "extended RMSE", "extended bias"], rows), ""]
    lines += [f"Timings: " + ", ".join(f"{k} {v:.1f} s" for k, v in report["timings_s"].items()),
              ""]
    return "\n".join(lines)
