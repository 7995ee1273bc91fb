"""Filter consistency: NEES and NIS with chi-square confidence bounds.

A consistent filter (seed ``001_59da564c4b2d6a48.txt`` ch. 4.2, eqs. 4.13-4.16) has
``E[NEES] = n`` (states) and ``E[NIS] = m`` (measurement rows). The time average of N
independent chi-square(d) values, times N, is chi-square(N d), which gives the two-sided
bounds of :func:`mean_chi2_bounds`. Successive NEES values of a filter are correlated, so
the bounds use an *effective* sample count ``N / tau`` with ``tau`` the integrated
autocorrelation time of the sequence (:func:`effective_sample_size`); the nominal iid bounds
are reported beside them. With ground truth (simulation) NEES can be computed, which the
thesis could not do (ch. 4.2).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import stats

from terrain.errors import (ConfigError, CovarianceError, DataWarning, EstimationError,
                            NonFiniteInputError, ShapeError, config_flags, config_numbers,
                            config_positive, first_items, is_integer, refuse_booleans)
from terrain.estimation.ekf import SYMMETRY_RTOL, real_array
from terrain.estimation.model import wrap_angle


def nees(errors: np.ndarray, covariances: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ``e_k^T P_k^-1 e_k`` (seed 001 eq. 4.13).

    Parameters
    ----------
    errors : ndarray, shape (N, n)
        Estimate minus truth (angles wrapped by the caller).
    covariances : ndarray, shape (N, n, n)
        Posterior covariances.

    Returns
    -------
    ndarray, shape (N,)

    Raises
    ------
    ShapeError
        Shapes that do not match.
    CovarianceError
        A covariance that is not symmetric (``|P - P^T|`` above ``SYMMETRY_RTOL`` times its
        largest entry, as :func:`~terrain.estimation.ekf.as_covariance`: the solve used the
        matrix as given, so ``[[1, 0.5], [0, 1]]`` gave a NEES of a matrix that is no
        covariance), one that is singular (e.g. a state with zero variance), or one that is not
        positive definite where it gives a negative NEES (``-np.eye(n)``: NEES ``-|e|^2``,
        returned before); the message names the steps.
    NonFiniteInputError
        NaN or inf in a covariance (the steps named): an infinite one gave a NEES of 0. A NaN
        error (no truth at a step) gives a NaN NEES there.
    EstimationError
        Booleans, text or complex numbers given for the errors or the covariances.
    """
    refuse_booleans(EstimationError, "nees", errors=errors, covariances=covariances)
    e = real_array(errors, "nees: errors")
    P = real_array(covariances, "nees: covariances")
    if e.ndim != 2 or P.shape != (e.shape[0], e.shape[1], e.shape[1]):
        raise ShapeError(f"errors (N, n) and covariances (N, n, n) expected, got {e.shape} "
                         f"and {P.shape}")
    # (an infinite covariance gave a NEES of 0, a consistent-looking value, and a NaN one
    # NaN; a NaN error, a step without truth, stays a NaN NEES)
    bad = np.flatnonzero(~np.isfinite(P.reshape(P.shape[0], -1)).all(axis=1))
    if bad.size:
        raise NonFiniteInputError(f"NEES: the covariance is not finite at "
                                  f"{first_items(bad.tolist(), word='step')}")
    if P.size:
        scale = np.maximum(np.abs(P).max(axis=(1, 2)), 1e-300)
        asym = np.abs(P - P.transpose(0, 2, 1)).max(axis=(1, 2))
        bad = np.flatnonzero(asym > SYMMETRY_RTOL * scale)
        if bad.size:
            raise CovarianceError(f"NEES: the covariance is not symmetric (max |P - P^T| = "
                                  f"{asym[bad[0]]:.3g}) at "
                                  f"{first_items(bad.tolist(), word='step')}")
    try:
        sol = np.linalg.solve(P, e[..., None])[..., 0]
    except np.linalg.LinAlgError:
        with np.errstate(all="ignore"):
            singular = np.flatnonzero(np.linalg.slogdet(P)[0] == 0)
        raise CovarianceError(f"NEES: the covariance is singular at "
                              f"{first_items(singular.tolist(), word='step')}") from None
    out = np.einsum("ij,ij->i", e, sol)
    negative = np.flatnonzero(out < 0.0)     # (e^T P^-1 e < 0: P has a negative eigenvalue)
    if negative.size:
        raise CovarianceError(f"NEES: the covariance is not positive definite (NEES "
                              f"{out[negative[0]]:.3g} < 0) at "
                              f"{first_items(negative.tolist(), word='step')}")
    return out


def state_errors(estimates: np.ndarray, truth: np.ndarray,
                 angle_columns: tuple[int, ...] = ()) -> np.ndarray:
    """``estimates - truth`` with the angle columns wrapped to [-pi, pi).

    Parameters
    ----------
    estimates, truth : ndarray, shape (N, n)
        Estimated and true states (SI units).
    angle_columns : tuple of int
        Columns holding angles (rad).

    Returns
    -------
    ndarray, shape (N, n)

    Raises
    ------
    ShapeError
        ``estimates`` not 2-D, ``truth`` of another shape (a single state is not broadcast
        over the steps), ``angle_columns`` not a sequence, an angle column that is not an
        integer (a boolean, a float) or one outside the ``n`` columns.
    EstimationError
        Booleans, text or complex numbers given for the estimates or the truth.
    """
    refuse_booleans(EstimationError, "state_errors", estimates=estimates, truth=truth)
    x = real_array(estimates, "state_errors: estimates")
    t = real_array(truth, "state_errors: truth")
    if x.ndim != 2 or t.shape != x.shape:
        raise ShapeError(f"estimates and truth must both be (N, n), got estimates {x.shape} "
                         f"and truth {t.shape}")
    # (True was column 1 and 1.0 a bare IndexError: a column is an integer index; None or
    # one integer a bare TypeError)
    if not isinstance(angle_columns, (tuple, list, np.ndarray)):
        raise ShapeError(f"angle_columns must be a tuple of integer column indices, got "
                         f"{angle_columns!r}")
    wrong = [j for j in angle_columns if not is_integer(j)]
    if wrong:
        raise ShapeError(f"angle_columns must hold integer column indices, got {wrong[0]!r}")
    bad = [j for j in angle_columns if not -x.shape[1] <= j < x.shape[1]]
    if bad:
        raise ShapeError(f"angle column {bad[0]} outside the {x.shape[1]} state columns")
    e = x - t
    for j in angle_columns:
        e[:, j] = wrap_angle(e[:, j])
    return e


def rmse(errors: np.ndarray, *, ignore_nan: bool = False) -> float:
    """Root mean square of estimation errors, ``sqrt(mean(e^2))`` over every element.

    Parameters
    ----------
    errors : array_like
        Errors ``estimate - truth`` of any shape, in the unit of the quantity.
    ignore_nan : bool
        Average over the errors that are not NaN (``numpy.nanmean``; for estimates that are
        NaN by design, e.g. a slip inside its dead band); an infinite error, a diverged
        estimate, still gives inf. False: a NaN error gives NaN.

    Returns
    -------
    float
        In the unit of ``errors``; NaN, with a :class:`~terrain.errors.DataWarning`, where
        there is no error to average (``errors`` empty, or every one NaN with
        ``ignore_nan``): the RMSE of nothing is no number, and the validation tables that
        call this per subset (e.g. the transient steps of a run, which one run may lack)
        keep their other cells, where an error would lose the whole table (NumPy's own
        "Mean of empty slice" RuntimeWarning said nothing of the errors).

    Warns
    -----
    DataWarning
        No error to average.

    Raises
    ------
    EstimationError
        Booleans given for the errors (a mask of misses had an RMSE of 1 per miss), None,
        text or complex numbers.
    ConfigError
        ``ignore_nan`` not a boolean.
    """
    refuse_booleans(EstimationError, "rmse", errors=errors)
    config_flags("rmse", ignore_nan=ignore_nan)     # (the text "no" was True)
    if errors is None:      # (it was an RMSE of NaN)
        raise EstimationError("rmse: errors must hold numbers, got None")
    sq = real_array(errors, "rmse: errors") ** 2
    if not sq.size or (ignore_nan and np.isnan(sq).all()):
        what = "no errors" if not sq.size else f"every one of the {sq.size} errors NaN"
        warnings.warn(f"rmse: {what}, nothing to average: NaN", DataWarning, stacklevel=2)
        return float("nan")
    return float(np.sqrt(np.nanmean(sq) if ignore_nan else np.mean(sq)))


def _check_probability(probability: float) -> None:
    """Refuse a two-sided coverage outside (0, 1) (chi-square quantiles would be NaN)."""
    try:
        if isinstance(probability, (str, bytes)):   # ("0.95" passed, then failed bare)
            raise TypeError
        ok = 0.0 < float(probability) < 1.0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ConfigError(f"probability (two-sided coverage) must be in (0, 1), e.g. 0.95, got "
                          f"{probability!r}")


def mean_chi2_bounds(dof: float, n_samples: float, probability: float = 0.95
                     ) -> tuple[float, float]:
    """Two-sided bounds of the mean of ``n_samples`` independent chi-square(``dof``) values
    (Bar-Shalom, Li & Kirubarajan 2001, ch. 5.4.2).

    Parameters
    ----------
    dof : float
        Degrees of freedom of each value.
    n_samples : float
        Number of (effectively independent) values averaged, > 0 (a fraction of one
        effective sample is taken as 1).
    probability : float
        Two-sided coverage, in (0, 1).

    Returns
    -------
    (lower, upper) : tuple of float
        ``chi2.ppf((1 -/+ p) / 2, n dof) / n``.

    Raises
    ------
    ConfigError
        ``probability`` not a number in (0, 1), ``dof`` not a finite number > 0 or
        ``n_samples`` not a finite number (each gave bounds of NaN), or ``n_samples`` <= 0
        (the mean of no value; it got the bounds of one sample).
    """
    _check_probability(probability)
    config_positive("mean_chi2_bounds", dof=dof)
    config_numbers("mean_chi2_bounds", n_samples=n_samples)
    if not (np.isfinite(n_samples) and n_samples > 0):
        raise ConfigError(f"mean_chi2_bounds.n_samples must be a finite number > 0 (values "
                          f"averaged), got {n_samples!r}")
    n = max(float(n_samples), 1.0)
    a = (1.0 - probability) / 2.0
    return (float(stats.chi2.ppf(a, n * dof) / n), float(stats.chi2.ppf(1.0 - a, n * dof) / n))


def _check_max_lag(owner: str, max_lag: int) -> None:
    """Refuse a lag window that is not an integer >= 1: a negative one sliced the
    autocorrelation from the end and summed nearly every lag, a float (2.5, or 2000.0 on a
    series longer than it) was a bare TypeError of the slice. ``max_lag = 1`` sums no lag
    (the lags summed are ``1 .. max_lag - 1``): tau 1, the samples taken as independent."""
    if not (is_integer(max_lag) and max_lag >= 1):
        raise ConfigError(f"{owner}: max_lag must be an integer >= 1 (lags 1 .. max_lag - 1 "
                          f"are summed; 1: none), got {max_lag!r}")


def integrated_autocorrelation_time(series: np.ndarray, max_lag: int = 2000,
                                    threshold: float = 0.05) -> np.ndarray:
    """Integrated autocorrelation time ``tau = 1 + 2 sum_k rho_k`` of each row, the sum
    taken until ``rho_k`` first drops below ``threshold`` (Sokal's windowed estimator,
    Sokal 1997, "Monte Carlo methods in statistical mechanics", eq. 3.19; the variance of
    the mean of ``N`` correlated samples is ``tau var / N``).

    Parameters
    ----------
    series : ndarray, shape (..., N)
        Finite values along the last axis (e.g. NEES over time, or the accelerometer
        samples of each window).
    max_lag : int
        The sum runs over lags ``1 .. min(N, max_lag) - 1`` at most, samples (an integer
        >= 1; 1 sums none: tau 1).
    threshold : float
        The sum stops at the first lag whose autocorrelation is below it.

    Returns
    -------
    ndarray, shape (...)
        ``tau`` (>= 1); 1 for a constant row or fewer than 3 samples; NaN for a row holding
        a non-finite value (it was given 1, i.e. independent samples).

    Raises
    ------
    ConfigError
        ``max_lag`` not an integer >= 1 (a negative one summed nearly every lag, a float
        was a bare TypeError), or ``threshold`` not a finite real number (NaN, a boolean,
        text).
    ShapeError
        ``series`` a scalar (or None).
    EstimationError
        Booleans given for the series (a mask's 0/1 steps were read as a correlated signal),
        text or complex numbers.
    """
    _check_max_lag("integrated_autocorrelation_time", max_lag)
    refuse_booleans(EstimationError, "integrated_autocorrelation_time", series=series)
    # (NaN stopped the sum at lag 1 without a word: tau 1, independent samples)
    config_numbers("integrated_autocorrelation_time", threshold=threshold)
    if not np.isfinite(threshold):
        raise ConfigError(f"integrated_autocorrelation_time: threshold must be a finite "
                          f"autocorrelation, e.g. 0.05, got {threshold!r}")
    x = real_array(series, "integrated_autocorrelation_time: series")
    if x.ndim == 0:     # (a bare IndexError; None was one too)
        raise ShapeError(f"integrated_autocorrelation_time: series must have shape (..., N), "
                         f"got a scalar {series!r}")
    n = x.shape[-1]
    if n < 3:      # (a row holding NaN or inf was given 1 here too)
        return np.where(np.isfinite(x).all(axis=-1), 1.0, np.nan)
    d = x - x.mean(axis=-1, keepdims=True)
    var = np.einsum("...i,...i->...", d, d) / n
    nfft = 1 << int(np.ceil(np.log2(2 * n)))
    f = np.fft.rfft(d, nfft, axis=-1)
    lags = min(n, max_lag)
    with np.errstate(invalid="ignore", divide="ignore"):
        acf = np.fft.irfft(f * np.conj(f), nfft, axis=-1)[..., 1:lags] / (var[..., None] * n)
    # keep the lags before the first one below the threshold
    kept = np.cumprod(np.nan_to_num(acf, nan=-1.0) >= threshold, axis=-1, dtype=bool)
    tau = 1.0 + 2.0 * np.where(kept, acf, 0.0).sum(axis=-1)
    # constant by its values, not by var > 0: the mean of 0.3 repeated is 5.6e-17 off it,
    # and the residuals, one tiny constant, were perfectly correlated (tau ~ N)
    constant = (x == x[..., :1]).all(axis=-1)
    return np.where((var > 0) & ~constant, tau, np.where(np.isfinite(var), 1.0, np.nan))


def effective_sample_size(series: np.ndarray, max_lag: int = 2000) -> float:
    """``N / tau`` with ``tau`` the integrated autocorrelation time
    (:func:`integrated_autocorrelation_time`); non-finite values are dropped.

    Parameters
    ----------
    series : ndarray, shape (N,)
        Values (e.g. NEES over time).
    max_lag : int
        The sum runs over lags ``1 .. min(N, max_lag) - 1`` at most, samples (an integer
        >= 1; 1 sums none: ``N``).

    Returns
    -------
    float
        Between 1 and N.

    Raises
    ------
    ConfigError
        ``max_lag`` not an integer >= 1 (:func:`integrated_autocorrelation_time`).
    ShapeError
        ``series`` not one-dimensional (rows of several series were joined end to end into
        one: a (2, 500) array gave 17.9 where its rows give 500 and 4.6).
    EstimationError
        Booleans, text or complex numbers given for the series.
    """
    _check_max_lag("effective_sample_size", max_lag)
    refuse_booleans(EstimationError, "effective_sample_size", series=series)
    x = real_array(series, "effective_sample_size: series")
    if x.ndim != 1:
        raise ShapeError(f"effective_sample_size: series must have shape (N,), got {x.shape} "
                         "(one series at a time; integrated_autocorrelation_time takes rows)")
    x = x[np.isfinite(x)]
    n = x.size
    if n < 3:
        return float(max(n, 1))
    tau = float(integrated_autocorrelation_time(x, max_lag))
    return float(np.clip(n / tau, 1.0, n))


@dataclass(frozen=True)
class ChiSquareTest:
    """Time-averaged NEES or NIS against its chi-square bounds.

    Attributes
    ----------
    mean : float
        Time average of the statistic.
    dof : float
        Expected value (states or mean number of rows).
    n_samples : int
        Number of finite samples averaged.
    n_effective : float
        Effective number of independent samples.
    bounds : tuple of float
        Bounds of the mean with ``n_effective`` samples, at the two-sided coverage
        ``probability`` of :func:`chi2_test` (0.95 by default).
    bounds_iid : tuple of float
        The same coverage assuming independent samples (``n_samples``).
    fraction_in_pointwise : float
        Fraction of samples inside the pointwise interval of chi-square(dof) at that
        coverage.
    """

    mean: float
    dof: float
    n_samples: int
    n_effective: float
    bounds: tuple[float, float]
    bounds_iid: tuple[float, float]
    fraction_in_pointwise: float

    @property
    def inside(self) -> bool:
        """Whether the mean lies within :attr:`bounds`."""
        return self.bounds[0] <= self.mean <= self.bounds[1]

    def as_dict(self, prefix: str) -> dict[str, float]:
        """Flat metrics ``<prefix>_mean``, ``<prefix>_dof``, ``<prefix>_lo``, ``<prefix>_hi``,
        ``<prefix>_n_eff``, ``<prefix>_in_pointwise``, ``<prefix>_inside``.

        Parameters
        ----------
        prefix : str
            Metric name prefix (e.g. ``nees``).

        Returns
        -------
        dict
            Name -> float.
        """
        return {f"{prefix}_mean": self.mean, f"{prefix}_dof": self.dof,
                f"{prefix}_lo": self.bounds[0], f"{prefix}_hi": self.bounds[1],
                f"{prefix}_n_eff": self.n_effective,
                f"{prefix}_in_pointwise": self.fraction_in_pointwise,
                f"{prefix}_inside": float(self.inside)}


def chi2_test(values: np.ndarray, dof: np.ndarray | float, probability: float = 0.95
              ) -> ChiSquareTest:
    """Average a NEES or NIS sequence and test it against chi-square bounds.

    Parameters
    ----------
    values : ndarray, shape (N,)
        NEES or NIS values, >= 0 (NaN entries are ignored; an infinite one, a filter that
        diverged, is averaged: the mean is then infinite and outside the bounds).
    dof : float or ndarray, shape (N,)
        Degrees of freedom of each value (the number of rows for NIS), >= 0; a value of
        dof 0 (a step without an accepted row) or a NaN value is left out.
    probability : float
        Two-sided coverage of the bounds, in (0, 1).

    Returns
    -------
    ChiSquareTest

    Raises
    ------
    ConfigError
        ``probability`` not a number in (0, 1), a ``dof`` that is negative or NaN (the index
        named; such values were dropped silently), or an infinite ``dof``
        (:func:`mean_chi2_bounds`).
    ShapeError
        ``values`` not 1-D, or ``dof`` neither a number nor of the shape of ``values``.
    EstimationError
        Booleans given for ``values`` or ``dof`` (a mask was read as 0 and 1), text
        (``"1"`` was parsed) or complex numbers, or a negative value (a NEES or NIS is a
        quadratic form: it was averaged in).
    """
    _check_probability(probability)
    refuse_booleans(EstimationError, "chi2_test", values=values, dof=dof)
    v = real_array(values, "chi2_test: values")
    dof = real_array(dof, "chi2_test: dof")
    if v.ndim != 1 or dof.shape not in ((), v.shape):
        raise ShapeError(f"values (N,) and dof (a number or (N,)) expected, got values "
                         f"{v.shape} and dof {dof.shape}")
    d = np.broadcast_to(dof, v.shape)
    bad = np.flatnonzero(~(d >= 0))      # (NaN and negative dof dropped their values)
    if bad.size:
        raise ConfigError(f"chi2_test: dof must be >= 0 (0: a step without rows, left out), "
                          f"got {d[bad[0]]!r} at index {int(bad[0])}")
    negative = np.flatnonzero(v < 0.0)
    if negative.size:
        raise EstimationError(f"chi2_test: NEES / NIS values must be >= 0, got "
                              f"{float(v[negative[0]])!r} at index {int(negative[0])}")
    # (an infinite value, a diverged filter, was dropped as NaN is: the rest read consistent)
    ok = ~np.isnan(v) & (d > 0)
    v, d = v[ok], d[ok]
    if v.size == 0:
        nan = float("nan")
        return ChiSquareTest(nan, nan, 0, 0.0, (nan, nan), (nan, nan), nan)
    mean_dof = float(d.mean())
    n_eff = effective_sample_size(v)
    a = (1.0 - probability) / 2.0
    lo = stats.chi2.ppf(a, d)
    hi = stats.chi2.ppf(1.0 - a, d)
    return ChiSquareTest(mean=float(v.mean()), dof=mean_dof, n_samples=int(v.size),
                         n_effective=n_eff,
                         bounds=mean_chi2_bounds(mean_dof, n_eff, probability),
                         bounds_iid=mean_chi2_bounds(mean_dof, v.size, probability),
                         fraction_in_pointwise=float(((v >= lo) & (v <= hi)).mean()))
