"""Longitudinal traction-slip curves ``mu(s)`` and their peaks.

``mu`` is the gross tractive force of a wheel (or track) divided by its normal load, as a
function of the SAE longitudinal slip ``s`` in [-1, 1] (positive when driving; seed 001
eqs. 7.1-7.2). All curves are odd in ``s`` (braking mirrors traction).

Curve families
--------------
:class:`BurckhardtCurve`
    ``mu = c1 (1 - exp(-c2 s)) - c3 s`` (M. Burckhardt, *Fahrwerktechnik:
    Radschlupf-Regelsysteme*, Vogel, 1993; coefficients as tabulated in U. Kiencke and
    L. Nielsen, *Automotive Control Systems*, Springer 2005). Paved, icy and snowy roads.
:class:`JanosiCurve`
    Janosi-Hanamoto shear ``tau = tau_max (1 - exp(-j / K))`` with shear displacement
    ``j = s x`` integrated over a contact of length ``L`` (J. Y. Wong, *Theory of Ground
    Vehicles*, 4th ed., Wiley 2008, ch. 2.4-2.5; seed 003 eqs. 14-17):
    ``mu = mu_max (1 - (k / s)(1 - exp(-s / k)))`` with ``k = K / L`` and
    ``mu_max = tan(phi) + c A / W`` (Mohr-Coulomb).
:class:`BrixiusCurve`
    Brixius (1987) traction equation for tyres on agricultural soils (ASAE paper 87-1622):
    gross traction ratio ``0.88 (1 - exp(-0.1 Bn)) (1 - exp(-7.5 s))`` with the mobility number
    ``Bn``; the motion resistance ratio ``1/Bn + 0.5 s / sqrt(Bn)`` lives in
    :mod:`terrain.terramechanics.resistance`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BurckhardtCurve:
    """Burckhardt tyre-road friction curve.

    Parameters
    ----------
    c1, c2, c3 : float
        Coefficients (dimensionless).
    source : str
    """

    c1: float
    c2: float
    c3: float
    source: str = ""


@dataclass(frozen=True)
class JanosiCurve:
    """Janosi-Hanamoto traction curve averaged over the contact patch.

    Parameters
    ----------
    mu_max : float
        Shear strength over normal load ``tan(phi) + c A / W`` (dimensionless).
    shear_slip : float
        ``k = K / L``: shear deformation modulus over contact length (dimensionless).
    source : str
    """

    mu_max: float
    shear_slip: float
    source: str = ""

    @classmethod
    def from_soil(cls, cohesion_pa: float, friction_angle_deg: float,
                  shear_modulus_m: float, contact_area_m2: float, contact_length_m: float,
                  load_n: float, source: str = "") -> "JanosiCurve":
        """Build the curve from Mohr-Coulomb / Janosi soil parameters and a contact patch.

        Parameters
        ----------
        cohesion_pa : float
            Soil cohesion c, Pa.
        friction_angle_deg : float
            Internal friction angle phi, degrees.
        shear_modulus_m : float
            Shear deformation modulus K, m.
        contact_area_m2 : float
            Contact area A of one wheel or track, m^2.
        contact_length_m : float
            Contact length L, m.
        load_n : float
            Normal load W on that contact, N.
        source : str
        """
        mu_max = np.tan(np.radians(friction_angle_deg)) + cohesion_pa * contact_area_m2 / load_n
        return cls(float(mu_max), shear_modulus_m / contact_length_m, source)


@dataclass(frozen=True)
class BrixiusCurve:
    """Brixius gross traction curve for a given mobility number.

    Parameters
    ----------
    mobility_number : float
        ``Bn`` (dimensionless), see :func:`brixius_mobility_number`.
    source : str
    """

    mobility_number: float
    source: str = ""


TractionCurve = BurckhardtCurve | JanosiCurve | BrixiusCurve


@dataclass(frozen=True)
class TractionPeak:
    """Where a traction-slip curve saturates.

    Parameters
    ----------
    slip : float
        Slip at the maximum of ``mu`` on (0, 1]; for a curve that rises monotonically to
        ``s = 1``, the smallest slip reaching ``saturation`` x the maximum.
    mu : float
        ``mu`` at that slip.
    mu_max : float
        Maximum of ``mu`` on [0, 1].
    monotonic : bool
        Whether the curve has no interior maximum.
    """

    slip: float
    mu: float
    mu_max: float
    monotonic: bool


def brixius_mobility_number(cone_index_pa: float, section_width_m: float,
                            diameter_m: float, load_n: float,
                            deflection_ratio: float = 0.1) -> float:
    """Brixius (1987) mobility number of a pneumatic tyre.

    ``Bn = (CI b d / W) (1 + 5 delta/h) / (1 + 3 b/d)``.

    Parameters
    ----------
    cone_index_pa : float
        Soil cone index CI, Pa.
    section_width_m, diameter_m : float
        Tyre section width b and unloaded diameter d, m.
    load_n : float
        Wheel load W, N.
    deflection_ratio : float
        Tyre deflection over section height delta/h.

    Returns
    -------
    float
    """
    return (cone_index_pa * section_width_m * diameter_m / load_n
            * (1.0 + 5.0 * deflection_ratio) / (1.0 + 3.0 * section_width_m / diameter_m))


def _janosi_g(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``g(x) = 1 - (1 - e^-x)/x`` and ``g'(x)`` for x >= 0, series near 0."""
    small = x < 1e-4
    xs = np.where(small, 1.0, x)
    e = np.exp(-xs)
    g = np.where(small, x / 2.0 - x * x / 6.0, 1.0 - (1.0 - e) / xs)
    dg = np.where(small, 0.5 - x / 3.0, (1.0 - e) / (xs * xs) - e / xs)
    return g, dg


def traction_coefficient(curve: TractionCurve, slip: np.ndarray | float) -> np.ndarray:
    """Gross traction coefficient ``mu(s)``.

    Parameters
    ----------
    curve : TractionCurve
    slip : float or ndarray, shape (...)
        SAE slip, clipped to [-1, 1] (dimensionless).

    Returns
    -------
    ndarray, shape (...)
        ``mu`` (dimensionless), odd in ``slip``.
    """
    return traction_curve_and_slope(curve, slip)[0]


def traction_curve_and_slope(curve: TractionCurve, slip: np.ndarray | float
                             ) -> tuple[np.ndarray, np.ndarray]:
    """``mu(s)`` and its derivative ``d mu / d s``.

    Parameters
    ----------
    curve : TractionCurve
    slip : float or ndarray, shape (...)

    Returns
    -------
    mu : ndarray, shape (...)
    dmu_ds : ndarray, shape (...)
        Zero outside [-1, 1] (the slip is saturated there).
    """
    s_raw = np.asarray(slip, dtype=float)
    s = np.clip(s_raw, -1.0, 1.0)
    a = np.abs(s)
    sign = np.sign(s)
    if isinstance(curve, BurckhardtCurve):
        e = np.exp(-curve.c2 * a)
        mu = curve.c1 * (1.0 - e) - curve.c3 * a
        dmu = curve.c1 * curve.c2 * e - curve.c3
    elif isinstance(curve, JanosiCurve):
        g, dg = _janosi_g(a / curve.shear_slip)
        mu = curve.mu_max * g
        dmu = curve.mu_max * dg / curve.shear_slip
    elif isinstance(curve, BrixiusCurve):
        amp = 0.88 * (1.0 - np.exp(-0.1 * curve.mobility_number))
        e = np.exp(-7.5 * a)
        mu = amp * (1.0 - e)
        dmu = amp * 7.5 * e
    else:  # pragma: no cover - guarded by the type
        raise TypeError(f"unknown traction curve {type(curve).__name__}")
    dmu = np.where(np.abs(s_raw) > 1.0, 0.0, dmu)
    return sign * mu, dmu


def traction_peak(curve: TractionCurve, saturation: float = 0.95) -> TractionPeak:
    """Slip at which the traction-slip curve peaks (the target of traction control).

    Parameters
    ----------
    curve : TractionCurve
    saturation : float
        For curves rising monotonically up to ``s = 1`` (Janosi, Brixius, Burckhardt with
        ``c3 = 0``), the peak is taken as the smallest slip reaching this fraction of the
        maximum (the curve is flat beyond it).

    Returns
    -------
    TractionPeak
    """
    if isinstance(curve, BurckhardtCurve) and curve.c3 > 0:
        s_star = np.log(curve.c1 * curve.c2 / curve.c3) / curve.c2
        if 0.0 < s_star < 1.0:
            mu = float(traction_coefficient(curve, s_star))
            return TractionPeak(float(s_star), mu, mu, False)
    grid = np.linspace(0.0, 1.0, 20001)
    mu = traction_coefficient(curve, grid)
    mu_max = float(mu.max())
    idx = int(np.argmax(mu >= saturation * mu_max))
    return TractionPeak(float(grid[idx]), float(mu[idx]), mu_max, True)


def sae_slip(omega_r_m_s: np.ndarray, v_long_m_s: np.ndarray,
             eps_m_s: float = 1e-3) -> np.ndarray:
    """SAE longitudinal slip (seed 001 eqs. 7.1-7.2), denominator ``max(|omega r|, |v|)``.

    Parameters
    ----------
    omega_r_m_s : ndarray, shape (...)
        Rim speed, m/s.
    v_long_m_s : ndarray, shape (...)
        Longitudinal ground speed of the wheel centre, m/s.
    eps_m_s : float
        Floor of the denominator (avoids 0/0 at standstill; slip 0 there).

    Returns
    -------
    ndarray, shape (...)
        Slip in [-1, 1] (dimensionless).
    """
    wr = np.asarray(omega_r_m_s, dtype=float)
    v = np.asarray(v_long_m_s, dtype=float)
    den = np.maximum(np.maximum(np.abs(wr), np.abs(v)), eps_m_s)
    return np.clip((wr - v) / den, -1.0, 1.0)
