"""Compiled (numba) EKF run loop for models with numba kernels: the fast path of
:func:`terrain.estimation.run_filter`.

The NumPy functions :func:`~terrain.estimation.predict`, :func:`~terrain.estimation.correct`
and the reference loop of :func:`~terrain.estimation.run_filter` (``engine="numpy"``) stay the
documented reference; this module computes the same quantities in one jitted loop, without
the ~1 us dispatch of each of the ~20 small NumPy calls of a step:

* prediction (seed ``001_59da564c4b2d6a48.txt`` eqs. 4.3 and 4.5)
  ``x = f(x, dt)``, ``P = F P F^T + Q(dt)``, symmetrised;
* update (eqs. 4.7-4.11) over the rows available at the step (NaN = no sample): innovation
  ``y = z - h(x)`` with the angle rows wrapped to [-pi, pi) (eq. 4.7), ``S = H P H^T + R``
  (eq. 4.9), the gain ``K = P H^T S^-1`` (eq. 4.10) from a Cholesky factorisation of ``S``
  and two triangular solves of ``S [K^T | u] = [H P | y]`` (no inverse; ``u = S^-1 y`` gives
  the NIS ``y^T u``), ``x = x + K y`` (eq. 4.11) and the Joseph form
  ``P = (I - K H) P (I - K H)^T + K R K^T`` (kept PSD by construction, see
  :mod:`terrain.estimation.ekf`);
* the optional chi-square gate of :class:`~terrain.estimation.Gate`, per sensor group, on the
  marginal NIS ``y_g^T S_gg^-1 y_g`` of the group's available rows.

The results equal the reference to round-off (the sums are taken in another order than
BLAS / LAPACK's; ``tests/estimation/test_fast.py`` checks 1e-9).

Models opt in with a method ``fast_kernel() -> FastKernel | None`` that hands over the model's
own kernels (``transition_into``, ``observation_into`` of
:mod:`terrain.estimation.equations`). This
module holds no model equation and names no model: the kernels are compiled to C callbacks
(``numba.cfunc``) and the loop, compiled once for every model, calls them through function
pointers. Each piece sits in numba's on-disk cache (``cache=True``) next to its own source
file, which is what numba checks for staleness: an edit of a model's equations recompiles that
model's kernels only, an edit of this file the loop only (first call on a machine: a few
seconds of compilation; later processes load the cache). Restrictions of the fast path: the
measurement noise is diagonal (``R_diag``), the process noise is diagonal (``q_diag`` per
step, or ``q_diag dt``), and the model's ``residual`` is the default one (``z - h(x)``, angle
rows wrapped).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Callable

import numba
import numpy as np
from numba import types

from terrain.errors import ConfigError, CovarianceError, NonFiniteInputError, ShapeError
from terrain.estimation.result import LoopArrays
from terrain.vehicles.common import wrap_angle

#: Status codes returned by the compiled loop.
_OK, _S_NOT_PD, _NIS_NEGATIVE, _GATE_SINGULAR = 0, 1, 2, 3
_VEC = types.float64[::1]
#: Compilation options of the loop: no bounds checks, NumPy's error model (no Python
#: ZeroDivisionError checks). No fast-math: the loop tests for NaN (missing samples, failed
#: factorisations), and the reordering flags measured slower (benchmarks/bench_ekf.py).
_JIT = MappingProxyType({"boundscheck": False, "error_model": "numpy", "fastmath": False})
_MAT = types.float64[:, ::1]
#: Signature of a model's process kernel ``transition_into(x, u, dt, p, fx, F)``.
TRANSITION_SIGNATURE = types.void(_VEC, _VEC, types.float64, _VEC, _VEC, _MAT)
#: Signature of a model's measurement kernel ``observation_into(x, p, hx, H)``.
OBSERVATION_SIGNATURE = types.void(_VEC, _VEC, _VEC, _MAT)


@dataclass(frozen=True)
class FastKernel:
    """What the compiled loop needs from a model: its two kernels and their constants.

    The loop does not know any model: a model hands over its own kernels (see
    :mod:`terrain.estimation.equations`), compiled here to C callbacks of
    :data:`TRANSITION_SIGNATURE` / :data:`OBSERVATION_SIGNATURE` that the loop calls through a
    function pointer. Adding a model never edits this module.

    Parameters
    ----------
    transition : numba dispatcher or function
        ``transition_into(x, u, dt, p, fx, F)``: writes ``f(x, u, dt)`` (n,) into ``fx`` and
        its Jacobian (n, n) into ``F`` (the ``transition_into`` of a module of
        :mod:`terrain.estimation.equations`).
    observation : numba dispatcher or function
        ``observation_into(x, p, hx, H)``: writes ``h(x)`` (m,) into ``hx`` and its Jacobian
        (m, n) into ``H``.
    params : tuple of float
        The kernels' parameter vector ``p`` (the model's parameter dataclass ``as_array()``;
        SI units).
    n_states, n_measurements : int
        n and m.
    q_diag : tuple of float
        Process noise variances (n,), SI units squared, per step or per second.
    q_per : {"step", "second"}
        ``Q = diag(q_diag)`` at every step, or ``Q = diag(q_diag) dt``.
    angle_rows : tuple of int
        Measurement rows whose innovation is wrapped to [-pi, pi).

    Raises
    ------
    ConfigError
        A kernel that is not callable, ``q_diag`` of the wrong length, unknown ``q_per`` or
        an angle row outside ``0..m-1`` (a ValueError, as before).
    """

    transition: Callable[..., Any]
    observation: Callable[..., Any]
    params: tuple[float, ...]
    n_states: int
    n_measurements: int
    q_diag: tuple[float, ...]
    q_per: str = "step"
    angle_rows: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if not (callable(self.transition) and callable(self.observation)):
            raise ConfigError("FastKernel transition and observation must be (numba-compilable) "
                              "functions")
        if len(self.q_diag) != self.n_states:
            raise ConfigError(f"FastKernel q_diag needs {self.n_states} values, got "
                              f"{len(self.q_diag)}")
        if self.q_per not in ("step", "second"):
            raise ConfigError(f"FastKernel q_per must be 'step' or 'second', got {self.q_per!r}")
        if any(not 0 <= r < self.n_measurements for r in self.angle_rows):
            raise ConfigError(f"FastKernel angle rows {self.angle_rows} outside "
                              f"0..{self.n_measurements - 1}")


def fast_kernel_of(model: object) -> FastKernel | None:
    """The :class:`FastKernel` of ``model``, or None when it has none.

    Parameters
    ----------
    model : StateSpaceModel
        Any model; one with a ``fast_kernel()`` method returning a :class:`FastKernel` can
        run on the compiled loop.

    Returns
    -------
    FastKernel or None
    """
    method = getattr(model, "fast_kernel", None)
    return method() if callable(method) else None


@functools.lru_cache(maxsize=None)
def _callback(function: Callable[..., Any], signature: Any) -> Any:
    """``function`` (a numba dispatcher's Python function, or a plain one) compiled to a C
    callback of ``signature``; cached on disk next to the function's own module, so an edit
    of a model's equations recompiles its kernel and never the loop."""
    return numba.cfunc(signature, cache=True)(getattr(function, "py_func", function))


@numba.njit(cache=True, **_JIT)
def _cholesky(A, n, L):
    """Lower Cholesky factor of ``A[:n, :n]`` into ``L``; False when not positive definite."""
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        L[j, j] = d
        inv = 1.0 / d
        for i in range(j + 1, n):
            t = A[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t * inv
    return True


@numba.njit(cache=True, **_JIT)
def _cho_solve(L, n, B, ncols):
    """Overwrite ``B[:n, :ncols]`` with ``(L L^T)^-1 B`` (forward, then back substitution,
    right-looking: each solved row is subtracted from the rows still to solve, one
    reciprocal per row, then multiplications)."""
    for k in range(n):
        inv = 1.0 / L[k, k]
        for c in range(ncols):
            B[k, c] *= inv
        for i in range(k + 1, n):
            lik = L[i, k]
            for c in range(ncols):
                B[i, c] -= lik * B[k, c]
    for k in range(n - 1, -1, -1):
        inv = 1.0 / L[k, k]
        for c in range(ncols):
            B[k, c] *= inv
        for i in range(k):
            lki = L[k, i]
            for c in range(ncols):
                B[i, c] -= lki * B[k, c]


@numba.njit(cache=True, inline="always", **_JIT)
def _row_nonzeros(M, i, nz, cnt):
    """Column indices of the non-zeros of row ``i`` of ``M`` into ``nz[i, :cnt[i]]`` (the
    sparsity the loop exploits in ``F`` and ``H``)."""
    c = 0
    for j in range(M.shape[1]):
        if M[i, j] != 0.0:
            nz[i, c] = j
            c += 1
    cnt[i] = c


@numba.njit(cache=True, inline="always", **_JIT)
def _sparse_row_times(M, i, nz, cnt, P, out):
    """``out[i, :] = M[i, :] P`` through the non-zeros ``nz[i, :cnt[i]]`` of row ``i``."""
    n = P.shape[1]
    for c in range(n):
        out[i, c] = 0.0
    for a in range(cnt[i]):
        j = nz[i, a]
        mij = M[i, j]
        for c in range(n):
            out[i, c] += mij * P[j, c]


@numba.njit(cache=True, inline="always", **_JIT)
def _dot_row_nonzeros(X, i, M, j, nz, cnt):
    """``X[i, :] . M[j, :]`` over the non-zeros ``nz[j, :cnt[j]]`` of row ``j`` of ``M``."""
    s = 0.0
    for e in range(cnt[j]):
        c = nz[j, e]
        s += X[i, c] * M[j, c]
    return s


@numba.njit(cache=True, **_JIT)
def _filter_loop(transition, observation, model, data, options, out):
    """The whole run on the grid; writes ``out`` in place and returns ``(status, step)``
    (status 0 = ok; otherwise the step where it failed).

    ``transition``, ``observation``: the model's C callbacks; ``model = (p, u, q_diag,
    r_diag, is_angle)``; ``data = (dts, Z, x0, P0, row_sensor, thresholds)``; ``options =
    [q_per_second, n_sensors, gate_on, store_cov]`` (int64); ``out = (x, P_diag, P, y,
    S_diag, accepted, nis, dof)`` as in :class:`LoopArrays`."""
    params, u, q_diag, r_diag, is_angle = model
    dts, Z, x0, P0, row_sensor, thresholds = data
    q_per_second, n_sensors = options[0] != 0, options[1]
    gate_on, store_cov = options[2] != 0, options[3] != 0
    xs, Pd, Ps, Y, Sd, accepted, nis, dof = out
    N, m = Z.shape
    n = x0.shape[0]
    x = x0.copy()
    P = P0.copy()
    fx = np.empty(n)
    F = np.empty((n, n))
    T = np.empty((n, n))
    f_nz = np.empty((n, n), dtype=np.int64)       # column indices of the non-zeros of a row
    f_cnt = np.empty(n, dtype=np.int64)
    hx = np.empty(m)
    Hf = np.empty((m, n))
    rows = np.empty(m, dtype=np.int64)            # available rows (positions in 0..m-1)
    ya = np.empty(m)
    Ha = np.empty((m, n))
    h_nz = np.empty((m, n), dtype=np.int64)
    h_cnt = np.empty(m, dtype=np.int64)
    HP = np.empty((m, n))
    S = np.empty((m, m))
    L = np.empty((m, m))
    Sg = np.empty((m, m))
    gidx = np.empty(m, dtype=np.int64)
    gb = np.empty((m, 1))
    ok_row = np.empty(m, dtype=np.bool_)
    sel = np.empty(m, dtype=np.int64)             # accepted positions among the available
    Sa = np.empty((m, m))
    B = np.empty((m, n + 1))
    At = np.empty((n, n))                         # (I - K H)^T of an update
    for k in range(N):
        if k > 0:
            # -- predict (eqs. 4.3, 4.5): P = F P F^T + Q, F applied through its non-zeros
            dt = dts[k - 1]
            transition(x, u, dt, params, fx, F)
            for i in range(n):
                _row_nonzeros(F, i, f_nz, f_cnt)
            for i in range(n):                    # T = F P
                _sparse_row_times(F, i, f_nz, f_cnt, P, T)
            for i in range(n):                    # P = T F^T + Q: the upper triangle,
                for j in range(i, n):             # mirrored (symmetric by construction)
                    v = _dot_row_nonzeros(T, i, F, j, f_nz, f_cnt)
                    P[i, j] = v
                    P[j, i] = v
                P[i, i] += q_diag[i] * dt if q_per_second else q_diag[i]
            for i in range(n):
                x[i] = fx[i]
        # -- update (eqs. 4.7-4.11) with the rows that have a sample at this step; the
        # outputs of the step start as "no sample" (written here, not pre-filled)
        for r in range(m):
            Y[k, r] = np.nan
            Sd[k, r] = np.nan
            accepted[k, r] = False
        nis[k] = np.nan
        dof[k] = 0
        na = 0
        for r in range(m):
            if math.isfinite(Z[k, r]):
                rows[na] = r
                na += 1
        if na > 0:
            observation(x, params, hx, Hf)
            for a in range(na):
                r = rows[a]
                yv = Z[k, r] - hx[r]
                if is_angle[r]:
                    yv = wrap_angle(yv)
                ya[a] = yv
                for j in range(n):
                    Ha[a, j] = Hf[r, j]
                _row_nonzeros(Ha, a, h_nz, h_cnt)
            for a in range(na):                   # HP = H P
                _sparse_row_times(Ha, a, h_nz, h_cnt, P, HP)
            for a in range(na):                   # S = H P H^T + R (eq. 4.9), lower
                for b in range(a + 1):            # triangle: all the factorisations read
                    S[a, b] = _dot_row_nonzeros(HP, a, Ha, b, h_nz, h_cnt)
                S[a, a] += r_diag[rows[a]]
            for a in range(na):
                ok_row[a] = True
            if gate_on:                           # marginal NIS of each sensor group
                for g in range(n_sensors):
                    ng = 0
                    for a in range(na):
                        if row_sensor[rows[a]] == g:
                            gidx[ng] = a
                            ng += 1
                    if ng == 0:
                        continue
                    for a in range(ng):
                        for b in range(ng):
                            Sg[a, b] = S[gidx[a], gidx[b]]
                        gb[a, 0] = ya[gidx[a]]
                    if not _cholesky(Sg, ng, L):
                        return _GATE_SINGULAR, k
                    _cho_solve(L, ng, gb, 1)
                    d2 = 0.0
                    for a in range(ng):
                        d2 += ya[gidx[a]] * gb[a, 0]
                    if not d2 <= thresholds[ng - 1]:
                        for a in range(ng):
                            ok_row[gidx[a]] = False
            nacc = 0
            for a in range(na):
                r = rows[a]
                Y[k, r] = ya[a]
                Sd[k, r] = S[a, a]
                accepted[k, r] = ok_row[a]
                if ok_row[a]:
                    sel[nacc] = a
                    nacc += 1
            if nacc > 0:
                # Cholesky solve S_a [K^T | u] = [H_a P | y_a] (eq. 4.10 without S^-1)
                for a in range(nacc):             # (the lower triangle of S_a: all
                    for b in range(a + 1):        # the factorisation reads)
                        Sa[a, b] = S[sel[a], sel[b]]
                    for c in range(n):
                        B[a, c] = HP[sel[a], c]
                    B[a, n] = ya[sel[a]]
                if not _cholesky(Sa, nacc, L):
                    return _S_NOT_PD, k
                _cho_solve(L, nacc, B, n + 1)
                d2 = 0.0
                for a in range(nacc):
                    d2 += ya[sel[a]] * B[a, n]
                if not d2 >= 0.0:
                    return _NIS_NEGATIVE, k
                nis[k] = d2
                dof[k] = nacc
                for a in range(nacc):             # x = x + K y (eq. 4.11), K = B[:, :n]^T
                    yv = ya[sel[a]]
                    for i in range(n):
                        x[i] += B[a, i] * yv
                # Joseph form P = A P A^T + K R K^T with A = I - K H formed first, as the
                # reference does: a sum of two PSD terms, so round-off cannot take P far
                # from PSD (evaluated as (P - K H P) + (K R - (P - K H P) H^T) K^T it was
                # the short form (I - K H) P plus a term zero for the optimal gain, and lost
                # PSD as the short form does: -3e-6 of the largest eigenvalue where the
                # reference kept -3e-12). A is kept as its transpose At, so that both
                # products are row updates over contiguous rows (vectorised; each entry
                # summed over e = 0, 1, ... as a dot product would)
                for e in range(n):                # At = (I - K H)^T, K = B[:, :n]^T, H
                    for i in range(n):            # through its non-zeros
                        At[e, i] = 1.0 if i == e else 0.0
                for a in range(nacc):
                    s_a = sel[a]
                    for nz in range(h_cnt[s_a]):
                        e = h_nz[s_a, nz]
                        hae = Ha[s_a, e]
                        for i in range(n):
                            At[e, i] -= B[a, i] * hae
                for i in range(n):                # T = A P, row i: sum_e A[i, e] P[e, :]
                    for c in range(n):
                        T[i, c] = 0.0
                    for e in range(n):
                        aie = At[e, i]
                        for c in range(n):
                            T[i, c] += aie * P[e, c]
                for i in range(n):                # P = T A^T + K R K^T (P is read no more:
                    for j in range(n):            # T holds A P), row i: sum_e T[i, e] At[e, :]
                        P[i, j] = 0.0
                    for e in range(n):
                        tie = T[i, e]
                        for j in range(n):
                            P[i, j] += tie * At[e, j]
                    for a in range(nacc):
                        kr = B[a, i] * r_diag[rows[sel[a]]]
                        for j in range(n):
                            P[i, j] += kr * B[a, j]
                # symmetrised as (P + P^T) / 2, as the reference: the round-off of A P is
                # large against a posterior far below the prior, and the mean of the two
                # triangles keeps P PSD to round-off where mirroring one did not (-4e-7 of
                # the largest eigenvalue on tests/estimation/test_numerics_est25_review's
                # draws, the mean -6e-11)
                for i in range(n):
                    for j in range(i + 1, n):
                        v = 0.5 * (P[i, j] + P[j, i])
                        P[i, j] = v
                        P[j, i] = v
        for i in range(n):
            xs[k, i] = x[i]
            Pd[k, i] = P[i, i]
        if store_cov:
            for i in range(n):
                for j in range(n):
                    Ps[k, i, j] = P[i, j]
    return _OK, N


def run_compiled(kernel: FastKernel, dts: np.ndarray, Z: np.ndarray, x0: np.ndarray,
                 P0: np.ndarray, R_diag: np.ndarray, row_sensor: np.ndarray, n_sensors: int,
                 *, thresholds: np.ndarray | None = None,
                 store_covariance: bool = False) -> LoopArrays:
    """Run the compiled EKF loop over prepared measurements.

    Called by :func:`terrain.estimation.run_filter` after its scheduling (which places the
    samples on the grid and validates the inputs); not normally called directly.

    Parameters
    ----------
    kernel : FastKernel
        The model's kernels and constants.
    dts : ndarray, shape (N - 1,)
        Grid steps, s (> 0).
    Z : ndarray, shape (N, m)
        Measurement of each row at each step (SI units), NaN where there is no sample.
    x0 : ndarray, shape (n,)
        Initial state.
    P0 : ndarray, shape (n, n)
        Initial covariance.
    R_diag : ndarray, shape (m,)
        Measurement noise variances (> 0).
    row_sensor : ndarray of int, shape (m,)
        Sensor group of each row (index into the model's ``sensor_rows``; -1 = none, never
        gated).
    n_sensors : int
        Number of sensor groups.
    thresholds : ndarray, shape (d_max,), optional
        Chi-square gate threshold for 1..d_max degrees of freedom
        (:meth:`~terrain.estimation.Gate.threshold`); None = no gating.
    store_covariance : bool
        Keep the full covariance of every step.

    Returns
    -------
    LoopArrays

    Raises
    ------
    ShapeError
        Sizes that disagree with each other or with the kernel: ``dts`` not ``(N - 1,)``,
        ``P0`` not ``(n, n)``, ``R_diag`` or ``row_sensor`` not ``(m,)``, fewer
        ``thresholds`` than the rows of the largest sensor group (the loop runs without
        bounds checks: a short array was read past its end).
    CovarianceError
        ``S`` (or a gated group's block of it) is not positive definite, or a NIS is
        negative, at some step (the message names the step).
    NonFiniteInputError
        A non-finite innovation among a step's accepted rows (the model's ``h(x)`` is NaN
        or inf; the message names the step and rows).
    """
    Z = np.ascontiguousarray(Z, dtype=np.float64)
    N, m = Z.shape
    x0 = np.ascontiguousarray(x0, dtype=np.float64)
    n = x0.shape[0]
    if (n, m) != (kernel.n_states, kernel.n_measurements):
        raise ShapeError(f"the kernel needs {kernel.n_states} states and "
                         f"{kernel.n_measurements} rows, got {n} and {m}")
    dts = np.ascontiguousarray(dts, dtype=np.float64)
    P0 = np.ascontiguousarray(P0, dtype=np.float64)
    R_diag = np.ascontiguousarray(R_diag, dtype=np.float64)
    row_sensor = np.ascontiguousarray(row_sensor, dtype=np.int64)
    for name, arr, shape in (("dts", dts, (max(N - 1, 0),)), ("P0", P0, (n, n)),
                             ("R_diag", R_diag, (m,)), ("row_sensor", row_sensor, (m,))):
        if arr.shape != shape:
            raise ShapeError(f"run_compiled: {name} must be of shape {shape} for {N} steps, "
                             f"{n} states and {m} rows, got {arr.shape}")
    is_angle = np.zeros(m, dtype=np.bool_)
    is_angle[list(kernel.angle_rows)] = True
    gate_on = thresholds is not None
    thr = np.ones(1) if thresholds is None else np.ascontiguousarray(thresholds, np.float64)
    if gate_on:     # (only then: the window filters call this once per window, ungated)
        largest = max([int(np.count_nonzero(row_sensor == g)) for g in range(int(n_sensors))],
                      default=0)
        if thr.ndim != 1 or thr.size < largest:
            raise ShapeError(f"run_compiled: thresholds must hold one per degree of freedom "
                             f"up to the {largest} rows of the largest sensor group, got "
                             f"shape {thr.shape}")
    out = (np.empty((N, n)), np.empty((N, n)),
           np.empty((N if store_covariance else 0, n, n)), np.empty((N, m)),
           np.empty((N, m)), np.empty((N, m), dtype=np.bool_), np.empty(N),
           np.empty(N, dtype=np.int64))            # every entry written by the loop
    model = (np.asarray(kernel.params, dtype=np.float64), np.zeros(0),
             np.asarray(kernel.q_diag, dtype=np.float64), R_diag, is_angle)
    data = (dts, Z, x0, P0, row_sensor, thr)
    options = np.array([kernel.q_per == "second", int(n_sensors), gate_on,
                        bool(store_covariance)], dtype=np.int64)
    status, step = _filter_loop(_callback(kernel.transition, TRANSITION_SIGNATURE),
                                _callback(kernel.observation, OBSERVATION_SIGNATURE),
                                model, data, options, out)
    if status == _S_NOT_PD:
        raise CovarianceError("innovation covariance S = H P H^T + R is not positive definite "
                              f"(Cholesky failed at step {step})")
    if status == _NIS_NEGATIVE:
        Y, used = out[3][step], out[5][step]
        if not np.isfinite(Y[used]).all():
            raise NonFiniteInputError(f"innovation y is not finite at step {step} (rows "
                                      f"{np.flatnonzero(used & ~np.isfinite(Y)).tolist()}: "
                                      "the model's h(x) is NaN or inf)")
        raise CovarianceError(f"innovation covariance S is not positive definite (NIS not "
                              f">= 0 at step {step})")
    if status == _GATE_SINGULAR:
        raise CovarianceError(f"innovation covariance S is singular (gate, step {step})")
    xs, Pd, Ps, Y, Sd, accepted, nis, dof = out
    return LoopArrays(x=xs, P_diag=Pd, P=Ps if store_covariance else None, y=Y, S_diag=Sd,
                      accepted=accepted, nis=nis, dof=dof)


__all__ = ["TRANSITION_SIGNATURE", "OBSERVATION_SIGNATURE", "FastKernel", "fast_kernel_of",
           "run_compiled"]
