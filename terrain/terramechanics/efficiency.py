"""Tractive efficiency of a driven wheel or track as a function of slip.

Tractive efficiency is drawbar (net pull) power over the power the drive puts into the wheel:

``eta_t = F_net v / (T omega) = ((mu(s) - rho(s)) / (mu(s) + h)) (1 - |s|)``

with ``mu`` the gross traction coefficient (:func:`~terrain.terramechanics.traction_coefficient`),
``rho`` the slip-producing soil resistance
(:func:`~terrain.terramechanics.soil_resistance_coefficient`), ``h`` the torque-only rolling
loss (:attr:`~terrain.terramechanics.TerrainParams.hysteresis`) and ``1 - |s| = v / (omega r)``
in traction (SAE slip, seed 001 eq. 7.1).

References
----------
J. Y. Wong, *Theory of Ground Vehicles*, 4th ed., Wiley 2008, ch. 4.2 (tractive efficiency
``eta_d = F_d V / (M omega) = (F_d / F)(1 - i)``); F. M. Zoz and R. D. Grisso, *Traction and
Tractor Performance*, ASAE ASABE Distinguished Lecture 27, 2003 (Brixius form
``TE = (NT / GT)(1 - s)`` with ``NT = GT - MR``; the catalogue keeps Brixius's 0.04 hysteresis
term in ``h``, so ``GT = mu + h`` and ``NT = mu - rho``).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from terrain.errors import config_integer
from terrain.terramechanics.resistance import soil_resistance_coefficient
from terrain.terramechanics.traction import numeric_array, traction_coefficient


def tractive_efficiency(terrain, slip: np.ndarray | float) -> np.ndarray:
    """Tractive efficiency ``((mu - rho) / (mu + h)) (1 - |s|)`` of one terrain.

    Parameters
    ----------
    terrain : TerrainParams
        Catalogue entry (:func:`terrain.terramechanics.get_terrain`): its traction-slip curve,
        soil resistance and hysteresis are used.
    slip : float or ndarray, shape (...)
        SAE longitudinal slip (dimensionless), clipped to [-1, 1]; the efficiency is even in
        the slip (driving in either direction).

    Returns
    -------
    ndarray, shape (...)
        Efficiency in [0, 1) (dimensionless); 0 where the gross traction does not exceed the
        soil resistance (no net pull: all the drive power is lost).

    Raises
    ------
    DataFormatError
        A slip that is not a number or a numeric array (a boolean was taken as full slip;
        :func:`~terrain.terramechanics.traction.numeric_array`).

    References
    ----------
    Wong (2008) ch. 4.2; Zoz & Grisso (2003), see the module docstring.
    """
    s = np.abs(np.clip(numeric_array("tractive_efficiency", "slip", slip), -1.0, 1.0))
    mu = np.abs(traction_coefficient(terrain.curve, s))
    rho = soil_resistance_coefficient(terrain, s)
    gross = mu + terrain.hysteresis
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(gross > 0.0, (mu - rho) / np.where(gross > 0.0, gross, 1.0), 0.0)
    return np.clip(eta, 0.0, None) * (1.0 - s)


def max_tractive_efficiency(terrain, points: int = 2001) -> tuple[float, float]:
    """Slip of maximum tractive efficiency on [0, 1] and that efficiency.

    Grid search over :func:`tractive_efficiency`, refined by a bounded scalar minimisation
    between the grid neighbours of the best point.

    Parameters
    ----------
    terrain : TerrainParams
        Catalogue entry (curve, soil resistance, hysteresis).
    points : int
        Points of the coarse grid on [0, 1] (>= 3).

    Returns
    -------
    slip : float
        Slip of the maximum, dimensionless.
    efficiency : float
        :func:`tractive_efficiency` there, dimensionless.

    Raises
    ------
    ConfigError
        ``points`` not an integer >= 3 (the refinement needs a grid point on each side of
        the best one).

    References
    ----------
    Wong (2008) ch. 4.2; Zoz & Grisso (2003), see the module docstring.
    """
    config_integer("max_tractive_efficiency points", points, 3)
    grid = np.linspace(0.0, 1.0, points)
    i = int(np.argmax(tractive_efficiency(terrain, grid)))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    res = minimize_scalar(lambda s: -float(tractive_efficiency(terrain, s)), bounds=(lo, hi),
                          method="bounded", options={"xatol": 1e-9})
    return float(res.x), float(-res.fun)
