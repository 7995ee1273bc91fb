"""One run prepared for the audit: replay predictions and measurements on the wheel clock.

Every comparison is made at the wheel-stream timestamps (the replay's inputs are sampled
there). IMU channels are low-passed with the replay's filter (:func:`~terrain.audit.replay.lowpass`)
and read at ``t - lag(t)``, the run's own clock offset (:mod:`terrain.audit.timing`, against
the commanded yaw rate or the replayed one, whichever explains the gyro better), because a
timestamp offset is a property of the recording, not of the model: it is estimated per run
from timing alone (scale- and offset-free) and reported as the ``wheel_lag`` effect.

Manoeuvre of each sample, from the measured wheel speeds (``x = (v_R - v_L) / B``,
``v = (v_L + v_R) / 2``):

=========  =================================================================
``stop``   both sides slower than ``moving_m_s``
``straight`` moving, ``|x| < turn_rad_s``
``curve``  moving, ``|x| >= turn_rad_s``, ``|v| >= |x| B / 2`` (ICR outside the track)
``spin``   moving, ``|x| >= turn_rad_s``, ``|v| < |x| B / 2`` (sides turn opposite ways,
           ICR between the wheels: spinning in place)
=========  =================================================================

Pitch (for ``grade_resistance``) is estimated from the accelerometer:
``pitch = asin((ax - ax_pred) / g)`` with both low-passed at ``pitch_cutoff_hz`` (seed
``003`` eq. 10 writes grade resistance with the pitch angle; a level IMU reads
``g sin(pitch)`` on x when the vehicle is pitched nose-up). Both low-passes mirror the series
at its ends, and the replay's ``ax_pred`` is low-passed within the scored span only (``edge_s``
from either end, held outside): the replay starts from rest, and its first samples (up to
7 m/s^2 on shipped runs) would otherwise lean on the slow trend for several seconds.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from terrain.audit.replay import (LOWPASS_MIN_SAMPLES, Replay, ReplaySettings, lowpass,
                                  require_ordered)
from terrain.audit.timing import LagSettings, LagTrack, estimate_lag_track
from terrain.errors import ConfigError, DataWarning, config_positive, is_integer
from terrain.run import TIME, Run
from terrain.terramechanics.resistance import G_M_S2
from terrain.vehicles import skid_steer_forward

MANOEUVRES = ("stop", "straight", "curve", "spin")
STOP, STRAIGHT, CURVE, SPIN = range(4)
#: Fewest IMU samples :func:`prepare_frame` uses; a run with a shorter IMU stream is audited
#: as one without IMU (with a :class:`~terrain.errors.DataWarning`). What the code needs:
#: the IMU channels are low-passed (:func:`~terrain.audit.replay.lowpass`), which returns a
#: series no longer than its end padding (15 samples) unfiltered, and then the comparisons
#: would mix bandwidths. The lag estimation sets no count of its own: a record too short
#: to span a window and the lag search range gives no identifiable lag (lag 0, listed as
#: such), and IMU samples within ``edge_s`` of the record's ends are not scored.
MIN_IMU_SAMPLES = LOWPASS_MIN_SAMPLES


@dataclass(frozen=True)
class FrameSettings:
    """How measured runs are put on the comparison clock.

    Parameters
    ----------
    imu_cutoff_hz : float
        Low-pass of the IMU channels, Hz (should equal ``ReplaySettings.output_cutoff_hz``).
    pitch_cutoff_hz : float
        Low-pass used for the pitch estimate, Hz.
    edge_s : float
        Samples closer than this to either end of the overlap of both streams are not scored
        (room for any lag in the search range and for the replay's start-up transient), s.
    moving_m_s : float
        Wheel speed below which a side is at rest, m/s.
    turn_rad_s : float
        Commanded yaw rate ``|x|`` from which a sample is a turn, rad/s.
    quiet_rad_s, quiet_margin_s : float
        A sample is *quiet* (used to estimate a gyro bias) when ``|x| < quiet_rad_s`` and no
        turning sample lies within ``quiet_margin_s``.
    """

    imu_cutoff_hz: float = 2.0
    pitch_cutoff_hz: float = 0.1
    edge_s: float = 2.0
    moving_m_s: float = 0.05
    turn_rad_s: float = 0.1
    quiet_rad_s: float = 0.05
    quiet_margin_s: float = 1.5

    def __post_init__(self) -> None:
        """Refuse a setting that is not a finite number in range (NaN passed before).

        Raises
        ------
        ConfigError
            A cut-off frequency or a rate threshold not finite and > 0, or ``edge_s``,
            ``moving_m_s`` or ``quiet_margin_s`` not finite and >= 0.
        """
        config_positive("FrameSettings", imu_cutoff_hz=self.imu_cutoff_hz,
                        pitch_cutoff_hz=self.pitch_cutoff_hz, turn_rad_s=self.turn_rad_s,
                        quiet_rad_s=self.quiet_rad_s)
        config_positive("FrameSettings", allow_zero=True, edge_s=self.edge_s,
                        moving_m_s=self.moving_m_s, quiet_margin_s=self.quiet_margin_s)


def check_same_bandwidth(replay: ReplaySettings, frames: FrameSettings, owner: str) -> None:
    """Refuse a replay low-passed at another cut-off than the IMU it is compared with.

    Parameters
    ----------
    replay : ReplaySettings
        Its ``output_cutoff_hz``, Hz.
    frames : FrameSettings
        Its ``imu_cutoff_hz``, Hz.
    owner : str
        Who checks (named in the message).

    Raises
    ------
    ConfigError
        The two cut-offs differ (a replay at 0.5 Hz against a gyro at 2 Hz puts the gyro's
        0.5-2 Hz band in the replay's yaw-rate error).
    """
    if float(replay.output_cutoff_hz) != float(frames.imu_cutoff_hz):
        raise ConfigError(
            f"{owner}: replay.output_cutoff_hz ({replay.output_cutoff_hz:g} Hz) and "
            f"frames.imu_cutoff_hz ({frames.imu_cutoff_hz:g} Hz) must be equal: predictions "
            "and IMU are compared at the same bandwidth")


@dataclass(frozen=True)
class AuditFrame:
    """One run (or one contiguous segment of a run) on the comparison clock.

    All arrays have shape (n,) unless stated; times in s, rates in rad/s, accelerations in
    m/s^2, currents in A.

    Attributes
    ----------
    run_id : str
        Run the samples come from.
    group : str
        Cross-validation unit: the run id, or ``<run_id>#<k>`` for a segment.
    terrain : str
    t_s : wheel timestamps.
    commanded_yaw_rate : yaw rate the measured wheel speeds command, ``(v_R - v_L) / B``
        (ideal differential drive, seed 000 eq. 2), rad/s.
    commanded_speed : speed the measured wheel speeds command, ``(v_L + v_R) / 2``, m/s.
    manoeuvre : int codes into :data:`MANOEUVRES`.
    quiet : bool, samples far from any turn (gyro-bias estimation).
    sim_wz, sim_ax, sim_ay, sim_vx : replay predictions (yaw rate, accelerations, speed).
    sim_cur : shape (n, 2), replay currents (left, right).
    cur : shape (n, 2), measured currents (left, right).
    has_imu : bool
    wz, ax, ay : measured IMU channels read at ``t - lag(t)`` (NaN without IMU).
    pitch : estimated pitch, rad (0 where :attr:`has_pitch` is False: a placeholder, not
        level ground).
    has_pitch : bool, samples with a pitch estimate: read at ``t - lag(t)`` within the IMU
        record (none without IMU); outside it the filtered accelerometer would be its end
        value held.
    imu_t_s, imu_wz : shape (m,), the low-passed gyro on its own clock (for constant-lag
        evaluation of ``wheel_lag``); empty without IMU.
    score_imu, score_cur : bool masks of the samples scored for IMU and current signals.
    lag : LagTrack
    imu_raw : shape (m, 3), the IMU's ``wz, ax, ay`` as measured (not low-passed) on
        ``imu_t_s``: what :func:`split_frame` aligns each segment from; empty for a frame
        built without it (then a segment keeps the run's aligned channels).
    imu_rate_hz : float, the IMU's own rate (median step), Hz (0 without ``imu_raw``).
    imu_gaps : tuple of (start, stop) IMU gaps, s (``run.meta["gaps"]["imu"]``).
    """

    run_id: str
    group: str
    terrain: str
    t_s: np.ndarray
    commanded_yaw_rate: np.ndarray
    commanded_speed: np.ndarray
    manoeuvre: np.ndarray
    quiet: np.ndarray
    sim_wz: np.ndarray
    sim_ax: np.ndarray
    sim_ay: np.ndarray
    sim_vx: np.ndarray
    sim_cur: np.ndarray
    cur: np.ndarray
    has_imu: bool
    wz: np.ndarray
    ax: np.ndarray
    ay: np.ndarray
    pitch: np.ndarray
    has_pitch: np.ndarray
    imu_t_s: np.ndarray
    imu_wz: np.ndarray
    score_imu: np.ndarray
    score_cur: np.ndarray
    lag: LagTrack
    imu_raw: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))
    imu_rate_hz: float = 0.0
    imu_gaps: tuple = ()

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.t_s)

    def wz_at_lag(self, lag_s: float) -> np.ndarray:
        """Gyro yaw rate read with a constant lag instead of the run's own lag track.

        Parameters
        ----------
        lag_s : float
            Constant lag of the wheel stream, s (positive = wheel data late).

        Returns
        -------
        ndarray, shape (n,)
            Low-passed gyro yaw rate at ``t_s - lag_s``, rad/s (NaN without IMU).
        """
        if not self.has_imu:
            return np.full(self.n, np.nan)
        return np.interp(self.t_s - lag_s, self.imu_t_s, self.imu_wz)


def classify_manoeuvres(x: np.ndarray, v: np.ndarray, vel_l: np.ndarray, vel_r: np.ndarray,
                        track_m: float, settings: FrameSettings = FrameSettings()) -> np.ndarray:
    """Manoeuvre code of each sample (module docstring).

    Parameters
    ----------
    x, v, vel_l, vel_r : ndarray, shape (n,)
        Commanded yaw rate (rad/s), speed and side speeds (m/s).
    track_m : float
        Track width B, m.
    settings : FrameSettings
        ``moving_m_s`` and ``turn_rad_s`` thresholds.

    Returns
    -------
    ndarray of int, shape (n,)
        Codes into :data:`MANOEUVRES`.
    """
    moving = np.maximum(np.abs(vel_l), np.abs(vel_r)) >= settings.moving_m_s
    turning = np.abs(x) >= settings.turn_rad_s
    spin = np.abs(v) < 0.5 * np.abs(x) * track_m
    out = np.full(len(x), STOP, dtype=np.int8)
    out[moving & ~turning] = STRAIGHT
    out[moving & turning & ~spin] = CURVE
    out[moving & turning & spin] = SPIN
    return out


def _quiet(t: np.ndarray, x: np.ndarray, settings: FrameSettings) -> np.ndarray:
    turning_t = t[np.abs(x) >= settings.turn_rad_s]
    quiet = np.abs(x) < settings.quiet_rad_s
    m = turning_t.size
    if m:
        idx = np.searchsorted(turning_t, t)
        left = np.where(idx > 0, t - turning_t[np.maximum(idx - 1, 0)], np.inf)
        right = np.where(idx < m, turning_t[np.minimum(idx, m - 1)] - t, np.inf)
        quiet &= np.minimum(np.abs(left), np.abs(right)) > settings.quiet_margin_s
    return quiet


def _slow_within_edges(t: np.ndarray, values: np.ndarray, inner: np.ndarray,
                       settings: FrameSettings) -> np.ndarray:
    """Low-pass at ``pitch_cutoff_hz`` of the samples of ``inner``, held at the filtered end
    values outside (the whole series when ``inner`` holds fewer than 2 samples).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times, s.
    values : ndarray, shape (n,)
    inner : ndarray of bool, shape (n,)
        The samples at least ``edge_s`` from either end (the scored span of
        :func:`prepare_frame`).
    settings : FrameSettings

    Returns
    -------
    ndarray, shape (n,)
    """
    rate = 1.0 / max(float(np.median(np.diff(t))), 1e-3)
    if inner.sum() < 2:
        inner = np.ones(len(t), dtype=bool)
    slow = lowpass(values[inner], rate, settings.pitch_cutoff_hz, padtype="even")
    return np.interp(t, t[inner], slow)


def _in_gaps(t: np.ndarray, gaps) -> np.ndarray:
    bad = np.zeros(len(t), dtype=bool)
    for g in gaps or []:
        bad |= (t > float(g[0])) & (t < float(g[1]))
    return bad


def scored_span(t: np.ndarray, settings: FrameSettings) -> np.ndarray:
    """The samples the audit scores: at least ``edge_s`` from either end of the record
    (the replay's start and the zero-phase filters' edges are not scored).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times of one record, s, increasing.
    settings : FrameSettings
        Its ``edge_s`` is used.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    return (t >= t[0] + settings.edge_s) & (t <= t[-1] - settings.edge_s)


def prepare_frame(run: Run, replay: Replay, settings: FrameSettings = FrameSettings(),
                  lag_settings: LagSettings = LagSettings()) -> AuditFrame:
    """Put one run and its replay on the comparison clock.

    Parameters
    ----------
    run : Run
        The measured run (``wheels`` stream required, ``imu`` optional).
    replay : Replay
        Its replay (:func:`~terrain.audit.replay.replay_run`).
    settings : FrameSettings
        Filters, scored edges, manoeuvre thresholds.
    lag_settings : LagSettings
        Window-by-window lag estimation (:func:`~terrain.audit.timing.estimate_lag_track`).

    Returns
    -------
    AuditFrame

    Raises
    ------
    MissingColumnError
        The ``imu`` stream lacks ``wz``, ``ax`` or ``ay`` (a
        :class:`~terrain.errors.DataFormatError`).
    NonFiniteError
        One of those or its ``t_s`` holds a NaN or infinite value (a
        :class:`~terrain.errors.DataFormatError` naming the run, column and first row).
    TimestampError
        The IMU's times do not strictly increase
        (:func:`~terrain.audit.replay.require_ordered`).

    Warns
    -----
    DataWarning
        The run has an IMU stream of fewer than :data:`MIN_IMU_SAMPLES` samples: it is
        audited as a run without IMU.
    """
    wheels = run.streams["wheels"]
    t = replay.t_s
    v, x = skid_steer_forward(replay.vel_l, replay.vel_r, replay.track_m)  # seed 000 eq. 2
    cur = wheels[["cur_l", "cur_r"]].to_numpy(dtype=float)
    gaps = dict(run.meta.get("gaps", {}) or {})
    score = scored_span(t, settings)
    score_cur = score & ~_in_gaps(t, gaps.get("wheels"))
    imu = run.streams.get("imu")
    if imu is not None:
        run.require_columns("imu", ("wz", "ax", "ay"))
        run.require_finite("imu", ("wz", "ax", "ay"))
        require_ordered(run, "imu")
    if imu is not None and len(imu) < MIN_IMU_SAMPLES:
        warnings.warn(f"{run.run_id}: IMU stream of {len(imu)} samples ignored (fewer than "
                      f"{MIN_IMU_SAMPLES}, too short to low-pass): audited as a run without "
                      "IMU", DataWarning, stacklevel=2)
        imu = None
    raw, rate, imu_gaps = np.empty((0, 3)), 0.0, tuple(gaps.get("imu") or ())
    ti = np.empty(0)
    if imu is not None:
        ti = imu[TIME].to_numpy(dtype=float)
        rate = run.rate_hz("imu")   # the run's own rate (median step)
        raw = imu[["wz", "ax", "ay"]].to_numpy(dtype=float)
    ch = _align_imu(t, x, replay.yaw_rate,
                    lambda: _slow_within_edges(t, replay.ax, score, settings), score_cur,
                    ti, raw, rate, imu_gaps, settings, lag_settings)
    return AuditFrame(
        run_id=run.run_id, group=run.run_id, terrain=replay.terrain, t_s=t,
        commanded_yaw_rate=x, commanded_speed=v,
        manoeuvre=classify_manoeuvres(x, v, replay.vel_l, replay.vel_r, replay.track_m,
                                      settings),
        quiet=_quiet(t, x, settings), sim_wz=replay.yaw_rate, sim_ax=replay.ax,
        sim_ay=replay.ay, sim_vx=replay.v_x, sim_cur=replay.cur, cur=cur, score_cur=score_cur,
        imu_raw=raw, imu_rate_hz=rate, imu_gaps=imu_gaps, **ch)


def _align_imu(t: np.ndarray, x: np.ndarray, sim_wz: np.ndarray,
               sim_ax_slow: Callable[[], np.ndarray], score: np.ndarray, ti: np.ndarray,
               raw: np.ndarray, rate: float, imu_gaps, settings: FrameSettings,
               lag_settings: LagSettings) -> dict:
    """The IMU channels of one record (a run or a segment) on its wheel clock.

    The measured ``wz, ax, ay`` (``raw``, on ``ti``) are low-passed over this record only,
    its lag track is estimated from this record only, and they are read at ``t - lag(t)``;
    the scored IMU samples are those of ``score`` at least ``edge_s`` inside the IMU record
    on both clocks and outside the IMU gaps (the body of :func:`prepare_frame`).

    Parameters
    ----------
    t, x, sim_wz : ndarray, shape (n,)
        Wheel times (s), commanded and replayed yaw rate (rad/s).
    sim_ax_slow : callable
        ``sim_ax_slow()`` is the replayed longitudinal acceleration low-passed for the
        pitch, shape (n,), m/s^2 (computed only where there is an IMU).
    score : ndarray of bool, shape (n,)
        Wheel samples that may be scored (the record's span, no wheel gap).
    ti : ndarray, shape (m,)
        IMU times, s (empty, or fewer than :data:`MIN_IMU_SAMPLES`: no IMU).
    raw : ndarray, shape (m, 3)
        Measured ``wz`` (rad/s), ``ax``, ``ay`` (m/s^2).
    rate : float
        The IMU's rate, Hz.
    imu_gaps : sequence of (start, stop)
        IMU gaps, s.
    settings : FrameSettings
    lag_settings : LagSettings

    Returns
    -------
    dict
        The :class:`AuditFrame` fields ``has_imu, wz, ax, ay, pitch, has_pitch, imu_t_s,
        imu_wz, score_imu, lag``.
    """
    if len(ti) < MIN_IMU_SAMPLES:
        nan = np.full(len(t), np.nan)
        return dict(has_imu=False, wz=nan, ax=nan.copy(), ay=nan.copy(),
                    pitch=np.zeros(len(t)), has_pitch=np.zeros(len(t), dtype=bool),
                    imu_t_s=np.empty(0), imu_wz=np.empty(0),
                    score_imu=np.zeros(len(t), dtype=bool),
                    lag=LagTrack(np.empty(0), np.empty(0), np.empty(0), 0))
    chans = lowpass(raw, rate, settings.imu_cutoff_hz)
    lag = estimate_lag_track(t, x, ti, chans[:, 0], lag_settings, alternative=sim_wz)
    t_imu = t - lag.at(t)
    wz, ax, ay = (np.interp(t_imu, ti, chans[:, j]) for j in range(3))
    ax_slow = np.interp(t_imu, ti, lowpass(raw[:, 1], rate, settings.pitch_cutoff_hz,
                                           padtype="even"))
    has_pitch = (t_imu >= ti[0]) & (t_imu <= ti[-1])
    pitch = np.where(has_pitch, np.arcsin(np.clip((ax_slow - sim_ax_slow()) / G_M_S2,
                                                  -1.0, 1.0)), 0.0)
    score_imu = (score & (t_imu >= ti[0] + settings.edge_s)
                 & (t_imu <= ti[-1] - settings.edge_s)
                 & (t >= ti[0] + settings.edge_s) & (t <= ti[-1] - settings.edge_s)
                 & ~_in_gaps(t_imu, imu_gaps))
    return dict(has_imu=True, wz=wz, ax=ax, ay=ay, pitch=pitch, has_pitch=has_pitch,
                imu_t_s=ti, imu_wz=chans[:, 0], score_imu=score_imu, lag=lag)


def segment_lag(frame: AuditFrame, start: int, stop: int,
                lag_settings: LagSettings = LagSettings()) -> LagTrack:
    """The lag track of one segment, estimated from the segment's own samples only.

    The wheel samples ``start:stop`` and the gyro samples stamped within their time span
    (:func:`~terrain.audit.timing.estimate_lag_track`, against the commanded yaw rate or the
    replayed one, as for the whole run): a segment left out in cross-validation then
    contributes nothing to the lag of the segments the ``wheel_lag`` fit is trained on.

    Parameters
    ----------
    frame : AuditFrame
        One run on the comparison clock.
    start, stop : int
        Sample range of the segment (``stop`` excluded).
    lag_settings : LagSettings
        Window-by-window lag estimation (the run's own settings).

    Returns
    -------
    LagTrack
        Empty (not identifiable) without an IMU or with fewer than 2 gyro samples in the span.
    """
    empty = LagTrack(np.empty(0), np.empty(0), np.empty(0), 0)
    t = frame.t_s[start:stop]
    if not frame.has_imu or len(t) < 2:
        return empty
    inside = (frame.imu_t_s >= t[0]) & (frame.imu_t_s <= t[-1])
    if inside.sum() < 2:
        return empty
    return estimate_lag_track(t, frame.commanded_yaw_rate[start:stop], frame.imu_t_s[inside],
                              frame.imu_wz[inside], lag_settings,
                              alternative=frame.sim_wz[start:stop])


def split_frame(frame: AuditFrame, n_parts: int,
                lag_settings: LagSettings = LagSettings(),
                settings: FrameSettings = FrameSettings()) -> list[AuditFrame]:
    """Cut a frame into ``n_parts`` contiguous segments of equal sample count.

    Used when a terrain has too few runs for leave-one-run-out: the segments become the
    cross-validation units (``group = <run_id>#<k>``). Each segment is aligned from its own
    samples only, as a run of its own (:func:`prepare_frame`): its measured IMU channels
    (the samples stamped within its wheel time span) are low-passed over the segment, its
    lag track is estimated from them (:func:`segment_lag`), and they are read on that track;
    IMU samples within ``edge_s`` of the segment's IMU record are not scored. So the gyro of
    a left-out segment moves nothing of the segments the fold is trained on (with the
    run's track and zero-phase low-pass it moved its neighbour's aligned gyro). The
    replay, the currents and their scored samples are the run's, cut. A frame without its
    raw IMU record (``imu_raw`` empty: built other than by :func:`prepare_frame`) keeps the
    run's aligned channels, with each segment's own lag.

    Parameters
    ----------
    frame : AuditFrame
        One run on the comparison clock.
    n_parts : int
        Number of segments (1 or less: the frame itself).
    lag_settings : LagSettings
        Lag estimation of each segment (those the run's track was estimated with).
    settings : FrameSettings
        Filters and scored edges of each segment (those the run was prepared with).

    Returns
    -------
    list of AuditFrame

    Raises
    ------
    ConfigError
        ``n_parts`` not an integer (2.5 cut two segments, ``True`` one, NaN failed in
        NumPy).
    """
    if not is_integer(n_parts):
        raise ConfigError(f"split_frame: n_parts must be an integer, got {n_parts!r}")
    if n_parts <= 1:
        return [frame]
    per_sample = ("t_s", "commanded_yaw_rate", "commanded_speed", "manoeuvre", "quiet",
                  "sim_wz", "sim_ax", "sim_ay", "sim_vx", "sim_cur", "cur", "wz", "ax", "ay",
                  "pitch", "has_pitch", "score_imu", "score_cur")
    realign = frame.has_imu and len(frame.imu_raw) == len(frame.imu_t_s)
    if realign:
        sim_ax_slow = _slow_within_edges(frame.t_s, frame.sim_ax,
                                         scored_span(frame.t_s, settings), settings)
    parts = []
    for k, idx in enumerate(np.array_split(np.arange(frame.n), n_parts)):
        if idx.size == 0:
            continue
        sl = slice(int(idx[0]), int(idx[-1]) + 1)
        part = replace(frame, group=f"{frame.run_id}#{k}",
                       **{name: getattr(frame, name)[sl] for name in per_sample})
        if not realign:
            part = replace(part, lag=segment_lag(frame, sl.start, sl.stop, lag_settings))
        else:
            t = frame.t_s[sl]
            inside = (frame.imu_t_s >= t[0]) & (frame.imu_t_s <= t[-1])
            slow = sim_ax_slow[sl]
            ch = _align_imu(t, frame.commanded_yaw_rate[sl], frame.sim_wz[sl], lambda: slow,
                            frame.score_cur[sl], frame.imu_t_s[inside], frame.imu_raw[inside],
                            frame.imu_rate_hz, frame.imu_gaps, settings, lag_settings)
            part = replace(part, imu_raw=frame.imu_raw[inside], **ch)
        parts.append(part)
    return parts
