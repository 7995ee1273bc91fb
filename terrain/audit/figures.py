"""Figures of the audit report (matplotlib :class:`~matplotlib.figure.Figure` objects built
without pyplot, so no global figure state and no GUI backend is involved).

:func:`make_figures` returns every figure by key: ``yaw`` (gyro against the commanded yaw
rate per terrain with the fitted chi), ``lags`` (lag tracks per run), ``rmse`` (replay vs
extended RMSE per signal and terrain), ``currents`` (mean current against the commanded
turn rate), ``example`` (time series of one run).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from terrain.audit.core import POOLED, AuditResult
from terrain.audit.effects import predict_current, predict_yaw
from terrain.audit.frames import STOP
from terrain.vehicles.icr import icr_expansion_factor

_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
           "tab:pink", "tab:gray", "tab:olive", "tab:cyan")


def _grid(n: int, width: float = 4.0, height: float = 3.2) -> tuple[Figure, np.ndarray]:
    cols = min(n, 3)
    rows = int(np.ceil(n / cols))
    fig = Figure(figsize=(width * cols, height * rows))
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig, axes


def _heldout(result: AuditResult, terrain: str, group: str):
    res = result.groups.get((terrain, group))
    if res is None:
        return []
    return [(f, p) for unit, p in zip(res.units, res.heldout_params) for f in unit]


def fig_yaw(result: AuditResult, max_points: int = 4000, seed: int = 0) -> Figure:
    """Aligned gyro yaw rate against ``(v_R - v_L) / B`` per terrain.

    With the ideal line, the replay's effective chi
    (:func:`terrain.vehicles.icr.icr_expansion_factor` over turning samples) and the fitted
    ``icr_expansion`` / ``immobilised`` chi.

    Parameters
    ----------
    result : AuditResult
        Output of :func:`terrain.audit.run_audit`.
    max_points : int
        Scored samples drawn per panel.
    seed : int
        Seed of the sample draw.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per terrain.
    """
    terrains = result.terrains
    fig, axes = _grid(len(terrains))
    rng = np.random.default_rng(seed)
    for ax, t in zip(axes, terrains):
        fs = [f for f in result.frames if f.terrain == t and f.has_imu]
        if not fs:
            ax.set_title(f"{t}: no IMU")
            continue
        x = np.concatenate([f.commanded_yaw_rate[f.score_imu] for f in fs])
        if not x.size:  # e.g. a run shorter than the settling time: nothing scored
            ax.set_title(f"{t}: no scored IMU sample")
            continue
        y = np.concatenate([f.wz[f.score_imu] for f in fs])
        s = np.concatenate([f.sim_wz[f.score_imu] for f in fs])
        idx = rng.permutation(len(x))[:max_points]
        ax.scatter(x[idx], y[idx], s=3, alpha=0.3, color="tab:gray", label="gyro (aligned)")
        lim = max(float(np.percentile(np.abs(x), 99.5)), 0.2)
        grid = np.linspace(-lim, lim, 3)
        ax.plot(grid, grid, "k--", lw=1, label="ideal (chi = 1)")
        turn = np.abs(x) >= result.settings.frames.turn_rad_s
        chi_r = icr_expansion_factor(s[turn], x[turn]) if turn.sum() > 10 else np.inf
        if np.isfinite(chi_r):
            ax.plot(grid, grid / chi_r, color="tab:blue", lw=1.2,
                    label=f"replay (chi {chi_r:.2f})")
        res = result.groups.get((t, "yaw"))
        if res is not None and res.params.kinematic:
            ax.plot(grid, grid / res.params.chi, color="tab:red", lw=1.5,
                    label=f"fitted chi {res.params.chi:.2f}")
        ax.set_title(t)
        ax.set_xlabel("(v_R - v_L)/B (rad/s)")
        ax.set_ylabel("wz (rad/s)")
        ax.legend(fontsize=7, loc="upper left")
        ax.grid(alpha=0.3)
    fig.suptitle("Yaw rate: gyro against the wheels' command")
    fig.tight_layout()
    return fig


def fig_lags(result: AuditResult) -> Figure:
    """Lag of the wheel stream behind the IMU over time, one line per run.

    Parameters
    ----------
    result : AuditResult
        Output of :func:`terrain.audit.run_audit`.

    Returns
    -------
    matplotlib.figure.Figure
        Lag (s) against time in run (s: from the run's first wheel sample, whatever its
        clock's origin), runs with an identifiable lag.
    """
    fig = Figure(figsize=(10, 4.5))
    ax = fig.subplots()
    terrains = result.terrains
    for f in result.frames:
        if not f.has_imu or not f.lag.identifiable:
            continue
        c = _COLORS[terrains.index(f.terrain) % len(_COLORS)]
        # time in run: the window centres are wheel-clock times, 1.7e9 s on an epoch clock
        t_run = f.lag.centres_s - f.t_s[0]
        ax.plot(t_run, f.lag.lags_s, "o-", color=c, ms=3, lw=1)
        ax.annotate(f.run_id.split("/", 1)[-1], (t_run[-1], f.lag.lags_s[-1]),
                    fontsize=6, color=c)
    for t in terrains:
        ax.plot([], [], color=_COLORS[terrains.index(t) % len(_COLORS)], label=t)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("time in run (s)")
    ax.set_ylabel("lag of wheel stream (s)")
    ax.set_title(f"wheel_lag per run ({result.settings.lag.window_s:g} s windows)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def fig_rmse(result: AuditResult) -> Figure:
    """Replay (aligned) and extended held-out RMSE per signal and terrain.

    Parameters
    ----------
    result : AuditResult
        Output of :func:`terrain.audit.run_audit`.

    Returns
    -------
    matplotlib.figure.Figure
        One bar panel per signal (rad/s, m/s^2, A).
    """
    r = result.residuals
    r = r[(r.run_id == "*") & (r.manoeuvre == "all")]
    signals = [s for s in ("wz", "ay", "ax", "cur_l", "cur_r") if s in set(r.signal)]
    fig, axes = _grid(len(signals), 4.2, 3.0)
    for ax, s in zip(axes, signals):
        g = r[r.signal == s]
        scopes = [t for t in result.terrains + [POOLED] if t in set(g.terrain)]
        xs = np.arange(len(scopes))
        for k, (model, c) in enumerate((("replay", "tab:blue"), ("extended", "tab:red"))):
            vals = [float(g[(g.terrain == t) & (g.model == model)].rmse.iloc[0])
                    if len(g[(g.terrain == t) & (g.model == model)]) else np.nan for t in scopes]
            ax.bar(xs + (k - 0.5) * 0.38, vals, width=0.38, color=c, label=model)
        ax.set_xticks(xs, scopes, rotation=30, ha="right", fontsize=7)
        ax.set_title(s)
        ax.set_ylabel("RMSE")
        ax.legend(fontsize=7)
    fig.suptitle("Held-out RMSE: replay vs replay + supported effects")
    fig.tight_layout()
    return fig


def fig_currents(result: AuditResult, n_bins: int = 8) -> Figure:
    """Mean current per side against ``|v_R - v_L| / B``: measured, replay, extended.

    Parameters
    ----------
    result : AuditResult
        Output of :func:`terrain.audit.run_audit`.
    n_bins : int
        Quantile bins of the commanded turn rate.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per terrain (moving samples, held-out predictions).
    """
    terrains = result.terrains
    fig, axes = _grid(len(terrains))
    for ax, t in zip(axes, terrains):
        pairs = _heldout(result, t, "current")
        if not pairs:
            ax.set_title(f"{t}: -")
            continue
        x, meas, rep, ext = [], [], [], []
        for f, p in pairs:
            m = f.score_cur & (f.manoeuvre != STOP)
            x.append(np.abs(f.commanded_yaw_rate[m]))
            meas.append(f.cur[m].mean(axis=1))
            rep.append(f.sim_cur[m].mean(axis=1))
            ext.append(predict_current(f, p)[m].mean(axis=1))
        x, meas, rep, ext = (np.concatenate(a) for a in (x, meas, rep, ext))
        if not x.size:  # no scored moving sample (a short run, dead current sensors)
            ax.set_title(f"{t}: no scored current sample")
            continue
        edges = np.unique(np.quantile(x, np.linspace(0, 1, n_bins + 1)))
        if len(edges) < 3:
            edges = np.linspace(x.min(), x.max() + 1e-6, 3)
        b = np.clip(np.digitize(x, edges) - 1, 0, len(edges) - 2)
        centres = [x[b == k].mean() for k in range(len(edges) - 1) if np.any(b == k)]
        for vals, lab, style in ((meas, "measured", "ko-"), (rep, "replay", "s--"),
                                 (ext, "extended (held-out)", "^-")):
            ax.plot(centres, [vals[b == k].mean() for k in range(len(edges) - 1)
                              if np.any(b == k)], style, ms=4, label=lab)
        ax.set_title(t)
        ax.set_xlabel("|v_R - v_L|/B (rad/s)")
        ax.set_ylabel("mean current per side (A)")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle("Motor current against the commanded turn rate (moving samples)")
    fig.tight_layout()
    return fig


def fig_example(result: AuditResult, run_id: str | None = None) -> Figure:
    """Time series of one run: gyro vs replay vs extended, currents vs replay vs extended.

    Parameters
    ----------
    result : AuditResult
        Output of :func:`terrain.audit.run_audit`.
    run_id : str, optional
        Run to show; default (or unknown id): the run with IMU whose commanded yaw rate
        crosses the turn threshold most often.

    Returns
    -------
    matplotlib.figure.Figure
        Yaw rate (rad/s) and currents (A) against time (s); empty without a run that has
        both held-out yaw and current predictions.
    """
    pairs: dict[str, dict[str, list]] = {}
    for t in result.terrains:
        for group in ("yaw", "current"):
            for f, p in _heldout(result, t, group):
                pairs.setdefault(f.run_id, {}).setdefault(group, []).append((f, p))
    candidates = [k for k, v in pairs.items() if "yaw" in v and "current" in v]
    fig = Figure(figsize=(12, 6))
    if not candidates:
        return fig
    if run_id not in candidates:
        turn_rad_s = result.settings.frames.turn_rad_s

        def transitions(k):                          # turns started or ended in scored time
            return sum(int(np.sum(np.diff(
                (np.abs(f.commanded_yaw_rate[f.score_imu]) >= turn_rad_s).astype(int)) != 0))
                for f, _ in pairs[k]["yaw"])
        run_id = max(candidates, key=transitions)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for f, p in pairs[run_id]["yaw"]:
        m = f.score_imu
        ax1.plot(f.t_s[m], f.wz[m], "k", lw=1, label="gyro (aligned)")
        ax1.plot(f.t_s[m], f.sim_wz[m], "tab:blue", lw=1, label="replay")
        ax1.plot(f.t_s[m], predict_yaw(f, p)[m], "tab:red", lw=1, label="extended (held-out)")
    for f, p in pairs[run_id]["current"]:
        m = f.score_cur
        pred = predict_current(f, p)
        for j, (side, ls) in enumerate((("left", "-"), ("right", ":"))):
            ax2.plot(f.t_s[m], f.cur[m, j], "k" + ls, lw=1, label=f"measured {side}")
            ax2.plot(f.t_s[m], f.sim_cur[m, j], ls, color="tab:blue", lw=1,
                     label=f"replay {side}")
            ax2.plot(f.t_s[m], pred[m, j], ls, color="tab:red", lw=1,
                     label=f"extended {side}")
    for ax in (ax1, ax2):
        h, lab = ax.get_legend_handles_labels()
        uniq = dict(zip(lab, h))
        ax.legend(uniq.values(), uniq.keys(), fontsize=7, ncol=3)
        ax.grid(alpha=0.3)
    ax1.set_ylabel("yaw rate (rad/s)")
    ax2.set_ylabel("current (A)")
    ax2.set_xlabel("time (s)")
    ax1.set_title(run_id)
    fig.tight_layout()
    return fig


def make_figures(result: AuditResult) -> dict[str, Figure]:
    """Every figure of the report, by key (module docstring).

    Parameters
    ----------
    result : AuditResult
        Output of :func:`terrain.audit.run_audit`.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        ``yaw``, ``rmse``, ``currents``, ``example`` and, when any run has an identifiable
        lag, ``lags``.
    """
    out = {"yaw": fig_yaw(result), "rmse": fig_rmse(result),
           "currents": fig_currents(result), "example": fig_example(result)}
    if any(f.has_imu and f.lag.identifiable for f in result.frames):
        out["lags"] = fig_lags(result)
    return out
