"""Inverse of a traction-slip curve: the slip that produces a given traction coefficient.

A relation of the curve only (:mod:`terrain.terramechanics.traction`): on the *stable* side of
``mu(s)`` (``0 <= |s| <= s_peak``, where ``d mu / d s > 0``) the curve is strictly increasing
and has a unique inverse; a wheel that is asked for more than ``mu_max`` spins up past the
peak (unstable side), which a steady measurement cannot place, so the inverse saturates there
and says so. The forward curve is evaluated through :func:`traction_coefficient`; nothing of
it is re-typed here.
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from scipy.optimize import brentq

from terrain.errors import config_fraction, config_integer
from terrain.terramechanics.traction import (TractionCurve, numeric_array,
                                             traction_coefficient, traction_peak)

#: Points of the tabulated stable side (the inverse is linear between them).
INVERSE_GRID_POINTS = 4001


class StableSlip(NamedTuple):
    """Slip on the stable side of a traction curve.

    Attributes
    ----------
    slip : ndarray, shape (...)
        SAE slip (dimensionless), same sign as ``mu``, ``|slip| <= s_peak``.
    saturated : ndarray of bool, shape (...)
        ``|mu|`` reached the curve's maximum: the slip is the peak slip or more.
    """

    slip: np.ndarray
    saturated: np.ndarray


def stable_side_end(curve: TractionCurve) -> tuple[float, float]:
    """End of the stable side of a curve: the peak slip and the traction coefficient there.

    The interior maximum of a curve that falls after its peak (Burckhardt with ``c3 > 0``:
    ``ln(c1 c2 / c3) / c2``), found by :func:`~terrain.terramechanics.traction.traction_peak`;
    ``(1, mu(1))`` for a curve rising up to ``s = 1`` (Janosi, Brixius, Burckhardt with
    ``c3 = 0``), whose whole ``[0, 1]`` is stable.

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve (catalogue entry's ``curve``).

    Returns
    -------
    slip : float
        Peak slip, dimensionless, in (0, 1].
    mu : float
        Traction coefficient at that slip, dimensionless.
    """
    peak = traction_peak(curve)
    if peak.monotonic:
        return 1.0, float(traction_coefficient(curve, 1.0))
    return float(peak.slip), float(peak.mu)


def slip_at_peak_fraction(curve: TractionCurve, fraction: float) -> float:
    """Smallest slip at which ``mu`` reaches ``fraction`` of its peak (stable side).

    The exact (root-found, not tabulated) inverse of
    :func:`~terrain.terramechanics.traction.traction_coefficient` at the level
    ``fraction * mu_peak`` on ``[0, s_peak]`` (:func:`stable_side_end`); used for set points
    "on the stable side of the friction peak" (issue 11, seed 001 ch. 8.3.2).

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve.
    fraction : float
        Fraction of the peak, in (0, 1].

    Returns
    -------
    float
        Slip in (0, s_peak] (dimensionless).

    Raises
    ------
    ConfigError
        ``fraction`` not a number in (0, 1] (NaN included).
    """
    config_fraction("slip_at_peak_fraction", fraction=fraction)
    s_peak, mu_peak = stable_side_end(curve)
    level = fraction * mu_peak
    if fraction == 1.0:
        return s_peak
    return float(brentq(lambda s: float(traction_coefficient(curve, s)) - level, 0.0, s_peak,
                        xtol=1e-12))


def stable_side(curve: TractionCurve, points: int = INVERSE_GRID_POINTS
                ) -> tuple[np.ndarray, np.ndarray]:
    """Tabulated stable side ``(s, mu(s))`` of a curve, ``0 <= s <= s_peak``.

    For curves with an interior maximum ``s_peak`` is that maximum; for curves rising up to
    ``s = 1`` (Janosi, Brixius) the whole ``[0, 1]`` is stable.

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve (catalogue entry's ``curve``).
    points : int
        Number of grid points (>= 2).

    Returns
    -------
    slip : ndarray, shape (points,)
        Slip grid, dimensionless, increasing from 0.
    mu : ndarray, shape (points,)
        ``mu`` on the grid, strictly increasing.

    Raises
    ------
    ConfigError
        ``points`` not an integer >= 2 (one point tabulates only ``(0, 0)``, which every
        ``mu`` would read as saturated at slip 0).
    """
    config_integer("stable_side points", points, 2)
    try:
        hash(curve)
    except TypeError:   # a curve holding arrays (physics v2's SlipCompactionResistance)
        return _build_stable_side(curve, points)
    return _stable_side_table(curve, points)


@lru_cache(maxsize=128)
def _stable_side_table(curve: TractionCurve, points: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`stable_side`, memoised per (frozen, hashable) curve: a pure function of its
    arguments, so the table is built once per curve and handed out read-only (the per-window
    physics slip inverts the same few catalogue curves thousands of times)."""
    return _build_stable_side(curve, points)


def _build_stable_side(curve: TractionCurve, points: int) -> tuple[np.ndarray, np.ndarray]:
    """The table of :func:`stable_side`, read-only (unmemoised: any curve)."""
    s_end, _ = stable_side_end(curve)
    s = np.linspace(0.0, s_end, points)
    mu = traction_coefficient(curve, s)
    # keep the strictly increasing part (flat tails of saturated curves add no information)
    keep = np.concatenate([[True], np.diff(mu) > 0.0])
    s, mu = s[keep], mu[keep]
    s.flags.writeable = False
    mu.flags.writeable = False
    return s, mu


def slip_from_traction(curve: TractionCurve, mu: np.ndarray | float,
                       points: int = INVERSE_GRID_POINTS) -> StableSlip:
    """Slip on the stable side at which ``curve`` delivers the traction coefficient ``mu``.

    Inverse of :func:`terrain.terramechanics.traction.traction_coefficient` restricted to
    ``|s| <= s_peak``: ``traction_coefficient(curve, slip_from_traction(curve, mu).slip) == mu``
    (to the grid resolution) for ``|mu| < mu_max``. Odd in ``mu``.

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve.
    mu : float or ndarray, shape (...)
        Gross traction coefficient (force over normal load), dimensionless; NaN passes
        through (slip NaN, not saturated); +-inf is beyond the curve's maximum (slip +-peak
        slip, saturated).
    points : int
        Resolution of the tabulated stable side (an integer >= 2, :func:`stable_side`).

    Returns
    -------
    StableSlip
        Slip and whether ``|mu|`` was at or beyond the curve's maximum (slip = peak slip).

    Raises
    ------
    ConfigError
        ``points`` not an integer >= 2.
    DataFormatError
        ``mu`` not a number or a numeric array (a boolean was read as ``mu`` 1, text was
        parsed, None a silent NaN; :func:`~terrain.terramechanics.traction.numeric_array`).
    """
    m = numeric_array("slip_from_traction", "mu", mu)
    s_grid, mu_grid = stable_side(curve, points)
    mag = np.abs(m)
    slip = np.sign(m) * np.interp(mag, mu_grid, s_grid)
    # np.interp reads +-inf as past the table's end (the peak slip); only NaN is unknown
    # (every non-finite mu was masked to a NaN slip, not saturated, before)
    unknown = np.isnan(m)
    saturated = (mag >= mu_grid[-1]) & ~unknown
    return StableSlip(np.where(unknown, np.nan, slip), saturated)
