"""Window features and targets of the slip models (issue 10).

Windows come from :func:`features.windows.make_windows` (aligned clock, run provenance);
statistics from :mod:`features.calculators`. Per window:

* ``<channel>__mean`` / ``<channel>__std`` of :data:`SLIP_CHANNELS` (currents, rim speeds and
  their differences, accelerometer, gyro yaw rate);
* ``vel_mean__slope``: least-squares slope of the mean rim speed, m/s^2 (transients);
* ``pitch``: :func:`terrain.slip.physics.pitch_from_accelerometer` with that slope removed, rad;
* ``inv_chi``: :func:`features.calculators.regression_gain` of the gyro yaw rate on the wheel
  yaw rate ``(v_R - v_L)/B`` with the given vehicle's track B (the inverse ICR expansion,
  seed 000 eqs. 1-5);
* with terrain probabilities: one column per terrain (``p__<TERRAIN>``) and the physics slip
  under them (``phys_slip_l``, ``phys_slip_r``, ``phys_std``,
  :func:`terrain.slip.physics.physics_slip`).

Targets (simulated runs, ``truth`` stream): window means of ``slip_1``, ``slip_2``, the lateral
body velocity ``v_by`` and the
effective turning factor ``chi = mean(v_R - v_L) / (B mean(yaw_rate))`` (NaN when the robot
turns slower than :data:`MIN_TURN_RATE_RAD_S`; defined at it), which with the measured rim
speeds gives the true yaw rate ``(v_R - v_L) / (chi B)``.
"""

from __future__ import annotations

import warnings
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from features.calculators import mean, regression_gain, std
from features.windows import (WindowConfig, WindowSet, derived_track_m, make_windows,
                              refuse_non_finite)
from terrain.errors import (ConfigError, DataWarning, NonFiniteInputError, NonNumericError,
                            config_positive, duplicated, first_items, listed, real_arrays,
                            refuse_booleans)
from terrain.io.align import first_non_number, interpolated_mean_count
from terrain.run import TIME, Run, runs_by_id, step_index
from terrain.sim.sensors import SensorSettings
from terrain.slip.physics import (physics_slip, pitch_from_accelerometer,
                                  pitch_std_from_accelerometer)
from terrain.vehicles import HuskyParams, TrackedParams, body_rates

#: Channels whose window statistics feed the slip models.
SLIP_CHANNELS = ("cur_l", "cur_r", "vel_l", "vel_r", "vel_diff", "cur_diff",
                 "yaw_rate_wheels", "ax", "ay", "az", "wz")
#: Windows of the slip models: 2 s, hop 1 s, on the 50 Hz aligned clock.
SLIP_WINDOW = WindowConfig(window_s=2.0, hop_s=1.0)
#: Below this |yaw rate| (rad/s) a window's chi target is undefined; at it (to a relative
#: 1e-9, :data:`TURN_RATE_ROUNDING`) it is defined.
MIN_TURN_RATE_RAD_S = 0.1
#: Relative allowance of :data:`MIN_TURN_RATE_RAD_S` for the rounding of a window's mean
#: yaw rate, taken from the truth's running sum (a steady 0.1 rad/s turn averaged to
#: 0.09999999999999995 rad/s late in a 10 min run, which left chi undefined); the rounding
#: grows with the running sum, 3e-12 relative after 10 h at 100 Hz.
TURN_RATE_ROUNDING = 1e-9
#: Floor of the wheel yaw rate in the ``inv_chi`` regression, rad/s.
INV_CHI_FLOOR_RAD_S = 0.05
#: Columns of a simulated run's ``truth`` stream that :func:`slip_targets` reads.
TRUTH_COLUMNS = ("slip_1", "slip_2", "yaw_rate", "v_by", "terrain")


def slip_windows(runs: Sequence[Run], config: WindowConfig = SLIP_WINDOW) -> WindowSet:
    """Windows of :data:`SLIP_CHANNELS` of every run (runs without IMU or wheels skipped).

    Parameters
    ----------
    runs : sequence of Run
        Measured or simulated runs.
    config : WindowConfig
        Window length, hop and clock.

    Returns
    -------
    WindowSet
    """
    return make_windows(runs, SLIP_CHANNELS, config)


def slip_features(ws: WindowSet, vehicle, terrain_probabilities: pd.DataFrame | None = None,
                  current_rate_hz: float = SensorSettings.wheel_rate_hz) -> pd.DataFrame:
    """Feature table of the slip models (module docstring).

    Parameters
    ----------
    ws : WindowSet
        Windows of :data:`SLIP_CHANNELS` (:func:`slip_windows`).
    vehicle : HuskyParams or TrackedParams
        Skid-steer vehicle (track, physics slip).
    terrain_probabilities : pandas.DataFrame, shape (n_windows, n_terrains), optional
        Classifier probability of each catalogue terrain per window (columns = terrain
        names); None leaves the terrain and physics columns out.
    current_rate_hz : float
        Rate of independent current samples, Hz (the wheel stream's; default the simulated
        Husky's and BorealTC's 6.5 Hz, the rate the learned slip models are trained on;
        Vulpi's Husky logs 15 Hz), for the noise of the window-mean current.

    Returns
    -------
    pandas.DataFrame, shape (n_windows, n_features)

    Raises
    ------
    ConfigError
        ``vehicle`` is not a skid-steer vehicle's parameters, a channel of
        :data:`SLIP_CHANNELS` is missing, or the probabilities have the wrong
        number of rows, two columns of one name (as text: ``1`` and ``'1'``) or a column
        of booleans.
    DataFormatError
        ``ws.X`` holds booleans or does not convert to real numbers
        (:func:`slip_feature_matrix`).
    NonNumericError
        A probability that is not a number: text (``"1"`` too, which NumPy read as 1.0),
        bytes, a complex number, a boolean among numbers (a
        :class:`~terrain.errors.DataFormatError` naming the terrain's column and the row:
        :func:`terrain.io.align.first_non_number`, row 0 for a column whose dtype holds no
        real number).
    NonFiniteInputError
        ``ws.X`` holds NaN or inf, naming the channels and the first windows.
    """
    probs = None
    if terrain_probabilities is not None:
        if len(terrain_probabilities) != len(ws):
            raise ConfigError(f"{len(terrain_probabilities)} probability rows for {len(ws)} "
                              f"windows")
        _refuse_repeated_terrains("slip_features", terrain_probabilities.columns)
        # (read as float first, a mask of the terrain seen passed slip_feature_matrix's
        # boolean check as probabilities 0 and 1, and text failed in pandas naming nothing)
        columns = {str(k): terrain_probabilities[k] for k in terrain_probabilities.columns}
        named = {f"probability of {k}": v for k, v in columns.items()}
        # a mask first, as real_arrays judges it; then text, which NumPy parsed ("1" was
        # probability 1.0), and other values that are not numbers, named with their row
        refuse_booleans(ConfigError, "slip_features", **named)
        _refuse_non_numbers("slip_features", named)
        probs = dict(zip(columns, real_arrays("slip_features", ConfigError, **named)))
    names, values = slip_feature_matrix(ws.X, ws.channels, ws.rate_hz, vehicle, probs,
                                        current_rate_hz)
    return pd.DataFrame(values, columns=list(names))


def window_feature_vector(x: np.ndarray, channels: Sequence[str], rate_hz: float, vehicle,
                          terrain_probabilities: Mapping[str, float] | None = None,
                          current_rate_hz: float = SensorSettings.wheel_rate_hz) -> np.ndarray:
    """Features of ONE window, NumPy only (the streaming / closed-loop path).

    The same computation as :func:`slip_features` (both call :func:`slip_feature_matrix`), so
    the vector equals that table's row for the same window, without a ``WindowSet`` or a
    ``DataFrame``.

    Parameters
    ----------
    x : ndarray, shape (n_channels, n_samples)
        One window on the aligned clock (channels as in ``channels``; SI units of
        :data:`SLIP_CHANNELS`: A, m/s, rad/s, m/s^2).
    channels : sequence of str
        Channel names of the rows of ``x`` (must include :data:`SLIP_CHANNELS`).
    rate_hz : float
        Sample rate of ``x``, Hz.
    vehicle : HuskyParams or TrackedParams
        Skid-steer vehicle.
    terrain_probabilities : mapping of str to float, optional
        Probability of each catalogue terrain (the column order of the fitted model's
        ``p__*`` features); None leaves the terrain and physics features out.
    current_rate_hz : float
        Rate of independent current samples, Hz (the noise of a window's mean current is
        that of :func:`terrain.io.align.interpolated_mean_count` samples).

    Returns
    -------
    ndarray, shape (n_features,)
        In the column order of :func:`slip_features`.

    Raises
    ------
    ConfigError
        ``vehicle`` is not a skid-steer vehicle's parameters, ``x`` is not 2-D with one row
        per channel and at least 2 samples, a channel is missing or named twice,
        ``rate_hz`` is not a finite number > 0, or a terrain probability is a boolean or
        two terrains have one name as text (``1`` and ``'1'``).
    DataFormatError
        ``x`` holds booleans (a mask) or does not convert to real numbers (text), as
        :func:`slip_feature_matrix` judges the windows.
    NonNumericError
        A terrain probability that is not a number (text such as ``"1"``, bytes, a complex
        number), naming the terrain, as :func:`slip_features` judges a column.
    NonFiniteInputError
        ``x`` holds NaN or inf, naming the channel (:func:`slip_feature_matrix`).
    """
    x = np.asarray(x)     # (as float, a mask was samples of 0 and 1: the batch judges it)
    if x.ndim != 2 or x.shape[0] != len(channels):
        raise ConfigError(f"one window must have shape ({len(channels)}, n_samples), "
                          f"got {x.shape}")
    if terrain_probabilities is not None:     # (True was read as probability 1)
        _refuse_repeated_terrains("window_feature_vector", terrain_probabilities)
        named = {f"probability of {k}": v for k, v in terrain_probabilities.items()}
        refuse_booleans(ConfigError, "window_feature_vector", **named)
        _refuse_non_numbers("window_feature_vector", {   # ("1" was read as 1.0)
            name: pd.Series([v], dtype=object) for name, v in named.items()}, rows=False)
    probs = (None if terrain_probabilities is None else
             {str(k): np.asarray([v], dtype=float) for k, v in terrain_probabilities.items()})
    return slip_feature_matrix(x[None], channels, rate_hz, vehicle, probs,
                               current_rate_hz)[1][0]


def slip_feature_matrix(x: np.ndarray, channels: Sequence[str], rate_hz: float, vehicle,
                        probabilities: Mapping[str, np.ndarray] | None = None,
                        current_rate_hz: float = SensorSettings.wheel_rate_hz
                        ) -> tuple[tuple[str, ...], np.ndarray]:
    """Feature names and values of windows (the core of :func:`slip_features`).

    Parameters
    ----------
    x : ndarray, shape (n_windows, n_channels, n_samples)
        Windows (``WindowSet.X``).
    channels : sequence of str
        Channel names of axis 1.
    rate_hz : float
        Sample rate, Hz.
    vehicle : HuskyParams or TrackedParams
        Skid-steer vehicle.
    probabilities : mapping of str to ndarray, shape (n_windows,), optional
        Probability of each terrain per window; None leaves the terrain and physics columns
        out.
    current_rate_hz : float
        Rate of independent current samples, Hz (the noise of a window's mean current is
        that of :func:`terrain.io.align.interpolated_mean_count` samples).

    Returns
    -------
    names : tuple of str
        Column names (module docstring).
    values : ndarray, shape (n_windows, n_features)

    Raises
    ------
    ConfigError
        ``vehicle`` is not a skid-steer vehicle's parameters, a channel of
        :data:`SLIP_CHANNELS` is missing, a channel is named twice, ``x`` is
        not 3-D with one row per channel and at least 2 samples, ``rate_hz`` is not a
        finite number > 0, or a terrain probability holds booleans.
    DataFormatError
        ``x`` holds booleans (a mask) or does not convert to real numbers (text).
    NonFiniteInputError
        ``x`` holds NaN or inf (a ValueError naming each channel holding one and the first
        windows).
    """
    if not isinstance(vehicle, (HuskyParams, TrackedParams)):
        # (the AgriMaRo's parameters, None or a bare track width: a bare AttributeError on
        # vehicle.track_m)
        raise ConfigError(f"slip features need a skid-steer vehicle (HuskyParams, "
                          f"TrackedParams), whose left and right sides the features read; got "
                          f"{type(vehicle).__name__}")
    missing = [c for c in SLIP_CHANNELS if c not in channels]
    if missing:
        raise ConfigError(f"slip features need channels {missing}")
    twice = duplicated(channels)
    if twice:      # (the channels are read by position: the last of the two was read)
        raise ConfigError(f"slip features: channels {twice} named twice")
    x = np.asarray(x)     # (nested lists failed on x.ndim)
    if x.ndim != 3 or x.shape[1] != len(channels):     # channels are read by position
        raise ConfigError(f"windows must have shape (n_windows, {len(channels)}, n_samples), "
                          f"got {x.shape}")
    # as the statistics read them (text was read by them, then failed in the slope's NumPy
    # product naming nothing; a mask passed the one-window path as samples of 0 and 1)
    x, = real_arrays("slip features", x=x)
    if x.shape[2] < 2:      # (0/0 gave a NaN slope and pitch with a RuntimeWarning)
        raise ConfigError(f"windows must hold n_samples >= 2 for the speed slope, got "
                          f"{x.shape}")
    # (a negative rate flipped the sign of the slope and of the pitch correction)
    config_positive("slip_feature_matrix", rate_hz=rate_hz)
    # a NaN or inf sample made its channel's mean and std NaN, and the slope, pitch, inv_chi
    # and physics slip read from it, without a word (make_windows keeps finite windows only)
    refuse_non_finite(x, channels, NonFiniteInputError, "slip features")
    ch = {c: i for i, c in enumerate(channels)}
    cols: dict[str, np.ndarray] = {}
    means, stds = mean(x), std(x)
    for c in SLIP_CHANNELS:
        cols[f"{c}__mean"] = means[:, ch[c]]
        cols[f"{c}__std"] = stds[:, ch[c]]
    n_s = x.shape[-1]
    tc = (np.arange(n_s) - 0.5 * (n_s - 1)) / rate_hz
    # mean rim speed and the wheel yaw rate (v_R - v_L) / B of the vehicle given (the windows
    # may come from another's runs): the skid-steer kinematics' one home, ideal drive chi = 1
    v_mean, wheel_yaw_rate = body_rates(x[:, ch["vel_l"]], x[:, ch["vel_r"]],
                                        vehicle.track_m, 1.0)
    slope = (v_mean * tc).sum(axis=-1) / (tc ** 2).sum()
    cols["vel_mean__slope"] = slope
    pitch = pitch_from_accelerometer(cols["ax__mean"], cols["ay__mean"], cols["az__mean"], slope)
    cols["pitch"] = pitch
    cols["inv_chi"] = regression_gain(x[:, ch["wz"]], wheel_yaw_rate, INV_CHI_FLOOR_RAD_S)
    if probabilities is not None:
        # (a boolean mask of the terrain seen was read as probabilities 0 and 1)
        refuse_booleans(ConfigError, "slip features", **{
            f"probability of {k}": p for k, p in probabilities.items()})
        for k, p in probabilities.items():
            cols[f"p__{k}"] = p
        cur = np.column_stack([cols["cur_l__mean"], cols["cur_r__mean"]])
        rim = np.column_stack([cols["vel_l__mean"], cols["vel_r__mean"]])
        r_w = vehicle.contact_geometry().wheel_radius_m
        wheel_acc = np.column_stack([slope, slope]) / r_w
        # noise of the window-mean current: the current stream is interpolated
        n_cur = interpolated_mean_count(n_s, rate_hz, current_rate_hz)
        spread = np.column_stack([cols["cur_l__std"], cols["cur_r__std"]])
        phys = physics_slip(vehicle, dict(probabilities), cur, rim, pitch, wheel_acc,
                            n_averaged=n_cur, current_within_std_a=spread,
                            pitch_std_rad=pitch_std_from_accelerometer(x[:, ch["ax"]]))
        cols["phys_slip_l"] = phys.slip[:, 0]
        cols["phys_slip_r"] = phys.slip[:, 1]
        cols["phys_std"] = phys.std.mean(axis=1)
    values = np.empty((x.shape[0], len(cols)))
    for j, v in enumerate(cols.values()):
        values[:, j] = v
    return tuple(cols), values


def _refuse_non_numbers(owner: str, named: Mapping[str, pd.Series], rows: bool = True
                        ) -> None:
    """Refuse terrain probabilities that are not numbers (text, even text that spells one,
    bytes, a complex number, a date, a boolean among numbers) by the one rule of cells that
    must be numbers, :func:`terrain.io.align.first_non_number`: a
    :class:`~terrain.errors.NonNumericError` naming the terrain and (``rows``) the row."""
    for name, cells in named.items():
        row = first_non_number(cells)
        if row is not None:
            value = cells.iloc[row]
            raise NonNumericError(f"{owner}: {name} holds a value that is not a number "
                                  f"({type(value).__name__} {value!r:.40}): a terrain "
                                  "probability is a number in [0, 1]",
                                  column=name, row=row if rows else None)


def _refuse_repeated_terrains(owner: str, names) -> None:
    """Refuse terrain probability names that occur twice as ``p__<name>`` (as text): the
    columns were merged without a word, the last kept (1 and '1' alike), or split into a
    shape error naming neither."""
    twice = duplicated(str(k) for k in names)
    if twice:
        raise ConfigError(f"{owner}: terrain(s) {listed(twice)} given twice among the terrain "
                          "probabilities (one p__<terrain> column each)")


def one_hot_probabilities(labels: Sequence[str], terrains: Sequence[str]) -> pd.DataFrame:
    """Terrain probabilities of a perfect classifier (1 for the label, 0 elsewhere).

    Parameters
    ----------
    labels : sequence of str, length n
        True terrain of each window.
    terrains : sequence of str
        Column order (catalogue names).

    Returns
    -------
    pandas.DataFrame, shape (n, len(terrains))

    Raises
    ------
    ConfigError
        ``labels`` is one text (not a sequence of labels), a terrain is named twice in
        ``terrains`` (one column each), or a label is not among ``terrains`` (its row
        would hold no probability, refused later by the physics slip as "sum to 0" naming
        neither label nor window).
    """
    if isinstance(labels, str):
        raise ConfigError(f"one_hot_probabilities needs a sequence of labels, got the text "
                          f"{labels!r}")
    _refuse_repeated_terrains("one_hot_probabilities", terrains)
    lab = np.asarray(labels, dtype=object)
    outside = ~np.isin(lab, np.asarray(list(terrains), dtype=object))
    if outside.any():
        raise ConfigError(f"one_hot_probabilities: label(s) {listed(pd.unique(lab[outside]))} "
                          f"of {first_items(np.flatnonzero(outside), word='window')} not "
                          f"among the terrains {listed(terrains)}")
    return pd.DataFrame({t: (lab == t).astype(float) for t in terrains})


def _window_means(t: np.ndarray, values: np.ndarray, t0: np.ndarray, t1: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # the mean of the samples in [t0, t1) of each column, and the window's samples a:b (its
    # first and one past its last); NaN where the window holds none,
    # or holds a NaN or inf (counted apart: in the running sum one made every later window
    # NaN). A sample on an edge (within the clock's rounding, the placement rule step_index)
    # is the window's it starts: by raw float comparison the 100 Hz truth sample k * 0.01
    # on a 1.7 s window's end fell inside it in 6 % of the windows
    a = step_index(t, t0)
    b = step_index(t, t1)
    missing = ~np.isfinite(values)
    zero = np.zeros((1, values.shape[1]))
    csum = np.vstack([zero, np.cumsum(np.where(missing, 0.0, values), axis=0)])
    cnan = np.vstack([zero, np.cumsum(missing, axis=0)])
    n = np.maximum(b - a, 1)[:, None]
    out = (csum[b] - csum[a]) / n
    out[b <= a] = np.nan
    out[(cnan[b] - cnan[a]) > 0] = np.nan
    return out, a, b


def slip_targets(runs: Sequence[Run], ws: WindowSet, track_m: float | None = None
                 ) -> pd.DataFrame:
    """True per-window ``slip_1``, ``slip_2``, ``chi`` and terrain from the ``truth`` streams.

    Parameters
    ----------
    runs : sequence of Run
        The simulated runs the windows were cut from (each with a ``truth`` stream).
    ws : WindowSet
        Their windows.
    track_m : float or None
        Track width B of ``chi``, m; None (default): each run's own vehicle's,
        :func:`features.windows.derived_track_m` of ``run.vehicle``, the track the windows'
        derived wheel channels were made with (the Husky's made a tracked run's ``chi``
        0.5708 / 0.393 times its own).

    Returns
    -------
    pandas.DataFrame, shape (n_windows, 6)
        ``slip_1, slip_2, chi, v_by`` (lateral body velocity, m/s), ``yaw_rate`` (rad/s),
        ``terrain``; each a mean of the truth samples in ``[t_start_s, t_end_s)`` (a sample
        within rounding of an edge on it, :func:`terrain.run.step_index`); a mean is NaN
        where its window holds no truth sample or a NaN or inf one (that window only), and
        ``chi`` where the window's mean ``|yaw_rate|`` is below :data:`MIN_TURN_RATE_RAD_S`
        (a turn at exactly that rate has one). ``terrain``: that of the window's truth
        sample at (or first after) its middle, else of its last one before it (the window
        half in a gap of the truth); missing (None) where the window holds no truth sample
        (before the truth's start, past its end, in a gap of it), as its targets are NaN.

    Raises
    ------
    ConfigError
        A run of the window set is not among ``runs`` or has no ``truth`` stream, two of
        ``runs`` share an id, the windows lack ``vel_l`` or ``vel_r``, or
        ``track_m`` is not a finite number > 0 (0 made ``chi`` infinite or NaN, a negative
        track made it negative).
    MissingColumnError
        A ``truth`` stream lacks ``t_s`` or one of :data:`TRUTH_COLUMNS`, naming the run,
        the stream and the column.

    Warns
    -----
    DataWarning
        Windows holding no truth sample: their count, the first few and their runs (past
        the truth's end they were labelled with its last terrain, without a word).
    """
    out, unmeasured = _slip_targets(runs, ws, track_m)
    if unmeasured.any():    # no target and no terrain: said, not left to be found out
        warnings.warn(f"slip_targets: {_unmeasured(ws, unmeasured)}; their targets are NaN "
                      "and their terrain missing (None)", DataWarning, stacklevel=2)
    return out


def _unmeasured(ws: WindowSet, unmeasured: np.ndarray) -> str:
    """What a warning says of the windows holding no truth sample (their count, the first
    few, their runs)."""
    windows = np.flatnonzero(unmeasured)
    return (f"{windows.size} of {len(ws)} windows hold no truth sample "
            f"({first_items(windows.tolist(), limit=5, word='window')}; run(s) "
            f"{listed(pd.unique(ws.run_ids[unmeasured]))}): before the truth's start, past "
            "its end or in a gap of it")


def _slip_targets(runs: Sequence[Run], ws: WindowSet, track_m: float | None
                  ) -> tuple[pd.DataFrame, np.ndarray]:
    """:func:`slip_targets` and the ``(n_windows,)`` mask of the windows holding no truth
    sample (their terrain missing), without the warning."""
    if track_m is not None:
        config_positive("slip_targets", track_m=track_m)
    by_id: Mapping[str, Run] = runs_by_id(runs, "slip_targets")
    speeds = [c for c in ("vel_l", "vel_r") if c not in ws.channels]
    if speeds:      # (chi reads them: a bare KeyError after the truth was read)
        raise ConfigError(f"slip_targets: the windows lack channel(s) {listed(speeds)}, "
                          f"which chi reads; they hold {listed(list(ws.channels))}")
    out = pd.DataFrame(index=np.arange(len(ws)),
                       columns=["slip_1", "slip_2", "chi", "v_by", "yaw_rate", "terrain"],
                       dtype=object)
    tracks = np.full(len(ws), np.nan if track_m is None else float(track_m))
    unmeasured = np.zeros(len(ws), dtype=bool)
    for rid in pd.unique(ws.run_ids):
        run = by_id.get(rid)
        if run is None:     # (a bare KeyError before)
            raise ConfigError(f"slip_targets: the windows' run {rid!r} is not among the "
                              f"{len(by_id)} run(s) given")
        if "truth" not in run.streams:
            raise ConfigError(f"run {rid} has no truth stream (slip targets need simulated runs)")
        # (a column missing was pandas' bare KeyError naming neither run nor stream)
        tr = run.require_columns("truth", TRUTH_COLUMNS)
        sel = np.flatnonzero(ws.run_ids == rid)
        t = tr[TIME].to_numpy()
        m, a, b = _window_means(t, tr[["slip_1", "slip_2", "yaw_rate", "v_by"]].to_numpy(
            float), ws.t_start_s[sel], ws.t_end_s[sel])
        # the terrain of the window's own truth sample at (or first after) its middle; none
        # where it holds no sample (past the truth's end it was the last truth's terrain)
        held = b > a
        mid = np.clip(np.searchsorted(t, 0.5 * (ws.t_start_s[sel] + ws.t_end_s[sel])), a,
                      b - 1)
        terrain = np.full(len(sel), None, dtype=object)
        terrain[held] = tr["terrain"].to_numpy()[mid[held]]
        unmeasured[sel] = ~held
        out.loc[sel, "slip_1"] = m[:, 0]
        out.loc[sel, "slip_2"] = m[:, 1]
        out.loc[sel, "yaw_rate"] = m[:, 2]
        out.loc[sel, "v_by"] = m[:, 3]
        out.loc[sel, "terrain"] = terrain
        if track_m is None:
            tracks[sel] = derived_track_m(run.vehicle)
    ch = {c: i for i, c in enumerate(ws.channels)}
    dv = (ws.X[:, ch["vel_r"]] - ws.X[:, ch["vel_l"]]).mean(axis=-1)
    yaw = out["yaw_rate"].to_numpy(float)
    turning = np.abs(yaw) >= MIN_TURN_RATE_RAD_S * (1.0 - TURN_RATE_ROUNDING)
    out["chi"] = np.where(turning, dv / (tracks * np.where(turning, yaw, 1.0)), np.nan)
    for c in ("slip_1", "slip_2", "yaw_rate", "chi", "v_by"):
        out[c] = out[c].astype(float)
    return out, unmeasured


def terrain_columns(columns: Sequence[str]) -> list[str]:
    """Columns of a feature table that carry terrain knowledge (``p__*``, ``phys_*``).

    Parameters
    ----------
    columns : sequence of str
        Feature table columns.

    Returns
    -------
    list of str
        The columns starting ``p__`` or ``phys_``, in their order.

    Raises
    ------
    ConfigError
        ``columns`` one text (its letters were read as columns: ``"p__ICE"`` had none) or
        not a sequence, or a column that is not text (a bare AttributeError).
    """
    if isinstance(columns, str) or not hasattr(columns, "__iter__"):
        raise ConfigError(f"terrain_columns: columns must be a sequence of column names, got "
                          f"{columns!r:.60}")
    columns = list(columns)
    odd = [c for c in columns if not isinstance(c, str)]
    if odd:
        raise ConfigError(f"terrain_columns: column names are text, got {odd[0]!r}")
    return [c for c in columns if c.startswith(("p__", "phys_"))]


def slip_table(runs: Sequence[Run], vehicle, terrains: Sequence[str],
               config: WindowConfig = SLIP_WINDOW
               ) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Features (perfect-classifier terrain probabilities), targets and provenance of windows.

    Parameters
    ----------
    runs : sequence of Run
        Simulated runs with ``truth`` (``meta["scenario"]``, ``meta["seed"]``), each read
        once (an iterator of runs gives the tables of the same runs in a list).
    vehicle : HuskyParams or TrackedParams
        Skid-steer vehicle.
    terrains : sequence of str
        Terrain probability columns (catalogue names).
    config : WindowConfig
        Windows.

    Returns
    -------
    X : pandas.DataFrame, shape (n, n_features)
        :func:`slip_features` with one-hot terrain probabilities.
    Y : pandas.DataFrame, shape (n, 6)
        :func:`slip_targets`.
    meta : pandas.DataFrame, shape (n, 6)
        ``run_id, terrain, scenario, seed, t_start_s, t_end_s``.

    Warns
    -----
    DataWarning
        Windows holding no truth sample (:func:`slip_targets`: no target, no terrain) are
        left out of the three tables: their count, the first few and their runs.
    """
    runs = list(runs)   # (an iterator was read to its end by the windowing)
    ws = slip_windows(runs, config)
    Y, unmeasured = _slip_targets(runs, ws, vehicle.track_m)
    if unmeasured.any():    # no target to learn or score, nor a terrain to give
        warnings.warn(f"slip_table: {_unmeasured(ws, unmeasured)}; left out of X, Y and meta "
                      "(no target to learn or score)", DataWarning, stacklevel=2)
        ws = ws.subset(~unmeasured)
        Y = Y[~unmeasured].reset_index(drop=True)
    X = slip_features(ws, vehicle, one_hot_probabilities(Y["terrain"], terrains))
    info = {r.run_id: (r.meta.get("scenario", ""), int(r.meta.get("seed", -1))) for r in runs}
    meta = pd.DataFrame({"run_id": ws.run_ids.astype(str), "terrain": Y["terrain"].astype(str),
                         "scenario": [info[r][0] for r in ws.run_ids],
                         "seed": [info[r][1] for r in ws.run_ids],
                         "t_start_s": ws.t_start_s, "t_end_s": ws.t_end_s})
    return X, Y, meta
