"""Tables of ``docs/sim_validation.md``: the simulator against the thesis and the measured runs.

``terrain validate sim [--out FILE]`` (:mod:`pipelines.validate`) prints them as Markdown.
The checks with tolerances are tests (``tests/sim``); this module only computes the figures.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Callable, Mapping

import numpy as np
import pandas as pd

from terrain.run import TIME, Run
from terrain.sim import Effects, SimConfig, simulate
from terrain.sim.dynamics import integrate
from terrain.sim.simulate import motor_currents
from terrain.terramechanics import MEASURED_HUSKY_STRAIGHT, get_terrain
from terrain.vehicles import HUSKY

#: ICR expansion planted in the straight-line current runs (the measured asphalt chi).
STRAIGHT_CHI = 1.55

#: The thesis's measured straight-line slip per terrain (seed ``001_59da564c4b2d6a48.txt``
#: ch. 7.2.3, figs. 7.2-7.4; AgriMaRo, 1 m/s^2 to 1 m/s): ``(steady_lo, steady_hi, peak)``,
#: dimensionless SAE slip. Tiles: steady "a maximum of 0.01 from zero", peak 0.16; grass:
#: steady 11.6-13.5 %, peak 33.9 %; gravel (firm soil with loose gravel): 12.2-14.6 %, peak
#: 47.5 % (each stated in the text beside its figure; the catalogue's calibration,
#: :mod:`terrain.terramechanics.catalogue`, takes the same peaks).
THESIS_STRAIGHT_LINE: Mapping[str, tuple[float, float, float]] = MappingProxyType({
    "TILES": (-0.01, 0.01, 0.16), "GRASS": (0.116, 0.135, 0.339),
    "GRAVEL": (0.122, 0.146, 0.475)})


def straight_line_slip(terrain: str, duration_s: float = 8.0, seed: int = 0
                       ) -> tuple[np.ndarray, np.ndarray]:
    """True SAE slip of a simulated AgriMaRo ``straight_accel`` run, averaged over its wheels.

    Parameters
    ----------
    terrain : str
        Terrain class.
    duration_s : float
        Simulated time, s.
    seed : int
        Seed of the run.

    Returns
    -------
    t_s : numpy.ndarray
        ``(n,)`` times of the truth stream, s.
    slip : numpy.ndarray
        ``(n,)`` mean of ``slip_1..slip_3`` (dimensionless).
    """
    run = simulate(SimConfig(vehicle="agrimaro", terrains=(terrain,),
                             scenario="straight_accel", duration_s=duration_s, seed=seed))
    tr = run.streams["truth"]
    return tr[TIME].to_numpy(), tr[["slip_1", "slip_2", "slip_3"]].to_numpy().mean(axis=1)


def thesis_straight_line_table(duration_s: float = 8.0, seed: int = 0) -> pd.DataFrame:
    """AgriMaRo straight-line test (seed 001 ch. 7.2.3): true SAE slip, steady and peak.

    Parameters
    ----------
    duration_s : float
        Simulated time of each ``straight_accel`` run, s.
    seed : int
        Seed of the runs.

    Returns
    -------
    pandas.DataFrame
        terrain, ``steady_slip`` (mean of the three-wheel average after 4 s), ``peak_slip``
        (maximum of the three-wheel average after 0.2 s), and the thesis's figures
        ``thesis_steady_lo, thesis_steady_hi, thesis_peak`` (:data:`THESIS_STRAIGHT_LINE`).
    """
    rows = []
    for terrain, (lo, hi, peak) in THESIS_STRAIGHT_LINE.items():
        t, mean_slip = straight_line_slip(terrain, duration_s, seed)
        rows.append({"terrain": terrain, "steady_slip": float(mean_slip[t > 4.0].mean()),
                     "peak_slip": float(mean_slip[t > 0.2].max()),
                     "thesis_steady_lo": lo, "thesis_steady_hi": hi, "thesis_peak": peak})
    return pd.DataFrame(rows)


def regression_chi(run: Run) -> float:
    """ICR factor from regressing ``wz`` on ``x = (v_R - v_L) / B`` where ``|x| > 0.2`` rad/s.

    The least-squares slope of ``wz`` on ``x`` through the origin is ``1 / chi``, so chi is
    ``sum(x^2) / sum(x wz)`` over those samples (turns either way; ``wz`` interpolated at the
    wheel samples' times).

    Parameters
    ----------
    run : Run
        Simulated Husky run (``imu`` and ``wheels`` streams).

    Returns
    -------
    float
        chi (dimensionless); NaN when no sample turns faster than 0.2 rad/s.
    """
    wheels, imu = run.streams["wheels"], run.streams["imu"]
    x = ((wheels.vel_r - wheels.vel_l) / HUSKY.track_m).to_numpy()
    wz = np.interp(wheels[TIME], imu[TIME], imu.wz)
    m = np.abs(x) > 0.2
    if not m.any():
        return float("nan")
    return float(np.sum(x[m] ** 2) / np.sum(x[m] * wz[m]))


def husky_current_chi_table(orchard_s: float = 120.0, seed: int = 7) -> pd.DataFrame:
    """Husky straight-line current against the measured mean, and the effects-off chi.

    Parameters
    ----------
    orchard_s : float
        Duration of the orchard run giving ``baseline_chi``, s.
    seed : int
        Seed of the orchard runs.

    Returns
    -------
    pandas.DataFrame
        terrain, ``measured_a``, ``sim_a`` (mean current after 6 s of a ramp to the measured
        speed), ``baseline_chi`` (orchard, every effect off).
    """
    rows = []
    geometry = HUSKY.contact_geometry()
    t = np.arange(0, 12.0, 0.01)
    for terrain, (target, speed) in MEASURED_HUSKY_STRAIGHT.items():
        twist = np.zeros((len(t), 3))
        twist[:, 0] = np.minimum(t * 0.5, speed)
        phys = integrate(HUSKY, geometry, (get_terrain(terrain),), 25.0, t, twist, 0.0,
                         STRAIGHT_CHI)
        cur = motor_currents(phys, HUSKY, Effects(icr_expansion=STRAIGHT_CHI))
        orchard = simulate(SimConfig(vehicle="husky", terrains=(terrain,), scenario="orchard",
                                     duration_s=orchard_s, seed=seed))
        rows.append({"terrain": terrain, "measured_a": target,
                     "sim_a": float(cur[t > 6.0].mean()),
                     "baseline_chi": regression_chi(orchard)})
    return pd.DataFrame(rows)


def sections(quick: bool = False) -> list[tuple[str, Callable[[], pd.DataFrame]]]:
    """The report's tables, in order.

    Parameters
    ----------
    quick : bool
        Shorter orchard runs (a smoke run, not the published figures).

    Returns
    -------
    list of (title, table function)
    """
    return [
        ("AgriMaRo straight-line test (seed 001 ch. 7.2.3)", thesis_straight_line_table),
        ("Husky straight-line currents and chi",
         lambda: husky_current_chi_table(60.0 if quick else 120.0)),
    ]
