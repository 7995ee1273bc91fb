"""Base of the EKF process / measurement models used with :func:`terrain.estimation.run_filter`.

A model is a frozen dataclass that knows its state and measurement names, which measurement
rows each sensor feeds, and implements

* ``f(x, dt) -> (n,)`` and ``F(x, dt) -> (n, n)`` (process model and its Jacobian),
* ``h(x) -> (m,)`` and ``H(x) -> (m, n)`` (measurement model and its Jacobian),
* ``Q(dt) -> (n, n)`` (process noise of one step), ``R_diag`` ``(m,)`` (measurement noise
  variances), ``x0`` ``(n,)`` and ``P0`` ``(n, n)``.

``transition`` and ``observation`` return a value and its Jacobian together; models override
them when the two share work (trigonometry), which is what the run loop calls.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, ClassVar, Mapping

import numpy as np

from terrain.errors import ConfigError, config_positive
from terrain.estimation.ekf import as_vector, check_time_step
from terrain.estimation.equations.evaluate import NO_INPUT, observation_pair, transition_pair
from terrain.vehicles.common import wrap_angle

if TYPE_CHECKING:
    from terrain.estimation.fast import FastKernel


class StateSpaceModel:
    """Interface of an EKF model (see the module docstring). Subclasses are frozen dataclasses.

    Attributes
    ----------
    state_names : tuple of str
        Length n.
    measurement_names : tuple of str
        Length m.
    sensor_rows : Mapping[str, tuple of int]
        Sensor (stream) name -> the measurement rows its samples fill, in column order.
    angle_rows : tuple of int
        Measurement rows holding angles (their innovation is wrapped to [-pi, pi)).
    """

    state_names: tuple[str, ...] = ()
    measurement_names: tuple[str, ...] = ()
    angle_rows: tuple[int, ...] = ()

    @property
    def sensor_rows(self) -> Mapping[str, tuple[int, ...]]:  # pragma: no cover - interface
        raise NotImplementedError

    @property
    def n_states(self) -> int:
        """Number of states n."""
        return len(self.state_names)

    @property
    def n_measurements(self) -> int:
        """Number of measurement rows m."""
        return len(self.measurement_names)

    def f(self, x: np.ndarray, dt: float) -> np.ndarray:  # pragma: no cover - interface
        """Process model (interface).

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).
        dt : float
            Step, s (> 0).

        Returns
        -------
        ndarray, shape (n,)
        """
        raise NotImplementedError

    def F(self, x: np.ndarray, dt: float) -> np.ndarray:  # pragma: no cover - interface
        """Jacobian of :meth:`f` (interface).

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).
        dt : float
            Step, s (> 0).

        Returns
        -------
        ndarray, shape (n, n)
        """
        raise NotImplementedError

    def h(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        """Measurement model (interface).

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).

        Returns
        -------
        ndarray, shape (m,)
        """
        raise NotImplementedError

    def H(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        """Jacobian of :meth:`h` (interface).

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).

        Returns
        -------
        ndarray, shape (m, n)
        """
        raise NotImplementedError

    def Q(self, dt: float) -> np.ndarray:  # pragma: no cover - interface
        """Process noise covariance of one step (interface).

        Parameters
        ----------
        dt : float
            Step, s (> 0).

        Returns
        -------
        ndarray, shape (n, n)
        """
        raise NotImplementedError

    @property
    def R_diag(self) -> np.ndarray:  # pragma: no cover - interface
        """Measurement noise variances, ``(m,)``."""
        raise NotImplementedError

    @property
    def state_bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Physical range of each state, or None (default) for an unbounded state.

        Returns
        -------
        (lower, upper) of ndarray, shape (n,), or None
            :func:`terrain.estimation.runner.run_filter` clips the state mean into this box
            after every update (the covariance is left as it is; the steps where the clip
            moved the mean are counted in ``meta["state_bounds_clipped"]``); ``-inf`` / ``inf``
            for a state without a bound. None: no clipping.
        """
        return None

    @property
    def x0(self) -> np.ndarray:  # pragma: no cover - interface
        """Initial state, ``(n,)``."""
        raise NotImplementedError

    @property
    def P0(self) -> np.ndarray:  # pragma: no cover - interface
        """Initial covariance, ``(n, n)``."""
        raise NotImplementedError

    def transition(self, x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(f(x, dt), F(x, dt))``; models override it when the two share work.

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).
        dt : float
            Step, s (> 0).

        Returns
        -------
        fx : ndarray, shape (n,)
        F : ndarray, shape (n, n)
        """
        return self.f(x, dt), self.F(x, dt)

    def observation(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(h(x), H(x))``; models override it when the two share work.

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).

        Returns
        -------
        hx : ndarray, shape (m,)
        H : ndarray, shape (m, n)
        """
        return self.h(x), self.H(x)

    def residual(self, z: np.ndarray, hx: np.ndarray) -> np.ndarray:
        """Innovation ``z - hx`` over all m rows, angle rows wrapped to [-pi, pi) (seed
        ``001_59da564c4b2d6a48.txt`` eq. 4.7).

        Parameters
        ----------
        z : ndarray, shape (m,)
            Measurement (NaN where a row has no sample; NaN stays NaN).
        hx : ndarray, shape (m,)
            Predicted measurement ``h(x)``.

        Returns
        -------
        ndarray, shape (m,)
        """
        y = np.asarray(z, dtype=float) - hx
        for r in self.angle_rows:
            y[r] = wrap_angle(y[r])      # NaN stays NaN
        return y

    def sensor_groups(self) -> list[np.ndarray]:
        """Measurement rows of each sensor, for per-sensor gating.

        Returns
        -------
        list of ndarray of int
            One array of row indices per sensor, in the order of ``sensor_rows``.
        """
        return [np.asarray(r) for r in self.sensor_rows.values()]


@dataclass(frozen=True)
class KernelModel(StateSpaceModel):
    """A model whose equations are a pair of kernels of :mod:`terrain.estimation.equations`.

    ``f``, ``F``, ``transition``, ``h``, ``H`` and ``observation`` all evaluate the same two
    kernels (the compiled loop of :mod:`terrain.estimation.fast` calls them too, see
    :meth:`kernel_for_fast_loop`). Subclasses (frozen dataclasses) set the class attributes
    ``transition_kernel`` and ``observation_kernel`` and the property ``equation_params``
    (a parameter dataclass with ``as_array()``); ``_p``, the packed constants, is filled in
    ``__post_init__`` (a subclass that validates its fields calls ``super().__post_init__()``
    last).

    Attributes
    ----------
    transition_kernel : callable ``(x, u, dt, p, fx, F) -> None``
        The model's ``transition_into``.
    observation_kernel : callable ``(x, p, hx, H) -> None``
        The model's ``observation_into``.
    """

    transition_kernel: ClassVar[Callable[..., None]]
    observation_kernel: ClassVar[Callable[..., None]]
    _p: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_p", self.equation_params.as_array())

    @property
    def equation_params(self):  # pragma: no cover - interface
        """Constants of the model's equations (a dataclass with ``as_array()``)."""
        raise NotImplementedError

    def f(self, x: np.ndarray, dt: float) -> np.ndarray:
        """Process model: first output of :meth:`transition`.

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).
        dt : float
            Step, s (> 0).

        Returns
        -------
        ndarray, shape (n,)
        """
        return self.transition(x, dt)[0]

    def F(self, x: np.ndarray, dt: float) -> np.ndarray:
        """Jacobian of :meth:`f`: second output of :meth:`transition`.

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).
        dt : float
            Step, s (> 0).

        Returns
        -------
        ndarray, shape (n, n)
        """
        return self.transition(x, dt)[1]

    def transition(self, x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(f(x, dt), F(x, dt))`` of the model's ``transition_kernel``.

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).
        dt : float
            Step, s (> 0).

        Returns
        -------
        fx : ndarray, shape (n,)
        F : ndarray, shape (n, n)
        """
        return transition_pair(type(self).transition_kernel, x, NO_INPUT, dt, self._p,
                               self.n_states)

    def h(self, x: np.ndarray) -> np.ndarray:
        """Measurement model: first output of :meth:`observation`.

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).

        Returns
        -------
        ndarray, shape (m,)
        """
        return self.observation(x)[0]

    def H(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`h`: second output of :meth:`observation`.

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).

        Returns
        -------
        ndarray, shape (m, n)
        """
        return self.observation(x)[1]

    def observation(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(h(x), H(x))`` of the model's ``observation_kernel``.

        Parameters
        ----------
        x : ndarray, shape (n,)
            State (SI units of each state).

        Returns
        -------
        hx : ndarray, shape (m,)
        H : ndarray, shape (m, n)
        """
        return observation_pair(type(self).observation_kernel, x, self._p,
                                len(self.measurement_names), self.n_states)

    def kernel_for_fast_loop(self, q_diag: tuple[float, ...], q_per: str) -> FastKernel:
        """The model's kernels and constants for the compiled loop of
        :mod:`terrain.estimation.fast` (the functions :meth:`transition` and
        :meth:`observation` call).

        Parameters
        ----------
        q_diag : tuple of float, length n
            Process noise variances of :meth:`Q` (SI units squared, per step or per second).
        q_per : {"step", "second"}
            ``Q = diag(q_diag)`` or ``Q = diag(q_diag) dt``.

        Returns
        -------
        FastKernel
        """
        from terrain.estimation.fast import FastKernel

        return FastKernel(type(self).transition_kernel, type(self).observation_kernel,
                          tuple(self._p.tolist()), self.n_states, self.n_measurements,
                          tuple(float(q) for q in q_diag), q_per, tuple(self.angle_rows))


def diagonal_process_noise(q_diag: tuple[float, ...], q_per: str, dt: float) -> np.ndarray:
    """``diag(q)`` per step or ``diag(q) dt`` (seed ``001_59da564c4b2d6a48.txt`` eqs. 4.41
    and 6.14; the compiled loop of :mod:`terrain.estimation.fast` forms the same ``Q``).

    Parameters
    ----------
    q_diag : tuple of float, length n
        Process noise variances (SI units squared, per step or per second).
    q_per : {"step", "second"}
        Whether ``q_diag`` holds variances per filter step or per second.
    dt : float
        Step, s (> 0).

    Returns
    -------
    ndarray, shape (n, n)

    Raises
    ------
    ConfigError
        ``q_per`` neither ``"step"`` nor ``"second"`` (anything else, ``"Step"`` included,
        was taken as per second).
    TimeStepError
        ``q_per = "second"`` with ``dt`` not a finite number > 0 (a negative step gave
        negative variances, NaN a NaN ``Q``).
    """
    q = np.asarray(q_diag, dtype=float)
    if q_per == "step":
        return np.diag(q)
    if q_per != "second":
        raise ConfigError(f"q_per must be 'step' or 'second', got {q_per!r}")
    return np.diag(q * check_time_step(dt))


def finite_difference_jacobian(fun, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Central-difference Jacobian of ``fun`` at ``x`` (to check analytic Jacobians).

    Parameters
    ----------
    fun : callable ``fun(x) -> (m,)``
        Function to differentiate.
    x : ndarray, shape (n,)
        Point of evaluation, finite.
    eps : float
        Step, relative to ``max(1, |x_j|)``: a finite number > 0, large enough to move
        every ``x_j``.

    Returns
    -------
    ndarray, shape (m, n)

    Raises
    ------
    ShapeError, NonFiniteInputError, EstimationError
        ``x`` not one-dimensional, not finite, or not real numbers (None, text, booleans),
        named (:func:`terrain.estimation.ekf.as_vector`; None was a bare IndexError, a 2-D
        ``x`` NumPy's "truth value is ambiguous").
    ConfigError
        ``eps`` not a finite number > 0 (0 gave a Jacobian of NaN), or so small that
        ``x_j + h`` rounds to ``x_j - h`` (a Jacobian of zeros).
    """
    x = as_vector(x, "x")
    config_positive("finite_difference_jacobian", eps=eps)
    cols = []
    for j in range(x.size):
        h = eps * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        if xp[j] == xm[j]:
            raise ConfigError(f"finite_difference_jacobian.eps = {eps!r} is too small to move "
                              f"x[{j}] = {x[j]!r}: give a larger step")
        cols.append((np.asarray(fun(xp)) - np.asarray(fun(xm))) / (2.0 * h))
    return np.column_stack(cols)
