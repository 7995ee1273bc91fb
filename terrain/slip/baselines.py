"""The seed slip models as named baselines (compared with the physics and learned models).

``pitch-linear`` (seed ``003_557e4138a8e06c5e.txt`` eq. 22)
    Steady slip linear in pitch, ``s ~ R_c / C + (W / C) theta_pitch``, the two coefficients
    fitted per terrain by least squares (:func:`fit_pitch_slip`, :func:`pitch_slip`).
``endo`` (seed 003 eq. 27)
    Endo's turning slip ratio ``alpha_l / alpha_r = -sgn(v_r v_l) |v_r / v_l|^n``
    (:func:`terrain.vehicles.skid_steer.endo_slip_ratio_ratio`) closed with the gyro yaw rate:
    ``B yaw_rate = v_r (1 - alpha_r) - v_l (1 - alpha_l)`` gives both slips
    (:func:`endo_turning_slip`); undefined when driving straight.
``observer`` (seed ``000_f24201ff985633bf.txt`` eq. 8)
    The adaptive observer of the track efficiencies ``eta = 1 - i``
    (:func:`terrain.estimation.observer.run_adaptive_observer`) in its yaw-only variant (no
    position sensor on the Husky runs), slip ``1 - eta`` (:func:`observer_slip`).

``endo`` and ``observer`` give the seeds' slip ratio ``alpha = 1 - v / (omega r)``; scored
against the simulator's SAE slip they are first read in its convention
(:func:`slip_ratio_as_sae`).
"""

from __future__ import annotations

import warnings
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np

from terrain.errors import DataWarning, ShapeError, config_positive, refuse_mixed_types
from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer
from terrain.terramechanics.slip import sae_slip
from terrain.vehicles.common import float_arrays
from terrain.vehicles.skid_steer import TRACKED, endo_slip_ratio_ratio


def fit_pitch_slip(pitch_rad: np.ndarray, slip: np.ndarray, terrains: Sequence[str]
                   ) -> Mapping[str, tuple[float, float]]:
    """Least-squares ``slip = a + b pitch`` per terrain (seed 003 eq. 22).

    A terrain whose windows span less than 0.01 rad of pitch gets ``b = 0`` (its mean slip).
    Windows with a non-finite pitch or slip are left out of the fit, counted in a
    :class:`~terrain.errors.DataWarning`.

    Parameters
    ----------
    pitch_rad : ndarray, shape (n,)
        Window pitch, rad.
    slip : ndarray, shape (n,)
        True window slip (dimensionless).
    terrains : sequence of str, length n
        Terrain of each window.

    Returns
    -------
    Mapping str -> (a, b)
        Intercept (dimensionless) and slope (1/rad), read-only.

    Raises
    ------
    ShapeError
        Lengths differ.
    EstimationError
        Booleans (or values that are not numbers) given for the pitch or the slip (a mask
        was fitted as pitches or slips of 0 and 1).
    MixedTypesError
        Values of types that do not sort together (text or booleans beside numbers) in ``terrains``
        (:func:`terrain.errors.refuse_mixed_types`).

    Warns
    -----
    DataWarning
        Windows left out for a non-finite pitch or slip (their count).
    """
    p, s = float_arrays("fit_pitch_slip", pitch_rad=pitch_rad, slip=slip)
    lab = np.asarray(terrains, dtype=object)
    if not (p.shape == s.shape == lab.shape):
        raise ShapeError(f"pitch, slip and terrains differ in length: {p.shape}, {s.shape}, "
                         f"{lab.shape}")
    refuse_mixed_types("fit_pitch_slip", "terrains", lab)   # (NumPy's bare TypeError)
    finite = np.isfinite(p) & np.isfinite(s)
    if not finite.all():
        warnings.warn(f"fit_pitch_slip: {int((~finite).sum())} of {finite.size} windows with a "
                      "non-finite pitch or slip left out of the fit", DataWarning, stacklevel=2)
    out = {}
    for name in np.unique(lab):
        sel = (lab == name) & finite
        if not sel.any():
            continue
        if np.ptp(p[sel]) < 0.01:
            out[str(name)] = (float(np.mean(s[sel])), 0.0)
        else:
            b, a = np.polyfit(p[sel], s[sel], 1)
            out[str(name)] = (float(a), float(b))
    return MappingProxyType(out)


def pitch_slip(coefficients: Mapping[str, tuple[float, float]], pitch_rad: np.ndarray,
               terrains: Sequence[str]) -> np.ndarray:
    """Slip of the eq. 22 model for windows of known terrain.

    Parameters
    ----------
    coefficients : Mapping str -> (a, b)
        From :func:`fit_pitch_slip`.
    pitch_rad : ndarray, shape (n,)
        Pitch, rad.
    terrains : sequence of str, length n
        Terrain of each window.

    Returns
    -------
    ndarray, shape (n,)
        Slip (NaN for a terrain without coefficients).

    Raises
    ------
    ShapeError
        ``terrains`` has another shape than ``pitch_rad`` (one bare string is not a terrain
        for every window).
    EstimationError
        Booleans (or values that are not numbers) given for the pitch.
    """
    p, = float_arrays("pitch_slip", pitch_rad=pitch_rad)
    out = np.full(p.shape, np.nan)
    lab = np.asarray(terrains, dtype=object)
    if lab.shape != p.shape:    # a numpy IndexError, or one string's line on every window
        raise ShapeError(f"pitch_slip: terrains has shape {lab.shape} for pitch_rad of shape "
                         f"{p.shape} (one terrain per window)")
    for name, (a, b) in coefficients.items():
        sel = lab == name
        out[sel] = a + b * p[sel]
    return out


def endo_turning_slip(v_left_m_s: np.ndarray, v_right_m_s: np.ndarray,
                      yaw_rate_rad_s: np.ndarray, track_m: float,
                      n: float = TRACKED.slip_parameter_n, min_turn_rad_s: float = 0.1
                      ) -> np.ndarray:
    """Left and right slip from Endo's ratio (seed 003 eq. 27) and the measured yaw rate.

    ``alpha_l = rho alpha_r`` with ``rho`` of eq. 27, and
    ``B yaw_rate = v_r (1 - alpha_r) - v_l (1 - alpha_l)``, so
    ``alpha_r = (v_r - v_l - B yaw_rate) / (v_r - rho v_l)``.

    Parameters
    ----------
    v_left_m_s, v_right_m_s : ndarray, shape (n,)
        Side rim speeds, m/s.
    yaw_rate_rad_s : ndarray, shape (n,)
        Gyro yaw rate, rad/s.
    track_m : float
        Track B, m (finite, > 0).
    n : float
        Endo's exponent (default the seed's 0.847, Table 2).
    min_turn_rad_s : float
        Below this |yaw rate|, rad/s, finite and >= 0 (or with a zero side speed) the slips
        are NaN (straight driving leaves eq. 27 undetermined).

    Returns
    -------
    ndarray, shape (n, 2)
        ``alpha_l, alpha_r`` clipped to [-1, 1].

    Raises
    ------
    ConfigError
        ``track_m`` not a finite number > 0 or ``min_turn_rad_s`` not a finite number >= 0
        (:func:`terrain.errors.config_positive`).
    ShapeError
        Speeds and yaw rate of shapes that do not broadcast (their shapes are named).

    Warns
    -----
    DataWarning
        Slips outside [-1, 1] (a yaw rate the wheel speeds cannot give under eq. 27, e.g.
        against their turn) were clipped (their count of the defined slips).
    """
    config_positive("endo_turning_slip", track_m=track_m)  # B yaw_rate closes eq. 27
    # (NaN made every window "not turning": every slip NaN without a word)
    config_positive("endo_turning_slip", allow_zero=True, min_turn_rad_s=min_turn_rad_s)
    vl = np.asarray(v_left_m_s, dtype=float)
    vr = np.asarray(v_right_m_s, dtype=float)
    w = np.asarray(yaw_rate_rad_s, dtype=float)
    try:
        np.broadcast_shapes(vl.shape, vr.shape, w.shape)
    except ValueError:      # a bare numpy broadcast error before
        raise ShapeError(f"endo_turning_slip: v_left_m_s, v_right_m_s and yaw_rate_rad_s must "
                         f"share a shape (n,), got {vl.shape}, {vr.shape}, {w.shape}") from None
    ok = (np.abs(w) >= min_turn_rad_s) & (np.abs(vl) > 1e-3) & (np.abs(vr) > 1e-3)
    rho = endo_slip_ratio_ratio(np.where(ok, vl, 1.0), np.where(ok, vr, 1.0), n)
    den = vr - rho * vl
    ok &= np.abs(den) > 1e-6
    a_r = np.where(ok, (vr - vl - track_m * w) / np.where(ok, den, 1.0), np.nan)
    alpha = np.column_stack([rho * a_r, a_r])
    out = np.abs(alpha) > 1.0
    if out.any():
        warnings.warn(f"endo_turning_slip: {int(out.sum())} of {int(ok.sum()) * 2} slips "
                      "outside [-1, 1] clipped to it (a yaw rate the wheel speeds cannot give "
                      "under eq. 27)", DataWarning, stacklevel=2)
    return np.clip(alpha, -1.0, 1.0)


def observer_slip(t_s: np.ndarray, yaw_rad: np.ndarray, v_left_m_s: np.ndarray,
                  v_right_m_s: np.ndarray, half_track_m: float) -> np.ndarray:
    """Slip ``1 - eta`` of the seed 000 adaptive observer, yaw-only (no position sensor).

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Strictly increasing times, s.
    yaw_rad : ndarray, shape (N,)
        Heading (integral of the gyro yaw rate), rad.
    v_left_m_s, v_right_m_s : ndarray, shape (N,)
        Side rim speeds, m/s.
    half_track_m : float
        Half track d, m.

    Returns
    -------
    ndarray, shape (N, 2)
        ``1 - eta_L, 1 - eta_R`` (left, right).

    Raises
    ------
    ConfigError
        ``half_track_m`` not a finite number > 0 (:func:`terrain.errors.config_positive`;
        text or a list raised a bare TypeError), or other bad observer settings.
    """
    config_positive("observer_slip", half_track_m=half_track_m)
    pose = np.column_stack([np.full(len(t_s), np.nan), np.full(len(t_s), np.nan), yaw_rad])
    res = run_adaptive_observer(t_s, pose, v_right_m_s, v_left_m_s,
                                AdaptiveObserverSettings(half_track_m=half_track_m,
                                                         use_position=False))
    return np.column_stack([1.0 - res.eta_left, 1.0 - res.eta_right])


def slip_ratio_as_sae(rim_speed_m_s: np.ndarray, slip_ratio: np.ndarray) -> np.ndarray:
    """The seeds' slip ratio as the SAE slip of the simulator's truth.

    Seed 003 (eqs. 3-4, Endo's eq. 27) and seed 000 (``1 - eta``) define the slip ratio
    ``alpha = 1 - v / (omega r)``: relative to the rim speed whatever the sign of the slip.
    The SAE slip (seed 001 eqs. 7.1-7.2, :func:`terrain.terramechanics.slip.sae_slip`)
    divides by the larger of the two speeds and is signed by the direction of travel, so
    the two agree only in forward traction: braking (rim 0.8 m/s, ground 1.0 m/s) is
    ``alpha = -0.25`` but SAE -0.20, and reversing in traction (rim -0.3, ground -0.2) is
    ``alpha = +0.33`` but SAE -0.33. The ground speed ``v = omega r (1 - alpha)`` is
    recovered and its SAE slip taken (no dead band: only the convention changes).

    Parameters
    ----------
    rim_speed_m_s : ndarray, shape (...)
        Rim speed ``omega r`` of each side, m/s.
    slip_ratio : ndarray, shape (...)
        ``alpha`` of the same sides (broadcast with ``rim_speed_m_s``), dimensionless; NaN
        stays NaN.

    Returns
    -------
    ndarray, shape (...)
        SAE slip in [-1, 1], dimensionless; 0 where the rim is still (``v = 0`` too).
    """
    rim = np.asarray(rim_speed_m_s, dtype=float)
    return sae_slip(rim, rim * (1.0 - np.asarray(slip_ratio, dtype=float)), dead_band_m_s=0.0)
