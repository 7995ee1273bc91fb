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
    ``mu_max = tan(phi) + c A / W`` (Mohr-Coulomb). Seed 003 prints eqs. 17 and 19 as
    ``1 - (K / (s l)) exp(-s l / K)``, without the ``1 -`` before the exponential: a
    misprint (the mean of ``1 - exp(-s x / K)`` over ``0 <= x <= l`` is Wong's form, used
    here; the printed one falls to minus infinity as ``s -> 0`` instead of to 0). With a
    ``residual_ratio`` the shear follows Wong's hump-type curve instead, which peaks and falls
    to a residual strength (snow covers and organic terrain, Wong ch. 2.4;
    :func:`patch_mobilisation`).
:class:`BrixiusCurve`
    Brixius (1987) traction equations for tyres on agricultural soils (ASAE paper 87-1622):
    gross traction ratio ``0.88 (1 - exp(-0.1 Bn)) (1 - exp(-7.5 s)) + 0.04`` and motion
    resistance ratio ``1/Bn + 0.04 + 0.5 s / sqrt(Bn)`` with the mobility number ``Bn``; the
    curve uses both without their 0.04 tyre-hysteresis term, which cancels in the net
    traction and is part of the terrain's torque-only ``hysteresis``
    (:func:`brixius_traction`).

Each relation is one function (:func:`burckhardt_traction`, :func:`janosi_traction`,
:func:`brixius_traction`, :func:`brixius_motion_resistance`); each curve is a frozen parameter
dataclass satisfying the :class:`TractionCurve` protocol (one method, ``coefficients``), so
callers never dispatch on the curve type. :class:`TractionAndResistance` pairs the traction
of one curve with the motion resistance of another (physics v2 of the simulator).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numba
import numpy as np
from scipy.optimize import minimize_scalar

from terrain.errors import (ConfigError, DataFormatError, ShapeError, config_fraction,
                            config_numbers, config_positive)


class CurveCoefficients(NamedTuple):
    """Longitudinal coefficients of a contact at slip magnitudes ``|s|`` (arrays, shape (...)).

    Attributes
    ----------
    mu : ndarray
        Gross traction coefficient ``mu(|s|)`` (force over normal load), >= 0.
    dmu_ds : ndarray
        ``d mu / d|s|``.
    resistance : ndarray
        Slip-producing motion resistance coefficient (soil compaction / bulldozing).
    dresistance_ds : ndarray
        ``d resistance / d|s|``.
    """

    mu: np.ndarray
    dmu_ds: np.ndarray
    resistance: np.ndarray
    dresistance_ds: np.ndarray


class TractionCurve(Protocol):  # noqa: D101 - documented below
    """What the simulator and the terramechanics relations need of a traction-slip curve.

    A curve is a frozen, cited parameter dataclass with one method; the equations are the
    module-level functions (:func:`burckhardt_traction`, :func:`janosi_traction`,
    :func:`brixius_traction`, :func:`brixius_motion_resistance`). The project's curves also
    have its two halves, ``traction_terms(abs_slip)`` and ``resistance_terms(abs_slip,
    soil_resistance)``, so that a curve built of two (:class:`TractionAndResistance`) does
    not compute the half it drops (:func:`curve_traction_terms`,
    :func:`curve_resistance_terms`).
    """

    def coefficients(self, abs_slip: np.ndarray, soil_resistance: float) -> CurveCoefficients:
        """Coefficients at slip magnitudes ``abs_slip`` in [0, 1].

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            ``|s|``, dimensionless, in [0, 1].
        soil_resistance : float
            The terrain's constant motion resistance coefficient
            (:attr:`TerrainParams.soil_resistance`); curves with their own resistance law
            (Brixius) ignore it.

        Returns
        -------
        CurveCoefficients
        """
        ...  # pragma: no cover - protocol


def burckhardt_traction(abs_slip: np.ndarray, c1: float, c2: float, c3: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Burckhardt ``mu = c1 (1 - exp(-c2 s)) - c3 s`` and its slope, ``s = |slip|``.

    Source: M. Burckhardt, *Fahrwerktechnik: Radschlupf-Regelsysteme*, Vogel 1993
    (coefficients tabulated in Kiencke & Nielsen, *Automotive Control Systems*, 2005).

    Parameters
    ----------
    abs_slip : ndarray, shape (...)
        Slip magnitude in [0, 1].
    c1, c2, c3 : float
        Burckhardt coefficients (dimensionless).

    Returns
    -------
    mu, dmu_ds : ndarray, shape (...)
    """
    # 1 - exp(-c2 s) as -expm1: written out it lost its digits at small slip and rounded to
    # 0 below c2 s ~ 1e-16, leaving -c3 s, a traction against the slip
    x = -c2 * np.asarray(abs_slip, dtype=float)
    return c1 * -np.expm1(x) - c3 * abs_slip, c1 * c2 * np.exp(x) - c3


def janosi_traction(abs_slip: np.ndarray, mu_max: float, shear_slip: float,
                    residual_ratio: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Janosi-Hanamoto traction averaged over the contact, ``mu = mu_max g(s / k)``.

    ``g(x) = 1 - (1 - e^-x) / x`` (Wong, *Theory of Ground Vehicles*, 4th ed., ch. 2.4-2.5;
    seed 003 eqs. 14-17), or the patch mean of Wong's hump-type shear curve when
    ``residual_ratio`` is given (:func:`patch_mobilisation`).

    Parameters
    ----------
    abs_slip : ndarray, shape (...)
        Slip magnitude in [0, 1].
    mu_max : float
        Shear strength over normal load (dimensionless).
    shear_slip : float
        ``k = K / L`` (dimensionless), > 0.
    residual_ratio : float or None
        Residual over peak shear strength ``K_r`` in (0, 1) of the hump-type curve; None =
        the exponential Janosi-Hanamoto curve.

    Returns
    -------
    mu, dmu_ds : ndarray, shape (...)
    """
    g, dg = patch_mobilisation(abs_slip / shear_slip, residual_ratio)
    return mu_max * g, mu_max * dg / shear_slip


def brixius_traction(abs_slip: np.ndarray, mobility_number: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Brixius (1987) gross traction ratio less its tyre-hysteresis term.

    Source form (Brixius, ASAE paper 87-1622): gross traction ratio
    ``GT = 0.88 (1 - e^(-0.1 Bn)) (1 - e^(-7.5 s)) + 0.04`` and motion resistance ratio
    ``MR = 1/Bn + 0.04 + 0.5 s / sqrt(Bn)``, net traction ratio ``NT = GT - MR``. This
    function returns ``GT - 0.04 = 0.88 (1 - e^(-0.1 Bn)) (1 - e^(-7.5 s))`` and
    :func:`brixius_motion_resistance` returns ``MR - 0.04``: the 0.04 is the tyre's rolling
    (hysteresis) loss, present in both, so it cancels in the net traction, which is Brixius's
    ``NT`` exactly. It reappears in the wheel torque ``r W (GT - 0.04 + h)`` through the
    terrain's torque-only ``hysteresis`` ``h``, calibrated to the measured Husky currents
    (0.12-0.21 on the catalogue's Brixius terrains, so it holds Brixius's 0.04 plus drive-train
    losses; :mod:`terrain.terramechanics.calibration`).

    Parameters
    ----------
    abs_slip : ndarray, shape (...)
        Slip magnitude in [0, 1].
    mobility_number : float
        ``Bn`` (dimensionless), :func:`brixius_mobility_number`.

    Returns
    -------
    mu, dmu_ds : ndarray, shape (...)
    """
    # 1 - exp(-x) as -expm1, as in burckhardt_traction: written out it lost its digits at
    # small slip (8e-8 of mu at s = 1e-10, 48 % at 1e-17), so the friction ellipse's secant
    # mu / s jumped where it switches to the slope at 0
    amp = 0.88 * -np.expm1(-0.1 * mobility_number)
    x = -7.5 * np.asarray(abs_slip, dtype=float)
    return amp * -np.expm1(x), amp * 7.5 * np.exp(x)


def brixius_motion_resistance(abs_slip: np.ndarray, mobility_number: float
                              ) -> tuple[np.ndarray, np.ndarray]:
    """Soil part of the Brixius (1987) motion resistance ratio ``1/Bn + 0.5 s / sqrt(Bn)``.

    Brixius's ratio is ``1/Bn + 0.04 + 0.5 s / sqrt(Bn)``; its 0.04 tyre-hysteresis term is
    left out here and in :func:`brixius_traction` alike (it cancels in the net traction) and
    is part of :attr:`TerrainParams.hysteresis` (torque only, no slip).

    Parameters
    ----------
    abs_slip : ndarray, shape (...)
        Slip magnitude in [0, 1].
    mobility_number : float
        ``Bn`` (dimensionless).

    Returns
    -------
    resistance, dresistance_ds : ndarray, shape (...)
    """
    # float arrays of the slip's shape: np.full_like would take an integer slip's dtype
    # and truncate the slope to 0
    return (1.0 / mobility_number + 0.5 * abs_slip / np.sqrt(mobility_number),
            np.full(np.shape(abs_slip), 0.5 / np.sqrt(mobility_number)))


def _constant(abs_slip: np.ndarray, value: float) -> tuple[np.ndarray, np.ndarray]:
    """``value`` and a zero slope at every slip, as float arrays of the slip's shape (an
    integer slip such as ``np.array([0, 1])`` must not truncate ``value`` to 0)."""
    shape = np.shape(abs_slip)
    constant = np.empty(shape)
    constant.fill(float(value))     # np.full's values, without its Python wrapper
    return constant, np.zeros(shape)


class TwoHalves:
    """Mixin of the curves whose coefficients are their two halves side by side
    (:class:`BurckhardtCurve`, :class:`JanosiCurve`, :class:`BrixiusCurve`): their
    ``coefficients``, from the ``traction_terms`` and ``resistance_terms`` each class
    defines with its own equations."""

    def coefficients(self, abs_slip: np.ndarray, soil_resistance: float) -> CurveCoefficients:
        """Coefficients at slip magnitudes ``abs_slip``: the curve's ``traction_terms``
        (its traction equation) and ``resistance_terms`` (its motion resistance law).

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].
        soil_resistance : float
            Constant motion resistance coefficient of the terrain (ignored by a curve with
            its own resistance law: Brixius).

        Returns
        -------
        CurveCoefficients
        """
        return CurveCoefficients(*self.traction_terms(abs_slip),
                                 *self.resistance_terms(abs_slip, soil_resistance))


class ConstantResistance(TwoHalves):
    """Mixin of the curves whose motion resistance is the terrain's constant coefficient
    (:class:`BurckhardtCurve`, :class:`JanosiCurve`): their ``resistance_terms``."""

    def resistance_terms(self, abs_slip: np.ndarray, soil_resistance: float
                         ) -> tuple[np.ndarray, np.ndarray]:
        """The resistance half of ``coefficients``: the terrain's constant resistance.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].
        soil_resistance : float
            Constant motion resistance coefficient of the terrain.

        Returns
        -------
        resistance, dresistance_ds : ndarray, shape (...)
        """
        return _constant(abs_slip, soil_resistance)


@dataclass(frozen=True)
class BurckhardtCurve(ConstantResistance):
    """Burckhardt tyre-road friction curve.

    Parameters
    ----------
    c1, c2, c3 : float
        Coefficients (dimensionless): ``c1``, ``c2`` finite and > 0, ``c3`` finite and >= 0,
        ``c1 c2 > c3`` (the slope ``d mu / d s = c1 c2 - c3`` at ``s = 0``) and
        ``c1 (1 - exp(-c2)) >= c3`` (``mu(1) >= 0``: the traction never turns against the
        slip).
    source : str
        Citation of the coefficients.

    Raises
    ------
    ConfigError
        A coefficient outside its range (``mu`` would not rise from 0 at ``s = 0``, would turn
        negative before full slip, or NaN).
    """

    c1: float
    c2: float
    c3: float
    source: str = ""

    def __post_init__(self) -> None:
        config_positive("BurckhardtCurve", c1=self.c1, c2=self.c2)
        config_positive("BurckhardtCurve", allow_zero=True, c3=self.c3)
        if not self.c1 * self.c2 > self.c3:
            raise ConfigError(f"BurckhardtCurve: need c1 c2 > c3 (mu must rise from 0 at s = 0: "
                              f"slope c1 c2 - c3), got c1 c2 = {self.c1 * self.c2} and c3 = "
                              f"{self.c3}")
        # the curve is concave: mu >= 0 on [0, 1] exactly when mu(1) >= 0
        mu_full = self.c1 * -math.expm1(-self.c2) - self.c3
        if not mu_full >= 0.0:
            raise ConfigError(f"BurckhardtCurve: need mu(1) = c1 (1 - exp(-c2)) - c3 >= 0 (a "
                              f"traction against the slip pushes a spinning wheel's body "
                              f"backward), got mu(1) = {mu_full:.6g} for {self.c1}, {self.c2}, "
                              f"{self.c3}")

    def traction_terms(self, abs_slip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The traction half of ``coefficients`` (:class:`TwoHalves`):
        :func:`burckhardt_traction`.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].

        Returns
        -------
        mu, dmu_ds : ndarray, shape (...)
        """
        return burckhardt_traction(abs_slip, self.c1, self.c2, self.c3)


@dataclass(frozen=True)
class JanosiCurve(ConstantResistance):
    """Janosi-Hanamoto traction curve averaged over the contact patch.

    Parameters
    ----------
    mu_max : float
        Shear strength over normal load ``tan(phi) + c A / W`` (dimensionless).
    shear_slip : float
        ``k = K / L``: shear deformation modulus over contact length (dimensionless).
    source : str
        Citation of the coefficients.
    residual_ratio : float or None
        ``K_r`` of Wong's hump-type shear curve (residual over peak strength, in (0, 1));
        None = the exponential Janosi-Hanamoto curve (:func:`patch_mobilisation`).

    Raises
    ------
    ConfigError
        A value that is not a real number (text, a boolean, ``None`` but for
        ``residual_ratio``), ``mu_max`` is negative or not finite, ``shear_slip`` is not a
        finite value > 0, or ``residual_ratio`` is outside (0, 1).
    """

    mu_max: float
    shear_slip: float
    source: str = ""
    residual_ratio: float | None = None

    def __post_init__(self) -> None:
        config_numbers("JanosiCurve", optional=("residual_ratio",), mu_max=self.mu_max,
                       shear_slip=self.shear_slip, residual_ratio=self.residual_ratio)
        if not (np.isfinite(self.mu_max) and self.mu_max >= 0.0):
            raise ConfigError(f"JanosiCurve.mu_max must be a finite value >= 0, got "
                              f"{self.mu_max}")
        if not (np.isfinite(self.shear_slip) and self.shear_slip > 0.0):
            raise ConfigError(f"JanosiCurve.shear_slip (K/L) must be a finite value > 0, got "
                              f"{self.shear_slip}")
        if self.residual_ratio is not None and not 0.0 < self.residual_ratio < 1.0:
            raise ConfigError(f"JanosiCurve.residual_ratio must be in (0, 1) or None, got "
                              f"{self.residual_ratio}")

    def traction_terms(self, abs_slip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The traction half of ``coefficients`` (:class:`TwoHalves`):
        :func:`janosi_traction`.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].

        Returns
        -------
        mu, dmu_ds : ndarray, shape (...)
        """
        return janosi_traction(abs_slip, self.mu_max, self.shear_slip, self.residual_ratio)

    @classmethod
    def from_soil(cls, cohesion_pa: float, friction_angle_deg: float,
                  shear_modulus_m: float, contact_area_m2: float, contact_length_m: float,
                  load_n: float, source: str = "",
                  residual_ratio: float | None = None) -> "JanosiCurve":
        """Build the curve from Mohr-Coulomb / Janosi soil parameters and a contact patch.

        Parameters
        ----------
        cohesion_pa : float
            Soil cohesion c, Pa (>= 0).
        friction_angle_deg : float
            Internal friction angle phi, degrees, in [0, 90).
        shear_modulus_m : float
            Shear deformation modulus K, m (> 0).
        contact_area_m2 : float
            Contact area A of one wheel or track, m^2 (> 0).
        contact_length_m : float
            Contact length L, m.
        load_n : float
            Normal load W on that contact, N.
        source : str
            Citation of the soil parameters.
        residual_ratio : float or None
            ``K_r`` of the hump-type shear curve; None = exponential (see the class).

        Returns
        -------
        JanosiCurve
            ``mu_max = tan(phi) + c A / W``, ``shear_slip = K / L``.

        Raises
        ------
        ConfigError
            ``load_n`` is not a finite load > 0 (``c A / W`` has no value),
            ``contact_length_m`` not a finite length > 0 (``K / L`` has none),
            ``cohesion_pa`` negative or not finite, ``friction_angle_deg`` outside [0, 90)
            (``tan phi`` is infinite at 90 and negative beyond), ``shear_modulus_m`` or
            ``contact_area_m2`` not a finite value > 0, or the curve's own checks fail;
            each message names the field.
        """
        config_numbers("JanosiCurve.from_soil", cohesion_pa=cohesion_pa,
                       friction_angle_deg=friction_angle_deg, shear_modulus_m=shear_modulus_m,
                       contact_area_m2=contact_area_m2, contact_length_m=contact_length_m,
                       load_n=load_n)
        if not (np.isfinite(cohesion_pa) and cohesion_pa >= 0.0):
            raise ConfigError(f"JanosiCurve.from_soil: cohesion_pa must be a finite cohesion "
                              f">= 0 Pa, got {cohesion_pa}")
        if not 0.0 <= friction_angle_deg < 90.0:
            raise ConfigError(f"JanosiCurve.from_soil: friction_angle_deg must be in [0, 90) "
                              f"degrees, got {friction_angle_deg}")
        for key, value, unit in (("shear_modulus_m", shear_modulus_m, "m"),
                                 ("contact_area_m2", contact_area_m2, "m^2")):
            if not (np.isfinite(value) and value > 0.0):
                raise ConfigError(f"JanosiCurve.from_soil: {key} must be a finite value "
                                  f"> 0 {unit}, got {value}")
        if not (np.isfinite(load_n) and load_n > 0.0):
            raise ConfigError(f"JanosiCurve.from_soil: load_n must be a finite load > 0 N, "
                              f"got {load_n}")
        if not (np.isfinite(contact_length_m) and contact_length_m > 0.0):
            raise ConfigError(f"JanosiCurve.from_soil: contact_length_m must be a finite "
                              f"length > 0 m, got {contact_length_m}")
        mu_max = np.tan(np.radians(friction_angle_deg)) + cohesion_pa * contact_area_m2 / load_n
        return cls(float(mu_max), shear_modulus_m / contact_length_m, source, residual_ratio)


@dataclass(frozen=True)
class BrixiusCurve(TwoHalves):
    """Brixius gross traction curve for a given mobility number.

    Parameters
    ----------
    mobility_number : float
        ``Bn`` (dimensionless, finite and > 0), see :func:`brixius_mobility_number`.
    source : str
        Citation of the coefficients.

    Raises
    ------
    ConfigError
        ``mobility_number`` not a finite number > 0 (the curve divides by it).
    """

    mobility_number: float
    source: str = ""

    def __post_init__(self) -> None:
        config_numbers("BrixiusCurve", mobility_number=self.mobility_number)
        if not (np.isfinite(self.mobility_number) and self.mobility_number > 0.0):
            raise ConfigError(f"BrixiusCurve.mobility_number must be a finite number > 0, got "
                              f"{self.mobility_number}")

    def traction_terms(self, abs_slip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The traction half of ``coefficients`` (:class:`TwoHalves`):
        :func:`brixius_traction`.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].

        Returns
        -------
        mu, dmu_ds : ndarray, shape (...)
        """
        return brixius_traction(abs_slip, self.mobility_number)

    def resistance_terms(self, abs_slip: np.ndarray, soil_resistance: float
                         ) -> tuple[np.ndarray, np.ndarray]:
        """The resistance half of ``coefficients`` (:class:`TwoHalves`):
        :func:`brixius_motion_resistance`.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].
        soil_resistance : float
            Ignored: Brixius curves carry their own motion resistance.

        Returns
        -------
        resistance, dresistance_ds : ndarray, shape (...)
        """
        return brixius_motion_resistance(abs_slip, self.mobility_number)


@dataclass(frozen=True)
class TractionAndResistance:
    """Gross traction of one curve with the motion-resistance law of another.

    Physics v2 of the simulator replaces a catalogue terrain's traction curve by the
    Janosi-Hanamoto curve of its soil (:func:`terrain.terramechanics.lateral.longitudinal_curve`)
    but keeps the terrain's motion resistance. When that resistance lives inside the catalogue
    curve (Brixius: ``1/Bn + 0.5 s / sqrt(Bn)``, :func:`brixius_motion_resistance`) rather than
    in the terrain's constant ``soil_resistance``, swapping the curve alone would drop it; this
    curve takes ``mu`` and ``d mu / d|s|`` from ``traction`` and the resistance terms from
    ``resistance``, each curve applying its own law (no equation here).

    Parameters
    ----------
    traction : TractionCurve
        Curve giving the gross traction coefficient and its slope.
    resistance : TractionCurve
        Curve giving the motion resistance coefficient and its slope (with the terrain's
        constant ``soil_resistance`` where its law is that constant).
    source : str
        Citation (the two curves' sources).

    Raises
    ------
    ConfigError
        ``traction`` or ``resistance`` not a traction curve (no ``coefficients`` method),
        named ``TractionAndResistance.<field>``.
    """

    traction: TractionCurve
    resistance: TractionCurve
    source: str = ""

    def __post_init__(self) -> None:
        """Refuse parts that are not traction curves (a terrain name, None: an
        AttributeError naming no field at the first use), naming the field."""
        for name in ("traction", "resistance"):
            part = getattr(self, name)
            if not callable(getattr(part, "coefficients", None)):
                raise ConfigError(f"TractionAndResistance.{name} must be a traction curve "
                                  f"(BurckhardtCurve, JanosiCurve, BrixiusCurve...), got "
                                  f"{part!r:.80}")

    def coefficients(self, abs_slip: np.ndarray, soil_resistance: float) -> CurveCoefficients:
        """``mu`` of :attr:`traction`, resistance of :attr:`resistance`.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].
        soil_resistance : float
            Constant motion resistance coefficient of the terrain, passed to both curves.

        Returns
        -------
        CurveCoefficients
        """
        return CurveCoefficients(*curve_traction_terms(self.traction, abs_slip, soil_resistance),
                                 *self.resistance_terms(abs_slip, soil_resistance))

    def resistance_terms(self, abs_slip: np.ndarray, soil_resistance: float
                         ) -> tuple[np.ndarray, np.ndarray]:
        """The resistance half of :meth:`coefficients`, that of :attr:`resistance`.

        Its ``resistance_terms`` where it has one (the curves of this module and
        :class:`~terrain.terramechanics.lateral.SlipCompactionResistance`: its traction is
        not computed only to be dropped), else the last two of its ``coefficients``.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].
        soil_resistance : float
            Constant motion resistance coefficient of the terrain.

        Returns
        -------
        resistance, dresistance_ds : ndarray, shape (...)
        """
        return curve_resistance_terms(self.resistance, abs_slip, soil_resistance)

    def traction_terms(self, abs_slip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The traction half of :meth:`coefficients`, that of :attr:`traction`.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].

        Returns
        -------
        mu, dmu_ds : ndarray, shape (...)
        """
        return curve_traction_terms(self.traction, abs_slip, 0.0)


def curve_traction_terms(curve: TractionCurve, abs_slip: np.ndarray, soil_resistance: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Traction coefficient of a curve and its slope, without its motion resistance.

    ``curve.traction_terms`` where the curve has that method (every curve of the project),
    else ``curve.coefficients(...)[:2]`` (a curve that only meets :class:`TractionCurve`).

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve.
    abs_slip : ndarray, shape (...)
        Slip magnitude in [0, 1].
    soil_resistance : float
        Constant motion resistance coefficient of the terrain (for ``coefficients``).

    Returns
    -------
    mu, dmu_ds : ndarray, shape (...)
    """
    terms = getattr(curve, "traction_terms", None)
    if terms is None:
        return tuple(curve.coefficients(abs_slip, soil_resistance)[:2])
    return terms(abs_slip)


def curve_resistance_terms(curve: TractionCurve, abs_slip: np.ndarray,
                           soil_resistance: float) -> tuple[np.ndarray, np.ndarray]:
    """Motion resistance coefficient of a curve and its slope, without its traction.

    ``curve.resistance_terms`` where the curve has that method (every curve of the
    project), else ``curve.coefficients(...)[2:]`` (a curve that only meets
    :class:`TractionCurve`).

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve.
    abs_slip : ndarray, shape (...)
        Slip magnitude in [0, 1].
    soil_resistance : float
        Constant motion resistance coefficient of the terrain.

    Returns
    -------
    resistance, dresistance_ds : ndarray, shape (...)
    """
    terms = getattr(curve, "resistance_terms", None)
    if terms is None:
        return tuple(curve.coefficients(abs_slip, soil_resistance)[2:])
    return terms(abs_slip, soil_resistance)


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
        Wheel load W, N (> 0: the number of an unloaded tyre is undefined).
    deflection_ratio : float
        Tyre deflection over section height delta/h, in [0, 1).

    Returns
    -------
    float
        ``Bn`` (dimensionless, > 0).

    Raises
    ------
    ConfigError
        A value that is not a real number, ``cone_index_pa``, ``section_width_m``,
        ``diameter_m`` or ``load_n`` not a finite value > 0 (a zero load divided by zero), or
        ``deflection_ratio`` outside [0, 1).
    """
    config_numbers("brixius_mobility_number", cone_index_pa=cone_index_pa,
                   section_width_m=section_width_m, diameter_m=diameter_m, load_n=load_n,
                   deflection_ratio=deflection_ratio)
    config_positive("brixius_mobility_number", cone_index_pa=cone_index_pa,
                    section_width_m=section_width_m, diameter_m=diameter_m, load_n=load_n)
    if not 0.0 <= deflection_ratio < 1.0:
        raise ConfigError(f"brixius_mobility_number: deflection_ratio (delta/h) must be in "
                          f"[0, 1), got {deflection_ratio}")
    return (cone_index_pa * section_width_m * diameter_m / load_n
            * (1.0 + 5.0 * deflection_ratio) / (1.0 + 3.0 * section_width_m / diameter_m))


@numba.njit(cache=True)
def _mobilisation_kernel(a: np.ndarray, kr: float, b: float, s0: float, c2: float,
                         g: np.ndarray, dg: np.ndarray) -> None:
    """Patch means and slopes of :func:`patch_mobilisation`, element by element (compiled).

    ``kr <= 0``: the exponential curve, ``g(x) = 1 - (1 - e^-x) / x``, ``g'(x)``; else the
    hump-type curve with the constants of :func:`_hump_constants`. Below ``1e-4`` (of
    ``a``, resp. ``U``) the second-order series, where the closed forms lose their digits.
    Written into ``g`` and ``dg`` (1-D, the size of ``a``), allocated by the caller: two
    arrays and a tuple returned cost more than the arithmetic on a vehicle's contacts.
    """
    for i in range(a.size):
        x = a[i]
        if kr <= 0.0:
            if x < 1e-4:
                g[i] = x / 2.0 - x * x / 6.0
                dg[i] = 0.5 - x / 3.0
            else:
                one_minus_e = -math.expm1(-x)
                g[i] = 1.0 - one_minus_e / x
                dg[i] = one_minus_e / (x * x) - (1.0 - one_minus_e) / x
            continue
        u = x / s0
        if u < 1e-4:
            g[i] = s0 * u / 2.0 - c2 * u * u / 3.0
            dg[i] = (s0 / 2.0 - 2.0 * c2 * u / 3.0) / s0
        else:
            e1 = -math.expm1(-u)                     # 1 - e^-U
            e2 = -math.expm1(-2.0 * u)               # 1 - e^-2U
            mean = kr * (u - e1 + b * math.e * (e1 - 0.5 * e2)) / u
            f_u = kr * (1.0 + b * math.exp(1.0 - u)) * e1
            g[i] = mean
            dg[i] = (f_u - mean) / u / s0


@functools.lru_cache(maxsize=32)
def _hump_constants(kr: float) -> tuple[float, float, float]:
    """``(B, s0, c)`` of the hump-type curve with residual ratio ``kr``
    (:func:`patch_mobilisation`): ``B = 1 / (K_r (1 - 1/e)) - 1``, ``f'(0) = s0 =
    K_r (1 + B e)`` and the series coefficient near 0, ``f(u) = s0 u - c u^2 + ...``,
    ``c = K_r (1/2 + 3 B e / 2)``."""
    b = 1.0 / (kr * (1.0 - np.exp(-1.0))) - 1.0
    return b, kr * (1.0 + b * np.e), kr * (0.5 + 1.5 * b * np.e)


def patch_mobilisation(a: np.ndarray, residual_ratio: float | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Mean shear mobilisation over a patch sheared linearly from 0 to ``a K``, and its slope.

    A soil element passing under a contact of length ``l`` is sheared by ``j(x) = a K x / l``
    (``a = s l / K`` longitudinally, ``l tan(beta) / K`` laterally), so the contact's force is
    ``tau_max`` times the patch mean of the shear curve ``tau(j) / tau_max``:

    * ``residual_ratio`` None: Janosi-Hanamoto ``1 - exp(-j / K)`` (Wong, *Theory of Ground
      Vehicles*, 4th ed., eq. 2.56), patch mean ``g(a) = 1 - (1 - e^-a) / a``;
    * ``residual_ratio = K_r``: Wong's hump-type curve (ch. 2.4, the shear curve of snow
      covers and organic terrain that peaks and falls to a residual strength)
      ``f(u) = K_r {1 + [1 / (K_r (1 - 1/e)) - 1] e^(1 - u)} (1 - e^-u)``, ``u = j / K_w``,
      which peaks near ``u = 1`` and tends to ``K_r``. ``K_w`` is set so that the initial
      shear stiffness equals the exponential curve's, ``f'(0) / K_w = 1 / K``:
      ``K_w = K K_r (1 + B e)`` with ``B = 1 / (K_r (1 - 1/e)) - 1`` (ASSUMED: the chosen
      ``K`` keeps its meaning; the strength then peaks near where the exponential curve is
      95 % mobilised). Patch mean, ``U = a K / K_w``:
      ``K_r [U - (1 - e^-U) + B e ((1 - e^-U) - (1 - e^-2U) / 2)] / U``.

    Parameters
    ----------
    a : ndarray, shape (...)
        Shear displacement at the rear of the patch over K (>= 0).
    residual_ratio : float or None
        ``K_r`` in (0, 1), or None for the exponential curve.

    Returns
    -------
    g : ndarray, shape (...)
        Patch mean of ``tau / tau_max`` (dimensionless, >= 0).
    dg_da : ndarray, shape (...)
        Its derivative with respect to ``a`` (negative past the hump's peak).

    Raises
    ------
    ConfigError
        ``residual_ratio`` not a real number (text, a boolean, a list:
        :func:`~terrain.errors.config_numbers`) or outside (0, 1) (a ``ValueError`` too).
    """
    a = np.asarray(a, dtype=float)
    if residual_ratio is None:
        kr, b, s0, c2 = 0.0, 0.0, 1.0, 0.0
    else:
        if not isinstance(residual_ratio, float):   # (text, a list: float() named nothing)
            config_numbers("patch_mobilisation", residual_ratio=residual_ratio)
        kr = float(residual_ratio)
        if not 0.0 < kr < 1.0:
            raise ConfigError(f"patch_mobilisation: residual_ratio must be in (0, 1), got "
                              f"{residual_ratio}")
        b, s0, c2 = _hump_constants(kr)
    g, dg = np.empty(a.shape), np.empty(a.shape)
    _mobilisation_kernel(np.ascontiguousarray(a).reshape(-1), kr, b, s0, c2, g.reshape(-1),
                         dg.reshape(-1))
    return g, dg


def numeric_array(owner: str, name: str, value: np.ndarray | float) -> np.ndarray:
    """A slip or traction argument as a float array, refused unless it holds numbers.

    The shared check of the relations that take a slip (or a traction coefficient):
    :func:`traction_curve_and_slope`,
    :func:`~terrain.terramechanics.resistance.soil_resistance_coefficient`,
    :func:`~terrain.terramechanics.efficiency.tractive_efficiency` and
    :func:`~terrain.terramechanics.inverse.slip_from_traction`.

    Parameters
    ----------
    owner : str
        The refusing function, for the message.
    name : str
        The argument's name, for the message.
    value : float or ndarray, shape (...)
        A number or an integer or float array (NaN passes: it is a number).

    Returns
    -------
    ndarray, shape (...)
        ``value`` as floats.

    Raises
    ------
    DataFormatError
        ``value`` not a number or a numeric (integer or float) array: a boolean was taken as
        full slip, text was parsed ('0.1') or a bare ValueError ('abc'), None a silent NaN.
    """
    raw = np.asarray(value)
    if raw.dtype.kind not in "iuf":
        raise DataFormatError(f"{owner}: {name} must be a number or a numeric array, got "
                              f"{value!r:.80} (dtype {raw.dtype})")
    return raw.astype(float, copy=False)


def check_numeric_pair(owner: str, **pair) -> None:
    """Refuse two array arguments of a relation unless both hold numbers and broadcast.

    The slow path of the relations called on every simulator step
    (:func:`~terrain.terramechanics.resistance.lateral_force_and_slope`,
    :func:`~terrain.terramechanics.combined_slip.combined_slip_coefficients`,
    :func:`~terrain.terramechanics.slip.ground_speed_from_slip`): each is refused by
    :func:`numeric_array`, then their shapes must broadcast (NumPy's "operands could not be
    broadcast together" named neither).

    Parameters
    ----------
    owner : str
        The refusing function, for the message.
    **pair
        The two arguments' names -> values (floats or arrays, any shapes), in order.

    Raises
    ------
    DataFormatError
        An argument that is not a number or a numeric array (:func:`numeric_array`).
    ShapeError
        Shapes that do not broadcast: "<owner>: <a> of shape (...) and <b> of shape (...)
        do not broadcast".
    """
    (name_a, a), (name_b, b) = pair.items()
    shape_a = numeric_array(owner, name_a, a).shape
    shape_b = numeric_array(owner, name_b, b).shape
    try:
        np.broadcast_shapes(shape_a, shape_b)
    except ValueError:
        raise ShapeError(f"{owner}: {name_a} of shape {shape_a} and {name_b} of shape "
                         f"{shape_b} do not broadcast") from None


def traction_coefficient(curve: TractionCurve, slip: np.ndarray | float) -> np.ndarray:
    """Gross traction coefficient ``mu(s)``.

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve.
    slip : float or ndarray, shape (...)
        SAE slip, clipped to [-1, 1] (dimensionless).

    Returns
    -------
    ndarray, shape (...)
        ``mu`` (dimensionless), odd in ``slip``.

    Raises
    ------
    DataFormatError
        A slip that is not a number or a numeric array (:func:`traction_curve_and_slope`).
    """
    return traction_curve_and_slope(curve, slip)[0]


def traction_curve_and_slope(curve: TractionCurve, slip: np.ndarray | float
                             ) -> tuple[np.ndarray, np.ndarray]:
    """``mu(s)`` and its derivative ``d mu / d s``.

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve.
    slip : float or ndarray, shape (...)
        SAE slip (dimensionless), clipped to [-1, 1].

    Returns
    -------
    mu : ndarray, shape (...)
    dmu_ds : ndarray, shape (...)
        Zero outside [-1, 1] (the slip is saturated there).

    Raises
    ------
    DataFormatError
        A slip that is not a number or a numeric (integer or float) array: a boolean was
        taken as full slip, text was parsed ('0.1') or a bare ValueError ('abc'), None a
        silent NaN.
    """
    s_raw = numeric_array("traction_curve_and_slope", "slip", slip)
    s = np.clip(s_raw, -1.0, 1.0)
    mu, dmu = curve.coefficients(np.abs(s), 0.0)[:2]
    dmu = np.where(np.abs(s_raw) > 1.0, 0.0, dmu)
    return np.sign(s) * mu, dmu


def traction_peak(curve: TractionCurve, saturation: float = 0.95) -> TractionPeak:
    """Slip at which the traction-slip curve peaks (the target of traction control).

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve.
    saturation : float
        For curves rising monotonically up to ``s = 1`` (Janosi, Brixius, Burckhardt with
        ``c3 = 0``), the peak is taken as the smallest slip reaching this fraction of the
        maximum (the curve is flat beyond it); in (0, 1].

    Returns
    -------
    TractionPeak

    Raises
    ------
    ConfigError
        ``saturation`` not a number in (0, 1] (a percentage such as 95 gave slip 0).
    """
    config_fraction("traction_peak", saturation=saturation)
    grid = np.linspace(0.0, 1.0, 20001)
    mu = traction_coefficient(curve, grid)
    i_max = int(np.argmax(mu))
    if mu[-1] < (1.0 - 1e-9) * mu[i_max]:      # falls after an interior maximum: refine it
        best = minimize_scalar(lambda s: -float(traction_coefficient(curve, s)),
                               bounds=(grid[i_max - 1], grid[i_max + 1]), method="bounded",
                               options={"xatol": 1e-10})
        mu_star = float(-best.fun)
        return TractionPeak(float(best.x), mu_star, mu_star, False)
    mu_max = float(mu.max())
    idx = int(np.argmax(mu >= saturation * mu_max))
    return TractionPeak(float(grid[idx]), float(mu[idx]), mu_max, True)
