"""The library of named model extensions (fixed vocabulary) and their fits.

Each effect is a physically meaningful cause with few parameters. Effects act on one of three
groups of signals and are fitted jointly with the other effects of their group:

=======================  ========  ==================  ==========================================
effect                   group     parameter           extended model (baseline: the replay)
=======================  ========  ==================  ==========================================
``wheel_lag``            timing    ``lag_s`` (s)       gyro read at ``t - lag_s`` for a wheel
                                                       sample stamped ``t`` (positive = wheel
                                                       data late)
``icr_expansion``        yaw       ``chi`` (1)         ``wz = (v_R - v_L) / (chi B)`` instead of
                                                       the replayed yaw rate (Mandow et al. 2007;
                                                       seed 000 eq. 3 with the slip folded in chi)
``gyro_bias``            yaw       ``bias_rad_s``      ``wz += bias_rad_s``
``immobilised``          yaw       ``fraction`` (1)    the robot digs in: no yaw although the
                                                       wheels turn, during ``fraction`` of the
                                                       turning time; mobile turns follow
                                                       ``(v_R - v_L) / (chi_m B)`` or the
                                                       replay, whichever fits better
``turning_resistance``   current   ``k_a`` (A)         both sides ``+= k_a g(|x|)``, ``g = 1`` at
                                                       the reference turn ``|x| = 0.5 rad/s``
``current_offset``       current   ``offset_a`` (A)    constant offsets of the left and right
                                                       readings while moving, fitted on straight
                                                       driving; ``offset_a`` = right - left
``grade_resistance``     current   ``k_a_per_rad``     both sides ``+= k_a_per_rad |pitch|``
                                   (A/rad)             (seed 003 eq. 10: ``W sin(pitch)``)
=======================  ========  ==================  ==========================================

``x = (v_R - v_L) / B`` is the yaw rate the wheels command (seed 000 eq. 2). Forms:

* ``turning_resistance``: ``coulomb``, ``g = tanh(|x| / 0.1) / tanh(5)`` (the scrub force of a
  sliding tyre does not depend on how fast it slides; the same shape as the simulator's
  effect) or ``proportional``, ``g = |x| / 0.5`` (viscous-like scrub). The form with the lower
  training error is kept.
* ``immobilised``: ``uniform`` (the expected yaw rate is ``1 - fraction`` times the mobile
  one in every turn: when the robot digs in is not predictable) or ``rate_dependent`` (one
  immobile fraction below and one above a threshold on ``|x|``: sinkage grows with the slip
  velocity, so fast scrubbing turns dig in more), the threshold chosen on training runs
  among those that separate the fractions by at least ``min_rate_contrast``. The form with
  the lower training error is kept. Either way the prediction is the expectation, which is
  the squared-error-optimal prediction when the dug-in episodes cannot be told apart.

Fitting rules (all closed form, no optimiser):

* ``chi``: least squares of ``wz - bias`` on ``x`` over the *mobile* turning samples; a
  turning sample is immobile when ``|wz - bias| < rho |x| / chi`` (``rho`` =
  :attr:`EffectSettings.immobile_ratio`, decided on the 1 s median-filtered sequence), iterated.
  ``chi`` describes a vehicle that turns; dug-in samples are the business of ``immobilised``.
* ``bias_rad_s``: mean of ``wz`` minus the mobile model over *quiet* samples (far from any
  turn), where no yaw-rate model error can leak into it.
* ``offset_a``: the median residual (measured minus replayed current) of each side over
  straight samples (median: at speeds where the wheel-speed quantum rounds the two sides
  differently, the replay fights a sub-resolution speed difference and its currents split by
  up to +-1 A for a while); their difference is ``offset_a``, their mean (a level shift of both
  readings, e.g. the simulator's one-sided ``current_offset`` raises the mean by half its
  value) is reported as ``common_a`` in the details. The simulator's straight-line current is
  calibrated to the mean of both sides (``MEASURED_HUSKY_STRAIGHT``), so on the measured runs
  the two offsets come out of opposite sign.
* ``k_a``, ``k_a_per_rad``: least squares of the mean-of-sides current residual over moving
  samples (the turning term acts on turning samples only), alternated with the offsets until
  they converge; without the offsets, with a nuisance level column (:func:`fit_current`).

Scoring scopes (:attr:`EffectSpec.scope`): each effect's held-out gain is measured where it acts:
``icr_expansion``, ``immobilised`` and ``turning_resistance`` on turning samples,
``wheel_lag`` on the samples near turns (where the yaw rate moves), ``gyro_bias`` on every
scored sample, ``current_offset`` on the
right-minus-left difference in straight driving, ``grade_resistance`` on moving samples (the
simulator's stand-still currents are left out: see the report).

Negligible effects (:attr:`EffectSettings.negligible`): an effect whose fitted size is below
a practical floor (e.g. chi within 5 % of the replay's own chi, which the 0.2/25.4 m/s
wheel-speed quantum alone can produce in a steady spin) is not supported, whatever its gain.
* ``lag_s``: median of the runs' own lags (:mod:`terrain.audit.timing`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from scipy.ndimage import median_filter

from terrain.audit.frames import CURVE, SPIN, STOP, STRAIGHT, AuditFrame
from terrain.errors import (ConfigError, TerrainError, config_integer, config_numbers,
                            config_positive, duplicated, indexed)
from terrain.sim.effects import TURN_RATE_SCALE_RAD_S
from terrain.vehicles.icr import icr_expansion_factor, inverse_icr_factor


@dataclass(frozen=True)
class EffectSpec:
    """One effect of the audit's fixed vocabulary (module docstring).

    Parameters
    ----------
    name : str
        Effect name (the JSON report's ``name``).
    group : str
        Signal group it is fitted and scored in: ``timing``, ``yaw`` or ``current``.
    param : str
        Name of its vocabulary parameter (the JSON report's ``params`` key).
    unit : str
        Unit of the parameter (``1`` = dimensionless).
    scope : str
        Samples on which its held-out gain is scored: ``all`` scored samples, ``active``
        (turning or near a turn), ``moving`` (not stopped), ``turning`` (curve or spin),
        ``straight_diff`` (right-minus-left current difference on straight samples).
    cause : str
        Plain-language physical cause (printed in the report).
    """

    name: str
    group: str
    param: str
    unit: str
    scope: str
    cause: str


#: the vocabulary of named model extensions, by name (the order is the order of evaluation
#: and of the report)
EFFECT_VOCABULARY: Mapping[str, EffectSpec] = MappingProxyType({spec.name: spec for spec in (
    EffectSpec(
        name="icr_expansion", group="yaw", param="chi", unit="1", scope="turning",
        cause=("A skid-steer robot turns by dragging its tyres sideways. The scrub moves the "
               "instantaneous centres of rotation of the two sides outward (ICR expansion), "
               "so the robot turns as if its track were chi times wider than it is, and "
               "slower than ideal differential drive predicts.")),
    EffectSpec(
        name="gyro_bias", group="yaw", param="bias_rad_s", unit="rad/s", scope="all",
        cause=("The gyro reads a constant yaw rate when the robot does not turn: a sensor "
               "offset.")),
    EffectSpec(
        name="wheel_lag", group="timing", param="lag_s", unit="s", scope="active",
        cause=("The wheel/current stream and the IMU are stamped by different clocks or "
               "buffers. The wheel data arrive late (or early) by lag_s. The offset is a "
               "property of each recording and can drift within one.")),
    EffectSpec(
        name="turning_resistance", group="current", param="k_a", unit="A", scope="turning",
        cause=("While turning, the tyres slide sideways against the ground (skid-steer "
               "lateral friction). The motors must supply this scrub torque, so the current "
               "rises in every turn by more than the simulated contact model gives.")),
    EffectSpec(
        name="current_offset", group="current", param="offset_a", unit="A",
        scope="straight_diff",
        cause=("When driving straight without yawing, the right motor reads more current "
               "than the left. A traction difference would make the robot yaw, so the cause "
               "is a current-sensor offset or extra drive-train friction on one side.")),
    EffectSpec(
        name="grade_resistance", group="current", param="k_a_per_rad", unit="A/rad",
        scope="moving",
        cause=("On a slope, climbing costs gravity torque, W sin(pitch) (seed 003 eq. 10). "
               "The flat-ground replay ignores it; the pitch comes from the accelerometer.")),
    EffectSpec(
        name="immobilised", group="yaw", param="fraction", unit="1", scope="turning",
        cause=("The wheels dig into soft ground: the robot stops turning while its wheels "
               "keep spinning, so the gyro reads nothing where the wheels command a turn.")),
)})
EFFECT_NAMES: tuple[str, ...] = tuple(EFFECT_VOCABULARY)
#: group -> its effects, in vocabulary order
GROUPS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    g: tuple(n for n, spec in EFFECT_VOCABULARY.items() if spec.group == g)
    for g in ("timing", "yaw", "current")})
#: signals each group is scored on
GROUP_SIGNALS: Mapping[str, tuple[str, ...]] = MappingProxyType(
    {"timing": ("wz",), "yaw": ("wz",), "current": ("cur_l", "cur_r")})
_SCOPE_CODES: Mapping[str, tuple[int, ...]] = MappingProxyType(
    {"moving": (STRAIGHT, CURVE, SPIN), "straight": (STRAIGHT,), "turning": (CURVE, SPIN)})


def scope_mask(frame: AuditFrame, scope: str = "all") -> np.ndarray:
    """Samples of a frame in a scope.

    Parameters
    ----------
    frame : AuditFrame
        The frame (``n`` samples).
    scope : str
        ``all``, ``active`` (not quiet: ``|x| >= quiet_rad_s``, or a turning sample
        within ``quiet_margin_s``, that distance included; see
        :class:`~terrain.audit.frames.FrameSettings`),
        ``moving``, ``straight`` or ``turning`` (manoeuvre classes of
        :mod:`terrain.audit.frames`).

    Returns
    -------
    ndarray of bool, shape (n,)

    Raises
    ------
    KeyError
        Unknown scope.
    """
    if scope == "all":
        return np.ones(frame.n, dtype=bool)
    if scope == "active":
        return ~frame.quiet
    return np.isin(frame.manoeuvre, _SCOPE_CODES[scope])


TURNING_FORMS = ("coulomb", "proportional")
IMMOBILE_FORMS = ("uniform", "rate_dependent")


class NotIdentifiable(TerrainError):
    """The data hold no information on an effect (no turns, no straight driving, level
    ground...). Raised by the group fits; the selection reports it as the effect's
    ``reason``."""


@dataclass(frozen=True)
class EffectSettings:
    """Constants of the effect models.

    Parameters
    ----------
    turn_ref_rad_s : float
        Reference turning condition of ``turning_resistance``: ``k_a`` is the extra current
        per side at a commanded yaw rate ``|x| = turn_ref_rad_s``, rad/s.
    coulomb_scale_rad_s : float
        Yaw rate scale of the Coulomb-like form ``tanh(|x| / scale)`` (the simulator's
        :data:`~terrain.sim.effects.TURN_RATE_SCALE_RAD_S`), rad/s.
    immobile_ratio : float
        A turning sample is immobile when the gyro shows less than this fraction of the mobile
        model's yaw rate.
    immobile_smooth_s : float
        Length of the median filter applied to the immobile flags, s (a dug-in episode lasts
        longer than a misaligned turn edge).
    min_pitch_spread_rad : float
        ``grade_resistance`` is identifiable only when the std of ``|pitch|`` exceeds this, rad.
    robust_iterations : int
        Iterations of the mobile/immobile classification.
    max_alternations : int
        Most alternations of the current fit's offset and coefficient steps
        (:func:`fit_current`); they stop earlier once the coefficients no longer change.
    min_turn_samples, min_straight_samples, min_quiet_samples : int
        Fewer samples than these make the effect not identifiable.
    threshold_quantiles : tuple of float
        Candidate thresholds of the ``rate_dependent`` form, as quantiles of ``|x|`` over
        turning samples (each side of the threshold keeps at least 15 % of them).
    negligible : tuple of (str, float)
        Practical floor of each effect's size below which it is not supported: relative
        change of chi against the replay's own chi, ``|bias_rad_s|`` (rad/s), ``|lag_s|``
        (s), ``fraction``, ``|k_a|`` (A), ``|offset_a|`` (A), ``|k_a_per_rad|`` (A/rad).
        The tuple replaces the default as a whole: an effect left out of it has no floor
        (any fitted size counts), so to change one floor give them all.
    min_rate_contrast : float
        The ``rate_dependent`` form is considered only where the immobile fraction above the
        threshold exceeds the one below by at least this much (sinkage grows with the slip
        velocity: faster scrub digs in more); otherwise the ``uniform`` form is used.
    """

    turn_ref_rad_s: float = 0.5
    coulomb_scale_rad_s: float = TURN_RATE_SCALE_RAD_S
    immobile_ratio: float = 0.3
    immobile_smooth_s: float = 1.0
    min_pitch_spread_rad: float = 0.01
    robust_iterations: int = 6
    max_alternations: int = 500
    min_turn_samples: int = 20
    min_straight_samples: int = 20
    min_quiet_samples: int = 10
    threshold_quantiles: tuple[float, ...] = tuple(np.round(np.arange(0.15, 0.86, 0.05), 2))
    min_rate_contrast: float = 0.3
    negligible: tuple[tuple[str, float], ...] = (
        ("icr_expansion", 0.05), ("gyro_bias", 0.002), ("wheel_lag", 0.05),
        ("immobilised", 0.05), ("turning_resistance", 0.1), ("current_offset", 0.1),
        ("grade_resistance", 1.0))

    def __post_init__(self) -> None:
        """Refuse a setting that is not a number in range (none was checked before).

        Raises
        ------
        ConfigError
            A rate scale, ratio or time not finite and > 0 (``immobile_ratio`` also <= 1);
            ``min_pitch_spread_rad`` or ``min_rate_contrast`` not finite and >= 0; an
            iteration or sample count not an integer >= 1; a threshold quantile outside
            (0, 1) or not a number (text, a boolean); ``negligible`` or
            ``threshold_quantiles`` one value (a number, text) instead of a sequence; a
            ``negligible`` entry that is not a ``(name, floor)`` pair, names an
            effect outside :data:`EFFECT_VOCABULARY` or one already named (a misspelt name
            left that effect without a floor, a repeated one kept the last floor), or a
            floor not finite and >= 0.
        """
        for name in ("negligible", "threshold_quantiles"):
            value = getattr(self, name)
            if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
                raise ConfigError(f"EffectSettings.{name} must be a sequence, got {value!r}")
        for entry in self.negligible:
            if not (isinstance(entry, (tuple, list)) and len(entry) == 2):
                raise ConfigError(f"EffectSettings.negligible entries must be (effect, floor) "
                                  f"pairs, got {entry!r}")
            if entry[0] not in EFFECT_VOCABULARY:
                raise ConfigError(f"EffectSettings.negligible names {entry[0]!r}, not an "
                                  f"effect; valid: {list(EFFECT_VOCABULARY)}")
        repeated = duplicated(name for name, _ in self.negligible)
        if repeated:
            raise ConfigError(f"EffectSettings.negligible names {repeated[0]!r} twice")
        config_positive("EffectSettings", turn_ref_rad_s=self.turn_ref_rad_s,
                        coulomb_scale_rad_s=self.coulomb_scale_rad_s,
                        immobile_ratio=self.immobile_ratio,
                        immobile_smooth_s=self.immobile_smooth_s)
        config_positive("EffectSettings", allow_zero=True,
                        min_pitch_spread_rad=self.min_pitch_spread_rad,
                        min_rate_contrast=self.min_rate_contrast,
                        **{f"negligible[{name!r}]": floor for name, floor in self.negligible})
        if self.immobile_ratio > 1.0:
            raise ConfigError(f"EffectSettings.immobile_ratio must be <= 1, got "
                              f"{self.immobile_ratio!r}")
        for name in ("robust_iterations", "max_alternations", "min_turn_samples",
                     "min_straight_samples", "min_quiet_samples"):
            config_integer(f"EffectSettings.{name}", getattr(self, name), 1)
        config_numbers("EffectSettings",
                       **indexed("threshold_quantiles", self.threshold_quantiles))
        if not self.threshold_quantiles or not all(
                0.0 < float(q) < 1.0 for q in self.threshold_quantiles):
            raise ConfigError(f"EffectSettings.threshold_quantiles must be quantiles in "
                              f"(0, 1), got {self.threshold_quantiles!r}")


# ----------------------------------------------------------------------------------------
# yaw group

@dataclass(frozen=True)
class YawParams:
    """Fitted yaw-rate model.

    Attributes
    ----------
    kinematic : bool
        Whether the mobile yaw rate is ``inverse_chi x`` (``icr_expansion`` on, or
        ``immobilised`` with the kinematic mobile model) or the replay's.
    inverse_chi : float
        ``1 / chi`` of the kinematic mobile model
        (:func:`terrain.vehicles.icr.inverse_icr_factor`).
    bias_rad_s : float
        Gyro bias, rad/s.
    immobilised : bool
        Whether the ``immobilised`` effect is in the model.
    fraction : float
        Fraction of turning samples found immobile in the fitted data.
    form : str or None
        Immobilised form.
    threshold_rad_s : float
        ``rate_dependent`` threshold on ``|x|`` (inf: ``uniform``).
    fractions : (float, float)
        Immobile fraction of the turning samples below / above the threshold.
    n_turn, n_quiet : int
        Samples the fit used.
    chi_replay : float
        The replay's own effective chi on the same mobile turning samples,
        ``sum(x^2) / sum(x sim_wz)`` (:func:`~terrain.vehicles.icr.icr_expansion_factor`:
        the reciprocal of the least-squares slope of the replayed yaw rate on ``x``, as
        :attr:`chi` is of the gyro's): what the simulator already predicts.
    """

    kinematic: bool = False
    inverse_chi: float = float("nan")
    bias_rad_s: float = 0.0
    immobilised: bool = False
    fraction: float = 0.0
    form: str | None = None
    threshold_rad_s: float = float("inf")
    fractions: tuple[float, float] = (0.0, 0.0)
    n_turn: int = 0
    n_quiet: int = 0
    chi_replay: float = float("nan")

    @property
    def chi(self) -> float:
        """ICR expansion factor ``1 / inverse_chi`` of the mobile model (the replay's own chi
        when the mobile model is the replay; NaN without a fitted chi)."""
        if not np.isfinite(self.inverse_chi) or self.inverse_chi == 0:
            return float("nan")
        return float(1.0 / self.inverse_chi) if self.kinematic else float(self.chi_replay)


@dataclass(frozen=True)
class _YawData:
    x: np.ndarray
    y: np.ndarray
    sim: np.ndarray
    turn: np.ndarray
    quiet: np.ndarray
    bounds: np.ndarray          # frame boundaries in the concatenation, shape (k + 1,)
    filt: int                   # median filter length, samples


def _yaw_data(frames: Sequence[AuditFrame], settings: EffectSettings) -> _YawData:
    xs, ys, ss, ts, qs, sizes, dts = [], [], [], [], [], [0], []
    for f in frames:
        m = f.score_imu
        if not f.has_imu or not m.any():
            continue
        xs.append(f.commanded_yaw_rate[m])
        ys.append(f.wz[m])
        ss.append(f.sim_wz[m])
        ts.append(np.isin(f.manoeuvre[m], (CURVE, SPIN)))
        qs.append(f.quiet[m])
        sizes.append(int(m.sum()))
        if f.n > 1:
            dts.append(float(np.median(np.diff(f.t_s))))
    if len(sizes) == 1:
        raise NotIdentifiable("no run with IMU samples to score")
    dt = float(np.median(dts)) if dts else 0.15
    filt = max(1, int(round(settings.immobile_smooth_s / dt)) | 1)
    return _YawData(np.concatenate(xs), np.concatenate(ys), np.concatenate(ss),
                    np.concatenate(ts), np.concatenate(qs), np.cumsum(sizes), filt)


def _smooth_flags(flags: np.ndarray, bounds: np.ndarray, size: int) -> np.ndarray:
    out = flags.copy()
    if size <= 1:
        return out
    for i0, i1 in zip(bounds[:-1], bounds[1:]):
        out[i0:i1] = median_filter(flags[i0:i1].astype(np.int8), size=size,
                                   mode="nearest").astype(bool)
    return out


def immobile_scale(x: np.ndarray, turn: np.ndarray, fractions: tuple[float, float],
                   threshold_rad_s: float) -> np.ndarray:
    """Expected mobility ``1 - P(immobile)`` of each sample, shape (n,).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Commanded yaw rate, rad/s.
    turn : ndarray of bool, shape (n,)
        Turning samples (only they can be immobile).
    fractions : (float, float)
        Immobile fraction of turning samples below and above the threshold.
    threshold_rad_s : float
        Threshold on ``|x|`` (inf: one fraction for every turn), rad/s.

    Returns
    -------
    ndarray, shape (n,)
        ``1 - fraction`` on turning samples, 1 elsewhere (dimensionless).
    """
    f = np.where(np.abs(x) >= threshold_rad_s, fractions[1], fractions[0])
    return np.where(turn, 1.0 - f, 1.0)


def _immobile_flags(d: _YawData, mobile: np.ndarray, b: float,
                    settings: EffectSettings) -> np.ndarray:
    """Turning samples where the gyro shows less than ``immobile_ratio`` of the mobile
    model's yaw rate, on the median-filtered sequence."""
    flags = d.turn & (np.abs(d.y - b) < settings.immobile_ratio * np.abs(mobile))
    return _smooth_flags(flags, d.bounds, d.filt) & d.turn


def _fit_immobile(d: _YawData, mobile: np.ndarray, b: float, immobile: np.ndarray,
                  settings: EffectSettings, form: str | None):
    """Best threshold and fractions of the ``immobilised`` forms: (sse, threshold, fractions)."""
    ax = np.abs(d.x)
    cands = [float("inf")]
    if form != "uniform":
        q = np.quantile(ax[d.turn], settings.threshold_quantiles)
        cands += list(np.unique(np.round(q, 4)))
    best = None
    for thr in cands:
        hi = d.turn & (ax >= thr)
        lo = d.turn & ~hi
        fr = (float(immobile[lo].sum() / max(lo.sum(), 1)),
              float(immobile[hi].sum() / max(hi.sum(), 1)))
        if np.isfinite(thr) and fr[1] - fr[0] < settings.min_rate_contrast:
            continue
        pred = mobile * immobile_scale(d.x, d.turn, fr, thr) + b
        sse = float(np.sum((d.y - pred) ** 2))
        if best is None or sse < best[0] - 1e-12:
            best = (sse, thr, fr)
    return best


def fit_yaw(frames: Sequence[AuditFrame], spec: Sequence[str],
            settings: EffectSettings = EffectSettings(), form: str | None = None) -> YawParams:
    """Fit the yaw-rate model with the effects in ``spec`` (module docstring).

    The mobile yaw rate is ``x / chi`` when ``icr_expansion`` is in ``spec``, else the
    replay's. ``immobilised`` without ``icr_expansion`` tries both mobile models (the replay,
    and ``x / chi_m`` with ``chi_m`` fitted on the mobile samples: needed where the replayed
    robot itself digs in) and keeps the one with the lower training error.

    Parameters
    ----------
    frames : sequence of AuditFrame
        Training frames (those without IMU are skipped).
    spec : sequence of str
        Subset of ``icr_expansion``, ``gyro_bias``, ``immobilised``.
    settings : EffectSettings
        Constants of the effect models (thresholds, iterations, minimum sample counts).
    form : str, optional
        ``uniform`` forces one immobile fraction for every turn. Otherwise (None or
        ``rate_dependent``) the fractions below and above each candidate threshold compete
        with the uniform form, and the one with the lower training error is kept: a refit
        asked for ``rate_dependent`` comes back uniform where no threshold gives the
        contrast ``settings.min_rate_contrast``.

    Returns
    -------
    YawParams

    Raises
    ------
    NotIdentifiable
        No IMU samples, no turning samples for ``chi``, no quiet samples for the bias.
    """
    d = _yaw_data(frames, settings)
    bias_on = "gyro_bias" in spec
    imm_on = "immobilised" in spec
    icr_on = "icr_expansion" in spec
    n_quiet = int(d.quiet.sum())
    if bias_on and n_quiet < settings.min_quiet_samples:
        raise NotIdentifiable(f"gyro_bias: {n_quiet} quiet samples (robot not turning), "
                              f"need {settings.min_quiet_samples}")
    if not (icr_on or imm_on):
        b = float(np.mean(d.y[d.quiet] - d.sim[d.quiet])) if bias_on else 0.0
        return YawParams(bias_rad_s=b, n_quiet=n_quiet)
    n_turn = int(d.turn.sum())
    if n_turn < settings.min_turn_samples:
        raise NotIdentifiable(f"{'chi' if icr_on else 'immobilised'}: {n_turn} turning "
                              f"samples, need {settings.min_turn_samples}")
    # kinematic mobile model: robust chi on the mobile turning samples
    b = 0.0
    a = inverse_icr_factor(d.y[d.turn], d.x[d.turn])
    mobile_turn = d.turn.copy()
    for _ in range(settings.robust_iterations):
        if bias_on:
            b = float(np.mean(d.y[d.quiet] - a * d.x[d.quiet]))
        mobile_turn = d.turn & ~_immobile_flags(d, a * d.x, b, settings)
        if mobile_turn.sum() < settings.min_turn_samples:
            break
        a_new = inverse_icr_factor(d.y[mobile_turn] - b, d.x[mobile_turn])
        if not a_new > 0:
            break
        a = a_new
    fraction = float(1.0 - mobile_turn.sum() / n_turn)
    chi_replay = icr_expansion_factor(d.sim[mobile_turn], d.x[mobile_turn])
    common = dict(bias_rad_s=b, n_turn=n_turn, n_quiet=n_quiet, chi_replay=chi_replay)
    if not imm_on:
        return YawParams(kinematic=True, inverse_chi=a, fraction=fraction, **common)
    candidates = [(True, a, b, d.turn & ~mobile_turn, fraction)]
    if not icr_on:
        b_r = float(np.mean(d.y[d.quiet] - d.sim[d.quiet])) if bias_on else 0.0
        imm_r = _immobile_flags(d, d.sim, b_r, settings)
        candidates.append((False, a, b_r, imm_r, float(imm_r.sum() / n_turn)))
    best = None
    for kin, a_c, b_c, immobile, frac in candidates:
        mobile = a_c * d.x if kin else d.sim
        sse, thr, fr = _fit_immobile(d, mobile, b_c, immobile, settings, form)
        if best is None or sse < best[0]:
            best = (sse, kin, b_c, frac, thr, fr)
    _, kin, b, fraction, thr, fr = best
    common["bias_rad_s"] = b
    return YawParams(kinematic=kin, inverse_chi=a, immobilised=True, fraction=fraction,
                     form="uniform" if not np.isfinite(thr) else "rate_dependent",
                     threshold_rad_s=thr, fractions=fr, **common)


def predict_yaw(frame: AuditFrame, params: YawParams) -> np.ndarray:
    """Predicted gyro yaw rate of a frame.

    Parameters
    ----------
    frame : AuditFrame
        One run (or segment) on the comparison clock, ``n`` samples.
    params : YawParams
        Fitted yaw-rate model.

    Returns
    -------
    ndarray, shape (n,)
        Mobile yaw rate (``inverse_chi x`` or the replay's) times the expected mobility
        (:func:`immobile_scale`) plus the gyro bias, rad/s.
    """
    mobile = (params.inverse_chi * frame.commanded_yaw_rate if params.kinematic
              else frame.sim_wz)
    if params.immobilised:
        turn = np.isin(frame.manoeuvre, (CURVE, SPIN))
        mobile = mobile * immobile_scale(frame.commanded_yaw_rate, turn, params.fractions,
                                         params.threshold_rad_s)
    return mobile + params.bias_rad_s


def yaw_sse(frame: AuditFrame, params: YawParams, scope: str = "all") -> tuple[float, int]:
    """Squared yaw-rate errors of a frame under a fitted model.

    Parameters
    ----------
    frame : AuditFrame
        One run (or segment) on the comparison clock, ``n`` samples.
    params : YawParams
        Fitted yaw-rate model.
    scope : str
        Samples scored, among those with IMU (:func:`scope_mask`).

    Returns
    -------
    sse : float
        Sum of squared errors of :func:`predict_yaw` against the gyro, (rad/s)^2.
    n : int
        Samples summed.
    """
    m = frame.score_imu & scope_mask(frame, scope)
    if not frame.has_imu or not m.any():
        return 0.0, 0
    r = frame.wz[m] - predict_yaw(frame, params)[m]
    return float(np.sum(r * r)), int(m.sum())


# ----------------------------------------------------------------------------------------
# current group

@dataclass(frozen=True)
class CurrentParams:
    """Fitted motor-current model (extra terms on top of the replay's currents).

    Attributes
    ----------
    offset_left_a, offset_right_a : float
        Constant offsets of the left and right readings while moving, A (fitted on straight
        driving). ``offset_a = offset_right_a - offset_left_a``.
    k_a : float
        Turning term at the reference turn, A per side.
    form : str or None
        ``coulomb`` or ``proportional``.
    k_a_per_rad : float
        Grade term, A per rad of ``|pitch|`` per side.
    turn_ref_rad_s, coulomb_scale_rad_s : float
        Constants of the turning term.
    n_straight : int
        Straight samples used for the offsets.
    n_without_pitch : int
        Moving samples of runs without an IMU left out of a fit with ``grade_resistance``
        (no pitch estimate: their pitch 0 is a placeholder, not level ground); 0 without it.
    n_outside_imu : int
        Moving samples of runs with an IMU read outside its record (``has_pitch`` False on
        the frame: before its first or after its last stamp) left out of a fit with
        ``grade_resistance``, for the same reason; 0 without it.
    """

    offset_left_a: float = 0.0
    offset_right_a: float = 0.0
    k_a: float = 0.0
    form: str | None = None
    k_a_per_rad: float = 0.0
    turn_ref_rad_s: float = 0.5
    coulomb_scale_rad_s: float = TURN_RATE_SCALE_RAD_S
    n_straight: int = 0
    n_without_pitch: int = 0
    n_outside_imu: int = 0

    @property
    def offset_a(self) -> float:
        """Right-minus-left offset, A."""
        return self.offset_right_a - self.offset_left_a

    @property
    def common_a(self) -> float:
        """Mean of the two offsets (a level shift of both readings), A."""
        return 0.5 * (self.offset_right_a + self.offset_left_a)

    def turning_shape(self, x: np.ndarray, form: str | None = None) -> np.ndarray:
        """Shape ``g(|x|)`` of the turning term, 1 at the reference turn.

        Parameters
        ----------
        x : ndarray, shape (n,)
            Commanded yaw rate ``(v_R - v_L) / B``, rad/s.
        form : str, optional
            ``coulomb`` (``tanh(|x| / coulomb_scale) / tanh(turn_ref / coulomb_scale)``) or
            ``proportional`` (``|x| / turn_ref``); default :attr:`form`.

        Returns
        -------
        ndarray, shape (n,)
            ``g`` (dimensionless).
        """
        form = form or self.form
        ax = np.abs(np.asarray(x, dtype=float))
        if form == "proportional":
            return ax / self.turn_ref_rad_s
        return np.tanh(ax / self.coulomb_scale_rad_s) / np.tanh(
            self.turn_ref_rad_s / self.coulomb_scale_rad_s)


def _turning_shape(x: np.ndarray, form: str, settings: EffectSettings) -> np.ndarray:
    return CurrentParams(turn_ref_rad_s=settings.turn_ref_rad_s,
                         coulomb_scale_rad_s=settings.coulomb_scale_rad_s).turning_shape(x, form)


@dataclass(frozen=True)
class _CurrentData:
    x: np.ndarray
    res: np.ndarray          # (n, 2) measured - replay
    straight: np.ndarray
    turn: np.ndarray
    moving: np.ndarray
    pitch: np.ndarray        # |pitch|, 0 where there is no estimate
    has_imu: np.ndarray      # the sample's run has an IMU
    has_pitch: np.ndarray    # and the sample lies within its record


def _current_data(frames: Sequence[AuditFrame]) -> _CurrentData:
    cols: dict[str, list] = {k: [] for k in ("x", "res", "straight", "turn", "moving", "pitch",
                                             "has_imu", "has_pitch")}
    for f in frames:
        m = f.score_cur
        if not m.any():
            continue
        man = f.manoeuvre[m]
        cols["x"].append(f.commanded_yaw_rate[m])
        cols["res"].append(f.cur[m] - f.sim_cur[m])
        cols["straight"].append(man == STRAIGHT)
        cols["turn"].append(np.isin(man, (CURVE, SPIN)))
        cols["moving"].append(man != STOP)
        cols["pitch"].append(np.abs(f.pitch[m]))
        cols["has_imu"].append(np.full(int(m.sum()), f.has_imu))
        cols["has_pitch"].append(f.has_imu & f.has_pitch[m])
    if not cols["x"]:
        raise NotIdentifiable("no current samples to score")
    return _CurrentData(**{k: np.concatenate(v) for k, v in cols.items()})


def fit_current(frames: Sequence[AuditFrame], spec: Sequence[str],
                settings: EffectSettings = EffectSettings(), form: str | None = None
                ) -> CurrentParams:
    """Fit the current model with the effects in ``spec`` (module docstring).

    The model adds, on moving samples, ``offset_left_a`` / ``offset_right_a`` to each side
    (``current_offset``), ``k_a g(|x|)`` to both sides on turning samples
    (``turning_resistance``) and ``k_a_per_rad |pitch|`` to both sides
    (``grade_resistance``). Offsets are the median residuals of straight driving; the turning
    and grade coefficients are least squares over moving samples; with a grade, every step
    takes the samples of runs with an IMU only (a run without one has no pitch, not a level
    one: its straight rows would carry its climbing current into the offsets, its moving rows
    would tell the least squares "level ground"; likewise the samples of a run with an IMU
    read outside its record, :attr:`AuditFrame.has_pitch`), and counts the moving samples
    left out (:attr:`CurrentParams.n_without_pitch`, :attr:`CurrentParams.n_outside_imu`);
    the two steps alternate until the coefficients stop changing (relative 1e-9, at most
    ``settings.max_alternations``; a grade column, nonzero on straight samples too, couples
    them). Without ``current_offset``, the grade coefficient's least squares carries a
    constant column for the level of the moving currents, not part of the model: ``|pitch|``
    is never negative, so on level ground a least squares through the origin would report
    ``mean residual / mean |pitch|`` as a grade.

    Parameters
    ----------
    frames : sequence of AuditFrame
    spec : sequence of str
        Subset of ``turning_resistance``, ``current_offset``, ``grade_resistance``.
    settings : EffectSettings
        Constants of the effect models (reference turn, minimum sample counts).
    form : str, optional
        Force the ``turning_resistance`` form.

    Returns
    -------
    CurrentParams

    Raises
    ------
    NotIdentifiable
        No straight samples (offset), no turns (turning), level ground (grade).
    """
    d = _current_data(frames)
    offset_on = "current_offset" in spec
    turning_on = "turning_resistance" in spec
    grade_on = "grade_resistance" in spec
    # a run without an IMU has no pitch (0 is a placeholder): in a fit with a grade its rows
    # would say "level ground" while its currents climbed, in the least squares (2 of 4 hill
    # runs without one: 3.5 A/rad fitted for 10 planted) and, through the straight medians,
    # in the offsets (4.0 for 10), so such a fit takes the runs with a pitch only; and of
    # those, the samples read within the IMU record (past its end the filtered accelerometer
    # was held: an IMU of 12-40 s under 60 s of hills, 9.1 A/rad for 10.7 within it)
    fit_rows = d.has_pitch if grade_on else np.ones(len(d.x), dtype=bool)
    n_without_pitch = int((d.moving & ~fit_rows & ~d.has_imu).sum())
    n_outside_imu = int((d.moving & ~fit_rows & d.has_imu).sum())
    n_straight = int((d.straight & fit_rows).sum())
    if offset_on and n_straight < settings.min_straight_samples:
        raise NotIdentifiable(f"current_offset: {n_straight} straight samples, need "
                              f"{settings.min_straight_samples}")
    n_turn = int((d.turn & fit_rows).sum())
    if turning_on and n_turn < settings.min_turn_samples:
        raise NotIdentifiable(f"turning_resistance: {n_turn} turning samples, "
                              f"need {settings.min_turn_samples}")
    if grade_on:
        sel = fit_rows & d.moving
        spread = float(np.std(d.pitch[sel])) if sel.any() else 0.0
        if spread < settings.min_pitch_spread_rad:
            raise NotIdentifiable(f"grade_resistance: |pitch| spread {spread:.4f} rad below "
                                  f"{settings.min_pitch_spread_rad} rad (level ground)")
    forms = (None,) if not turning_on else (TURNING_FORMS if form is None else (form,))
    mv = d.moving & fit_rows
    best = None
    for fm in forms:
        cols = []
        if turning_on:
            cols.append(np.where(d.turn, _turning_shape(d.x, fm, settings), 0.0))
        if grade_on:
            cols.append(d.pitch)
        design = np.column_stack(cols) if cols else np.zeros((len(d.x), 0))
        coef = np.zeros(design.shape[1])
        off = np.zeros(2)
        # without the offsets, a level of the moving currents is a nuisance column of the
        # least squares (not part of the model): |pitch| >= 0 would otherwise absorb it
        level = grade_on and not offset_on
        ls_design = np.column_stack([design, np.ones(len(d.x))]) if level else design
        for _ in range(settings.max_alternations if (offset_on and cols) else 1):
            common = design @ coef
            if offset_on:
                st = d.straight & fit_rows
                off = np.median(d.res[st] - common[st, None], axis=0)
            if cols:
                target = (d.res - off[None, :] * mv[:, None]).mean(axis=1)
                new = np.linalg.lstsq(ls_design[mv], target[mv],
                                      rcond=None)[0][:len(coef)]
                converged = np.all(np.abs(new - coef) <= 1e-9 * (1.0 + np.abs(new)))
                coef = new
                if converged:
                    break
        fitted = (design @ coef)[:, None] + off[None, :] * mv[:, None]
        sse = float(np.sum((d.res[mv] - fitted[mv]) ** 2))
        if best is None or sse < best[0]:
            best = (sse, fm, coef, off)
    _, fm, coef, off = best
    return CurrentParams(offset_left_a=float(off[0]), offset_right_a=float(off[1]),
                         k_a=float(coef[0]) if turning_on else 0.0, form=fm,
                         k_a_per_rad=float(coef[-1]) if grade_on else 0.0,
                         turn_ref_rad_s=settings.turn_ref_rad_s,
                         coulomb_scale_rad_s=settings.coulomb_scale_rad_s, n_straight=n_straight,
                         n_without_pitch=n_without_pitch, n_outside_imu=n_outside_imu)


def predict_current(frame: AuditFrame, params: CurrentParams) -> np.ndarray:
    """Predicted motor currents of a frame.

    Parameters
    ----------
    frame : AuditFrame
        One run (or segment) on the comparison clock, ``n`` samples.
    params : CurrentParams
        Fitted current model.

    Returns
    -------
    ndarray, shape (n, 2)
        Replayed currents plus the turning, grade and offset terms (module docstring),
        left and right, A.
    """
    moving = frame.manoeuvre != STOP
    extra = np.zeros(frame.n)
    if params.k_a:
        turn = np.isin(frame.manoeuvre, (CURVE, SPIN))
        extra = extra + np.where(
            turn, params.k_a * params.turning_shape(frame.commanded_yaw_rate), 0.0)
    if params.k_a_per_rad:
        extra = extra + np.where(moving, params.k_a_per_rad * np.abs(frame.pitch), 0.0)
    out = frame.sim_cur + extra[:, None]
    out[moving, 0] += params.offset_left_a
    out[moving, 1] += params.offset_right_a
    return out


def current_sse(frame: AuditFrame, params: CurrentParams, scope: str = "all"
                ) -> tuple[float, int]:
    """Squared current errors of a frame under a fitted model.

    Parameters
    ----------
    frame : AuditFrame
        One run (or segment) on the comparison clock, ``n`` samples.
    params : CurrentParams
        Fitted current model.
    scope : str
        ``straight_diff`` scores the right-minus-left difference on straight samples (one
        value per sample); other scopes (:func:`scope_mask`) score both sides (two values
        per sample).

    Returns
    -------
    sse : float
        Sum of squared errors, A^2.
    n : int
        Values summed.
    """
    if scope == "straight_diff":
        m = frame.score_cur & (frame.manoeuvre == STRAIGHT)
        if not m.any():
            return 0.0, 0
        pred = predict_current(frame, params)[m]
        r = (frame.cur[m, 1] - frame.cur[m, 0]) - (pred[:, 1] - pred[:, 0])
        return float(np.sum(r * r)), int(m.sum())
    m = frame.score_cur & scope_mask(frame, scope)
    if not m.any():
        return 0.0, 0
    r = frame.cur[m] - predict_current(frame, params)[m]
    return float(np.sum(r * r)), int(2 * m.sum())


# ----------------------------------------------------------------------------------------
# timing group

@dataclass(frozen=True)
class LagParams:
    """Fitted timing model: a constant lag of the wheel stream.

    Parameters
    ----------
    lag_s : float
        Lag, s (positive = wheel data late; 0 = raw timestamps).
    per_run : mapping of str to float
        Cross-validation unit (:attr:`~terrain.audit.frames.AuditFrame.group`: the run id,
        or ``<run_id>#<k>`` for a segment) -> its own median lag, s (units with an
        identifiable lag).
    """

    lag_s: float = 0.0
    per_run: Mapping[str, float] = field(default_factory=dict)


def fit_lag(frames: Sequence[AuditFrame], spec: Sequence[str],
            settings: EffectSettings = EffectSettings(), form: str | None = None) -> LagParams:
    """Fit the timing model: the median of the units' own median lags (one per run, or one
    per segment, each from the segment's own span: :func:`~terrain.audit.frames.split_frame`),
    each frame counted as often as it is given (a bootstrap resample's repeats included).

    Parameters
    ----------
    frames : sequence of AuditFrame
        Training frames (their lag tracks, :mod:`terrain.audit.timing`).
    spec : sequence of str
        ``["wheel_lag"]`` or empty (lag 0).
    settings : EffectSettings
        Unused (the common signature of :class:`GroupModel` fits).
    form : str, optional
        Unused (no forms).

    Returns
    -------
    LagParams

    Raises
    ------
    NotIdentifiable
        No unit with an identifiable lag.
    """
    usable = [f for f in frames if f.has_imu and f.lag.identifiable]
    per_run = {f.group: f.lag.median_s for f in usable}
    if "wheel_lag" not in spec:
        return LagParams(0.0, per_run)
    if not usable:
        raise NotIdentifiable("wheel_lag: no run has a window where the wheels command a "
                              "varying yaw rate that the gyro follows")
    # over the frames, not the names: a unit a bootstrap resample draws k times counts k times
    return LagParams(float(np.median([f.lag.median_s for f in usable])), per_run)


def lag_sse(frame: AuditFrame, params: LagParams, scope: str = "all") -> tuple[float, int]:
    """Squared errors of the replayed yaw rate against the gyro read with a constant lag.

    Parameters
    ----------
    frame : AuditFrame
        One run (or segment) on the comparison clock, ``n`` samples.
    params : LagParams
        Fitted timing model.
    scope : str
        Samples scored, among those with IMU (:func:`scope_mask`).

    Returns
    -------
    sse : float
        Sum of squared errors, (rad/s)^2.
    n : int
        Samples summed.
    """
    m = frame.score_imu & scope_mask(frame, scope)
    if not frame.has_imu or not m.any():
        return 0.0, 0
    r = frame.wz_at_lag(params.lag_s)[m] - frame.sim_wz[m]
    return float(np.sum(r * r)), int(m.sum())


@dataclass(frozen=True)
class GroupModel:
    """How the effects of one group are fitted and scored.

    Parameters
    ----------
    fit : callable
        ``fit(frames, spec, settings, form=None) -> params`` (:func:`fit_lag`,
        :func:`fit_yaw`, :func:`fit_current`); raises :class:`NotIdentifiable`.
    sse : callable
        ``sse(frame, params, scope) -> (sum of squared errors, count)`` (:func:`lag_sse`,
        :func:`yaw_sse`, :func:`current_sse`).
    no_effect : type
        Parameter class whose default instance is the baseline (the replay, no effect):
        :class:`LagParams`, :class:`YawParams` or :class:`CurrentParams`.
    """

    fit: Callable[..., Any]
    sse: Callable[..., tuple[float, int]]
    no_effect: type


#: group -> how it is fitted and scored
GROUP_MODELS: Mapping[str, GroupModel] = MappingProxyType({
    "timing": GroupModel(fit=fit_lag, sse=lag_sse, no_effect=LagParams),
    "yaw": GroupModel(fit=fit_yaw, sse=yaw_sse, no_effect=YawParams),
    "current": GroupModel(fit=fit_current, sse=current_sse, no_effect=CurrentParams),
})


def effect_params(name: str, params: LagParams | YawParams | CurrentParams) -> dict[str, float]:
    """The vocabulary parameter of effect ``name`` read from a fitted group model.

    Parameters
    ----------
    name : str
        Effect name (a key of :data:`EFFECT_VOCABULARY`).
    params : LagParams or YawParams or CurrentParams
        Fitted model of the effect's group (every group parameter class names its attributes
        after the vocabulary parameters).

    Returns
    -------
    dict
        ``{EffectSpec.param: value}``, value in :attr:`EffectSpec.unit`.

    Raises
    ------
    KeyError
        ``name`` is not in the vocabulary.
    """
    param = EFFECT_VOCABULARY[name].param
    return {param: getattr(params, param)}


def effect_details(name: str, params: LagParams | YawParams | CurrentParams) -> dict:
    """Secondary quantities of a fitted effect (form, thresholds, reference condition).

    Parameters
    ----------
    name : str
        Effect name (a key of :data:`EFFECT_VOCABULARY`).
    params : LagParams or YawParams or CurrentParams
        Fitted model of the effect's group.

    Returns
    -------
    dict
        ``immobilised``: ``form, chi_mobile, mobile_model, threshold_rad_s, fractions``;
        ``turning_resistance``: ``form, reference``; ``icr_expansion``:
        ``fraction_excluded_immobile``; ``current_offset``: ``offset_left_a,
        offset_right_a, common_a`` (A); ``grade_resistance``: ``n_moving_without_imu``
        (moving samples of runs without IMU left out of its fit), ``n_moving_outside_imu``
        (those of runs with an IMU read outside its record); other effects: empty.
    """
    if name == "immobilised":
        return {"form": params.form, "chi_mobile": params.chi,
                "mobile_model": "kinematic" if params.kinematic else "replay",
                "threshold_rad_s": (None if not np.isfinite(params.threshold_rad_s)
                                    else params.threshold_rad_s),
                "fractions": list(params.fractions)}
    if name == "turning_resistance":
        return {"form": params.form, "reference": (
            f"extra current per side at a commanded yaw rate |v_R - v_L|/B = "
            f"{params.turn_ref_rad_s} rad/s; g = tanh(|x|/{params.coulomb_scale_rad_s})/"
            f"tanh({params.turn_ref_rad_s}/{params.coulomb_scale_rad_s}) (coulomb) or "
            f"|x|/{params.turn_ref_rad_s} (proportional)")}
    if name == "icr_expansion":
        return {"fraction_excluded_immobile": params.fraction}
    if name == "current_offset":
        return {"offset_left_a": params.offset_left_a, "offset_right_a": params.offset_right_a,
                "common_a": params.common_a}
    if name == "grade_resistance":
        return {"n_moving_without_imu": params.n_without_pitch,
                "n_moving_outside_imu": params.n_outside_imu}
    return {}


def effect_cause(name: str, params: LagParams | YawParams | CurrentParams) -> str:
    """The plain-language cause of a fitted effect, in the direction it was fitted.

    :attr:`EffectSpec.cause`, except for a ``turning_resistance`` fitted below zero: the
    measured turns then draw *less* current than the simulated contact model gives, and the
    vocabulary's cause (the current rises by more than the model gives) would contradict
    the fit.

    Parameters
    ----------
    name : str
        Effect name (a key of :data:`EFFECT_VOCABULARY`).
    params : LagParams or YawParams or CurrentParams
        Fitted model of the effect's group.

    Returns
    -------
    str
    """
    if name == "turning_resistance" and params.k_a < 0:
        return ("While turning, the tyres slide sideways against the ground (skid-steer "
                "lateral friction) and the motors supply that scrub torque. Here the "
                "measured turns draw less current than the simulated contact model gives "
                "(k_a < 0): its lateral friction or scrub torque is too high for this ground.")
    return EFFECT_VOCABULARY[name].cause
