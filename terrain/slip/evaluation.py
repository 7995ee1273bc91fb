"""Evaluation of slip models on simulated runs with truth: splits, error tables, odometry.

Everything here takes window tables (features ``X``, truth ``Y``, window provenance ``meta``
with columns ``run_id, terrain, scenario, seed, t_start_s, t_end_s``); the features themselves
come from :mod:`features.slip_features`. Splits are grouped by run (a run's windows are never
on both sides).

Steady straight driving (the issue's target condition): windows of ``straight_accel`` runs that
start after the 1 m/s^2 ramp (``t_start_s >= STEADY_AFTER_S``) with true |yaw rate| below
:data:`STRAIGHT_MAX_YAW_RATE_RAD_S` (0.05 rad/s).
"""

from __future__ import annotations

import warnings
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from terrain.errors import (ConfigError, DataWarning, EstimationError, MissingColumnError,
                            ShapeError, config_positive, duplicated, first_items, listed,
                            refuse_missing, refuse_mixed_types)
from terrain.run import TIME, Run, runs_by_id
from terrain.slip.baselines import observer_slip, slip_ratio_as_sae
from terrain.slip.odometry import dead_reckon

#: A run whose true path is longer than this many times the wheel path slid off its slope.
SLID_OFF_FACTOR = 3.0
#: Windows of straight_accel runs starting after this time are steady, s.
STEADY_AFTER_S = 3.0
#: A window whose mean |yaw rate| is below this drives straight, rad/s: the steady windows
#: (:func:`steady_straight`, true yaw rate), the windows eq. 22's baseline is fitted on and
#: :func:`measured_checks`' straight windows (gyro yaw rate).
STRAIGHT_MAX_YAW_RATE_RAD_S = 0.05
#: Range a predicted turning factor chi is clipped to before it divides the wheel yaw rate
#: (:func:`odometry_errors`, :func:`measured_checks`): a skid-steer chi is ~1.5-3
#: (:mod:`terrain.slip.odometry`); a prediction outside it (e.g. near 0 in straight driving,
#: where the chi model has no target) would blow the compensated yaw rate up. Counted and
#: warned about.
CHI_RANGE = (0.5, 5.0)


def _run_with(by_id: dict[str, Run], run_id: str, streams: Sequence[str]) -> Run:
    """The run ``run_id`` of ``by_id``, refused by name when absent or without ``streams``."""
    run = by_id.get(run_id)
    if run is None:
        raise ConfigError(f"run {run_id!r} is not among the {len(by_id)} run(s) given")
    missing = [s for s in streams if s not in run.streams]
    if missing:
        raise EstimationError(f"run {run_id} has no {' or '.join(missing)} stream")
    return run


def _clip_chi(chi: np.ndarray) -> tuple[np.ndarray, int]:
    """``chi`` clipped to :data:`CHI_RANGE` and how many of its values were outside (NaN is
    left as it is and not counted)."""
    chi = np.asarray(chi, dtype=float)
    out = (chi < CHI_RANGE[0]) | (chi > CHI_RANGE[1])
    return np.clip(chi, *CHI_RANGE), int(out.sum())


def _window_mask(owner: str, name: str, mask, n: int) -> np.ndarray:
    """``mask`` as a boolean array of one value per window, refused (ShapeError naming
    ``owner`` and ``name``) otherwise: an integer 0/1 mask was read as row labels or
    positions (``meta.loc``, fancy indexing), which selects other windows silently."""
    m = np.asarray(mask)
    if m.dtype != bool or m.shape != (n,):
        raise ShapeError(f"{owner}: {name} must be a boolean mask of shape ({n},) (one per "
                         f"window), got {m.dtype} of shape {m.shape}")
    return m


def _group_columns(owner: str, meta: pd.DataFrame, by: Sequence[str], name: str = "meta",
                   what: str = "grouping") -> list[str]:
    """The ``what`` columns ``by`` of the table ``meta`` (called ``name``), refused
    (MissingColumnError naming ``owner``, ``name`` and the column) when it lacks one: a bare
    pandas KeyError before."""
    by = list(by)
    missing = [c for c in by if c not in meta.columns]
    if missing:
        raise MissingColumnError(f"{owner}: {name} has no {what} column(s) {missing} (its "
                                 f"columns: {list(meta.columns)})", column=str(missing[0]))
    return by


def _window_sides(owner: str, name: str, values, n: int) -> np.ndarray:
    """The first two columns (left, right) of ``values``, refused (ShapeError naming
    ``owner`` and ``name``) unless it has one row per window and at least two columns: a
    one-column array was broadcast onto both sides and scored twice, another row count
    was a bare numpy error."""
    x = np.asarray(values, dtype=float)
    if x.ndim != 2 or x.shape[0] != n or x.shape[1] < 2:
        raise ShapeError(f"{owner}: {name} must have shape ({n}, >= 2) (left and right slip "
                         f"of each window first), got {x.shape}")
    return x[:, :2]


def steady_straight(meta: pd.DataFrame, yaw_rate_rad_s: np.ndarray) -> np.ndarray:
    """Mask of the steady straight-driving windows (module docstring).

    Parameters
    ----------
    meta : pandas.DataFrame, shape (n, ...)
        Window provenance (``scenario``, ``t_start_s``).
    yaw_rate_rad_s : ndarray, shape (n,)
        True mean yaw rate of each window, rad/s.

    Returns
    -------
    ndarray of bool, shape (n,)

    Raises
    ------
    MissingColumnError
        ``meta`` lacks ``scenario`` or ``t_start_s`` (named).
    ShapeError
        ``yaw_rate_rad_s`` is not one value per window (a column (n, 1) broadcast into an
        (n, n) mask, another length was a bare numpy error).
    """
    _group_columns("steady_straight", meta, ("scenario", "t_start_s"), what="provenance")
    yaw = np.asarray(yaw_rate_rad_s, dtype=float)
    if yaw.shape != (len(meta),):
        raise ShapeError(f"steady_straight: yaw_rate_rad_s must have shape ({len(meta)},) "
                         f"(one per window of meta), got {yaw.shape}")
    return ((meta["scenario"].to_numpy() == "straight_accel")
            & (meta["t_start_s"].to_numpy() >= STEADY_AFTER_S)
            & (np.abs(yaw) < STRAIGHT_MAX_YAW_RATE_RAD_S))


def fit_predict(make_model: Callable[[], object], X: pd.DataFrame, Y: np.ndarray,
                train: np.ndarray, test: np.ndarray) -> np.ndarray:
    """Fit a fresh model on the ``train`` windows and predict the ``test`` windows.

    Parameters
    ----------
    make_model : callable
        Returns an unfitted estimator with ``fit(X, Y)`` and ``predict(X)``.
    X : pandas.DataFrame, shape (n, n_features)
        Window features.
    Y : array-like, shape (n, k)
        Targets (a nested list too).
    train, test : ndarray of bool, shape (n,)
        Disjoint window masks (grouped by run by the caller).

    Returns
    -------
    ndarray, shape (n, k)
        Predictions on ``test`` rows, NaN elsewhere.

    Raises
    ------
    ShapeError
        ``train`` or ``test`` is not a boolean array of shape ``(n,)`` (integer 0/1 masks were
        read by ``X[mask]`` as column labels: a bare KeyError).
    ConfigError
        The masks overlap or one is empty.
    ShapeError
        ``Y`` has another number of rows than ``X`` (a bare numpy IndexError before).
    """
    train = _window_mask("fit_predict", "train", train, len(X))
    test = _window_mask("fit_predict", "test", test, len(X))
    Y = np.asarray(Y)     # (a list: a bare AttributeError on Y.shape, TypeError on Y[mask])
    if np.ndim(Y) < 1 or len(Y) != len(X):
        raise ShapeError(f"fit_predict: Y must have one row per window of X ({len(X)}), got "
                         f"shape {np.shape(Y)}")
    _check_disjoint(train, test)
    model = make_model()
    model.fit(X[train], Y[train])
    out = np.full(Y.shape, np.nan)
    out[test] = model.predict(X[test])
    return out


def _check_disjoint(train: np.ndarray, test: np.ndarray) -> None:
    """Refuse (ConfigError) train and test window masks that overlap or of which one is
    empty."""
    if np.any(train & test) or not train.any() or not test.any():
        raise ConfigError("train and test windows must be disjoint and non-empty")


def error_table(pred: np.ndarray, truth: np.ndarray, meta: pd.DataFrame, mask: np.ndarray,
                by: Sequence[str] = ("terrain",)) -> pd.DataFrame:
    """Median and 90th percentile absolute slip error over both sides, grouped.

    Side-windows whose error is not finite (a model undefined there, e.g. eq. 27 in straight
    driving, or a group left without a prediction) are left out of the median and p90 and
    counted: ``n_scored`` says how many side-windows the figures are over.

    Parameters
    ----------
    pred, truth : ndarray, shape (n, 2)
        Predicted and true ``slip_1, slip_2``.
    meta : pandas.DataFrame, shape (n, ...)
        Window provenance (columns named in ``by``).
    mask : ndarray of bool, shape (n,)
        Windows to score.
    by : sequence of str
        Grouping columns (windows whose value is missing form a group of their own, labelled
        NaN, after the others: none is left out).

    Returns
    -------
    pandas.DataFrame
        ``by`` columns, ``median_abs_err``, ``p90_abs_err``, ``n_windows`` (windows of the
        group), ``n_scored`` (side-windows with a finite error, at most ``2 n_windows``),
        ``n_runs``; no row, with these columns, when ``mask`` selects no window.

    Raises
    ------
    ShapeError
        ``mask`` is not a boolean array of one value per window (an integer 0/1 mask was
        read as row labels: other windows scored, silently), or ``pred`` or ``truth`` is
        not ``(n, >= 2)`` with ``n`` the windows of ``meta`` (a one-column prediction was
        broadcast onto both sides and scored twice).
    MissingColumnError
        ``meta`` lacks a column of ``by`` or ``run_id`` (named).
    """
    mask = _window_mask("error_table", "mask", mask, len(meta))
    # grouped by run itself: run_id once (twice, the group key was 2-D: a bare ValueError)
    columns = _group_columns("error_table", meta, dict.fromkeys([*by, "run_id"]))
    by = list(by)
    err = np.abs(_window_sides("error_table", "pred", pred, len(meta))
                 - _window_sides("error_table", "truth", truth, len(meta)))
    frame = meta.loc[mask, columns].copy()
    frame["e1"] = err[mask, 0]
    frame["e2"] = err[mask, 1]
    rows = []
    for key, g in frame.groupby(list(by), sort=True, dropna=False):   # unlabelled: kept
        e = np.concatenate([g["e1"].to_numpy(), g["e2"].to_numpy()])
        e = e[np.isfinite(e)]
        key = key if isinstance(key, tuple) else (key,)
        rows.append({**dict(zip(by, key)),
                     "median_abs_err": float(np.median(e)) if e.size else np.nan,
                     "p90_abs_err": float(np.percentile(e, 90)) if e.size else np.nan,
                     "n_windows": int(len(g)), "n_scored": int(e.size),
                     "n_runs": int(g["run_id"].nunique())})
    # no window to score: the documented columns still (a frame without any was a KeyError)
    return pd.DataFrame(rows, columns=[*by, "median_abs_err", "p90_abs_err", "n_windows",
                                       "n_scored", "n_runs"])


def std_calibration_table(pred: np.ndarray, std: np.ndarray, truth: np.ndarray,
                          meta: pd.DataFrame, mask: np.ndarray,
                          by: Sequence[str] = ("scenario",)) -> pd.DataFrame:
    """How well a predicted slip std describes the errors (held-out windows).

    Side-windows whose normalised error ``|error| / std`` is NaN (no prediction, no truth or
    no std there) are left out of the coverage and counted: ``n_scored`` says how many
    side-windows the coverage is over, as in :func:`error_table`.

    Parameters
    ----------
    pred : ndarray, shape (n, >=2)
        Predicted ``slip_1, slip_2`` in the first two columns.
    std : ndarray, shape (n, >=2)
        Their standard deviations (dimensionless slip) in the first two columns.
    truth : ndarray, shape (n, >=2)
        True ``slip_1, slip_2``.
    meta : pandas.DataFrame, shape (n, ...)
        Window provenance with the ``by`` columns.
    mask : ndarray of bool, shape (n,)
        Windows to score.
    by : sequence of str
        Grouping columns of ``meta`` (windows whose value is missing form a group of their
        own, labelled NaN, after the others: none is left out).

    Returns
    -------
    pandas.DataFrame
        Per group: ``n_windows``, ``n_scored`` (side-windows with a normalised error, at most
        ``2 n_windows``), ``coverage_1std`` and ``coverage_2std`` (fraction of the scored
        side-windows with ``|error| <= k std``; Gaussian 0.683, 0.954; NaN where the model
        gives no std), and over every side-window of the group (NaN if one is):
        ``median_normalised_sq`` (Gaussian 0.455), ``mean_normalised_sq`` (Gaussian 1),
        ``median_std``, ``median_abs_err``; no row, with these columns, when ``mask``
        selects no window.

    Raises
    ------
    ShapeError
        ``mask`` is not a boolean array of one value per window (window indices were taken
        for a mask: other windows scored, silently), or ``pred``, ``std`` or ``truth`` is
        not ``(n, >= 2)`` with ``n`` the windows of ``meta``.
    MissingColumnError
        ``meta`` lacks a column of ``by`` (named).
    EstimationError
        A negative ``std`` (its windows counted and the first named): ``|error| / std`` was
        negative, so the window was counted as covered whatever its error.
    """
    mask = _window_mask("std_calibration_table", "mask", mask, len(meta))
    by = _group_columns("std_calibration_table", meta, by)
    err = np.abs(_window_sides("std_calibration_table", "pred", pred, len(meta))
                 - _window_sides("std_calibration_table", "truth", truth, len(meta)))
    std = _window_sides("std_calibration_table", "std", std, len(meta))
    negative = np.flatnonzero((std < 0).any(axis=1))
    if negative.size:   # |error| / std < 0 <= 1: a negative std covered every error
        raise EstimationError(
            f"std_calibration_table: std must be >= 0 (or NaN where the model gives none), "
            f"got {std[negative[0]][std[negative[0]] < 0][0]:g} in {negative.size} of "
            f"{len(std)} windows ({first_items(negative.tolist(), word='window')})")
    with np.errstate(divide="ignore", invalid="ignore"):    # std 0: inf (uncovered) or NaN
        u = err / std
    pos = np.flatnonzero(mask)
    keys = meta[list(by)].iloc[pos].reset_index(drop=True)
    rows = []
    for key, g in keys.groupby(list(by), dropna=False):     # unlabelled windows: kept
        sel = pos[g.index.to_numpy()]
        uu = u[sel].ravel()
        finite = uu[~np.isnan(uu)]     # a model without a std covers nothing: NaN, not 0
        rows.append({**dict(zip(by, key if isinstance(key, tuple) else (key,))),
                     "n_windows": len(sel), "n_scored": int(finite.size),
                     "coverage_1std": float(np.mean(finite <= 1)) if finite.size else np.nan,
                     "coverage_2std": float(np.mean(finite <= 2)) if finite.size else np.nan,
                     "median_normalised_sq": float(np.median(uu ** 2)),
                     "mean_normalised_sq": float(np.mean(uu ** 2)),
                     "median_std": float(np.median(std[sel])),
                     "median_abs_err": float(np.median(err[sel]))})
    return pd.DataFrame(rows, columns=[*by, "n_windows", "n_scored", "coverage_1std",
                                       "coverage_2std", "median_normalised_sq",
                                       "mean_normalised_sq", "median_std", "median_abs_err"])


def observer_window_slip(runs: Sequence[Run], meta: pd.DataFrame, track_m: float
                         ) -> np.ndarray:
    """Window means of the seed 000 observer slip (yaw-only, gyro heading) per run.

    The observer's ``1 - eta`` is read as SAE slip sample by sample
    (:func:`terrain.slip.baselines.slip_ratio_as_sae`), the convention of the truth.

    Parameters
    ----------
    runs : sequence of Run
        Runs with ``imu`` and ``wheels`` streams.
    meta : pandas.DataFrame, shape (n, ...)
        Window provenance (``run_id, t_start_s, t_end_s``).
    track_m : float
        Track B, m.

    Returns
    -------
    ndarray, shape (n, 2)
        Left and right slip (NaN for a window without an IMU sample, which
        :func:`error_table` leaves out of ``n_scored``).

    Raises
    ------
    ConfigError
        A run of ``meta`` is not among ``runs``, or two of ``runs`` share an id (named).
    EstimationError
        A run without an ``imu`` or ``wheels`` stream (its id is named).
    NonFiniteError
        A non-finite time, ``wz``, ``vel_l`` or ``vel_r`` sample (run, column and row named):
        the heading integrates the gyro, so one would make every later window NaN.
    MissingColumnError
        ``meta`` lacks ``run_id``, ``t_start_s`` or ``t_end_s`` (named).
    """
    _group_columns("observer_window_slip", meta, ("run_id", "t_start_s", "t_end_s"),
                   what="provenance")
    out = np.full((len(meta), 2), np.nan)
    by_id = runs_by_id(runs, "observer_window_slip")
    for rid, idx in meta.groupby("run_id").indices.items():
        run = _run_with(by_id, rid, ("imu", "wheels"))
        run.require_finite("imu", ("wz",))
        run.require_finite("wheels", ("vel_l", "vel_r"))
        imu, wh = run.streams["imu"], run.streams["wheels"]
        t = imu[TIME].to_numpy()
        yaw = np.concatenate([[0.0], np.cumsum(np.diff(t) * imu["wz"].to_numpy()[:-1])])
        vl = np.interp(t, wh[TIME], wh["vel_l"])
        vr = np.interp(t, wh[TIME], wh["vel_r"])
        # the observer's 1 - eta, per sample in the SAE convention of the truth it is scored on
        s = slip_ratio_as_sae(np.column_stack([vl, vr]),
                              observer_slip(t, yaw, vl, vr, 0.5 * track_m))
        csum = np.vstack([np.zeros((1, 2)), np.cumsum(s, axis=0)])
        a = np.searchsorted(t, meta["t_start_s"].to_numpy()[idx])
        b = np.searchsorted(t, meta["t_end_s"].to_numpy()[idx])
        n = (b - a)[:, None]     # a window without an IMU sample has no mean: NaN, not 0
        out[idx] = np.where(n > 0, (csum[b] - csum[a]) / np.maximum(n, 1), np.nan)
    return out


def odometry_errors(runs: Sequence[Run], meta: pd.DataFrame, pred: np.ndarray,
                    track_m: float, run_ids: Sequence[str]) -> pd.DataFrame:
    """Final position error of plain and slip-compensated dead reckoning (percent of distance).

    The window predictions (``slip_1, slip_2, chi`` at the window centres) are interpolated
    onto the wheel samples; before the first centre the first prediction holds. The
    interpolated chi is clipped to :data:`CHI_RANGE` (counted in a warning).

    Parameters
    ----------
    runs : sequence of Run
        Simulated runs (``wheels`` and ``truth`` streams; the truth's ``x``, ``y``, m, are
        taken in the frame of its pose at the first wheel sample, where dead reckoning
        starts: origin there, x along its ``yaw``, rad, or along the truth's x without a
        ``yaw`` column).
    meta : pandas.DataFrame, shape (n, ...)
        Window provenance.
    pred : ndarray, shape (n, 4)
        Predicted ``slip_1, slip_2, chi, v_by`` per window.
    track_m : float
        Track B, m.
    run_ids : sequence of str
        Runs to evaluate.

    Returns
    -------
    pandas.DataFrame
        One row per run: ``run_id, terrain, scenario, distance_m, duration_s, slid_off,
        plain_err_pct`` (wheel speeds and wheel yaw), ``compensated_err_pct`` (predicted slip,
        chi and lateral velocity), ``reduction_pct`` (of compensated against plain),
        ``gyro_heading_err_pct`` (wheel speeds, heading from the gyro) and
        ``compensated_gyro_err_pct`` (predicted slip and lateral velocity, gyro heading; NaN
        without an IMU); the errors are NaN for a run whose true path has length 0 (no
        percentage of it). ``slid_off``: the body travelled more than
        :data:`SLID_OFF_FACTOR` x the wheels' path (it slid down the slope, e.g. the Husky on a
        15 deg icy slope, which no wheel odometry can follow).

    Raises
    ------
    ShapeError
        ``pred`` is not ``(n, >= 4)`` with ``n`` the windows of ``meta``.
    ConfigError
        A run of ``run_ids`` that is not among ``runs`` or has no window in ``meta``, a run
        given twice in ``run_ids`` (its row was repeated, weighing it twice in any mean of
        the table), or two of ``runs`` sharing an id (named).
    EstimationError
        A run without a ``wheels`` or ``truth`` stream (its id is named).
    NonFiniteError
        A non-finite time, wheel speed, truth position or yaw, or (with an IMU) ``wz``
        sample (run, column and row named): dead reckoning integrates them, so one would make
        the run's errors NaN.
    MissingColumnError
        ``meta`` lacks ``run_id``, ``t_start_s`` or ``t_end_s`` (named).

    Warns
    -----
    DataWarning
        Wheel samples whose interpolated chi lies outside :data:`CHI_RANGE` were clipped to
        it (their count, and of how many runs).
    """
    _group_columns("odometry_errors", meta, ("run_id", "t_start_s", "t_end_s"),
                   what="provenance")
    by_id = runs_by_id(runs, "odometry_errors")
    pred = np.asarray(pred, dtype=float)
    if pred.ndim != 2 or pred.shape[0] != len(meta) or pred.shape[1] < 4:
        # (a slip-only prediction was a bare IndexError, another row count read the
        # predictions of other windows)
        raise ShapeError(f"odometry_errors: pred must have shape ({len(meta)}, >= 4) (slip_1, "
                         f"slip_2, chi, v_by of each window of meta), got {pred.shape}")
    twice = duplicated(list(run_ids))
    if twice:   # (the run's row was repeated)
        raise ConfigError(f"odometry_errors: run(s) {listed(twice)} given more than once in "
                          f"run_ids (one row per run)")
    rows = []
    n_clipped = n_samples = n_runs_clipped = 0
    for rid in run_ids:
        run = _run_with(by_id, rid, ("wheels", "truth"))
        run.require_finite("wheels", ("vel_l", "vel_r"))
        has_yaw = "yaw" in run.streams["truth"]
        run.require_finite("truth", ("x", "y", "yaw") if has_yaw else ("x", "y"))
        if "imu" in run.streams:
            run.require_finite("imu", ("wz",))
        sel = np.flatnonzero(meta["run_id"].to_numpy() == rid)
        if not sel.size:    # no prediction to interpolate onto its wheel samples
            raise ConfigError(f"run {rid} has no window in meta: no slip prediction to "
                              "compensate its odometry with")
        wh, tr = run.streams["wheels"], run.streams["truth"]
        t = wh[TIME].to_numpy()
        centre = 0.5 * (meta["t_start_s"].to_numpy()[sel] + meta["t_end_s"].to_numpy()[sel])
        order = np.argsort(centre)
        p = pred[sel][order]
        c = centre[order]
        s1, s2, chi, v_by = (np.interp(t, c, p[:, k]) for k in range(4))
        vl, vr = wh["vel_l"].to_numpy(), wh["vel_r"].to_numpy()
        plain = dead_reckon(t, vl, vr, track_m)
        chi, n_out = _clip_chi(chi)
        n_clipped, n_samples = n_clipped + n_out, n_samples + t.size
        n_runs_clipped += n_out > 0
        comp = dead_reckon(t, vl, vr, track_m, s1, s2, chi, v_by)
        imu = run.streams.get("imu")
        wz = None if imu is None else np.interp(t, imu[TIME].to_numpy(), imu["wz"].to_numpy())
        xy = tr[["x", "y"]].to_numpy()
        end = _in_start_frame(tr, t[0], t[-1])
        dist = float(np.sum(np.hypot(*np.diff(xy, axis=0).T)))

        def pct(pose: np.ndarray) -> float:
            """Final position error, percent of the path (NaN for a run that did not move)."""
            return 100 * float(np.hypot(*(pose[-1, :2] - end))) / dist if dist > 0 else np.nan

        e_plain, e_comp = pct(plain), pct(comp)
        if wz is not None:
            gyro = dead_reckon(t, vl, vr, track_m, yaw_rate_rad_s=wz)
            comp_gyro = dead_reckon(t, vl, vr, track_m, s1, s2, lateral_m_s=v_by,
                                    yaw_rate_rad_s=wz)
            e_gyro, e_comp_gyro = pct(gyro), pct(comp_gyro)
        else:
            e_gyro = e_comp_gyro = np.nan
        wheel_path = float(np.sum(np.hypot(*np.diff(plain[:, :2], axis=0).T)))
        rows.append({"run_id": rid, "terrain": run.terrain,
                     "scenario": run.meta.get("scenario"), "distance_m": dist,
                     "slid_off": dist > SLID_OFF_FACTOR * max(wheel_path, 1e-9),
                     "duration_s": float(t[-1] - t[0]),
                     "plain_err_pct": e_plain, "compensated_err_pct": e_comp,
                     "reduction_pct": 100 * (1 - e_comp / e_plain) if e_plain > 0 else np.nan,
                     "gyro_heading_err_pct": e_gyro, "compensated_gyro_err_pct": e_comp_gyro})
    if n_clipped:
        warnings.warn(f"odometry_errors: chi of {n_clipped} of {n_samples} wheel samples "
                      f"({n_runs_clipped} of {len(rows)} runs) outside [{CHI_RANGE[0]:g}, "
                      f"{CHI_RANGE[1]:g}] clipped to it", DataWarning, stacklevel=2)
    return pd.DataFrame(rows, columns=["run_id", "terrain", "scenario", "distance_m",
                                       "duration_s", "slid_off", "plain_err_pct",
                                       "compensated_err_pct", "reduction_pct",
                                       "gyro_heading_err_pct", "compensated_gyro_err_pct"])


def _in_start_frame(truth: pd.DataFrame, t0_s: float, t1_s: float) -> np.ndarray:
    """The truth position at ``t1_s`` in the frame of its pose at ``t0_s`` (origin there, x
    along its heading; heading 0 without a ``yaw`` column), where dead reckoning starts.
    The heading is interpolated unwrapped: a heading wrapped to [-pi, pi) between samples
    on either side of +-pi was interpolated to ~0, a start frame turned by pi."""
    at = (lambda values, ts: float(np.interp(ts, truth[TIME], values)))
    d = np.array([at(truth["x"], t1_s) - at(truth["x"], t0_s),
                  at(truth["y"], t1_s) - at(truth["y"], t0_s)])
    yaw0 = (at(np.unwrap(truth["yaw"].to_numpy(float)), t0_s) if "yaw" in truth.columns
            else 0.0)
    c, s = np.cos(yaw0), np.sin(yaw0)
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])


def baseline_predictions(X: pd.DataFrame, Y: np.ndarray, meta: pd.DataFrame,
                         train: np.ndarray, runs: Sequence[Run], track_m: float
                         ) -> dict[str, np.ndarray]:
    """Per-window left/right slip of every non-learned model (same windows for all).

    ``zero`` (what the EKF reports for the common slip today), ``physics``
    (:mod:`terrain.slip.physics`, columns ``phys_slip_l/r`` of ``X``), ``pitch-linear`` (eq. 22
    fitted on the straight-driving ``train`` windows, gyro |yaw rate| < 0.05 rad/s), ``endo`` (eq.
    27 with the gyro), ``observer`` (seed 000); the last two in the SAE convention of the
    truth (:func:`terrain.slip.baselines.slip_ratio_as_sae`).

    Parameters
    ----------
    X : pandas.DataFrame, shape (n, n_features)
        Window features (``pitch``, ``vel_l__mean``, ``vel_r__mean``, ``wz__mean``,
        ``phys_slip_l``, ``phys_slip_r``).
    Y : array-like, shape (n, >= 2)
        True ``slip_1, slip_2`` (only the ``train`` rows are read; a nested list too).
    meta : pandas.DataFrame, shape (n, ...)
        Window provenance.
    train : ndarray of bool, shape (n,)
        Windows the eq. 22 coefficients are fitted on.
    runs : sequence of Run
        The runs (observer).
    track_m : float
        Track B, m.

    Returns
    -------
    dict str -> ndarray, shape (n, 2)

    Raises
    ------
    ShapeError
        ``train`` is not a boolean array of one value per window (an integer 0/1 mask
        fancy-indexed the windows: eq. 22 fitted on windows 0 and 1 only, silently), or
        ``Y`` is not ``(n, >= 2)`` with ``n`` the windows of ``X`` (one column was read as
        the slip of both sides, a list or another row count was a bare numpy error).
    MissingColumnError
        ``X`` lacks a feature column above or ``meta`` its ``terrain`` (named).
    """
    from terrain.slip.baselines import endo_turning_slip, fit_pitch_slip, pitch_slip

    train = _window_mask("baseline_predictions", "train", train, len(X))
    _group_columns("baseline_predictions", X, ("pitch", "vel_l__mean", "vel_r__mean",
                                               "wz__mean", "phys_slip_l", "phys_slip_r"),
                   name="X", what="feature")
    _group_columns("baseline_predictions", meta, ("terrain",), what="provenance")

    terr = meta["terrain"].to_numpy()
    pitch = X["pitch"].to_numpy()
    # eq. 22: straight driving
    straight = train & (np.abs(X["wz__mean"].to_numpy()) < STRAIGHT_MAX_YAW_RATE_RAD_S)
    # (a list or a 1-D Y was a bare numpy error; one column was taken for both sides)
    sides = _window_sides("baseline_predictions", "Y", Y, len(X))
    coef = fit_pitch_slip(pitch[straight], sides[straight].mean(axis=1), terr[straight])
    eq22 = pitch_slip(coef, pitch, terr)
    rim = X[["vel_l__mean", "vel_r__mean"]].to_numpy(dtype=float)
    return {
        "zero": np.zeros((len(X), 2)),
        "physics": X[["phys_slip_l", "phys_slip_r"]].to_numpy(),
        "pitch-linear": np.column_stack([eq22, eq22]),
        "endo": slip_ratio_as_sae(rim, endo_turning_slip(rim[:, 0], rim[:, 1],
                                                         X["wz__mean"].to_numpy(), track_m)),
        "observer": observer_window_slip(runs, meta, track_m),
    }


def measured_checks(X: pd.DataFrame, pred: np.ndarray, run_ids: np.ndarray,
                    terrains: np.ndarray, track_m: float, min_turn_rad_s: float = 0.1
                    ) -> pd.DataFrame:
    """What can be checked on measured runs without position truth, per terrain.

    * yaw: RMS over turning windows (gyro |yaw rate| >= ``min_turn_rad_s``) of the gyro yaw
      rate minus the wheel yaw rate, plain ``(v_R - v_L)/B`` and compensated
      ``(v_R - v_L)/(chi B)`` with the predicted ``chi`` clipped to :data:`CHI_RANGE`;
    * slip vs currents: median |learned - physics| slip (the physics slip is computed from
      the measured currents, :mod:`terrain.slip.physics`) and the Spearman correlation of the
      learned slip with the mean current, over straight windows (gyro |yaw rate| < 0.05
      rad/s; the correlation NaN with fewer than four of them, the median NaN with none).

    Parameters
    ----------
    X : pandas.DataFrame, shape (n, n_features)
        Window features of the measured runs (``wz__mean``, ``vel_diff__mean``,
        ``cur_l__mean``, ``cur_r__mean``, ``phys_slip_l``, ``phys_slip_r``).
    pred : ndarray, shape (n, 4)
        Learned ``slip_1, slip_2, chi, v_by``.
    run_ids : ndarray, shape (n,)
        Run of each window.
    terrains : ndarray, shape (n,)
        Terrain label of each window.
    track_m : float
        Track B, m (finite, > 0).
    min_turn_rad_s : float
        Turning threshold, rad/s, finite and >= 0.

    Returns
    -------
    pandas.DataFrame
        One row per terrain: ``terrain, n_runs, n_turning_windows, yaw_rms_plain_rad_s,
        yaw_rms_compensated_rad_s, median_learned_minus_physics, spearman_slip_current``;
        no row, with these columns, without a window.

    Raises
    ------
    ConfigError
        ``min_turn_rad_s`` not a finite number >= 0 or ``track_m`` not a finite number > 0
        (:func:`terrain.errors.config_positive`).
    ShapeError
        ``pred`` not ``(n, >= 3)`` (``slip_1, slip_2, chi`` first), or ``run_ids`` or
        ``terrains`` not ``(n,)``, with ``n`` the windows of ``X`` (bare numpy errors
        before).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``run_ids``
        or ``terrains`` (:func:`terrain.errors.refuse_mixed_types`).
    MissingColumnError
        ``X`` lacks a feature column above (named; a bare pandas KeyError before).

    Warns
    -----
    DataWarning
        Turning windows whose predicted chi lies outside :data:`CHI_RANGE` had it clipped
        (their count); windows whose ``wz__mean`` is NaN, and windows whose ``|wz__mean|``
        lies between the straight and the turning threshold (``0.05 <= |wz__mean| <
        min_turn_rad_s``), neither turning nor straight, were left out of every figure
        (each their count and the first few).
    """
    from scipy.stats import spearmanr

    # (NaN made no window turning: both yaw RMS NaN without a word)
    config_positive("measured_checks", allow_zero=True, min_turn_rad_s=min_turn_rad_s)
    # (the wheel yaw rate divides by it: 0 gave an infinite RMS, < 0 swapped the sides)
    config_positive("measured_checks", track_m=track_m)
    _group_columns("measured_checks", X, ("wz__mean", "vel_diff__mean", "cur_l__mean",
                                          "cur_r__mean", "phys_slip_l", "phys_slip_r"),
                   name="X", what="feature")
    n = len(X)
    pred = np.asarray(pred, dtype=float)
    if pred.ndim != 2 or pred.shape[0] != n or pred.shape[1] < 3:
        raise ShapeError(f"measured_checks: pred must have shape ({n}, >= 3) (slip_1, slip_2, "
                         f"chi of each window first), got {pred.shape}")
    run_ids, terrains = np.asarray(run_ids), np.asarray(terrains)
    for name, value in (("run_ids", run_ids), ("terrains", terrains)):
        if value.shape != (n,):
            raise ShapeError(f"measured_checks: {name} must have shape ({n},) (one per "
                             f"window), got {value.shape}")
        refuse_mixed_types("measured_checks", name, value)   # (NumPy's bare TypeError)
    wz = X["wz__mean"].to_numpy(dtype=float)
    dv = X["vel_diff__mean"].to_numpy()
    unknown = np.isnan(wz)
    if unknown.any():   # neither turning nor straight: left out of every figure, said
        warnings.warn(f"measured_checks: {int(unknown.sum())} of {n} windows have no gyro yaw "
                      f"rate (wz__mean NaN) and are left out of the turning and the straight "
                      f"windows ({first_items(np.flatnonzero(unknown).tolist(), word='window')})",
                      DataWarning, stacklevel=2)
    turning = np.abs(wz) >= min_turn_rad_s        # the windows chi is used on
    straight_all = np.abs(wz) < STRAIGHT_MAX_YAW_RATE_RAD_S
    between = ~(turning | straight_all | unknown)
    if between.any():   # neither turning nor straight either: left out, said
        warnings.warn(f"measured_checks: {int(between.sum())} of {n} windows have a gyro yaw "
                      f"rate between the straight (|wz__mean| < "
                      f"{STRAIGHT_MAX_YAW_RATE_RAD_S:g} rad/s) and the turning "
                      f"(>= {min_turn_rad_s:g} rad/s) thresholds and are left out of the "
                      f"turning and the straight windows "
                      f"({first_items(np.flatnonzero(between).tolist(), word='window')})",
                      DataWarning, stacklevel=2)
    chi, n_out = _clip_chi(np.where(turning, pred[:, 2], 1.0))
    if n_out:
        warnings.warn(f"measured_checks: chi of {n_out} of {int(turning.sum())} turning "
                      f"windows outside [{CHI_RANGE[0]:g}, {CHI_RANGE[1]:g}] clipped to it",
                      DataWarning, stacklevel=2)
    slip = pred[:, :2].mean(axis=1)
    phys = X[["phys_slip_l", "phys_slip_r"]].to_numpy().mean(axis=1)
    cur = X[["cur_l__mean", "cur_r__mean"]].to_numpy().mean(axis=1)
    rows = []
    for terr in np.unique(terrains):
        sel = terrains == terr
        turn = sel & turning
        straight = sel & straight_all
        rms = (lambda r: float(np.sqrt(np.mean(r ** 2))) if r.size else np.nan)
        rho = (float(spearmanr(slip[straight], cur[straight]).statistic)
               if straight.sum() > 3 else np.nan)
        rows.append({"terrain": terr, "n_runs": int(len(np.unique(run_ids[sel]))),
                     "n_turning_windows": int(turn.sum()),
                     "yaw_rms_plain_rad_s": rms(wz[turn] - dv[turn] / track_m),
                     "yaw_rms_compensated_rad_s": rms(wz[turn] - dv[turn] / (chi[turn] * track_m)),
                     "median_learned_minus_physics": float(np.median(np.abs(
                         slip[straight] - phys[straight]))) if straight.any() else np.nan,
                     "spearman_slip_current": rho})
    # no window: the documented columns still (a frame without any was a KeyError later)
    return pd.DataFrame(rows, columns=["terrain", "n_runs", "n_turning_windows",
                                       "yaw_rms_plain_rad_s", "yaw_rms_compensated_rad_s",
                                       "median_learned_minus_physics",
                                       "spearman_slip_current"])


def leave_one_out(make_model: Callable[[], object], X: pd.DataFrame, Y: np.ndarray,
                  groups: np.ndarray, train: np.ndarray, test: np.ndarray) -> np.ndarray:
    """Predictions where each group's test windows come from a model that never saw the group.

    For every value ``g`` of ``groups`` (a scenario, a terrain), a fresh model is fitted on
    the ``train`` windows of the other groups and predicts the ``test`` windows of ``g``.

    Parameters
    ----------
    make_model : callable
        Returns an unfitted estimator.
    X : pandas.DataFrame, shape (n, n_features)
        Window features.
    Y : array-like, shape (n, k) or (n,)
        Targets (a nested list too).
    groups : ndarray, shape (n,)
        Group of each window.
    train, test : ndarray of bool, shape (n,)
        Disjoint window masks (e.g. training and held-out seeds).

    Returns
    -------
    ndarray, shape of ``Y``
        NaN outside the ``test`` windows (and for groups without training data elsewhere).

    Raises
    ------
    ShapeError
        ``groups`` without one value per window, or ``train`` or ``test`` not a boolean mask
        of one value per window (an integer 0/1 mask picked the groups of windows 0 and 1).
    ConfigError
        As :func:`fit_predict`: ``train`` and ``test`` overlap or one is empty.
    NonFiniteInputError
        A missing group (NaN or None) (:func:`terrain.errors.refuse_missing`).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``groups``
        (:func:`terrain.errors.refuse_mixed_types`).
    """
    n = len(X)
    train = _window_mask("leave_one_out", "train", train, n)
    test = _window_mask("leave_one_out", "test", test, n)
    groups = np.asarray(groups)
    if groups.shape != (n,):    # a bare numpy IndexError before
        raise ShapeError(f"leave_one_out: groups must have shape ({n},) (one per window), got "
                         f"{groups.shape}")
    # (an empty test mask gave all NaN, overlapping masks were scored, without a word)
    _check_disjoint(train, test)
    # a window of no group is left out with none (NaN: a misleading mask error; None: a
    # bare TypeError sorting the groups)
    refuse_missing("leave_one_out", "groups", groups, "group(s)",
                   "every window belongs to the group it is left out with")
    refuse_mixed_types("leave_one_out", "groups", groups)   # (NumPy's bare TypeError)
    Y = np.asarray(Y)     # (a list: a bare AttributeError on Y.shape)
    out = np.full(Y.shape, np.nan)
    for g in np.unique(groups[test]):
        m = groups == g
        if (train & ~m).any():
            # the rows of g's test windows, whatever Y's dimension ((n,): a mask of shape
            # (n, 1) broadcast the predictions into an (n, n) table, without a word)
            rows = test & m
            out[rows] = fit_predict(make_model, X, Y, train & ~m, rows)[rows]
    return out
