"""Evaluate an in-place model kernel into new arrays: the one adapter between the kernels of
:mod:`terrain.estimation.equations` (``transition_into(x, u, dt, p, fx, F)``,
``observation_into(x, p, hx, H)``) and the callers that want values back (the python-control
style ``f``/``F``/``h``/``H`` of each equations module and the NumPy model classes of
:mod:`terrain.estimation`).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from terrain.errors import ShapeError

#: No control input: the models of :mod:`terrain.estimation.equations` are driven by their
#: states (accelerations, random walks), not by an input vector.
NO_INPUT = np.zeros(0)
NO_INPUT.flags.writeable = False


def _state(x: np.ndarray, n_states: int | None) -> np.ndarray:
    """``x`` as a C-contiguous float64 vector of ``n_states`` entries (the compiled kernels
    run without bounds checks: a shorter state was read, and written, past its end)."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.ndim != 1 or (n_states is not None and x.shape[0] != n_states):
        want = f"({n_states},)" if n_states is not None else "(n,)"
        raise ShapeError(f"the model's state must have shape {want}, got {x.shape}")
    return x


def transition_pair(kernel: Callable[..., None], x: np.ndarray, u: np.ndarray, dt: float,
                    p: np.ndarray, n_states: int | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """``(f(x), F(x))`` of a process kernel, in new arrays.

    Parameters
    ----------
    kernel : callable ``kernel(x, u, dt, p, fx, F)``
        A model's ``transition_into`` (numba-compiled, writes ``fx`` and ``F``).
    x : ndarray, shape (n,)
        State (SI units of each state); copied to C-contiguous float64 if needed.
    u : ndarray, shape (k,)
        Input (``NO_INPUT``, shape (0,), for the models of this package).
    dt : float
        Step, s.
    p : ndarray
        The model's packed constants (``as_array()`` of its parameter dataclass).
    n_states : int, optional
        The state length the kernel reads (None: not checked).

    Returns
    -------
    fx : ndarray, shape (n,)
        Next state.
    F : ndarray, shape (n, n)
        Jacobian ``df/dx``.

    Raises
    ------
    ShapeError
        ``x`` not one-dimensional, or not of length ``n_states``.
    """
    x = _state(x, n_states)
    n = x.shape[0]
    fx, F = np.empty(n), np.empty((n, n))
    kernel(x, u, float(dt), p, fx, F)
    return fx, F


def observation_pair(kernel: Callable[..., None], x: np.ndarray, p: np.ndarray,
                     m: int, n_states: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(h(x), H(x))`` of a measurement kernel, in new arrays.

    Parameters
    ----------
    kernel : callable ``kernel(x, p, hx, H)``
        A model's ``observation_into`` (numba-compiled, writes ``hx`` and ``H``).
    x : ndarray, shape (n,)
        State (SI units of each state); copied to C-contiguous float64 if needed.
    p : ndarray
        The model's packed constants (``as_array()`` of its parameter dataclass).
    m : int
        Number of measurement rows the kernel writes.
    n_states : int, optional
        The state length the kernel reads (None: not checked).

    Returns
    -------
    hx : ndarray, shape (m,)
        Predicted measurement.
    H : ndarray, shape (m, n)
        Jacobian ``dh/dx``.

    Raises
    ------
    ShapeError
        ``x`` not one-dimensional, or not of length ``n_states``.
    """
    x = _state(x, n_states)
    hx, H = np.empty(m), np.empty((m, x.shape[0]))
    kernel(x, p, hx, H)
    return hx, H


__all__ = ["NO_INPUT", "transition_pair", "observation_pair"]
