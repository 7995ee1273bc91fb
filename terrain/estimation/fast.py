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

Models opt in with a method ``fast_kernel() -> FastKernel | None`` (AgriMaRo, ch. 6.1, and
the skid-steer model implement it). The kernels live in this module, next to the loop that
calls them: numba's on-disk cache (``cache=True``: the first call on a machine compiles in
about 4.5 s on 2 cores, later processes load it in about 0.3 s) is invalidated only by edits
to the file of the cached function, so a kernel kept in another module could go stale
silently. Restrictions
of the fast path: the measurement noise is diagonal (``R_diag``), the process noise is
diagonal (``q_diag`` per step, or ``q_diag dt``), and the model's ``residual`` is the
default one (``z - h(x)``, angle rows wrapped).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from terrain.errors import CovarianceError, ShapeError
from terrain.estimation.runner import LoopArrays

#: Kernel names understood by the compiled loop, with their integer code.
KERNELS: tuple[str, ...] = ("agrimaro", "skid_steer")
#: Status codes returned by the compiled loop.
_OK, _S_NOT_PD, _NIS_NEGATIVE, _GATE_SINGULAR = 0, 1, 2, 3


@dataclass(frozen=True)
class FastKernel:
    """Description of a model for the compiled loop.

    Parameters
    ----------
    kind : str
        One of :data:`KERNELS`: ``"agrimaro"`` (12 states, 14 rows, seed 001 ch. 6.1,
        eqs. 6.2/4.33-4.34 and 6.6) or ``"skid_steer"`` (4 states, 3 rows, see
        :mod:`terrain.estimation.skid_steer`).
    params : tuple of float
        Model constants in the order the kernel reads them: AgriMaRo ``(coriolis sign,
        x_1, y_1, x_2, y_2, x_3, y_3, wheel radius, d_cam_x, d_cam_y)`` (sign 1 for the body
        convention, -1 for eq. 6.2 as printed; positions and radius in m); skid-steer
        ``(track B m, chi_min_yaw_rate rad/s)``.
    q_diag : tuple of float
        Process noise variances (n,), SI units squared, per step or per second.
    q_per : {"step", "second"}
        ``Q = diag(q_diag)`` at every step, or ``Q = diag(q_diag) dt``.
    angle_rows : tuple of int
        Measurement rows whose innovation is wrapped to [-pi, pi).
    """

    kind: str
    params: tuple[float, ...]
    q_diag: tuple[float, ...]
    q_per: str = "step"
    angle_rows: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in KERNELS:
            raise ValueError(f"unknown kernel {self.kind!r}; valid: {', '.join(KERNELS)}")
        if self.q_per not in ("step", "second"):
            raise ValueError(f"q_per must be 'step' or 'second', got {self.q_per!r}")


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


# -- model kernels (seed 001 ch. 6.1; skid-steer of terrain.estimation.skid_steer) -----------

@numba.njit(cache=True)
def _agrimaro_transition(x, dt, p, fx, F):
    """AgriMaRo process model (eqs. 6.2, 4.33-4.34) and its Jacobian, into ``fx`` (12,) and
    ``F`` (12, 12); ``p[0]`` is the Coriolis sign."""
    yaw, vx, vy, w, ax, ay = x[2], x[3], x[4], x[5], x[6], x[7]
    c, s = math.cos(yaw), math.sin(yaw)
    sg = p[0]
    for i in range(12):
        fx[i] = x[i]
        for j in range(12):
            F[i, j] = 0.0
        F[i, i] = 1.0
    fx[0] += dt * (vx * c - vy * s)
    fx[1] += dt * (vx * s + vy * c)
    fx[2] += dt * w
    fx[3] += dt * (ax + sg * w * vy)
    fx[4] += dt * (ay - sg * w * vx)
    F[0, 2] = -dt * (vx * s + vy * c)
    F[0, 3] = dt * c
    F[0, 4] = -dt * s
    F[1, 2] = dt * (vx * c - vy * s)
    F[1, 3] = dt * s
    F[1, 4] = dt * c
    F[2, 5] = dt
    F[3, 4] = sg * dt * w
    F[3, 5] = sg * dt * vy
    F[3, 6] = dt
    F[4, 3] = -sg * dt * w
    F[4, 5] = -sg * dt * vx
    F[4, 7] = dt


@numba.njit(cache=True)
def _agrimaro_observation(x, p, hx, H):
    """AgriMaRo measurement model (eq. 6.6) and its Jacobian, into ``hx`` (14,) and ``H``
    (14, 12); ``p = (sign, x_1, y_1, x_2, y_2, x_3, y_3, R_w, d_x, d_y)``."""
    yaw, vx, vy, w, ax, ay, bg = x[2], x[3], x[4], x[5], x[6], x[7], x[11]
    rw, dx, dy = p[7], p[8], p[9]
    for i in range(14):
        for j in range(12):
            H[i, j] = 0.0
    for i in range(3):
        xi, yi, d = p[1 + 2 * i], p[2 + 2 * i], x[8 + i]
        c, s = math.cos(d), math.sin(d)
        u = vx - w * yi
        v = vy + w * xi
        hx[i] = (u * c + v * s) / rw
        H[i, 3] = c / rw
        H[i, 4] = s / rw
        H[i, 5] = (-yi * c + xi * s) / rw
        H[i, 8 + i] = (-u * s + v * c) / rw
    hx[3] = ax
    hx[4] = ay
    hx[5] = w + bg
    hx[6] = yaw
    hx[7] = x[8]
    hx[8] = x[9]
    hx[9] = x[10]
    hx[10] = vx - w * dy
    hx[11] = vy + w * dx
    hx[12] = w
    hx[13] = yaw
    H[3, 6] = 1.0
    H[4, 7] = 1.0
    H[5, 5] = 1.0
    H[5, 11] = 1.0
    H[6, 2] = 1.0
    H[7, 8] = 1.0
    H[8, 9] = 1.0
    H[9, 10] = 1.0
    H[10, 3] = 1.0
    H[10, 5] = -dy
    H[11, 4] = 1.0
    H[11, 5] = dx
    H[12, 5] = 1.0
    H[13, 2] = 1.0


@numba.njit(cache=True)
def _skid_transition(x, dt, p, fx, F):
    """Skid-steer random walk: ``fx = x``, ``F = I`` (4 states)."""
    n = x.shape[0]
    for i in range(n):
        fx[i] = x[i]
        for j in range(n):
            F[i, j] = 0.0
        F[i, i] = 1.0


@numba.njit(cache=True)
def _skid_observation(x, p, hx, H):
    """Skid-steer ICR wheel model and gyro, into ``hx`` (3,) and ``H`` (3, 4);
    ``p = (track B, chi_min_yaw_rate)``."""
    v, w, b, lc = x[0], x[1], x[2], x[3]
    k = math.exp(lc) * 0.5 * p[0]
    hx[0] = v - k * w
    hx[1] = v + k * w
    hx[2] = w + b
    kw = k * w if abs(w) >= p[1] else 0.0
    H[0, 0], H[0, 1], H[0, 2], H[0, 3] = 1.0, -k, 0.0, -kw
    H[1, 0], H[1, 1], H[1, 2], H[1, 3] = 1.0, k, 0.0, kw
    H[2, 0], H[2, 1], H[2, 2], H[2, 3] = 0.0, 1.0, 1.0, 0.0


@numba.njit(cache=True)
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
        for i in range(j + 1, n):
            t = A[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d
    return True


@numba.njit(cache=True)
def _cho_solve(L, n, B, ncols):
    """Overwrite ``B[:n, :ncols]`` with ``(L L^T)^-1 B`` (forward, then back substitution)."""
    for i in range(n):
        for k in range(i):
            lik = L[i, k]
            for c in range(ncols):
                B[i, c] -= lik * B[k, c]
        d = L[i, i]
        for c in range(ncols):
            B[i, c] /= d
    for i in range(n - 1, -1, -1):
        for k in range(i + 1, n):
            lki = L[k, i]
            for c in range(ncols):
                B[i, c] -= lki * B[k, c]
        d = L[i, i]
        for c in range(ncols):
            B[i, c] /= d


@numba.njit(cache=True)
def _filter_loop(kind, params, q_diag, q_per_second, dts, Z, x0, P0, r_diag, is_angle,
                 row_sensor, n_sensors, gate_on, thresholds, store_cov,
                 xs, Pd, Ps, Y, Sd, acc, nis, dof):
    """The whole run on the grid; writes the outputs in place and returns
    ``(status, step)`` (status 0 = ok; otherwise the step where it failed)."""
    N, m = Z.shape
    n = x0.shape[0]
    x = x0.copy()
    P = P0.copy()
    fx = np.empty(n)
    F = np.empty((n, n))
    T = np.empty((n, n))
    U = np.empty((n, n))
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
    BR = np.empty((m, n))
    A = np.empty((n, n))
    AP = np.empty((n, n))
    two_pi = 2.0 * math.pi
    for k in range(N):
        if k > 0:
            # -- predict (eqs. 4.3, 4.5): P = F P F^T + Q, F applied through its non-zeros
            dt = dts[k - 1]
            if kind == 0:
                _agrimaro_transition(x, dt, params, fx, F)
            else:
                _skid_transition(x, dt, params, fx, F)
            for i in range(n):
                c = 0
                for j in range(n):
                    if F[i, j] != 0.0:
                        f_nz[i, c] = j
                        c += 1
                f_cnt[i] = c
            for i in range(n):                    # T = F P
                for j in range(n):
                    T[i, j] = 0.0
                for a in range(f_cnt[i]):
                    j = f_nz[i, a]
                    fij = F[i, j]
                    for c in range(n):
                        T[i, c] += fij * P[j, c]
            for i in range(n):                    # U = T F^T
                for j in range(n):
                    s = 0.0
                    for a in range(f_cnt[j]):
                        c = f_nz[j, a]
                        s += T[i, c] * F[j, c]
                    U[i, j] = s
            for i in range(n):
                U[i, i] += q_diag[i] * dt if q_per_second else q_diag[i]
            for i in range(n):
                for j in range(i, n):
                    v = 0.5 * (U[i, j] + U[j, i])
                    P[i, j] = v
                    P[j, i] = v
            for i in range(n):
                x[i] = fx[i]
        # -- update (eqs. 4.7-4.11) with the rows that have a sample at this step
        na = 0
        for r in range(m):
            if math.isfinite(Z[k, r]):
                rows[na] = r
                na += 1
        if na > 0:
            if kind == 0:
                _agrimaro_observation(x, params, hx, Hf)
            else:
                _skid_observation(x, params, hx, Hf)
            for a in range(na):
                r = rows[a]
                yv = Z[k, r] - hx[r]
                if is_angle[r]:
                    yv = (yv + math.pi) % two_pi - math.pi
                ya[a] = yv
                c = 0
                for j in range(n):
                    hv = Hf[r, j]
                    Ha[a, j] = hv
                    if hv != 0.0:
                        h_nz[a, c] = j
                        c += 1
                h_cnt[a] = c
            for a in range(na):                   # HP = H P
                for j in range(n):
                    HP[a, j] = 0.0
                for e in range(h_cnt[a]):
                    j = h_nz[a, e]
                    hv = Ha[a, j]
                    for c in range(n):
                        HP[a, c] += hv * P[j, c]
            for a in range(na):                   # S = H P H^T + R (eq. 4.9)
                for b in range(na):
                    s = 0.0
                    for e in range(h_cnt[b]):
                        j = h_nz[b, e]
                        s += HP[a, j] * Ha[b, j]
                    S[a, b] = s
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
                acc[k, r] = ok_row[a]
                if ok_row[a]:
                    sel[nacc] = a
                    nacc += 1
            if nacc > 0:
                # Cholesky solve S_a [K^T | u] = [H_a P | y_a] (eq. 4.10 without S^-1)
                for a in range(nacc):
                    for b in range(nacc):
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
                for i in range(n):                # A = I - K H
                    for j in range(n):
                        A[i, j] = 0.0
                    A[i, i] = 1.0
                for a in range(nacc):
                    s_a = sel[a]
                    for e in range(h_cnt[s_a]):
                        j = h_nz[s_a, e]
                        hv = Ha[s_a, j]
                        for i in range(n):
                            A[i, j] -= B[a, i] * hv
                for i in range(n):                # AP = A P
                    for c in range(n):
                        AP[i, c] = 0.0
                    for j in range(n):
                        aij = A[i, j]
                        if aij != 0.0:
                            for c in range(n):
                                AP[i, c] += aij * P[j, c]
                for a in range(nacc):             # K R (rows of B scaled by r)
                    r_a = r_diag[rows[sel[a]]]
                    for i in range(n):
                        BR[a, i] = B[a, i] * r_a
                for i in range(n):                # P = A P A^T + K R K^T (Joseph form),
                    for j in range(i, n):         # upper triangle, mirrored: symmetric
                        s = 0.0
                        for c in range(n):
                            s += AP[i, c] * A[j, c]
                        for a in range(nacc):
                            s += BR[a, i] * B[a, j]
                        P[i, j] = s
                        P[j, i] = s
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
        Sizes that disagree with each other or with the kernel.
    CovarianceError
        ``S`` (or a gated group's block of it) is not positive definite, or a NIS is
        negative, at some step (the message names the step).
    """
    Z = np.ascontiguousarray(Z, dtype=np.float64)
    N, m = Z.shape
    x0 = np.ascontiguousarray(x0, dtype=np.float64)
    n = x0.shape[0]
    sizes = {"agrimaro": (12, 14), "skid_steer": (4, 3)}[kernel.kind]
    if (n, m) != sizes:
        raise ShapeError(f"kernel {kernel.kind!r} needs {sizes[0]} states and {sizes[1]} rows, "
                         f"got {n} and {m}")
    is_angle = np.zeros(m, dtype=np.bool_)
    is_angle[list(kernel.angle_rows)] = True
    gate_on = thresholds is not None
    thr = np.ones(1) if thresholds is None else np.ascontiguousarray(thresholds, np.float64)
    xs = np.empty((N, n))
    Pd = np.empty((N, n))
    Ps = np.empty((N if store_covariance else 0, n, n))
    Y = np.full((N, m), np.nan)
    Sd = np.full((N, m), np.nan)
    acc = np.zeros((N, m), dtype=np.bool_)
    nis = np.full(N, np.nan)
    dof = np.zeros(N, dtype=np.int64)
    status, step = _filter_loop(
        KERNELS.index(kernel.kind), np.asarray(kernel.params, dtype=np.float64),
        np.asarray(kernel.q_diag, dtype=np.float64), kernel.q_per == "second",
        np.ascontiguousarray(dts, dtype=np.float64), Z, x0,
        np.ascontiguousarray(P0, dtype=np.float64),
        np.ascontiguousarray(R_diag, dtype=np.float64), is_angle,
        np.ascontiguousarray(row_sensor, dtype=np.int64), int(n_sensors), gate_on, thr,
        bool(store_covariance), xs, Pd, Ps, Y, Sd, acc, nis, dof)
    if status == _S_NOT_PD:
        raise CovarianceError("innovation covariance S = H P H^T + R is not positive definite "
                              f"(Cholesky failed at step {step})")
    if status == _NIS_NEGATIVE:
        raise CovarianceError(f"innovation covariance S is not positive definite (NIS not "
                              f">= 0 at step {step})")
    if status == _GATE_SINGULAR:
        raise CovarianceError(f"innovation covariance S is singular (gate, step {step})")
    return LoopArrays(x=xs, P_diag=Pd, P=Ps if store_covariance else None, y=Y, S_diag=Sd,
                   accepted=acc, nis=nis, dof=dof)


__all__ = ["KERNELS", "FastKernel", "fast_kernel_of", "run_compiled"]
