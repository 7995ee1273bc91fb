"""Figures of ``docs/estimation_validation.md`` and ``docs/sim_validation.md``.

``terrain validate REPORT --out FILE`` (:mod:`pipelines.validate`) draws each figure of
:data:`FIGURES` beside FILE as ``<FILE stem>_<name>.png`` (:func:`figures`):

* ``estimation``, ``slip_tracking``: the tables' first scenario (thesis ``straight_accel``,
  AgriMaRo, fine encoder, seed 1; seed ``001_59da564c4b2d6a48.txt`` ch. 7.2.3) over time,
  what the "Steady-state slip error per wheel" table sums up: the ``noise`` tuning follows
  the true slip once the drive settles, the ``thesis`` tuning (eqs. 6.9/6.13/6.14) stays
  0.07-0.09 low on grass and gravel (the ch. 4.6 "modelling blindness"); below it the
  ``noise`` tuning's NIS per degree of freedom in 1 s bins (seed 001 eqs. 4.14, 4.16);
* ``sim``, ``straight_line``: the simulated true slip of the same scenario against the
  thesis's measured steady range and peak
  (:data:`pipelines.validation.sim_tables.THESIS_STRAIGHT_LINE`).

Nothing in the library imports this module.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from types import MappingProxyType
from typing import Callable, Iterator, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import stats

from pipelines.validation.harness import THESIS_TERRAINS, simulate_agrimaro, truth_on_grid
from pipelines.validation.sim_tables import THESIS_STRAIGHT_LINE, straight_line_slip
from terrain.slip.estimate import estimate_run

#: tunings of :func:`terrain.slip.estimate.estimate_run` drawn, in legend order
TUNINGS = ("noise", "thesis")


def _save(fig, path: Path, title: str) -> Path:
    """Title, lay out and write ``fig``; returns ``path``."""
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    return path


@contextmanager
def _pyplot_figure(*args, **kwargs) -> Iterator[tuple]:
    """``matplotlib.pyplot.subplots(*args, **kwargs)``, the figure closed on leaving, also
    when drawing or writing it fails (a missing folder, a full disk): an open figure stays
    in pyplot's registry, held in memory by a process that draws again."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(*args, **kwargs)
    try:
        yield fig, axes
    finally:
        plt.close(fig)


def slip_tracking(terrains: Sequence[str] = THESIS_TERRAINS, seed: int = 1,
                  duration_s: float = 20.0) -> pd.DataFrame:
    """True and estimated slip of wheel 1 and the filter's NIS on simulated straight runs.

    Parameters
    ----------
    terrains : sequence of str
        Terrain classes (default the thesis's tiles, grass and gravel).
    seed : int
        Seed of each simulated run.
    duration_s : float
        Simulated time per run, s.

    Returns
    -------
    pandas.DataFrame
        One row per terrain, tuning and EKF step: ``terrain, tuning, t_s`` (s),
        ``slip_true, slip_est`` (SAE slip of wheel 1, dimensionless; the estimate 0 by the
        thesis's convention in the 0.05 m/s dead band, ch. 7.2.1, and NaN on a step past
        the last wheel sample), ``nis`` (NaN where no row was accepted), ``dof`` and
        ``seed``.
    """
    frames = []
    for terrain in terrains:
        result = simulate_agrimaro(terrain, seed, duration_s)
        for tuning in TUNINGS:
            est = estimate_run(result.run, tuning=tuning)
            truth = truth_on_grid(result, est.ekf.t_s)
            frames.append(pd.DataFrame({
                "terrain": terrain, "tuning": tuning, "t_s": est.ekf.t_s,
                "slip_true": truth["slip_1"].to_numpy(), "slip_est": est.slip[:, 0],
                "nis": est.ekf.nis, "dof": est.ekf.dof, "seed": seed}))
    return pd.concat(frames, ignore_index=True)


def binned_nis(t_s: np.ndarray, nis: np.ndarray, dof: np.ndarray, bin_s: float = 1.0,
               probability: float = 0.95) -> pd.DataFrame:
    """NIS per degree of freedom over bins of ``bin_s``, with its chi-square interval.

    The NIS summed over a bin is chi-square with the summed degrees of freedom when the
    filter is consistent and the steps independent (seed 001 eqs. 4.14, 4.16); divided by
    them its expected value is 1. Successive steps of a filter are correlated, so the
    interval is narrower than the true one: it reads as a scale, not as a test (the report's
    consistency table holds the test with the effective sample size).

    Parameters
    ----------
    t_s : numpy.ndarray
        ``(n,)`` step times, s.
    nis : numpy.ndarray
        ``(n,)`` NIS of each step (NaN where no row was accepted).
    dof : numpy.ndarray
        ``(n,)`` its degrees of freedom (0 where no row was accepted).
    bin_s : float
        Bin length, s.
    probability : float
        Probability mass inside the interval.

    Returns
    -------
    pandas.DataFrame
        One row per bin holding an accepted row: ``t_s`` (bin centre, s), ``nis_per_dof``,
        ``dof`` (summed), ``lower, upper`` (interval of ``nis_per_dof``); no row for no
        step.
    """
    t_s, nis, dof = (np.asarray(a, dtype=float) for a in (t_s, nis, dof))
    used = (dof > 0) & np.isfinite(nis)
    origin = float(t_s[0]) if t_s.size else 0.0     # (no step: no bin, not an IndexError)
    frame = pd.DataFrame({"bin": np.floor((t_s[used] - origin) / bin_s), "nis": nis[used],
                          "dof": dof[used]}).groupby("bin").sum()
    tail = 0.5 * (1.0 - probability)
    k = frame["dof"].to_numpy()
    return pd.DataFrame({"t_s": origin + (frame.index.to_numpy() + 0.5) * bin_s,
                         "nis_per_dof": frame["nis"].to_numpy() / k, "dof": k,
                         "lower": stats.chi2.ppf(tail, k) / k,
                         "upper": stats.chi2.ppf(1.0 - tail, k) / k})


def plot_slip_tracking(frame: pd.DataFrame, path: Path, smooth_s: float = 0.5) -> Path:
    """Draw :func:`slip_tracking`'s table: slip per terrain (top), NIS of ``noise`` (bottom).

    The estimates are drawn as centred moving means over ``smooth_s`` (step by step they
    scatter with the filter's velocity estimate, up to about +-0.1 around the mean, and hide
    the truth; the fine encoder's rim speed is smooth, no quantisation); the NIS as
    :func:`binned_nis`.

    Parameters
    ----------
    frame : pandas.DataFrame
        Output of :func:`slip_tracking`.
    path : pathlib.Path
        PNG file to write (its folder must exist).
    smooth_s : float
        Length of the moving mean of the estimates, s.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    terrains = list(dict.fromkeys(frame["terrain"]))
    with _pyplot_figure(2, len(terrains), figsize=(3.4 * len(terrains), 5.2), sharex=True,
                        squeeze=False) as (fig, axes):
        for j, terrain in enumerate(terrains):
            rows = frame[frame["terrain"] == terrain]
            top, bottom = axes[0, j], axes[1, j]
            first = rows[rows["tuning"] == TUNINGS[0]]
            step = float(np.median(np.diff(first["t_s"])))
            span = max(int(round(smooth_s / step)), 1)
            for tuning in TUNINGS:
                part = rows[rows["tuning"] == tuning]
                mean = part["slip_est"].rolling(span, center=True, min_periods=1).mean()
                top.plot(part["t_s"], mean, lw=1.0, label=f"EKF, {tuning} tuning")
            top.plot(first["t_s"], first["slip_true"], "k", lw=1.0, label="true")
            top.set(title=terrain, ylabel="slip ratio, wheel 1" if j == 0 else None)
            nis = binned_nis(first["t_s"], first["nis"], first["dof"])
            bottom.fill_between(nis["t_s"], nis["lower"], nis["upper"], color="0.85", step="mid",
                                label="95 % chi-square, independent steps")
            bottom.step(nis["t_s"], nis["nis_per_dof"], where="mid", label="noise tuning")
            bottom.axhline(1.0, color="k", lw=0.6)
            bottom.set(xlabel="t (s)", ylabel="NIS / dof, 1 s bins" if j == 0 else None)
        axes[0, 0].legend(fontsize=7)
        axes[1, 0].legend(fontsize=7)
        seeds = ", ".join(str(s) for s in sorted(set(frame["seed"])))
        return _save(fig, path, "AgriMaRo straight_accel (thesis ch. 7.2.3), fine encoder, "
                                f"seed {seeds}")


def plot_straight_line(path: Path, duration_s: float = 8.0, seed: int = 0) -> Path:
    """Draw the simulated slip of each thesis terrain against the thesis's figures.

    Parameters
    ----------
    path : pathlib.Path
        PNG file to write (its folder must exist).
    duration_s : float
        Simulated time of each run, s.
    seed : int
        Seed of the runs.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    with _pyplot_figure(1, len(THESIS_STRAIGHT_LINE), figsize=(10.2, 3.0),
                        sharex=True) as (fig, axes):
        for ax, (terrain, (lo, hi, peak)) in zip(axes, THESIS_STRAIGHT_LINE.items()):
            t, slip = straight_line_slip(terrain, duration_s, seed)
            ax.axhspan(lo, hi, color="0.85", label="thesis steady range")
            ax.axhline(peak, color="C3", ls="--", lw=0.9, label="thesis peak")
            ax.plot(t, slip, "k", lw=1.0, label="simulated (true slip)")
            ax.set(title=terrain, xlabel="t (s)",
                   ylabel="slip ratio, mean of 3 wheels" if ax is axes[0] else None)
        axes[0].legend(fontsize=7)
        return _save(fig, path, "AgriMaRo straight_accel (1 m/s^2 to 1 m/s, thesis ch. 7.2.3), "
                                f"seed {seed}")


def _draw_slip_tracking(path: Path, quick: bool) -> Path:
    """:func:`plot_slip_tracking` of :func:`slip_tracking` (8 s runs when ``quick``)."""
    return plot_slip_tracking(slip_tracking(duration_s=8.0 if quick else 20.0), path)


def _draw_straight_line(path: Path, quick: bool) -> Path:
    """:func:`plot_straight_line` (its runs are short already: ``quick`` changes nothing)."""
    return plot_straight_line(path)


#: report -> figure name -> ``draw(path, quick) -> path`` (read-only)
FIGURES: Mapping[str, Mapping[str, Callable[[Path, bool], Path]]] = MappingProxyType({
    "estimation": MappingProxyType({"slip_tracking": _draw_slip_tracking}),
    "sim": MappingProxyType({"straight_line": _draw_straight_line})})


def figures(report: str, out_file: Path, quick: bool = False) -> list[Path]:
    """Draw the figures of ``report`` beside its Markdown file.

    Parameters
    ----------
    report : str
        Report name (a key of :data:`FIGURES`; another name has no figure).
    out_file : pathlib.Path
        The report's ``--out`` file; figures are ``<stem>_<name>.png`` in its folder.
    quick : bool
        Shorter runs where a figure has them (a smoke run, not the published figure).

    Returns
    -------
    list of pathlib.Path
        Files written.
    """
    paths = figure_paths(report, out_file)
    return [draw(paths[name], quick) for name, draw in FIGURES.get(report, {}).items()]


def figure_paths(report: str, out_file: Path) -> dict[str, Path]:
    """The files :func:`figures` writes for ``report`` beside ``out_file`` (drawing nothing).

    Parameters
    ----------
    report : str
        Report name (a key of :data:`FIGURES`; another name has no figure).
    out_file : pathlib.Path
        The report's ``--out`` file.

    Returns
    -------
    dict
        Figure name -> ``<out_file stem>_<name>.png`` in ``out_file``'s folder.
    """
    return {name: out_file.with_name(f"{out_file.stem}_{name}.png")
            for name in FIGURES.get(report, {})}
