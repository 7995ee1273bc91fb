"""Generic extended Kalman filter core: pure predict / update functions and a streaming wrapper.

Model (seed ``001_59da564c4b2d6a48.txt`` ch. 4.1, eqs. 4.1-4.12)::

    x_k = f(x_{k-1}, dt) + w_k,   w_k ~ N(0, Q(dt))
    z_k = h(x_k) + v_k,           v_k ~ N(0, R)

* :func:`predict` propagates the mean through ``f`` and the covariance through the Jacobian
  ``F = df/dx`` evaluated at the previous estimate (eqs. 4.3, 4.5).
* :func:`update` forms the innovation ``y = z - h(x)`` (eq. 4.7, or a model ``residual`` that
  wraps angles), its covariance ``S = H P H^T + R`` (eq. 4.9) and the gain
  ``K = P H^T S^-1`` (eq. 4.10) *by a linear solve* (``S`` is never inverted: one Cholesky
  solve (LAPACK ``dposv``) of ``S [K^T | u] = [H P | y]`` gives both the gain and ``S^-1 y``
  for the NIS, and fails cleanly when ``S`` is not positive definite). The covariance
  is updated in Joseph form ``P = (I - K H) P (I - K H)^T + K R K^T`` rather than eq. 4.12
  ``(I - K H) P``: both are equal for the optimal gain, but the Joseph form is a sum of
  positive semi-definite terms, so round-off (or a gain computed from a gated subset of rows)
  cannot make ``P`` lose symmetry or positive semi-definiteness.
* Optional chi-square gating (:class:`Gate`): the innovation of each sensor group is tested on
  its own marginal NIS ``y_g^T S_gg^-1 y_g`` against the chi-square quantile of its size; a
  group that fails is left out of the update, so one outlier sensor cannot corrupt the state.

Arrays are plain vectors: states ``(n,)``, measurements ``(m,)``, covariances ``(n, n)`` and
``(m, m)`` (never ``(n, 1)`` column vectors). Functions return new arrays and never modify
their inputs. Bad input raises a subclass of :class:`terrain.errors.EstimationError`; a bad
setting (the gate probability) a :class:`terrain.errors.ConfigError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
from scipy import stats
from scipy.linalg import lapack

from terrain.errors import (ConfigError, CovarianceError, EstimationError, NonFiniteInputError,
                            ShapeError, TimeStepError, config_integer, config_numbers,
                            holds_booleans, is_integer)

#: Relative tolerance of the symmetry check of a covariance matrix.
SYMMETRY_RTOL = 1e-6
#: Smallest eigenvalue allowed for a PSD covariance, relative to its largest (round-off).
PSD_RTOL = 1e-9

Residual = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _refuse_booleans(v: Any, name: str) -> None:
    """Refuse a boolean array or scalar (``np.asarray(mask, float)`` silently gave 0 and 1)."""
    if holds_booleans(v):
        raise EstimationError(f"{name} must hold numbers, got booleans: {v!r}")


def real_array(v: Any, name: str) -> np.ndarray:
    """``v`` as a float64 array of any shape (``np.asarray(v, dtype=float)``, the same
    values), refused when it holds booleans, text or complex numbers.

    Numeric text such as ``"0.5"`` was parsed as a number and other text was a bare
    ValueError naming nothing; an array's imaginary part was dropped with a warning only. A
    float array passes on one type test.

    Parameters
    ----------
    v : array_like
        Values (any unit, any shape).
    name : str
        Argument name used in error messages.

    Returns
    -------
    ndarray
        float64, the shape of ``v`` (``v`` itself when it is a float64 array).

    Raises
    ------
    EstimationError
        Booleans, text, complex numbers, or anything else that does not convert to real
        numbers (e.g. a ragged list), naming ``name``.
    """
    if type(v) is np.ndarray and v.dtype.kind == "f":
        return np.asarray(v, dtype=float)
    _refuse_booleans(v, name)
    if isinstance(v, (str, bytes)):
        raise EstimationError(f"{name} must hold real numbers, got text {v!r}")
    try:
        a = v if isinstance(v, np.ndarray) else np.asarray(v)
        if a.dtype.kind in "USc":
            raise EstimationError(f"{name} must hold real numbers, got {a.dtype} values "
                                  f"such as {a.reshape(-1)[:3].tolist()}")
        return np.asarray(a, dtype=float)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, EstimationError):
            raise
        raise EstimationError(f"{name} must hold real numbers ({exc})") from None


def as_vector(v: Any, name: str, size: int | None = None) -> np.ndarray:
    """``v`` as a finite float vector of shape ``(size,)``.

    Parameters
    ----------
    v : array_like, shape (size,)
        Values (any unit).
    name : str
        Argument name used in error messages.
    size : int, optional
        Required length (any when None).

    Returns
    -------
    ndarray, shape (size,)
        float64 copy or view.

    Raises
    ------
    ShapeError
        Not one-dimensional, or the wrong length.
    NonFiniteInputError
        NaN or inf entries (their indices are named).
    EstimationError
        A boolean array (a mask is not a state or a measurement; it was read as 0 and 1),
        text or complex numbers.
    """
    a = real_array(v, name)
    if a.ndim != 1 or (size is not None and a.shape[0] != size):
        want = f"({size},)" if size is not None else "(n,)"
        raise ShapeError(f"{name} must have shape {want}, got {a.shape}")
    if not np.isfinite(a).all():
        bad = np.flatnonzero(~np.isfinite(a)).tolist()
        raise NonFiniteInputError(f"{name} has non-finite entries at indices {bad}")
    return a


def as_covariance(P: Any, size: int, name: str, *, definite: bool = False) -> np.ndarray:
    """``P`` as a finite, symmetric, positive semi-definite ``(size, size)`` matrix.

    A vector of length ``size`` is taken for the diagonal of a diagonal covariance.

    Parameters
    ----------
    P : array_like, shape (size, size) or (size,)
        Covariance (SI units squared), or its diagonal.
    size : int
        Required dimension.
    name : str
        Argument name used in error messages.
    definite : bool
        Require positive definiteness (Cholesky succeeds), as for a noise covariance ``R``.

    Returns
    -------
    ndarray, shape (size, size)
        float64 matrix (a diagonal one when a vector was given).

    Raises
    ------
    ShapeError, NonFiniteInputError, CovarianceError
        Wrong shape, non-finite entries, asymmetric, not positive semi-definite (or not
        positive definite with ``definite``).
    EstimationError
        A boolean array (read as 0 and 1 before: ``np.eye(n, dtype=bool)`` was a unit
        covariance), text or complex numbers.
    """
    a = real_array(P, name)
    if a.ndim == 1 and a.shape[0] == size:
        a = np.diag(a)
    if a.shape != (size, size):
        raise ShapeError(f"{name} must have shape ({size}, {size}), got {a.shape}")
    if not size:     # of no row (a reduction over it was NumPy's bare ValueError)
        return a
    if not np.isfinite(a).all():
        raise NonFiniteInputError(f"{name} has non-finite entries")
    scale = max(float(np.abs(a).max()), 1e-300)
    asym = float(np.abs(a - a.T).max())
    if asym > SYMMETRY_RTOL * scale:
        raise CovarianceError(f"{name} is not symmetric (max |{name} - {name}^T| = {asym:.3g})")
    eig = np.linalg.eigvalsh(0.5 * (a + a.T))
    if definite:
        if eig[0] <= 0.0:
            raise CovarianceError(f"{name} is not positive definite (smallest eigenvalue "
                                  f"{eig[0]:.3g})")
    elif eig[0] < -PSD_RTOL * max(float(eig[-1]), 1e-300):
        raise CovarianceError(f"{name} is not positive semi-definite (smallest eigenvalue "
                              f"{eig[0]:.3g}, largest {eig[-1]:.3g})")
    return a


def checked_process_noise(Q: Any, size: int) -> np.ndarray:
    """One step's process noise ``Q(dt)`` from a callable, with the checks of
    :func:`as_covariance`, cheaply enough for every step.

    A finite, non-negative diagonal (a vector of length ``size``, or a matrix whose non-zero
    entries are all on its diagonal: the diagonal process noise of every model here) is a
    covariance, so it is accepted after a count of its non-zero entries (1.4-1.9 us for the
    4x4 and 12x12 ``Q`` of the skid-steer and AgriMaRo models, against 12-13 us for
    :func:`as_covariance` and its eigen-decomposition, best of 7 on the shared 2-core
    machine); anything else goes through :func:`as_covariance` and gets the errors a
    constant ``Q`` gets.

    Parameters
    ----------
    Q : array_like, shape (size, size) or (size,)
        What the callable returned (SI units squared).
    size : int
        State dimension ``n``.

    Returns
    -------
    ndarray, shape (size, size)
        float64 matrix.

    Raises
    ------
    ShapeError, NonFiniteInputError, CovarianceError, EstimationError
        As :func:`as_covariance` with the name ``Q`` (booleans were a unit covariance).
    """
    a = real_array(Q, "Q")   # (a float array: one type test)
    # (Python comparisons on the few diagonal entries: NaN fails them; a NumPy reduction
    # costs about 2 us each)
    if a.shape == (size,):
        if all(0.0 <= v < math.inf for v in a.tolist()):
            return np.diag(a)
    elif a.shape == (size, size):
        d = a.diagonal()
        if np.count_nonzero(a) == np.count_nonzero(d) \
                and all(0.0 <= v < math.inf for v in d.tolist()):   # NaN counts as non-zero
            return a
    return as_covariance(a, size, "Q")


def check_time_step(dt: float) -> float:
    """``dt`` as a float, strictly positive and finite.

    Parameters
    ----------
    dt : float
        Time step, s.

    Returns
    -------
    float
        ``dt``, s.

    Raises
    ------
    TimeStepError
        Not a number (a boolean or text included), not finite or not > 0.
    """
    try:
        # float(True) is a 1 s step, float("0.1") a step of text
        if isinstance(dt, (bool, np.bool_, str, bytes)):
            raise TypeError
        d = float(dt)
    except (TypeError, ValueError):
        raise TimeStepError(f"time step must be a number, got {dt!r}") from None
    if not (math.isfinite(d) and d > 0.0):     # (math: 0.1 us where NumPy took 0.5 us)
        raise TimeStepError(f"time step must be > 0 and finite, got {dt!r} s")
    return d


def _row_partition(groups: Sequence[Any], m: int) -> list[np.ndarray]:
    """``groups`` as integer row arrays, refused (:class:`ShapeError`) unless they partition
    ``range(m)``: a row in no group was never gated (an outlier on it went into the state),
    a row out of range was a bare IndexError and a repeated one a false "S is singular"."""
    out = []
    for g in groups:
        a = np.asarray(g).reshape(-1)
        if a.size and a.dtype.kind not in "iu":
            raise ShapeError(f"gate groups must hold integer row numbers, got {g!r}")
        out.append(a.astype(int))
    rows = np.concatenate(out) if out else np.zeros(0, dtype=int)
    outside = rows[(rows < 0) | (rows >= m)]
    if outside.size:
        raise ShapeError(f"gate groups name row(s) {sorted(set(outside.tolist()))} outside "
                         f"0..{m - 1}")
    count = np.bincount(rows, minlength=m)
    if (count > 1).any():
        raise ShapeError(f"gate groups must partition the {m} rows: row(s) "
                         f"{np.flatnonzero(count > 1).tolist()} in more than one group")
    if (count == 0).any():
        raise ShapeError(f"gate groups must partition the {m} rows: row(s) "
                         f"{np.flatnonzero(count == 0).tolist()} in no group (never gated)")
    return out


@dataclass(frozen=True)
class Gate:
    """Chi-square innovation gate.

    A sensor group of ``d`` rows is rejected when its marginal NIS exceeds the
    ``probability`` quantile of the chi-square distribution with ``d`` degrees of freedom
    (``probability = 0.999``: a consistent filter rejects 0.1 % of good samples).

    Parameters
    ----------
    probability : float
        In (0, 1), exclusive (0 would reject every sample, 1 none).
    max_dof : int
        Largest group size supported (>= 1).

    Raises
    ------
    ConfigError
        ``probability`` not a real number in (0, 1) (text, a boolean), or ``max_dof`` not an
        integer >= 1 (a ``ValueError``).
    """

    probability: float = 0.999
    max_dof: int = 64
    _thresholds: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        try:
            config_numbers("Gate", probability=self.probability)   # (the text "0.999" passed)
            p = float(self.probability)
        except ConfigError:
            p = float("nan")
        if not 0.0 < p < 1.0:
            raise ConfigError(f"gate probability must be in (0, 1) exclusive, e.g. 0.999, got "
                              f"{self.probability!r}")
        config_integer("Gate.max_dof", self.max_dof, 1)   # (2.7 was 2 and True 1)
        table = stats.chi2.ppf(float(self.probability), np.arange(1, int(self.max_dof) + 1))
        object.__setattr__(self, "_thresholds", table)

    def threshold(self, dof: int) -> float:
        """Chi-square quantile for ``dof`` degrees of freedom.

        Parameters
        ----------
        dof : int
            Degrees of freedom, 1 <= dof <= ``max_dof``.

        Returns
        -------
        float
            The ``probability`` quantile (dimensionless NIS).

        Raises
        ------
        ConfigError
            ``dof`` not an integer (1.5 was 1 and True 1; text, None and NaN bare errors) or
            outside ``1 .. max_dof`` (a sensor group larger than the gate was built for:
            raise ``max_dof``).
        """
        if not is_integer(dof):
            raise ConfigError(f"gate threshold: dof must be an integer number of rows, got "
                              f"{dof!r}")
        d = int(dof)
        if not 1 <= d <= self._thresholds.size:
            raise ConfigError(f"gate has chi-square thresholds for 1..{self._thresholds.size} "
                              f"degrees of freedom, asked for {dof} (a sensor group of {dof} "
                              f"rows needs Gate(max_dof >= {dof}))")
        return float(self._thresholds[d - 1])


@dataclass(frozen=True)
class Innovation:
    """Innovation record of one update.

    Attributes
    ----------
    y : ndarray, shape (m,)
        Innovation ``z - h(x_prior)`` of every row (rejected rows included), units of ``z``.
    S : ndarray, shape (m, m)
        Innovation covariance ``H P H^T + R`` of every row.
    nis : float
        Normalised innovation squared ``y_a^T S_aa^-1 y_a`` over the accepted rows ``a``
        (seed 001 eq. 4.14); NaN when no row was accepted.
    accepted : ndarray of bool, shape (m,)
        Rows used in the update (False for rows rejected by the gate).
    """

    y: np.ndarray
    S: np.ndarray
    nis: float
    accepted: np.ndarray

    @property
    def dof(self) -> int:
        """Degrees of freedom of :attr:`nis` (number of accepted rows)."""
        return int(np.count_nonzero(self.accepted))

    @property
    def normalised(self) -> np.ndarray:
        """Per-row normalised innovation ``y_i / sqrt(S_ii)``, shape (m,)."""
        return self.y / np.sqrt(np.diag(self.S))


def predict(x: np.ndarray, P: np.ndarray, dt: float, f: Callable[..., np.ndarray],
            F: Callable[..., np.ndarray], Q: np.ndarray | Callable[[float], np.ndarray], *,
            args: tuple = (), check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """EKF prediction (seed 001 eqs. 4.3 and 4.5).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Posterior state at the previous step.
    P : ndarray, shape (n, n)
        Its covariance.
    dt : float
        Time step, s (> 0).
    f : callable ``f(x, dt, *args) -> (n,)``
        State transition.
    F : callable ``F(x, dt, *args) -> (n, n)``
        Jacobian of ``f`` with respect to ``x``, evaluated at the previous state.
    Q : ndarray, shape (n, n) or (n,), or callable ``Q(dt)``
        Process noise covariance of one step of length ``dt`` (a vector is its diagonal).
    args : tuple
        Extra arguments of ``f`` and ``F`` (e.g. a control input).
    check : bool
        Validate every input (shapes, finiteness, symmetry and PSD of ``P`` and ``Q``,
        ``dt > 0``). The streaming wrapper validates once and then skips the checks.

    Returns
    -------
    x_prior : ndarray, shape (n,)
    P_prior : ndarray, shape (n, n)

    Raises
    ------
    ShapeError
        ``f`` or ``F`` returned an array of the wrong shape (checked always); with ``check``,
        any input of the wrong shape.
    NonFiniteInputError, CovarianceError, TimeStepError
        Only when ``check`` is True.
    EstimationError
        With ``check``: booleans, text or complex numbers given for ``x``, ``P`` or ``Q``.
    """
    if check:
        x = as_vector(x, "x")
        P = as_covariance(P, x.size, "P")
        dt = check_time_step(dt)
    fx = np.asarray(f(x, dt, *args), dtype=float)
    Fm = np.asarray(F(x, dt, *args), dtype=float)
    Qm = Q(dt) if callable(Q) else Q
    n = x.shape[0]
    # always (two tuple comparisons): an f of another length replaced the state by it, and
    # an F of shape (n,) made F P F^T a scalar that Q broadcast into a "covariance"
    if fx.shape != (n,):
        raise ShapeError(f"f(x, dt) must have shape ({n},), got {fx.shape}")
    if Fm.shape != (n, n):
        raise ShapeError(f"F(x, dt) must have shape ({n}, {n}), got {Fm.shape}")
    if check:
        fx = as_vector(fx, "f(x, dt)", n)
        if not np.isfinite(Fm).all():
            raise NonFiniteInputError("F(x, dt) has non-finite entries")
        Qm = as_covariance(Qm, n, "Q")     # (booleans were a unit Q: converted before)
    else:
        if not callable(Q):
            Qm = np.asarray(Qm, dtype=float)
        if Qm.ndim == 1:
            Qm = np.diag(Qm)
    Pp = np.dot(np.dot(Fm, P), Fm.T) + Qm
    return fx, 0.5 * (Pp + Pp.T)


def correct(x: np.ndarray, P: np.ndarray, y: np.ndarray, H: np.ndarray, R: np.ndarray, *,
            gate: Gate | None = None, groups: Sequence[np.ndarray] | None = None,
            check: bool = True) -> tuple[np.ndarray, np.ndarray, Innovation]:
    """Kalman correction from an already formed innovation (seed 001 eqs. 4.9-4.11).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Prior state.
    P : ndarray, shape (n, n)
        Prior covariance.
    y : ndarray, shape (m,)
        Innovation ``z - h(x)`` (angle rows already wrapped).
    H : ndarray, shape (m, n)
        Measurement Jacobian at ``x``.
    R : ndarray, shape (m, m) or (m,)
        Measurement noise covariance (a vector is its diagonal, variances > 0).
    gate : Gate or None
        Chi-square gate applied to each group of ``groups``; None = no gating.
    groups : sequence of int arrays or None
        Row indices of each sensor group (a partition of ``range(m)``: each row in exactly
        one group); None = all rows form one group.
    check : bool
        Validate shapes, finiteness, covariances and that ``groups`` partition the rows.

    Returns
    -------
    x_post : ndarray, shape (n,)
    P_post : ndarray, shape (n, n)
        Joseph-form update, symmetrised.
    innovation : Innovation
        With no row (``m = 0``): the state and covariance unchanged, NIS NaN, dof 0.

    Raises
    ------
    ShapeError, NonFiniteInputError
        Bad shapes or non-finite values, or ``groups`` that do not partition the rows (a row
        in no group, in two, or outside ``0..m-1``; ``check`` True); a non-finite innovation
        among the rows used (always checked; a gate rejects such a row instead).
    CovarianceError
        ``P`` not symmetric PSD or ``R`` not positive definite (``check`` True), or the
        innovation covariance ``S`` is singular or indefinite (always checked).
    ConfigError
        A group of more rows than ``gate.max_dof``, or (``check`` True) a ``gate`` that is
        not a :class:`Gate` (a bare AttributeError before).
    EstimationError
        (``check`` True) booleans, text or complex numbers given for an array.
    """
    if check:
        x = as_vector(x, "x")      # (before x.shape: None was a bare AttributeError)
        n = x.size
        P = as_covariance(P, n, "P")
        y = as_vector(y, "innovation y")
        m = y.size
        H = real_array(H, "H")   # (a boolean H was a matrix of 0 and 1)
        if gate is not None and not isinstance(gate, Gate):
            raise ConfigError(f"gate must be a Gate (e.g. Gate(0.999)) or None, got {gate!r}")
        if H.shape != (m, n):
            raise ShapeError(f"H must have shape ({m}, {n}), got {H.shape}")
        if not np.isfinite(H).all():
            raise NonFiniteInputError("H has non-finite entries")
        R = as_covariance(R, m, "R", definite=True)
        if groups is not None:
            groups = _row_partition(groups, m)
    else:
        n = x.shape[0]
        y = np.asarray(y, dtype=float)
        H = np.asarray(H, dtype=float)
        m = y.shape[0] if y.ndim == 1 else -1
    if m == 0:      # no row: nothing to correct (LAPACK's bare ValueError before)
        return x.copy(), P.copy(), Innovation(y, np.zeros((0, 0)), float("nan"),
                                              np.zeros(0, dtype=bool))
    R = np.asarray(R, dtype=float)
    r_diag = R if R.ndim == 1 else None
    HP = np.dot(H, P)
    S = np.dot(HP, H.T)
    if r_diag is not None:
        S.flat[:: m + 1] += r_diag
    else:
        S = S + R
    accepted = np.ones(m, dtype=bool)
    if gate is None:
        rows = None
        ya, Ha, HPa, Sa = y, H, HP, S
    else:
        for g in (groups if groups is not None else (np.arange(m),)):
            g = np.asarray(g)
            if g.size == 0:
                continue
            Sg = S[np.ix_(g, g)]
            try:
                d2 = float(y[g] @ np.linalg.solve(Sg, y[g]))
            except np.linalg.LinAlgError:
                raise CovarianceError("innovation covariance S is singular") from None
            if not d2 <= gate.threshold(g.size):
                accepted[g] = False
        if accepted.all():
            rows = None
            ya, Ha, HPa, Sa = y, H, HP, S
        else:
            rows = np.flatnonzero(accepted)
            if rows.size == 0:
                return x.copy(), P.copy(), Innovation(y, S, float("nan"), accepted)
            ya, Ha, HPa, Sa = y[rows], H[rows], HP[rows], S[np.ix_(rows, rows)]
    # Cholesky solve S [K^T | u] = [H P | y]: K = P H^T S^-1, u = S^-1 y (no inverse)
    _, sol, info = lapack.dposv(Sa, np.concatenate([HPa, ya[:, None]], axis=1))
    if info != 0:
        raise CovarianceError("innovation covariance S = H P H^T + R is not positive "
                              f"definite (LAPACK dposv info {info})")
    K = sol[:, :n].T
    nis = float(np.dot(ya, sol[:, n]))
    if not nis >= 0.0:
        if not np.isfinite(ya).all():
            raise NonFiniteInputError("innovation y is not finite (a measurement or the "
                                      "model's h(x) is NaN or inf)")
        raise CovarianceError(f"innovation covariance S is not positive definite (NIS {nis})")
    x_new = x + np.dot(K, ya)
    A = np.dot(K, Ha)
    A *= -1.0
    A.flat[:: n + 1] += 1.0                       # A = I - K H
    if r_diag is not None:
        KRK = np.dot(K * (r_diag if rows is None else r_diag[rows]), K.T)
    else:
        Ra = R if rows is None else R[np.ix_(rows, rows)]
        KRK = np.dot(np.dot(K, Ra), K.T)
    P_new = np.dot(np.dot(A, P), A.T) + KRK
    return x_new, 0.5 * (P_new + P_new.T), Innovation(y, S, nis, accepted)


def update(x: np.ndarray, P: np.ndarray, z: np.ndarray, h: Callable[..., np.ndarray],
           H: Callable[..., np.ndarray], R: np.ndarray, *, args: tuple = (),
           residual: Residual | None = None, gate: Gate | None = None,
           groups: Sequence[np.ndarray] | None = None,
           check: bool = True) -> tuple[np.ndarray, np.ndarray, Innovation]:
    """EKF measurement update (seed 001 eqs. 4.7-4.11, Joseph form).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Prior state.
    P : ndarray, shape (n, n)
        Prior covariance.
    z : ndarray, shape (m,)
        Measurement (finite; the runner skips non-finite samples before calling this).
    h : callable ``h(x, *args) -> (m,)``
        Measurement model.
    H : callable ``H(x, *args) -> (m, n)``
        Its Jacobian.
    R : ndarray, shape (m, m) or (m,)
        Measurement noise covariance (vector = diagonal).
    args : tuple
        Extra arguments of ``h`` and ``H``.
    residual : callable ``residual(z, hx) -> (m,)``, optional
        Innovation (default ``z - hx``); use it to wrap angles to [-pi, pi).
    gate, groups :
        See :func:`correct`.
    check : bool
        Validate every input.

    Returns
    -------
    x_post : ndarray, shape (n,)
    P_post : ndarray, shape (n, n)
    innovation : Innovation

    Raises
    ------
    ShapeError, NonFiniteInputError, CovarianceError
        (``check`` True) among them ``h(x)`` or ``residual(z, h(x))`` not of the length of
        ``z``.
    """
    if check:
        x = as_vector(x, "x")
        z = as_vector(z, "z")
    hx = np.asarray(h(x, *args), dtype=float)
    Hm = np.asarray(H(x, *args), dtype=float)
    if check:
        hx = as_vector(hx, "h(x)", z.size)
    y = residual(z, hx) if residual is not None else z - hx
    if check and residual is not None:     # (one of another length was blamed on H)
        y = as_vector(y, "residual(z, h(x))", z.size)
    return correct(x, P, y, Hm, R, gate=gate, groups=groups, check=check)


def project_to_bounds(x: np.ndarray, P: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                      movable: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Project an estimate onto box constraints ``lower <= x <= upper`` in the metric of its
    covariance (estimate projection).

    The constrained estimate minimises ``(x_c - x)^T P^-1 (x_c - x)`` subject to the
    bounds, with the active bounds (those the minimum lies on) taken as equalities: with
    ``D`` the rows of the identity of the active states and ``d`` their bounds,
    ``x_c = x - P D^T (D P D^T)^-1 (D x - d)`` (Simon & Chia, "Kalman filtering with state
    equality constraints", IEEE Trans. Aerosp. Electron. Syst. 38(1), 2002, eq. 13 with
    ``W = P^-1``; Simon, "Kalman filtering with state constraints: a survey of linear and
    nonlinear algorithms", IET Control Theory Appl. 4(8), 2010, sec. 2.4). Unlike clipping,
    the projection also moves every state correlated with a violated one: a speed pushed
    back into its bound takes the slips that moved with it along. The active set is found
    by the primal active-set method for this convex quadratic programme (Nocedal & Wright,
    "Numerical Optimization", 2nd ed., sec. 16.5, Algorithm 16.3): from the clipped
    estimate (feasible, the bounds ``x`` violates held), each round steps towards the nearest
    point with the held bounds as equalities, stops at the first bound of a free state met on
    the way (which joins the held ones), and once the step is whole, releases the held bound
    whose Lagrange multiplier ``(D P D^T)^-1 (D x - d)`` has the wrong sign (negative at an
    upper bound, positive at a lower one: a state it would leave); it ends when every
    multiplier has the right sign, the minimum (at most ``8 n + 8`` rounds, then the
    feasible point reached). Every point it visits is inside the box, so the distance falls
    at each round and no active set comes back (an earlier version, which added every
    violated state of an infeasible point, cycled between active sets on 6 of 20 000 random
    boxes of 1-5 states and ended clipped, at up to 5.4 times the least squared distance; one
    bounded state, as in the filters' speed bounds, gets the same point from both). A violated
    state with no
    variance is set to its bound and moves nothing else (the clipped estimate is returned).
    The covariance is
    returned unchanged: the bounds say where the state cannot be, not where it is (Simon
    2010, sec. 2.4, the estimate projection with the unconstrained covariance), so no
    variance collapses onto a bound.

    With ``movable`` only those states move: the same distance is minimised with the others
    held, i.e. the projection runs in the metric of the movable states' covariance
    *conditioned* on the held ones (the Schur complement ``P_MM - P_MH P_HH^-1 P_HM``, the
    inverse of the movable block of ``P^-1``). A bound that says nothing about a state, such
    as a kinematic speed range about an attitude, then cannot move it through a correlation
    that the linearisation made.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Estimate, in the states' units.
    P : ndarray, shape (n, n)
        Its covariance.
    lower, upper : ndarray, shape (n,)
        Bounds, the states' units (``-inf`` / ``inf``: none; NaN is refused, not taken as
        none); ``lower <= upper``.
    movable : ndarray of bool, shape (n,), optional
        States the projection may move (default: all). Bounds of held states are not applied.

    Returns
    -------
    x_c : ndarray, shape (n,)
        The projected estimate, inside the bounds of the movable states (``x`` itself,
        copied, when it already was).
    active : ndarray of bool, shape (n,)
        The states held at a bound.

    Raises
    ------
    ShapeError
        Shapes that do not match (``x`` not one-dimensional: a 2-D ``x`` was NumPy's "truth
        value is ambiguous"), or ``lower > upper`` somewhere.
    NonFiniteInputError
        A NaN bound (named ``lower`` or ``upper``, with its states): every comparison with
        NaN is false, so it would be no bound without a word. A NaN or infinite ``x`` (its
        states named; a NaN came back as NaN, held "at a bound"), or a NaN or infinite ``P``
        where the projection uses it (a bare LinAlgError, or a NaN estimate, before).
    CovarianceError
        A held block of ``P`` (``movable``) that NumPy's least squares cannot solve.
    EstimationError
        ``x``, ``P``, ``lower`` or ``upper`` not real numbers (None, text, booleans: a bare
        IndexError or ValueError before), or ``movable`` not a boolean mask (``[0.5, 0]``
        was read as ``[True, False]``, state indices ``[0, 2]`` as a mask).

    Notes
    -----
    It runs at every step of the filters that bound a speed, so the checks of a float
    array are one type test each, and a NaN or inf is found by one dot product of the
    result (0.5 us, against 45-80 us for a call); other inputs are converted and judged
    once per call.
    """
    if type(x) is not np.ndarray or x.dtype.kind != "f" or x.ndim != 1:
        x = as_vector(x, "x")              # (None, text, booleans, 2-D: named)
    else:
        x = np.asarray(x, dtype=float)     # (a NaN or inf shows in the result: judged there)
    n = x.shape[0]
    if type(P) is not np.ndarray or P.dtype.kind != "f":
        P = real_array(P, "P")
    if type(lower) is not np.ndarray or lower.dtype.kind != "f":
        lower = real_array(lower, "lower")
    if type(upper) is not np.ndarray or upper.dtype.kind != "f":
        upper = real_array(upper, "upper")
    try:
        lower = np.broadcast_to(np.asarray(lower, dtype=float), (n,))
        upper = np.broadcast_to(np.asarray(upper, dtype=float), (n,))
    except ValueError:      # (NumPy's bare "operands could not be broadcast")
        raise ShapeError(f"lower and upper must have shape ({n},) or be scalars, got "
                         f"{np.shape(lower)} and {np.shape(upper)}") from None
    if np.shape(P) != (n, n):
        raise ShapeError(f"P must have shape ({n}, {n}) for a state of {n}; got {np.shape(P)}")
    for name, b in (("lower", lower), ("upper", upper)):
        if np.isnan(b).any():
            raise NonFiniteInputError(f"{name} holds NaN at state(s) "
                                      f"{np.flatnonzero(np.isnan(b)).tolist()}: give -inf / "
                                      "inf for no bound")
    if (lower > upper).any():
        raise ShapeError(f"lower bound above upper bound at state(s) "
                         f"{np.flatnonzero(lower > upper).tolist()}")
    if movable is not None:
        if type(movable) is not np.ndarray or movable.dtype.kind != "b":
            mask = np.asarray(movable) if not isinstance(movable, (str, bytes)) else None
            if mask is None or mask.dtype.kind != "b":     # (0.5 was True, 0 False)
                raise EstimationError(f"movable must be a boolean mask of the states (True: "
                                      f"may move), got {movable!r:.60}")
            movable = mask
        if movable.shape != (n,):
            raise ShapeError(f"movable must have shape ({n},); got {movable.shape}")
        held = np.flatnonzero(~movable)
        if held.size:
            lower = np.where(movable, lower, -np.inf)
            upper = np.where(movable, upper, np.inf)
            mov = np.flatnonzero(movable)
            P = np.asarray(P, dtype=float)
            cond = np.zeros((n, n))
            try:
                cond[np.ix_(mov, mov)] = (P[np.ix_(mov, mov)] - P[np.ix_(mov, held)]
                                          @ np.linalg.lstsq(P[np.ix_(held, held)],
                                                            P[np.ix_(held, mov)],
                                                            rcond=None)[0])
            except np.linalg.LinAlgError as exc:   # (NaN P: a bare "SVD did not converge")
                _refuse_non_finite(x, P)
                raise CovarianceError(f"P: the covariance of the held states cannot be "
                                      f"solved ({exc})") from None
            P = cond
    xc = np.clip(x, lower, upper)             # feasible start, on the bounds x violates
    active = xc != x
    bound = xc.copy()
    try:
        for _ in range(8 * n + 8):
            idx = np.flatnonzero(active)
            Paa = P[np.ix_(idx, idx)]
            if idx.size and ((Paa.diagonal() <= 0).any() or np.linalg.cond(Paa) > 1e12):
                xc = np.clip(xc, lower, upper)    # no metric to project in: the feasible point
                break
            # the nearest point with the working set held at its bounds (x_c = x - P_:a lam)
            lam = np.linalg.solve(Paa, x[idx] - bound[idx]) if idx.size else np.zeros(0)
            target = x - P[:, idx] @ lam
            target[idx] = bound[idx]              # exact, free of round-off
            step = target - xc
            # the first bound of a free state met on the way there stops the step and joins
            with np.errstate(divide="ignore", invalid="ignore"):
                room = np.where(step > 0, (upper - xc) / step, (lower - xc) / step)
            room[active | (step == 0)] = np.inf
            j = int(np.argmin(room))
            if room[j] < 1.0:
                xc = np.clip(xc + max(room[j], 0.0) * step, lower, upper)
                bound[j] = xc[j] = upper[j] if step[j] > 0 else lower[j]
                active[j] = True
                continue
            xc = target
            # multiplier of each bound held: >= 0 at an upper bound, <= 0 at a lower one; one
            # of the wrong sign holds its state against a bound it would leave: released (the
            # one of largest |lam|), the rest redone from here
            wrong = np.where(bound[idx] == upper[idx], -lam, lam)
            wrong[lower[idx] == upper[idx]] = -np.inf     # an equality is never released
            if not idx.size or wrong.max() <= 0.0:
                break                             # the minimum
            active[idx[int(np.argmax(wrong))]] = False
        else:
            xc = np.clip(xc, lower, upper)        # rounds spent: the feasible point reached
    except np.linalg.LinAlgError:
        _refuse_non_finite(x, P)
        raise
    # one scalar test: a NaN or inf x, or a NaN in the rows of P used, gives a NaN here
    if not math.isfinite(xc.dot(xc)):
        _refuse_non_finite(x, P)
    return xc, active


def _refuse_non_finite(x: np.ndarray, P: np.ndarray) -> None:
    """Raise :class:`NonFiniteInputError` naming the states of ``x``, or ``P``, that hold NaN
    or inf (the projection's slow path, once NumPy failed or gave a non-finite estimate;
    nothing where both are finite, the estimate only overflowing in the test's square)."""
    as_vector(x, "x")
    if not np.isfinite(P).all():
        raise NonFiniteInputError("P has non-finite entries: no metric to project in")


class ExtendedKalmanFilter:
    """Thin stateful wrapper over :func:`predict` and :func:`update` for streaming use.

    All inputs are validated here once; the per-step calls validate the time step, the
    measurement and what a callable ``Q`` returns (and skip the checks of ``P``, which the
    Joseph form keeps a covariance).

    Parameters
    ----------
    x0 : ndarray, shape (n,)
        Initial state.
    P0 : ndarray, shape (n, n) or (n,)
        Initial covariance.
    f, F : callables
        Transition ``f(x, dt, *args)`` and its Jacobian ``F(x, dt, *args)``.
    h, H : callables
        Measurement model ``h(x, *args) -> (m,)`` and its Jacobian ``(m, n)``.
    Q : ndarray, shape (n, n) or (n,), or callable ``Q(dt)``
        Process noise of one step.
    R : ndarray, shape (m, m) or (m,)
        Measurement noise.
    residual : callable, optional
        ``residual(z, hx) -> (m,)``.
    gate : Gate, optional
        Chi-square gating of each group of ``groups``.
    groups : sequence of int arrays, optional
        Sensor groups (rows of ``z``) for the gate: a partition of ``range(m)``.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Current estimate (a copy).
    P : ndarray, shape (n, n)
        Current covariance (a copy).
    last_innovation : Innovation or None
        Innovation record of the last update (None before the first).

    Raises
    ------
    ShapeError, NonFiniteInputError, CovarianceError
        An initial state or matrix of the wrong shape (``R`` a scalar included), not finite,
        or not a covariance; ``groups`` that do not partition the rows of ``R``.
    EstimationError
        Booleans, text or complex numbers given for ``x0``, ``P0``, ``Q`` or ``R``.
    ConfigError
        A ``gate`` that is not a :class:`Gate`.
    """

    def __init__(self, x0: np.ndarray, P0: np.ndarray, f: Callable, F: Callable,
                 h: Callable, H: Callable, Q: np.ndarray | Callable[[float], np.ndarray],
                 R: np.ndarray, *, residual: Residual | None = None, gate: Gate | None = None,
                 groups: Sequence[np.ndarray] | None = None) -> None:
        # copies: a float64 x0, P0, Q or R came back from the checks as the caller's own
        # array, so the caller refilling its buffer (the next run's x0) changed this filter
        self._x = as_vector(x0, "x0").copy()
        n = self._x.size
        self._P = as_covariance(P0, n, "P0").copy()
        self._f, self._F, self._h, self._H = f, F, h, H
        self._Q = Q if callable(Q) else as_covariance(Q, n, "Q").copy()
        R = np.array(real_array(R, "R"))   # (a copy; booleans were a unit R)
        if R.ndim not in (1, 2):   # a scalar has no size m (R.shape[0] was a bare IndexError)
            raise ShapeError(f"R must have shape (m, m) or (m,), got {R.shape}")
        self._m = R.shape[0]
        self._R = R if R.ndim == 1 else as_covariance(R, self._m, "R", definite=True)
        if R.ndim == 1:
            as_covariance(R, self._m, "R", definite=True)
        self._residual = residual
        if gate is not None and not isinstance(gate, Gate):
            raise ConfigError(f"gate must be a Gate (e.g. Gate(0.999)) or None, got {gate!r}")
        self._gate = gate
        self._groups = None if groups is None else _row_partition(groups, self._m)
        self.last_innovation: Innovation | None = None

    @property
    def x(self) -> np.ndarray:
        """Current state estimate, shape (n,) (a copy)."""
        return self._x.copy()

    @property
    def P(self) -> np.ndarray:
        """Current covariance, shape (n, n) (a copy)."""
        return self._P.copy()

    def predict(self, dt: float, *args: Any) -> None:
        """Propagate by ``dt`` seconds (seed 001 eqs. 4.3, 4.5).

        Parameters
        ----------
        dt : float
            Step, s (> 0).
        *args
            Extra arguments passed to ``f``, ``F`` (e.g. a control input).

        Raises
        ------
        TimeStepError
            ``dt`` not > 0 or not finite.
        ShapeError
            ``f`` or ``F`` returned an array of the wrong shape; nothing is changed.
        ShapeError, NonFiniteInputError, CovarianceError
            A callable ``Q`` returned a matrix of the wrong shape, non-finite, asymmetric or
            not positive semi-definite (:func:`checked_process_noise`); nothing is changed.
        NonFiniteInputError
            ``f`` or ``F`` gave a non-finite prior (e.g. a NaN control input in ``args``);
            nothing is changed, so the filter never carries a NaN state silently.
        """
        dt = check_time_step(dt)
        Q = self._Q
        if callable(Q):     # checked as a constant Q is in __init__, cheaply
            Q = checked_process_noise(Q(dt), self._x.size)
        x, P = predict(self._x, self._P, dt, self._f, self._F, Q, args=args, check=False)
        if not math.isfinite(x.sum() + P.sum()):   # one scalar test: any NaN/inf shows
            raise NonFiniteInputError(
                f"prediction over dt = {dt} s gave a non-finite state or covariance "
                f"(f(x, dt) finite: {bool(np.isfinite(x).all())}); check the control "
                f"input {args!r}; the filter keeps its previous state")
        self._x, self._P = x, P

    def update(self, z: np.ndarray, *args: Any, rows: Sequence[int] | None = None,
               R: np.ndarray | None = None) -> Innovation:
        """Correct with measurement ``z``.

        Parameters
        ----------
        z : ndarray, shape (m,) or (len(rows),)
            Measurement, or the subset of its rows given by ``rows`` (multi-rate sensors).
        *args
            Extra arguments passed to ``h``, ``H``.
        rows : sequence of int, optional
            Rows of the full measurement vector present in ``z``: distinct integers in
            ``0 .. m-1`` (none: nothing to correct, NIS NaN).
        R : ndarray, shape (len(z),) or (len(z), len(z)), optional
            Measurement noise of this update only (e.g. of a block-averaged or adaptively
            weighted row), units of ``z`` squared; None: the filter's ``R`` of these rows.

        Returns
        -------
        Innovation

        Raises
        ------
        ShapeError
            ``z`` of the wrong length, ``rows`` not distinct integers in ``0 .. m-1``, or
            ``h`` / ``H`` / ``residual`` returned an array of the wrong shape.
        NonFiniteInputError, CovarianceError
        EstimationError
            Booleans, text or complex numbers given for ``z`` or ``R``.
        """
        if rows is None:
            idx = np.arange(self._m)
        else:
            idx = np.asarray(rows)
            # per update (the control loop's estimators): a set of the few row numbers, not
            # np.unique and two reductions (0.7 against 5 us, a sixth of a small update)
            ids = (idx.tolist() if idx.ndim == 1 and (idx.dtype.kind in "iu" or not idx.size)
                   else None)      # ([] is a float array: no row, an update of none)
            if ids is None or len(set(ids)) != len(ids) or (
                    ids and not (0 <= min(ids) and max(ids) < self._m)):
                raise ShapeError(f"rows must be distinct integers in 0..{self._m - 1}, got "
                                 f"{idx.tolist()}")
            idx = idx.astype(int)
        z = as_vector(z, "z", idx.size)
        hx = np.asarray(self._h(self._x, *args), dtype=float)
        Hm = np.asarray(self._H(self._x, *args), dtype=float)
        n = self._x.shape[0]
        # (an h of another length was cut to the rows of z without a word; an H of another
        # width a bare ValueError of NumPy's dot)
        if hx.shape != (self._m,):
            raise ShapeError(f"h(x) must have shape ({self._m},), got {hx.shape}")
        if Hm.shape != (self._m, n):
            raise ShapeError(f"H(x) must have shape ({self._m}, {n}), got {Hm.shape}")
        if self._residual is None:
            y = z - hx[idx]
        else:
            if rows is None:
                y = self._residual(z, hx)
            else:  # the residual sees full vectors (it may wrap angle rows by position)
                z_full = hx.copy()
                z_full[idx] = z
                y = self._residual(z_full, hx)
            # (one of another length was blamed on H, "H must have shape (2, 2)", or was
            # NumPy's bare concatenation error)
            if np.shape(y) != (self._m,):
                raise ShapeError(f"residual(z, h(x)) must have shape ({self._m},), got "
                                 f"{np.shape(y)}")
            if rows is not None:
                y = np.asarray(y)[idx]
        if R is None:
            R = (self._R if rows is None else self._R[idx] if self._R.ndim == 1
                 else self._R[np.ix_(idx, idx)])
        else:
            R = real_array(R, "R")      # (booleans were a unit R)
            checked = as_covariance(R, idx.size, "R", definite=True)
            R = R if R.ndim == 1 else checked
        if rows is None:
            groups = self._groups
        else:
            groups = None
            if self._groups is not None:
                pos = {int(r): i for i, r in enumerate(idx)}
                groups = [np.array([pos[int(r)] for r in g if int(r) in pos])
                          for g in self._groups]
        self._x, self._P, inn = correct(self._x, self._P, y, Hm[idx], R, gate=self._gate,
                                        groups=groups, check=False)
        self.last_innovation = inn
        return inn
