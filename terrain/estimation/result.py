"""Result records of an EKF run: :class:`LoopArrays` (the per-step arrays one filter loop
fills, NumPy reference or compiled) and :class:`EKFResult` (those arrays with the grid, names,
sample counts and scheduling metadata, as :func:`terrain.estimation.run_filter` returns them).

Kept apart from the loops so that both engines (:mod:`terrain.estimation.runner`,
:mod:`terrain.estimation.fast`) import their output type from here and not from each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from terrain.errors import EstimationError


@dataclass(frozen=True)
class LoopArrays:
    """Per-step arrays of one filter loop, NumPy reference or compiled (the same meaning as
    in :class:`EKFResult`; N steps, n states, m rows).

    Attributes
    ----------
    x, P_diag : ndarray, shape (N, n)
        Posterior states (SI units) and variances.
    P : ndarray, shape (N, n, n) or None
        Full covariances when requested.
    y, S_diag : ndarray, shape (N, m)
        Innovations and their variances (NaN where the row had no sample).
    accepted : ndarray of bool, shape (N, m)
        Rows used in the update.
    nis : ndarray, shape (N,)
        NIS over the accepted rows (NaN when none).
    dof : ndarray of int, shape (N,)
        Its degrees of freedom.
    bound_active : ndarray of bool, shape (N,) or None
        Steps whose estimate was projected onto ``step_bounds``
        (:func:`terrain.estimation.runner.run_filter`); None when the loop had none.
    clipped : ndarray of bool, shape (N,) or None
        Steps whose estimate the model's ``state_bounds`` clipped (moved); None when the
        loop had none.
    """

    x: np.ndarray
    P_diag: np.ndarray
    P: np.ndarray | None
    y: np.ndarray
    S_diag: np.ndarray
    accepted: np.ndarray
    nis: np.ndarray
    dof: np.ndarray
    bound_active: np.ndarray | None = None
    clipped: np.ndarray | None = None


@dataclass
class EKFResult:
    """Output of :func:`run_filter` over N grid steps (n states, m measurement rows).

    Attributes
    ----------
    t_s : ndarray, shape (N,)
        Grid times, s.
    x : ndarray, shape (N, n)
        Posterior state at each step (SI units of each state).
    P_diag : ndarray, shape (N, n)
        Posterior variances.
    P : ndarray, shape (N, n, n) or None
        Full posterior covariances (``store_covariance=True``).
    y : ndarray, shape (N, m)
        Innovation of each measurement row (NaN where the row had no sample).
    S_diag : ndarray, shape (N, m)
        Innovation variances (NaN where the row had no sample).
    accepted : ndarray of bool, shape (N, m)
        Rows used in the update (False if absent or rejected by the gate).
    nis : ndarray, shape (N,)
        NIS over the accepted rows of each step (NaN when none).
    dof : ndarray of int, shape (N,)
        Its degrees of freedom.
    state_names, measurement_names : tuple of str
        Names of the n states and m measurement rows.
    sensor_rows : dict
        Sensor -> measurement rows.
    counts : dict
        Sensor -> ``{"samples", "used", "non_finite", "superseded", "outside", "rejected"}``.
    meta : dict
        Scheduling rule, gate, rates, settings of the caller.
    """

    t_s: np.ndarray
    x: np.ndarray
    P_diag: np.ndarray
    P: np.ndarray | None
    y: np.ndarray
    S_diag: np.ndarray
    accepted: np.ndarray
    nis: np.ndarray
    dof: np.ndarray
    state_names: tuple[str, ...]
    measurement_names: tuple[str, ...]
    sensor_rows: dict[str, tuple[int, ...]]
    counts: dict[str, dict[str, int]]
    meta: dict[str, Any] = field(default_factory=dict)

    def state(self, name: str) -> np.ndarray:
        """Estimated state ``name`` over time.

        Parameters
        ----------
        name : str
            One of :attr:`state_names`.

        Returns
        -------
        ndarray, shape (N,)
            In the state's SI unit.

        Raises
        ------
        EstimationError
            Unknown state name (a ``ValueError``; the name and the states named).
        """
        return self.x[:, self._state_index(name)]

    def std(self, name: str) -> np.ndarray:
        """Posterior standard deviation of state ``name``.

        Parameters
        ----------
        name : str
            One of :attr:`state_names`.

        Returns
        -------
        ndarray, shape (N,)
            In the state's SI unit.

        Raises
        ------
        EstimationError
            Unknown state name (a ``ValueError``; the name and the states named).
        """
        return np.sqrt(self.P_diag[:, self._state_index(name)])

    def _state_index(self, name: str) -> int:
        """Column of state ``name`` (a bare ``tuple.index(x): x not in tuple`` before)."""
        if name not in self.state_names:
            raise EstimationError(f"unknown state {name!r}; the filter's states: "
                                  f"{list(self.state_names)}")
        return self.state_names.index(name)

    def sensor_nis(self, sensor: str) -> np.ndarray:
        """Sum of squared normalised innovations of one sensor's rows.

        This ignores the correlation between rows of the sensor (exact when its rows are
        uncorrelated); NaN at steps where the sensor had no accepted sample.

        Parameters
        ----------
        sensor : str
            A key of :attr:`sensor_rows`.

        Returns
        -------
        ndarray, shape (N,)
            Dimensionless.

        Raises
        ------
        EstimationError
            ``sensor`` not a key of :attr:`sensor_rows` (a bare ``KeyError`` before).
        """
        if sensor not in self.sensor_rows:
            raise EstimationError(f"unknown sensor {sensor!r}; the filter's sensors: "
                                  f"{list(self.sensor_rows)}")
        rows = list(self.sensor_rows[sensor])
        nu2 = np.where(self.accepted[:, rows], self.y[:, rows] ** 2 / self.S_diag[:, rows],
                       0.0)
        out = nu2.sum(axis=1)
        out[~self.accepted[:, rows].any(axis=1)] = np.nan
        return out

    def to_frame(self, include_std: bool = True) -> pd.DataFrame:
        """Time-stamped table of the run.

        Parameters
        ----------
        include_std : bool
            Add the ``std_<state>`` columns.

        Returns
        -------
        pandas.DataFrame
            ``t_s``, states, ``std_<state>``, ``innov_<row>`` (NaN where the row was not used),
            ``nis``, ``nis_dof``; N rows.
        """
        cols: dict[str, np.ndarray] = {"t_s": self.t_s}
        for j, name in enumerate(self.state_names):
            cols[name] = self.x[:, j]
        if include_std:
            for j, name in enumerate(self.state_names):
                cols[f"std_{name}"] = np.sqrt(self.P_diag[:, j])
        for i, name in enumerate(self.measurement_names):
            cols[f"innov_{name}"] = np.where(self.accepted[:, i], self.y[:, i], np.nan)
        cols["nis"] = self.nis
        cols["nis_dof"] = self.dof
        return pd.DataFrame(cols)


__all__ = ["LoopArrays", "EKFResult"]
