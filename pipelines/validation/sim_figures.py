"""Figure of ``docs/sim_validation.md``: simulated straight-line slip against the thesis.

``terrain validate sim --out FILE`` (:mod:`pipelines.validate`) writes it beside FILE as
``<FILE stem>_straight_line.png``: the true slip of the runs of the report's first table
(:func:`pipelines.validation.sim_tables.straight_line_slip`) over time, with the thesis's
measured steady-state range and transient peak (:data:`~pipelines.validation.sim_tables.
THESIS_STRAIGHT_LINE`, seed ``001_59da564c4b2d6a48.txt`` ch. 7.2.3). Nothing in the library
imports this module.
"""

from __future__ import annotations

from pathlib import Path

from pipelines.validation.sim_tables import THESIS_STRAIGHT_LINE, straight_line_slip


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
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(THESIS_STRAIGHT_LINE), figsize=(10.2, 3.0), sharex=True)
    for ax, (terrain, (lo, hi, peak)) in zip(axes, THESIS_STRAIGHT_LINE.items()):
        t, slip = straight_line_slip(terrain, duration_s, seed)
        ax.axhspan(lo, hi, color="0.85", label="thesis steady range")
        ax.axhline(peak, color="C3", ls="--", lw=0.9, label="thesis peak")
        ax.plot(t, slip, "k", lw=1.0, label="simulated (true slip)")
        ax.set(title=terrain, xlabel="t (s)",
               ylabel="slip ratio, mean of 3 wheels" if ax is axes[0] else None)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"AgriMaRo straight_accel (1 m/s^2 to 1 m/s, thesis ch. 7.2.3), seed {seed}",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def figures(out_file: Path, quick: bool = False) -> list[Path]:
    """Write the report's figures beside its Markdown file.

    Parameters
    ----------
    out_file : pathlib.Path
        The report's ``--out`` file; figures are ``<stem>_<name>.png`` in its folder.
    quick : bool
        Unused (the runs are already short); kept for the common signature of
        :data:`pipelines.validate.FIGURES`.

    Returns
    -------
    list of pathlib.Path
        Files written.
    """
    return [plot_straight_line(out_file.with_name(f"{out_file.stem}_straight_line.png"))]
