"""Run an EKF model over a whole multi-rate recording.

Scheduling rule (explicit, recorded in :attr:`EKFResult.meta`):

* the filter steps on a time grid ``t_s`` (normally uniform at the IMU rate); at step ``k``
  it predicts from ``t_{k-1}`` to ``t_k`` and then updates with every sensor sample whose
  timestamp lies in ``(t_{k-1}, t_k]`` (the first step takes samples up to one step before
  ``t_0``). A sample is thus used at most one grid step (<= 10 ms at 100 Hz) after it was
  taken;
* when one sensor has two samples inside one step the later one is used and the earlier one
  is counted as ``superseded``; samples outside the grid are counted as ``outside``;
* a non-finite value is skipped for its row only (the sensor's other rows and the other
  sensors are still used) and counted in ``non_finite``: the filter keeps running on the
  remaining sensors, its covariance grows where information is missing, and it recovers when
  the sensor comes back;
* rows rejected by the chi-square gate are counted in ``rejected``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from terrain.errors import ConfigError, ShapeError, TimeStepError, config_numbers, listed
from terrain.estimation.ekf import Gate, as_covariance, as_vector, correct, project_to_bounds
from terrain.estimation.model import StateSpaceModel
from terrain.estimation.result import EKFResult, LoopArrays
from terrain.run import clock_slack, step_index, times_out_of_order
from terrain.vehicles.common import float_arrays

#: Engines of :func:`run_filter`.
ENGINES: tuple[str, ...] = ("auto", "numba", "numpy")
#: Fastest filter grid, Hz: five times the fastest MEMS IMU rate the readers accept
#: (2 kHz, :data:`terrain.io.plausibility.NOMINAL_RATE_HZ`); a faster grid only repeats
#: predictions between samples.
MAX_RATE_HZ = 10_000.0
#: Slowest filter grid, Hz: the slowest stream the readers accept (a wheel report at 1 Hz,
#: :data:`terrain.io.plausibility.NOMINAL_RATE_HZ`); a slower grid would skip measurements.
MIN_RATE_HZ = 1.0
#: Most filter steps of one grid (27.8 h at 100 Hz, 500 s at 10 kHz): a step of the
#: AgriMaRo EKF with its output table takes about 1.2 kB, so 6 GB at the bound.
MAX_GRID_STEPS = 5_000_000


def check_rate_hz(rate_hz: float | None, name: str = "rate_hz") -> float | None:
    """Validate a filter rate given by a user (None: the estimator's default).

    Parameters
    ----------
    rate_hz : float or None
        Rate, Hz; None stands for the default (the IMU rate). ``0`` is not a default: it is
        refused like any rate outside ``[MIN_RATE_HZ, MAX_RATE_HZ]``.
    name : str
        Name of the argument in the message (e.g. ``--rate-hz``).

    Returns
    -------
    float or None
        The rate as a float, or None.

    Raises
    ------
    ConfigError
        Not a finite number in ``[MIN_RATE_HZ, MAX_RATE_HZ]`` Hz (a boolean or text is not a
        number).
    """
    if rate_hz is None:
        return None
    try:
        if isinstance(rate_hz, (bool, np.bool_, str, bytes)):   # True was 1 Hz, "100" 100 Hz
            raise TypeError
        rate = float(rate_hz)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be a number of Hz, got {rate_hz!r}") from None
    if not (np.isfinite(rate) and MIN_RATE_HZ <= rate <= MAX_RATE_HZ):
        raise ConfigError(f"{name} must be in [{MIN_RATE_HZ:g}, {MAX_RATE_HZ:g}] Hz (omit it "
                          f"for the IMU rate), got {rate_hz}")
    return rate


def clock_rate_hz(t_s: np.ndarray) -> float:
    """Sample rate of a stream read off its own clock, Hz: the estimators' default filter
    rate.

    ``1 / median step``, the median step snapped, within the clock's rounding, to the span
    of the samples over the whole number of median steps it holds. A step between two
    timestamps is known to one unit in the last place of the clock only (1.5e-11 s at 1e5
    s, 2.4e-7 s on an epoch clock), so the median step of 100 Hz samples on a clock shifted
    by 1e5 s read 100.0000000524 Hz: a grid at that rate drifted 5e-9 s from the samples
    in 1000 steps, past the placement slack (:func:`terrain.run.clock_slack`, 1 ns there),
    and samples landed one step late. The span over its step count knows the step to that
    rounding divided by the count. A median step farther than two units in the last place
    of the clock from that mean step (jitter, gaps: a rate that is not the clock's rounding
    alone) is kept as it is.

    Parameters
    ----------
    t_s : ndarray, shape (k,)
        Sample times, s, finite and strictly increasing, ``k >= 2``.

    Returns
    -------
    float
        Rate, Hz.
    """
    t = np.asarray(t_s, dtype=float)
    step = float(np.median(np.diff(t)))
    span = float(t[-1] - t[0])
    n = round(span / step)
    if n >= 1 and abs(span / n - step) <= 2.0 * float(np.spacing(np.abs(t).max())):
        step = span / n     # the clock's rounding alone: the mean step knows it n times better
    return 1.0 / step


@dataclass(frozen=True)
class SensorSamples:
    """Samples of one sensor.

    Parameters
    ----------
    t_s : ndarray, shape (k,)
        Sample times, s, strictly increasing.
    values : ndarray, shape (k, d)
        Values in the column order of the model's ``sensor_rows[name]`` (SI units); NaN or
        inf entries are skipped and counted.

    Raises
    ------
    ShapeError
        ``t_s`` not ``(k,)`` or ``values`` not ``(k, d)`` (or ``(k,)``, one column).
    TimeStepError
        Times not finite and strictly increasing (the first such sample named).
    EstimationError
        Booleans given for the times or the values (a mask was filtered as measurements of
        0 and 1), or entries that are not numbers (text; NumPy's bare ValueError before).
    """

    t_s: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        t, v = float_arrays("SensorSamples", t_s=self.t_s, values=self.values)
        if v.ndim == 1:
            v = v[:, None]
        if t.ndim != 1 or v.ndim != 2 or v.shape[0] != t.shape[0]:
            raise ShapeError(f"sensor samples need t_s (k,) and values (k, d), got "
                             f"{t.shape} and {np.shape(self.values)}")
        out_of_order = times_out_of_order(t)
        if out_of_order.size:
            bad = out_of_order[0]
            after = f" after {t[bad - 1]:.6g} s" if bad and np.isfinite(t[bad]) else ""
            raise TimeStepError(f"sensor timestamps must be finite and strictly increasing: "
                                f"sample {bad} at {t[bad]:.6g} s{after}")
        # copies: checked once here, the caller's own arrays could change after the check
        # (a reused buffer gave the filter samples out of order)
        object.__setattr__(self, "t_s", t.copy())
        object.__setattr__(self, "values", v.copy())


def check_sensor_names(argument: str, names: Iterable[str], sensors: Iterable[str]) -> None:
    """Refuse names in an estimator's per-sensor argument that are not sensors of its filter
    (a latency or a selection for a misspelt sensor would otherwise not be applied).

    Parameters
    ----------
    argument : str
        The argument's name, for the message (e.g. ``time_offsets_s``).
    names : iterable of str
        The sensor names it holds.
    sensors : iterable of str
        The filter's sensors (a model's ``sensor_rows``).

    Raises
    ------
    ConfigError
        A name that is not one of ``sensors`` (the unknown names and the sensors listed), or
        ``names`` given as one text (``sensors="imu"`` was read letter by letter, and ``""``
        as no sensor at all: a filter without measurements).
    """
    if isinstance(names, (str, bytes)):
        raise ConfigError(f"{argument} must be a sequence of sensor names, got the text "
                          f"{names!r} (e.g. ({names!r},))")
    known = list(sensors)
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ConfigError(f"{argument} names {listed(unknown)}, not a sensor of the filter "
                          f"(sensors: {known})")


def check_time_offsets(time_offsets_s: Mapping[str, float] | None, sensors: Iterable[str]
                       ) -> dict[str, float]:
    """The per-sensor latencies an estimator subtracts from its sensors' timestamps, checked.

    Parameters
    ----------
    time_offsets_s : Mapping[str, float] or None
        Sensor -> latency, s (None: none).
    sensors : iterable of str
        The filter's sensors (a model's ``sensor_rows``).

    Returns
    -------
    dict
        Sensor -> latency, s (a copy; empty for None).

    Raises
    ------
    ConfigError
        A key that is not one of ``sensors`` (:func:`check_sensor_names`), a latency that is
        not a real number (a boolean, text, None, an array) or not finite (NaN or inf made
        every timestamp of the sensor NaN or inf, refused as the stream's own timestamps).
    """
    offsets = dict(time_offsets_s or {})
    check_sensor_names("time_offsets_s", offsets, sensors)
    config_numbers("time_offsets_s", **offsets)      # (True was a 1 s latency)
    bad = {k: v for k, v in offsets.items() if not np.isfinite(v)}
    if bad:
        raise ConfigError(f"time_offsets_s must be finite latencies (s), got {bad}")
    return offsets


def stream_samples(run_id: str, stream: str, t_s: np.ndarray, values: np.ndarray
                   ) -> SensorSamples:
    """:class:`SensorSamples` of one stream of a run, its time errors naming run and stream.

    Parameters
    ----------
    run_id : str
        The run's id, for the message.
    stream : str
        The stream the samples come from, for the message.
    t_s : ndarray, shape (k,)
        Sample times, s, strictly increasing.
    values : ndarray, shape (k, d) or (k,)
        Values (SI units).

    Returns
    -------
    SensorSamples

    Raises
    ------
    TimeStepError
        Times not finite and strictly increasing: ``run <id>: stream '<stream>': ...`` and
        the first such sample.
    ShapeError
        As :class:`SensorSamples`.
    """
    try:
        return SensorSamples(t_s, values)
    except TimeStepError as exc:
        raise TimeStepError(f"run {run_id}: stream {stream!r}: {exc}") from None


def stream_overlap_s(run_id: str, spans: Mapping[str, np.ndarray], why: str = ""
                     ) -> tuple[float, float]:
    """First and last time that every stream a filter reads covers (the span of its grid).

    Parameters
    ----------
    run_id : str
        The run's id, for the message.
    spans : Mapping[str, ndarray]
        Stream name -> its sample times, s, increasing (each non-empty).
    why : str
        Appended to the message (e.g. the latencies subtracted).

    Returns
    -------
    (t_start_s, t_end_s) : tuple of float
        The overlap, s, ``t_start_s < t_end_s``.

    Raises
    ------
    TimeStepError
        The streams do not overlap (run and each stream's span named; :func:`make_grid`'s
        'empty time span' named neither).
    """
    t0 = max(float(t[0]) for t in spans.values())
    t1 = min(float(t[-1]) for t in spans.values())
    if not t1 > t0:
        within = ", ".join(f"{name!r} {t[0]:.6g}..{t[-1]:.6g} s" for name, t in spans.items())
        raise TimeStepError(f"run {run_id}: the streams the filter reads do not overlap in "
                            f"time ({within}{why}); the grid spans their overlap")
    return t0, t1


def make_grid(t_start_s: float, t_end_s: float, rate_hz: float) -> np.ndarray:
    """Uniform grid ``t_start, t_start + 1/rate, ...`` up to ``t_end`` (inclusive).

    A rate read off a stream's own clock (``1 / median step``, the estimators' default) is
    off by up to one unit in the last place of its timestamps per step, so a grid at that
    rate drifts against the samples by up to that much per step: on a clock far from 0 (a
    robot's seconds since boot, an epoch clock) it ended a hair before the last sample, or
    one whole step short, and the stream's last sample was outside the grid (and, drifting
    past the slack of the placement rule of :func:`sample_steps`, samples inside it went
    to the next step, superseded there). A ``t_end`` within that rounding slack (twice the
    steps times the clock's unit in the last place, at most a quarter step) of a grid step
    is the last step: the count takes it and the steps are spread evenly over ``[t_start,
    t_end]`` (the rate corrected by the clock's rounding). A grid whose last step is already
    within 1e-9 s of ``t_end`` is left as computed. On a clock whose unit in the last place
    exceeds 1e-9 s (beyond about 8e6 s, an epoch clock) the samples lie off the grid's steps
    by their own rounding; the placement rule's slack (:func:`terrain.run.clock_slack`, 64
    units in the last place there) still puts each on its step.

    Parameters
    ----------
    t_start_s, t_end_s : float
        First and last time, s.
    rate_hz : float
        Grid rate, Hz, in ``(0, MAX_RATE_HZ]``.

    Returns
    -------
    ndarray, shape (N,)
        Times, s; ``N <= MAX_GRID_STEPS``.

    Raises
    ------
    TimeStepError
        ``rate_hz`` not > 0, ``t_end <= t_start``, or fewer than 2 steps.
    ConfigError
        ``rate_hz`` above :data:`MAX_RATE_HZ`, or a grid of more than :data:`MAX_GRID_STEPS`
        steps (checked before any memory is taken); an argument that is not a real number
        (``True`` was a 1 Hz grid, text a bare TypeError).
    """
    config_numbers("make_grid", t_start_s=t_start_s, t_end_s=t_end_s, rate_hz=rate_hz)
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise TimeStepError(f"rate must be > 0 Hz, got {rate_hz}")
    if rate_hz > MAX_RATE_HZ:
        raise ConfigError(f"filter rate {rate_hz:g} Hz is above the {MAX_RATE_HZ:g} Hz "
                          "allowed (5 x the fastest IMU rate the readers accept)")
    if not t_end_s > t_start_s:
        raise TimeStepError(f"empty time span [{t_start_s}, {t_end_s}] s")
    steps = (t_end_s - t_start_s) * rate_hz + 1.0
    if not steps <= MAX_GRID_STEPS:
        raise ConfigError(f"a grid at {rate_hz:g} Hz over {t_end_s - t_start_s:.6g} s would "
                          f"have {steps:.4g} steps, more than the {MAX_GRID_STEPS:,} allowed "
                          f"(about 1.2 kB each); lower the rate")
    span = (t_end_s - t_start_s) * rate_hz
    # the clock's rounding over the grid (a rate read off it is off by up to one unit in the
    # last place per step), s; 1e-9 steps as before where it is smaller
    slack_s = min(2.0 * span * float(np.spacing(max(abs(t_start_s), abs(t_end_s)))),
                  0.25 / rate_hz)
    n = int(np.floor(span + max(1e-9, slack_s * rate_hz))) + 1
    if n < 2:
        raise TimeStepError(f"a grid at {rate_hz:g} Hz over {t_end_s - t_start_s:.6g} s has "
                            f"{n} step: a filter needs at least 2")
    grid = t_start_s + np.arange(n) / rate_hz
    if 1e-9 < abs(t_end_s - grid[-1]) <= slack_s:
        # off t_end by the clock's rounding alone: the rate is the clock's own, so the steps
        # are spread evenly over [t_start, t_end] (the rate corrected by that rounding)
        grid = t_start_s + np.arange(n) * ((t_end_s - t_start_s) / (n - 1))
        grid[-1] = t_end_s
    return grid


def sample_steps(t_grid: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """Grid step that receives each sample: the first step at or after its time.

    The placement rule of :func:`run_filter` (:func:`terrain.run.step_index`: within
    :func:`terrain.run.clock_slack`, 1 ns on a clock below 2**17 s, so a sample on a step
    belongs to that step; the simulator reads its steps by the same rule),
    shared by the code that must agree with it step for step (the segments and
    the speed bound of :mod:`terrain.estimation.skid_steer_slip`).

    Parameters
    ----------
    t_grid : ndarray, shape (N,)
        Filter steps, s, increasing.
    t_s : ndarray, shape (k,)
        Sample times, s.

    Returns
    -------
    ndarray of int, shape (k,)
        Step index in ``0 .. N``; ``N`` for a sample after the last step.
    """
    return step_index(t_grid, t_s)


def samples_inside(t_grid: np.ndarray, t_s: np.ndarray, first_step_s: float | None = None
                   ) -> np.ndarray:
    """Which samples :func:`run_filter` may use: those after the step before the first
    (``t_0 - dt``, taken at the first step) and at or before the last step, both within the
    slack of the placement rule of :func:`sample_steps` (a sample at ``t_0 - dt`` belongs to
    that step, which is not the grid's); the others are counted as ``outside``. The slack
    is :func:`terrain.run.clock_slack` of the sample's time, as the placement rule's (1 ns
    below 2**17 s; 64 units in the last place beyond, where a fixed 1 ns is below one
    rounding of the clock).

    Parameters
    ----------
    t_grid : ndarray, shape (N,)
        Filter steps, s, increasing.
    t_s : ndarray, shape (k,)
        Sample times, s.
    first_step_s : float, optional
        ``dt`` of the step before the first, s (a grid cut from a longer one: that grid's
        step before its cut); None: the grid's first step, 1 s for a grid of one step.

    Returns
    -------
    ndarray of bool, shape (k,)
    """
    t = np.asarray(t_s, dtype=float)
    step0 = (first_step_s if first_step_s is not None
             else t_grid[1] - t_grid[0] if t_grid.size > 1 else 1.0)
    # the placement rule's slack, not a fixed 1 ns (below one rounding of an epoch clock:
    # the last sample a ulp late was outside, though sample_steps put it on the last step)
    slack = clock_slack(t)
    return (t > t_grid[0] - step0 + slack) & (t <= t_grid[-1] + slack)


def _place(t_grid: np.ndarray, samples: SensorSamples, width: int, name: str,
           first_step_s: float | None = None
           ) -> tuple[np.ndarray, np.ndarray, dict[str, int]]:
    """Step index of each kept sample and the counts of sensor ``name`` (``first_step_s``:
    :func:`samples_inside`)."""
    t = samples.t_s
    v = samples.values
    if v.shape[1] != width:
        raise ShapeError(f"sensor {name!r} has {v.shape[1]} columns, the model expects {width}")
    inside = samples_inside(t_grid, t, first_step_s)
    idx = sample_steps(t_grid, t)
    finite_any = np.isfinite(v).any(axis=1)
    non_finite = int((~np.isfinite(v).all(axis=1) & inside).sum())
    keep = inside & finite_any
    idx_k = idx[keep]
    # the last sample of each step wins
    last = np.r_[idx_k[1:] != idx_k[:-1], True] if idx_k.size else np.zeros(0, bool)
    superseded = int((~last).sum())
    counts = {"samples": int(t.size), "non_finite": non_finite, "superseded": superseded,
              "outside": int((~inside).sum())}
    rows = np.flatnonzero(keep)[last]
    return idx[rows], v[rows], counts


def sensor_groups(sensor_rows: Mapping[str, Sequence[int]], n_measurements: int
                  ) -> np.ndarray:
    """Sensor group of each measurement row (the ``row_sensor`` of the filter loops).

    Parameters
    ----------
    sensor_rows : Mapping[str, sequence of int]
        Sensor name -> its measurement rows (a model's ``sensor_rows``), in group order.
    n_measurements : int
        Rows of the measurement vector.

    Returns
    -------
    ndarray of int, shape (n_measurements,)
        Index of the row's sensor in ``sensor_rows``; -1 for a row of no sensor.
    """
    row_sensor = np.full(n_measurements, -1)
    for j, rows in enumerate(sensor_rows.values()):
        row_sensor[list(rows)] = j
    return row_sensor


def run_filter(model: StateSpaceModel, t_grid: np.ndarray,
               samples: Mapping[str, SensorSamples], *, gate: Gate | None = None,
               x0: np.ndarray | None = None, P0: np.ndarray | None = None,
               store_covariance: bool = False, engine: str = "auto",
               step_bounds: tuple[np.ndarray, np.ndarray] | None = None,
               step_bound_movable: np.ndarray | None = None,
               first_step_s: float | None = None) -> EKFResult:
    """Filter a recording with ``model`` on the grid ``t_grid``.

    Two engines compute the same result (to round-off, ~1e-12 relative): the NumPy reference
    loop (:func:`~terrain.estimation.correct` at every step) and the compiled loop of
    :mod:`terrain.estimation.fast` (numba; 3.2 us instead of 28 us per AgriMaRo step), which
    runs models that provide a ``fast_kernel()``
    (:class:`~terrain.estimation.agrimaro.AgriMaRoModel`,
    :class:`~terrain.estimation.skid_steer.SkidSteerModel`).

    Parameters
    ----------
    model : StateSpaceModel
        Process / measurement model, noises and initial state.
    t_grid : ndarray, shape (N,)
        Step times, s, strictly increasing (:func:`make_grid`).
    samples : Mapping[str, SensorSamples]
        Sensor name (a key of ``model.sensor_rows``) -> samples. Sensors not given are
        simply never used.
    gate : Gate, optional
        Per-sensor chi-square gating.
    x0 : ndarray, shape (n,), optional
        Initial state (default ``model.x0``), at ``t_grid[0]``.
    P0 : ndarray, shape (n, n) or (n,), optional
        Initial covariance (default ``model.P0``).
    store_covariance : bool
        Keep the full covariance of every step (needed for NEES); memory N n^2 floats.
    engine : {"auto", "numba", "numpy"}
        ``numpy``: the reference loop; ``numba``: the compiled loop (the model must provide
        ``fast_kernel()``); ``auto``: the compiled loop when the model provides a kernel and
        numba is importable, else the reference. The first compiled call on a machine
        compiles the loop (about 4.5 s, then cached on disk). The engine used is recorded in
        ``meta["engine"]``. A model with ``state_bounds`` (its states clipped into their
        physical range after every update; the steps where the clip moved the estimate are
        counted in ``meta["state_bounds_clipped"]``) runs on the reference loop, as does a
        filter with ``step_bounds``.
    step_bounds : (lower, upper), each ndarray of shape (N, n), optional
        Bounds of the state at each step, the states' units (``-inf`` / ``inf``: none),
        from measurements rather than from the model (e.g. the speed bound of
        :func:`terrain.estimation.skid_steer_slip.speed_bounds_m_s`). After each step's
        update (or prediction, at a step with no sample) an estimate outside them is
        projected onto them in the metric of its covariance
        (:func:`~terrain.estimation.ekf.project_to_bounds`), so the states correlated with
        a bounded one move with it; then the model's ``state_bounds`` clip. The steps where
        a bound was active are counted in ``meta["step_bounds_active"]``.
    step_bound_movable : ndarray of bool, shape (n,), optional
        The states the projection onto ``step_bounds`` may move (``movable`` of
        :func:`~terrain.estimation.ekf.project_to_bounds`; default: all).
    first_step_s : float, optional
        Length of the step before the first, s: the first step takes the samples of
        ``(t_0 - first_step_s, t_0]`` (:func:`samples_inside`). None: the grid's first step
        (1 s for a grid of one step); a grid cut from a longer one (the segments of
        :func:`terrain.estimation.skid_steer_slip.run_with_pseudo_slip`) passes that grid's.

    Returns
    -------
    EKFResult

    Raises
    ------
    ShapeError, NonFiniteInputError, CovarianceError
        Bad initial state or covariance, unknown sensor, wrong column count.
    TimeStepError
        Grid not strictly increasing.
    ConfigError
        Unknown ``engine``, or ``engine="numba"`` for a model without a kernel or with
        ``state_bounds``, or with ``step_bounds``.
    """
    if engine not in ENGINES:
        raise ConfigError(f"unknown engine {engine!r}; valid: {', '.join(ENGINES)}")
    t_grid = as_vector(t_grid, "t_grid")
    if t_grid.size < 1:
        raise ShapeError("t_grid is empty")
    dts = np.diff(t_grid)
    if (dts <= 0).any():
        raise TimeStepError(f"t_grid must increase strictly (step {int(np.argmin(dts)) + 1})")
    n, m = model.n_states, model.n_measurements
    x = as_vector(model.x0 if x0 is None else x0, "x0", n)
    P = as_covariance(model.P0 if P0 is None else P0, n, "P0")
    R_diag = as_vector(model.R_diag, "R_diag", m)
    as_covariance(R_diag, m, "R", definite=True)
    N = t_grid.size
    Z = np.full((N, m), np.nan)
    counts: dict[str, dict[str, int]] = {}
    sensor_rows = {k: tuple(v) for k, v in model.sensor_rows.items()}
    for name, s in samples.items():
        if name not in sensor_rows:
            raise ShapeError(f"unknown sensor {name!r}; the model has {list(sensor_rows)}")
        rows = list(sensor_rows[name])
        steps, values, c = _place(t_grid, s, len(rows), name, first_step_s)
        Z[steps[:, None], np.asarray(rows)[None, :]] = values
        counts[name] = c
    avail = np.isfinite(Z)
    row_sensor = sensor_groups(sensor_rows, m)
    bounds = getattr(model, "state_bounds", None)
    if (bounds is not None or step_bounds is not None) and engine == "numba":
        raise ConfigError(f"{type(model).__name__} bounds its states, which only the NumPy "
                          "reference loop applies; use engine='numpy' or 'auto'")
    if step_bounds is not None:
        try:
            lo_b, up_b = (np.broadcast_to(np.asarray(b, dtype=float), (N, n))
                          for b in step_bounds)
        except ValueError as exc:
            raise ShapeError(f"step_bounds must be (lower, upper), each of shape ({N}, {n}): "
                             f"{exc}") from None
        if np.isnan(lo_b).any() or np.isnan(up_b).any() or (lo_b > up_b).any():
            raise ShapeError("step_bounds hold NaN or a lower bound above its upper bound")
        step_bounds = (lo_b, up_b)
    kernel = (None if bounds is not None or step_bounds is not None
              else _fast_kernel(model, engine))
    if kernel is not None:
        from terrain.estimation.fast import run_compiled

        thresholds = None if gate is None else np.array(
            [gate.threshold(d) for d in range(1, max(map(len, sensor_rows.values())) + 1)])
        loop = run_compiled(kernel, dts, Z, x, P, R_diag, row_sensor, len(sensor_rows),
                            thresholds=thresholds, store_covariance=store_covariance)
    else:
        loop = _reference_loop(model, dts, Z, avail, x, P, R_diag, row_sensor,
                               len(sensor_rows), gate, store_covariance, bounds, step_bounds,
                               step_bound_movable)
    accepted = loop.accepted
    for name, rows in sensor_rows.items():
        if name in counts:
            r = list(rows)
            used = accepted[:, r].any(axis=1)
            present = avail[:, r].any(axis=1)
            counts[name]["used"] = int(used.sum())
            counts[name]["rejected"] = int((present & ~used).sum())
    meta = {"scheduling": "grid step k uses samples in (t_{k-1}, t_k]; latest wins",
            "engine": "numpy" if kernel is None else "numba",
            "gate_probability": None if gate is None else gate.probability,
            "n_steps": int(N),
            "rate_hz": float(1.0 / np.median(dts)) if dts.size else float("nan")}
    if step_bounds is not None:
        meta["step_bounds_active"] = int(loop.bound_active.sum())
    if bounds is not None:
        meta["state_bounds_clipped"] = int(loop.clipped.sum())
    # (a copy: t_grid is the caller's own array, and a result's times shifted in place moved
    # the grid the caller filters the next run on)
    return EKFResult(t_s=t_grid.copy(), x=loop.x, P_diag=loop.P_diag, P=loop.P, y=loop.y,
                     S_diag=loop.S_diag, accepted=accepted, nis=loop.nis, dof=loop.dof,
                     state_names=tuple(model.state_names),
                     measurement_names=tuple(model.measurement_names),
                     sensor_rows=dict(sensor_rows), counts=counts, meta=meta)


def _fast_kernel(model: StateSpaceModel, engine: str) -> Any:
    """The model's compiled-loop kernel for ``engine``, or None for the reference loop.

    Raises
    ------
    ConfigError
        ``engine="numba"`` and the model has no kernel.
    """
    if engine == "numpy":
        return None
    try:
        from terrain.estimation.fast import fast_kernel_of
    except ImportError:                         # numba missing: the reference still works
        if engine == "numba":
            raise
        return None
    kernel = fast_kernel_of(model)
    if kernel is None and engine == "numba":
        raise ConfigError(f"{type(model).__name__} has no compiled kernel (fast_kernel); "
                          "use engine='numpy' or 'auto'")
    return kernel


def _reference_loop(model: StateSpaceModel, dts: np.ndarray, Z: np.ndarray, avail: np.ndarray,
                    x: np.ndarray, P: np.ndarray, R_diag: np.ndarray, row_sensor: np.ndarray,
                    n_sensors: int, gate: Gate | None, store_covariance: bool,
                    bounds: tuple[np.ndarray, np.ndarray] | None = None,
                    step_bounds: tuple[np.ndarray, np.ndarray] | None = None,
                    step_bound_movable: np.ndarray | None = None) -> LoopArrays:
    """The NumPy reference loop of :func:`run_filter` (predict, then :func:`correct` with the
    rows available at each step, then the mean projected onto ``step_bounds`` (moving the
    ``step_bound_movable`` states) and clipped
    into ``bounds``, the model's ``state_bounds``, when given)."""
    if bounds is not None:
        lower, upper = (np.asarray(b, dtype=float) for b in bounds)
    N, m = Z.shape
    n = x.shape[0]
    if m <= 62:     # each step's set of rows as the sum of 2^row (int64)
        weights = np.left_shift(np.int64(1), np.arange(m, dtype=np.int64))
        keys = (avail.astype(np.int64) * weights).sum(axis=1)
    else:   # numbered (a row past 62 has no bit in int64: its samples were dropped)
        patterns, keys = np.unique(avail, axis=0, return_inverse=True)
        # key 0 is the step with no row, which sorts first when there is one
        keys = keys.reshape(-1) + (1 if patterns[0].any() else 0)
    cache: dict[int, tuple] = {}
    for key in np.unique(keys):
        if key == 0:
            continue
        rows = np.flatnonzero(avail[np.argmax(keys == key)])
        groups = [np.flatnonzero(row_sensor[rows] == j) for j in range(n_sensors)]
        full = rows.size == m          # every row present: no fancy indexing in the loop
        cache[int(key)] = (None if full else rows, R_diag[rows], [g for g in groups if g.size])

    xs = np.empty((N, n))
    Pd = np.empty((N, n))
    Ps = np.empty((N, n, n)) if store_covariance else None
    Y = np.full((N, m), np.nan)
    Sd = np.full((N, m), np.nan)
    accepted = np.zeros((N, m), dtype=bool)
    nis = np.full(N, np.nan)
    dof = np.zeros(N, dtype=int)
    bound_active = np.zeros(N, dtype=bool)
    clipped = np.zeros(N, dtype=bool)
    residual = model.residual
    transition, observation = model.transition, model.observation
    q_dt, Qk = None, None
    for k in range(N):
        if k:
            dt = dts[k - 1]
            if dt != q_dt:
                Qk = np.asarray(model.Q(dt), dtype=float)
                q_dt = dt
            fx, Fm = transition(x, dt)
            Pp = np.dot(np.dot(Fm, P), Fm.T) + Qk
            P = 0.5 * (Pp + Pp.T)
            x = fx
        key = int(keys[k])
        if key:
            rows, r_sub, groups = cache[key]
            hx, Hm = observation(x)
            y = residual(Z[k], hx)
            if rows is None:
                x, P, inn = correct(x, P, y, Hm, r_sub, gate=gate, groups=groups,
                                    check=False)
                Y[k] = inn.y
                Sd[k] = inn.S.diagonal()
                accepted[k] = inn.accepted
            else:
                x, P, inn = correct(x, P, y[rows], Hm[rows], r_sub, gate=gate,
                                    groups=groups, check=False)
                Y[k, rows] = inn.y
                Sd[k, rows] = inn.S.diagonal()
                accepted[k, rows] = inn.accepted
            nis[k] = inn.nis
            dof[k] = inn.dof
        if step_bounds is not None:
            lo_k, up_k = step_bounds[0][k], step_bounds[1][k]
            if (x < lo_k).any() or (x > up_k).any():
                x, active = project_to_bounds(x, P, lo_k, up_k, step_bound_movable)
                bound_active[k] = active.any()
        if bounds is not None and (key or step_bounds is not None):
            xc = np.clip(x, lower, upper)
            clipped[k] = bool((xc != x).any())
            x = xc
        xs[k] = x
        Pd[k] = P.diagonal()
        if Ps is not None:
            Ps[k] = P
    return LoopArrays(x=xs, P_diag=Pd, P=Ps, y=Y, S_diag=Sd, accepted=accepted, nis=nis, dof=dof,
                      bound_active=bound_active, clipped=clipped)
