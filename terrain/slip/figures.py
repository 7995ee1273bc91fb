"""Figures of the slip-model evaluation (``terrain slip-fit``); matplotlib, no global state."""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd


def error_figure(errors: pd.DataFrame, terrains: Sequence[str]):
    """Median absolute slip error per terrain and model, steady straight driving.

    A terrain without a score for a model (not among the runs, or the model undefined
    there) gets no bar, marked "n/a".

    Parameters
    ----------
    errors : pandas.DataFrame
        ``slip_errors.csv`` of ``terrain slip-fit`` (columns ``split, model, windows,
        terrain, median_abs_err``).
    terrains : sequence of str
        Terrains to show.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    sel = errors[(errors["windows"] == "steady_straight") & errors["terrain"].isin(terrains)]
    sel = sel.assign(label=np.where(sel["split"] == "held-out seeds", sel["model"],
                                    sel["model"] + " (" + sel["split"] + ")"))
    table = sel.pivot_table(index="terrain", columns="label", values="median_abs_err")
    table = table.reindex(list(terrains))
    fig = Figure(figsize=(9, 4))
    ax = fig.add_subplot()
    width = 0.8 / max(1, table.shape[1])
    x = np.arange(len(table))
    for k, col in enumerate(table.columns):
        # no score (terrain not simulated, model undefined there): no bar and "n/a", not a
        # bar at the axis floor that reads as the smallest error
        heights = table[col].to_numpy(dtype=float) + 1e-5
        ax.bar(x + k * width, heights, width, label=col)
        for i in np.flatnonzero(np.isnan(heights)):
            ax.text(x[i] + k * width, 0.02, "n/a", rotation=90, ha="center", va="bottom",
                    fontsize=6, transform=ax.get_xaxis_transform())
    ax.axhline(0.02, color="k", ls="--", lw=1, label="target 0.02")
    ax.set_yscale("log")
    ax.set_xticks(x + 0.4 - width / 2, table.index)
    ax.set_ylabel("median |slip error| (held-out seeds)")
    ax.set_title("Steady straight driving, simulated Husky")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return fig


def odometry_figure(odometry: pd.DataFrame):
    """Final position error of plain and compensated dead reckoning per held-out run.

    Parameters
    ----------
    odometry : pandas.DataFrame
        ``odometry.csv`` of ``terrain slip-fit``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    odo = odometry[~odometry["slid_off"].astype(bool)]
    groups = list(odo.groupby("scenario"))
    fig = Figure(figsize=(4.5 * max(1, len(groups)), 4))
    bars = [("plain_err_pct", "wheel odometry"), ("compensated_err_pct", "slip + chi"),
            ("compensated_gyro_err_pct", "slip + gyro heading")]
    bars = [b for b in bars if b[0] in odo.columns]
    w = 0.8 / len(bars)
    for k, (scen, g) in enumerate(groups):
        ax = fig.add_subplot(1, len(groups), k + 1)
        x = np.arange(len(g))
        for j, (col, label) in enumerate(bars):
            ax.bar(x - 0.4 + (j + 0.5) * w, g[col], w, label=label)
        ax.set_xticks(x, g["terrain"], rotation=70, fontsize=7)
        ax.set_ylabel("final position error, % of distance")
        ax.set_title(scen)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig
