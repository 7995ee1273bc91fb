"""Lateral wheel-soil force of a skid-steered wheel on deformable ground (physics v2).

A skid-steer turns by dragging its wheels sideways while they roll. On deformable ground
the lateral force of a wheel is built from three textbook relations, each a pure function
over a frozen, cited :class:`SoilParams`:

1. **Sinkage** from Bekker's pressure-sinkage relation ``p = (k_c / b + k_phi) z^n``
   (Wong, *Theory of Ground Vehicles*, 4th ed. 2008, eq. 2.33; the plate formula is
   :func:`terrain.terramechanics.resistance.bekker_sinkage_m`), with the contact length of a
   rigid wheel of radius ``r`` sunk by ``z``, ``l = 2 sqrt(2 r z - z^2)`` (never shorter than
   the tyre's own footprint), solved as a fixed point (:func:`wheel_sinkage_m`).
2. **Shear-displacement lateral force** (Janosi-Hanamoto, Wong eq. 2.56,
   ``tau = (c + p tan phi)(1 - exp(-j / K))``) integrated along the slip trajectory of the
   contact patch: a soil element entering the patch at its front travels with the wheel for
   ``x / |omega r|`` seconds while the wheel slides sideways at ``v_lat``, so it is sheared
   laterally by ``j(x) = x |v_lat| / |omega r|`` (Wong ch. 7.2 / 7.3, lateral shear of
   tracks in skid-steering; the lateral slip angle ``tan beta = v_lat / (omega r)``). Over a
   patch of length ``l`` the mean mobilisation is
   ``g(a) = 1 - (1 - exp(-a)) / a``, ``a = l tan(beta) / K`` (:func:`shear_mobilisation`).
   A soil with a :attr:`SoilParams.residual_ratio` follows Wong's hump-type shear curve
   instead (ch. 2.4: the strength peaks, then falls to ``K_r`` of the peak as the shearing
   goes on; SNOW and SANDY_LOAM), longitudinally and laterally alike
   (:func:`terrain.terramechanics.traction.patch_mobilisation`).
3. **Bulldozing** of the sinkage wall: the side of a sunk wheel pushes a wall of soil of
   depth ``z`` and width ``l`` sideways, the passive earth pressure of Wong eq. 2.61
   ``R_b = l (0.67 c z K_pc + 0.5 z^2 gamma_s K_pgamma)`` with
   ``K_pc = (N_c - tan phi) cos^2 phi``, ``K_pgamma = (2 N_gamma / tan phi + 1) cos^2 phi``
   and bearing-capacity factors (Wong eqs. 2.62-2.63 name Terzaghi's) in the closed forms
   of Prandtl-Reissner, ``N_q = exp(pi tan phi) tan^2(45 deg + phi / 2)``, ``N_c = (N_q - 1)
   cot phi``, and Vesic (1973), ``N_gamma = 2 (N_q + 1) tan phi``
   (:func:`bearing_capacity_factors`). Wong writes it for the wheel's front face; applying it
   to the side face is an ANALOGY. The passive pressure is taken to mobilise with the same
   displacement law as the shear (ASSUMED: both need the soil to move).

The longitudinal traction of the same contact is the Janosi-Hanamoto curve of the same soil
on the sunk patch (:func:`longitudinal_curve`, shear modulus K_x; the lateral shear has its
own K_y, :attr:`SoilParams.lateral_shear_modulus_m`).

The lateral force of a contact is therefore
``F_lat = -tanh(v_lat / v_slide) [c A + N tan phi + R_b(z)] g(a)``; it is bounded by the
soil's strength, smooth through ``v_lat = 0`` and grows with the lateral slip angle, so the
yaw response of a skid-steer (its ICR expansion chi) and the traction the motors must supply
to turn it (the turning current) come from one parameter set.

Rigid surfaces keep the Coulomb law of
:func:`terrain.terramechanics.resistance.lateral_force_and_slope`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from types import MappingProxyType
from typing import Mapping

import numpy as np
from scipy.optimize import brentq

from terrain.errors import (ConfigError, DataFormatError, ShapeError, config_flags,
                            config_integer, config_numbers, config_positive, refuse_booleans)
from terrain.terramechanics.resistance import (bekker_sinkage_m, check_lengths,
                                               check_slide_speed, compaction_resistance_n)
from terrain.terramechanics.traction import (CurveCoefficients, JanosiCurve, TractionCurve,
                                             curve_resistance_terms,
                                             curve_traction_terms, numeric_array,
                                             patch_mobilisation)

_WONG_T23 = ("Wong, Theory of Ground Vehicles, 4th ed. 2008, Table 2.3 (Bekker's values)")


#: Numeric fields of :class:`SoilParams`, refused unless real numbers (``None`` allowed for
#: the optional ones): a boolean is not a modulus, text not an angle.
_SOIL_NUMBERS = ("n", "k_c", "k_phi", "cohesion_pa", "friction_angle_deg", "shear_modulus_m",
                 "unit_weight_n_m3")
_OPTIONAL_SOIL_NUMBERS = ("lateral_shear_modulus_m", "layer_depth_m", "residual_ratio",
                          "slip_sinkage_ratio", "rate_weakening_speed_m_s")


@dataclass(frozen=True)
class SoilParams:
    """Pressure-sinkage and shear parameters of a deformable soil (SI units).

    Parameters
    ----------
    name : str
        Soil name as in the source table.
    n : float
        Bekker sinkage exponent (dimensionless).
    k_c : float
        Cohesive modulus of deformation, N/m^(n+1).
    k_phi : float
        Frictional modulus of deformation, N/m^(n+2).
    cohesion_pa : float
        Mohr-Coulomb cohesion c, Pa.
    friction_angle_deg : float
        Mohr-Coulomb internal friction angle phi, degrees.
    shear_modulus_m : float
        Janosi-Hanamoto shear deformation modulus K_x of the longitudinal shear
        (:func:`longitudinal_curve`), and of the lateral shear too where
        ``lateral_shear_modulus_m`` is None, m.
    unit_weight_n_m3 : float
        Specific weight of the soil gamma_s, N/m^3 (bulldozing).
    source : str
        Where every number comes from (ASSUMED / ANALOGY stated).
    lateral_shear_modulus_m : float or None
        Shear deformation modulus K_y of the lateral shear, m; None = ``shear_modulus_m``
        (isotropic). Anisotropic moduli as in Ishigami et al., "Terramechanics-based model
        for steering maneuver of planetary exploration rovers on loose soil", J. Field
        Robotics 24(3), 2007 (separate K_x, K_y, K_y below K_x on sand).
    layer_depth_m : float or None
        Depth of a deformable layer over a firm base (snow on frozen ground), m: no wheel
        sinks deeper (:func:`wheel_sinkage_m`; the limit of a pressure-sinkage relation
        that stiffens as the sinkage approaches the base, Wong ch. 2.2, simplified to a
        cap, ASSUMED). None: a layer deeper than any sinkage (every shipped soil; a SNOW
        layer of 0.01-0.06 m was swept on training runs and not adopted,
        docs/physics_v2.md).
    residual_ratio : float or None
        ``K_r``, residual over peak shear strength of Wong's hump-type shear curve (ch. 2.4:
        snow covers and organic terrain), for the longitudinal and the lateral shear and
        the bulldozing mobilisation alike
        (:func:`terrain.terramechanics.traction.patch_mobilisation`); None = the
        exponential Janosi-Hanamoto curve (shipped: SNOW 0.4, SANDY_LOAM 0.9, PLOUGHED
        None).
    slip_sinkage_ratio : float or None
        ``k_s`` of slip sinkage: a wheel that slips sinks deeper than its static sinkage,
        ``z(s) = z_0 (1 + k_s |s|)`` with ``s`` its longitudinal (SAE) slip ratio (capped
        at the wheel radius or ``layer_depth_m``), which deepens the sinkage wall its side
        bulldozes (:func:`soil_lateral_force_and_slope`). Ding et al., "Wheel slip-sinkage
        and its prediction model of lunar rover", J. Cent. South Univ. Technol. 17 (2010)
        129-135, measured 3-7 times the static sinkage at slip 0.6 (``k_s`` about 3-10) for
        lugged wheels on lunar soil simulant; Lyasko, "Slip sinkage effect in soil-vehicle
        mechanics", J. Terramechanics 47 (2010) 21-31, for agricultural soils. The linear
        form is ASSUMED and any value for snow is by ANALOGY. None: static sinkage only
        (every shipped soil; 2 and 5 on SNOW were tried on training runs and not adopted,
        docs/physics_v2.md, "Measured chi per manoeuvre").
    rate_weakening_speed_m_s : float or None
        ``u_c`` of a shear strength that falls with the slip speed ``u`` of the contact
        (velocity weakening), ``tau(u) = tau / (1 + u / u_c)``
        (:func:`rate_weakening_factor`): longitudinally ``u = |omega r - v_long|``,
        laterally ``u = |v_lat|``. The friction of snow falls with the sliding speed as
        frictional melting lubricates the contact (Bowden and Hughes, "The mechanism of
        sliding on ice and snow", Proc. R. Soc. A 172 (1939) 280-298); the form is
        ASSUMED, with no constant for this snow in the sources here. None: no weakening
        (every shipped soil; 0.05-1 m/s on SNOW were tried on training runs and not
        adopted, docs/physics_v2.md, "Measured chi per manoeuvre").
    combined_shear : bool
        True: the longitudinal traction and the lateral shear share the patch's
        Mohr-Coulomb strength ``c b l + N tan phi`` (Wong eq. 2.56 bounds the resultant
        shear stress): each direction keeps :func:`combined_shear_shares` of its own force,
        the shear along the resultant displacement. False (every shipped soil): each
        direction takes the whole strength, so a wheel that slips along and across at once
        can carry more than it (a v2 Husky spin on SANDY_LOAM: 71.5 N along and 68.9 N
        across, 99.3 N against 85.4 N). True was measured on the training runs and not
        adopted: it costs SANDY_LOAM's current what it keeps of the yaw rate
        (docs/physics_v2.md, "The shear strength shared between directions").
    slip_compaction : bool
        True, on a soil with a ``slip_sinkage_ratio``: the deeper rut of a slipping wheel
        also adds its compaction resistance to the longitudinal law
        (:class:`SlipCompactionResistance`, Wong eq. 2.54), not only a deeper wall to
        bulldoze sideways. False (every shipped soil): the wall only. Measured with
        ``combined_shear`` on the training runs and not adopted (same section).

    Raises
    ------
    ConfigError
        A numeric field that is not a real number (text, a boolean, ``None`` but for the
        optional fields), ``n``, ``shear_modulus_m`` or ``lateral_shear_modulus_m`` is not a
        finite value > 0, ``friction_angle_deg`` is outside (0, 90) (the bearing-capacity
        factors of :func:`bearing_capacity_factors` divide by ``tan phi``), ``cohesion_pa``
        or ``unit_weight_n_m3`` is negative or not finite, ``k_c`` or ``k_phi`` is not
        finite, ``layer_depth_m`` is not positive, ``residual_ratio`` is outside (0, 1),
        ``slip_sinkage_ratio`` is negative or not finite, or ``rate_weakening_speed_m_s``
        is not a finite positive speed, or ``combined_shear`` or ``slip_compaction`` is
        not ``True`` or ``False`` (a NumPy boolean is one).
    """

    name: str
    n: float
    k_c: float
    k_phi: float
    cohesion_pa: float
    friction_angle_deg: float
    shear_modulus_m: float
    unit_weight_n_m3: float
    source: str
    lateral_shear_modulus_m: float | None = None
    layer_depth_m: float | None = None
    residual_ratio: float | None = None
    slip_sinkage_ratio: float | None = None
    rate_weakening_speed_m_s: float | None = None
    combined_shear: bool = False
    slip_compaction: bool = False

    def __post_init__(self) -> None:
        try:
            self._check()
        except ConfigError as err:
            # the checks name SoilParams.<field>; the soil's name says which entry
            raise ConfigError(f"{err} (soil {self.name!r})") from None

    def _check(self) -> None:
        """The checks of :meth:`__post_init__` (ConfigError naming ``SoilParams.<field>``)."""
        owner = "SoilParams"
        config_numbers(owner, optional=_OPTIONAL_SOIL_NUMBERS, **{
            key: getattr(self, key) for key in _SOIL_NUMBERS + _OPTIONAL_SOIL_NUMBERS})
        positive = {"n": self.n, "shear_modulus_m": self.shear_modulus_m}
        if self.lateral_shear_modulus_m is not None:
            positive["lateral_shear_modulus_m"] = self.lateral_shear_modulus_m
        config_positive(owner, **positive)
        config_positive(owner, allow_zero=True, cohesion_pa=self.cohesion_pa,
                        unit_weight_n_m3=self.unit_weight_n_m3)
        for key, value in (("k_c", self.k_c), ("k_phi", self.k_phi)):
            if not np.isfinite(value):
                raise ConfigError(f"{owner}.{key} must be finite, got {value}")
        if not 0.0 < self.friction_angle_deg < 90.0:
            raise ConfigError(f"{owner}.friction_angle_deg must be in (0, 90) degrees "
                              f"(the bearing-capacity factors divide by tan phi), got "
                              f"{self.friction_angle_deg}")
        if self.rate_weakening_speed_m_s is not None and not (
                np.isfinite(self.rate_weakening_speed_m_s)
                and self.rate_weakening_speed_m_s > 0.0):
            raise ConfigError(f"{owner}.rate_weakening_speed_m_s must be a finite "
                              f"speed > 0 m/s or None, got {self.rate_weakening_speed_m_s}")
        if self.slip_sinkage_ratio is not None and not (
                np.isfinite(self.slip_sinkage_ratio) and self.slip_sinkage_ratio >= 0.0):
            raise ConfigError(f"{owner}.slip_sinkage_ratio must be a finite value >= 0 "
                              f"or None, got {self.slip_sinkage_ratio}")
        config_flags(owner, combined_shear=self.combined_shear,
                     slip_compaction=self.slip_compaction)
        if self.layer_depth_m is not None and not self.layer_depth_m > 0:
            raise ConfigError(f"{owner}.layer_depth_m must be > 0 m or None, got "
                              f"{self.layer_depth_m}")
        if self.residual_ratio is not None and not 0.0 < self.residual_ratio < 1.0:
            raise ConfigError(f"{owner}.residual_ratio must be in (0, 1) or None, got "
                              f"{self.residual_ratio}")

    @property
    def shear_modulus_y_m(self) -> float:
        """Shear deformation modulus of the lateral shear K_y, m."""
        return (self.shear_modulus_m if self.lateral_shear_modulus_m is None
                else self.lateral_shear_modulus_m)


#: Sandy loam of the BorealTC runs (also the analogue of the Vulpi PLOUGHED field).
_SANDY_LOAM = SoilParams(
    "sandy loam (LLL), 15 % moisture", n=0.7, k_c=5.27e3, k_phi=1515.04e3,
    cohesion_pa=1.72e3, friction_angle_deg=29.0, shear_modulus_m=0.006,
    unit_weight_n_m3=15.7e3, lateral_shear_modulus_m=0.010, residual_ratio=0.9,
    source=(f"n, k_c, k_phi, c, phi: sandy loam (Land Locomotion Lab) 15 % moisture, "
            f"{_WONG_T23}; K_x = 0.006 m and K_y = 0.010 m chosen on the TRAINING runs "
            "of benchmarks/sweep_soil_params.py (borealtc SANDY_LOAM 01, 03, 05, 07, 10, "
            "13; scored on 02, 04, 06, 08, 11) inside Wong's range of K for mineral "
            "soils (ch. 2.4: about 0.6 cm for compact clay to 2.5 cm for loose sand); "
            "hump-type shear curve (Wong ch. 2.4: dense, firm soils peak and soften) with "
            "residual ratio K_r = 0.9 chosen on the same runs over {none, 0.9, 0.8, 0.7, "
            "0.6, 0.4} (docs/physics_v2.md, 'Snow that softens when sheared'); gamma_s "
            "15.7 kN/m^3 ASSUMED (bulk density 1.6 t/m^3 of a moist sandy loam)"))

#: Soils of the physics-v2 lateral model, by catalogue terrain (read-only).
SOILS: Mapping[str, SoilParams] = MappingProxyType({
    "SANDY_LOAM": _SANDY_LOAM,
    "SNOW": SoilParams(
        "snow (U.S., Harrison)", n=1.6, k_c=2.49e3, k_phi=245.90e3, cohesion_pa=0.62e3,
        friction_angle_deg=23.2, shear_modulus_m=0.02, unit_weight_n_m3=2.45e3,
        lateral_shear_modulus_m=0.05, residual_ratio=0.4,
        source=(f"n, k_c, k_phi, c, phi: snow (U.S., Harrison), {_WONG_T23}, chosen over "
                "Wong's snow (U.S.) and snow (Sweden) rows on the TRAINING runs of "
                "benchmarks/sweep_soil_params.py (borealtc SNOW 01, 03, 05, 07, 10, 12, 16, "
                "18, 20, 23, 25; scored on the other 11); K_x = 0.02 m, K_y = 0.05 m chosen "
                "on the same runs, ASSUMED range 0.02-0.05 m (no snow K in the sources "
                "here; the catalogue's longitudinal value is 0.04 m); hump-type shear curve "
                "(Wong ch. 2.4, snow covers) with residual ratio K_r = 0.4 chosen on the "
                "same runs over {0.8, 0.6, 0.4, 0.3, 0.2} (no K_r of this snow in the "
                "sources here; docs/physics_v2.md, 'Snow that softens when sheared'); "
                "gamma_s 2.45 kN/m^3 ASSUMED (fresh forest snow, density 250 kg/m^3)")),
    "PLOUGHED": replace(
        _SANDY_LOAM, name="ploughed field (sandy loam row by analogy)",
        shear_modulus_m=0.025, lateral_shear_modulus_m=0.025, residual_ratio=None,
        source=(f"n, k_c, k_phi, c, phi and gamma_s: the SANDY_LOAM row above ({_WONG_T23}) "
                "by ANALOGY: the Vulpi et al. (2021) PLOUGHED runs were driven on a tilled "
                "agricultural field whose soil was not measured; K_x = K_y = 0.025 m chosen "
                "on the TRAINING runs of benchmarks/sweep_soil_params.py --dataset vulpi "
                "(vulpi PLOUGHED 1, 4, 6; scored on 3, 5) over K_x in {0.006, 0.01, 0.025} x "
                "K_y in {0.004, 0.006, 0.01, 0.025} m, inside Wong's range of K for mineral "
                "soils (ch. 2.4); chosen again 2026-11-25 once v2 kept the catalogue's "
                "Brixius motion resistance (0.010 m before, docs/physics_v2.md)")),
})


def _check_length_array(owner: str, name: str, value) -> None:
    """Refuse a length or array of lengths, m, holding a value that is not finite and >= 0
    (ConfigError naming ``owner.name`` and the first such flat index; 0 is a rim without a
    footprint, a wall of no width); a float in range passes on one ``isinstance`` test."""
    if isinstance(value, float) and 0.0 <= value < math.inf:
        return
    if np.ndim(value) == 0:
        config_positive(owner, allow_zero=True, **{name: value})
        return
    refuse_booleans(ConfigError, owner, **{name: value})
    x = np.asarray(value)
    if x.dtype.kind not in "iuf":
        raise ConfigError(f"{owner}.{name} must be real lengths, m, got an array of "
                          f"dtype {x.dtype}")
    bad = ~((x >= 0.0) & (x < math.inf))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ConfigError(f"{owner}.{name} must hold finite lengths >= 0 m, got "
                          f"{int(bad.sum())} that are not, the first {float(x.flat[i])!r} at flat "
                          f"index {i}")


def max_sinkage_m(wheel_radius_m: float, soil: SoilParams) -> float:
    """Deepest a wheel sinks: its radius, or the soil's layer depth where that is less.

    Parameters
    ----------
    wheel_radius_m : float
        Wheel radius r, m.
    soil : SoilParams
        Soil; :attr:`SoilParams.layer_depth_m` (None: no firm base within reach).

    Returns
    -------
    float
        ``z_max``, m.

    Raises
    ------
    ConfigError
        ``wheel_radius_m`` not a finite length > 0 (a negative radius was returned as a
        negative deepest sinkage, NaN as NaN).
    """
    check_lengths("max_sinkage_m", wheel_radius_m=wheel_radius_m)
    if soil.layer_depth_m is None:
        return wheel_radius_m
    return min(wheel_radius_m, soil.layer_depth_m)


def wheel_sinkage_m(load_n: float, width_m: float, footprint_length_m: float,
                    wheel_radius_m: float, soil: SoilParams, iterations: int = 30
                    ) -> tuple[float, float]:
    """Static sinkage and contact length of a wheel on soil (Bekker, Wong eq. 2.33).

    Fixed point of ``z = bekker_sinkage_m(W, b, l(z))`` with the chord of the sunk wheel
    ``l(z) = max(l_0, 2 sqrt(2 r z - z^2))``: damped iteration of the contact length, and
    where that leaves the pair off the fixed point (it oscillates for ``n < 1/6``, the heavy
    clays of Wong's Table 2.3) the root bracketed in ``[0, z_max]``.

    ``b`` in Bekker's ``k_c / b`` is the tyre width even where the contact is shorter than
    it is wide, whereas Bekker takes the plate's smaller side. For the Husky (width 0.11 m,
    firm footprint 0.08 m, static wheel load 123 N) on SANDY_LOAM the smaller side raises
    the pressure-sinkage modulus by 1.1 % and lowers the sinkage by 1.6 % (1.179 to
    1.160 mm), well inside the uncertainty of the soil's tabulated moduli; on SNOW the
    sunk chord (0.27 m) is longer than the width and nothing changes. The width is kept:
    the documented v2 figures were measured with it.

    Parameters
    ----------
    load_n : float
        Normal load of the wheel, N (>= 0).
    width_m : float
        Contact width b, m.
    footprint_length_m : float
        Footprint length of the tyre on firm ground l_0, m.
    wheel_radius_m : float
        Wheel radius r, m.
    soil : SoilParams
        Soil.
    iterations : int
        Damped fixed-point iterations (an integer >= 1) before the check that the pair is
        the fixed point.

    Returns
    -------
    sinkage_m : float
        z, m (at most ``r``).
    contact_length_m : float
        l, m.

    Raises
    ------
    ConfigError
        ``iterations`` not an integer >= 1 (0 returned no sinkage at all), ``load_n`` not a
        real number (``None`` and text raised a bare ``TypeError``), ``width_m``,
        ``footprint_length_m`` or ``wheel_radius_m`` not a finite length > 0 (a negative
        radius gave a negative sinkage), or a load, plate or soil
        :func:`~terrain.terramechanics.resistance.bekker_sinkage_m` refuses.
    """
    config_integer("wheel_sinkage_m iterations", iterations, 1)
    config_numbers("wheel_sinkage_m", load_n=load_n)
    config_positive("wheel_sinkage_m", width_m=width_m, footprint_length_m=footprint_length_m,
                    wheel_radius_m=wheel_radius_m)
    if load_n <= 0:
        return 0.0, footprint_length_m
    length = footprint_length_m
    z = 0.0
    z_max = max_sinkage_m(wheel_radius_m, soil)

    def sinkage_on(chord_m: float) -> float:
        return min(bekker_sinkage_m(load_n, width_m, chord_m, soil.k_c, soil.k_phi, soil.n),
                   z_max)

    def chord_of(z_m: float) -> float:
        return float(contact_chord_m(z_m, wheel_radius_m, footprint_length_m))

    for _ in range(iterations):
        z = sinkage_on(length)
        length = 0.5 * length + 0.5 * chord_of(z)   # damped
    if not (abs(length - chord_of(z)) <= 1e-9 * length
            and abs(z - sinkage_on(length)) <= 1e-9 * z):
        # the damped map oscillates where its slope 1/2 - 1/(4n) is below -1 (n < 1/6: the
        # heavy clays of Wong's Table 2.3, n = 0.11-0.13): the sinkage on the sunk chord
        # falls strictly as the sinkage grows, so its one root in [0, z_max] is bracketed
        z = float(brentq(lambda z_m: sinkage_on(chord_of(z_m)) - z_m, 0.0, z_max,
                         xtol=1e-300))
        length = chord_of(z)
    return float(z), float(length)


def bearing_capacity_factors(friction_angle_deg: float) -> tuple[float, float, float]:
    """Bearing-capacity factors ``N_c, N_q, N_gamma`` in the Prandtl-Reissner / Vesic forms.

    ``N_q = exp(pi tan phi) tan^2(45 deg + phi / 2)`` (Reissner), ``N_c = (N_q - 1) cot phi``
    (Prandtl) and ``N_gamma = 2 (N_q + 1) tan phi`` (Vesic 1973): 27.86, 16.44 and 19.34 at
    29 deg. Wong's bulldozing coefficients (eq. 2.61) cite Terzaghi's factors, whose
    ``K_pc = (N_c - tan phi) cos^2 phi`` and ``K_pgamma = (2 N_gamma / tan phi + 1)
    cos^2 phi`` are Terzaghi's own definitions of ``N_c`` and ``N_gamma`` solved for the
    passive earth-pressure coefficients; Terzaghi's closed forms are larger (``N_q =
    e^((3 pi / 2 - phi) tan phi) / (2 cos^2(45 deg + phi / 2))``: ``N_c`` 34.24 and ``N_q``
    19.98 at 29 deg, so ``K_pc`` 25.8 against 20.9 here). These factors are used as they
    stand: the documented physics-v2 figures were measured with them.

    Parameters
    ----------
    friction_angle_deg : float
        Internal friction angle phi, degrees, in (0, 90).

    Returns
    -------
    tuple of float
        ``(N_c, N_q, N_gamma)``, dimensionless (Wong ch. 2.5).

    Raises
    ------
    ConfigError
        ``friction_angle_deg`` not a real number or outside (0, 90): ``N_c`` divides by
        ``tan phi`` (0 gave ``-inf``), a negative angle gave negative factors and 90
        infinite ones.
    """
    config_numbers("bearing_capacity_factors", friction_angle_deg=friction_angle_deg)
    if not 0.0 < friction_angle_deg < 90.0:
        raise ConfigError(f"bearing_capacity_factors: friction_angle_deg must be in (0, 90) "
                          f"degrees, got {friction_angle_deg}")
    phi = np.radians(friction_angle_deg)
    n_q = np.exp(np.pi * np.tan(phi)) * np.tan(np.pi / 4 + phi / 2) ** 2
    n_c = (n_q - 1.0) / np.tan(phi)
    n_g = 2.0 * (n_q + 1.0) * np.tan(phi)
    return float(n_c), float(n_q), float(n_g)


def bulldozing_force_n(sinkage_m: float, wall_width_m: float, soil: SoilParams) -> float:
    """Passive-pressure bulldozing force of a sinkage wall (Wong eq. 2.61).

    ``R_b = w (0.67 c z K_pc + 0.5 z^2 gamma_s K_pgamma)`` with
    ``K_pc = (N_c - tan phi) cos^2 phi`` and ``K_pgamma = (2 N_gamma / tan phi + 1) cos^2 phi``.

    Parameters
    ----------
    sinkage_m : float or ndarray, shape (c,)
        Depth of the wall z, m. A negative one (a wheel above the surface) is taken as 0,
        no wall and no force, the limit of ``R_b`` as ``z -> 0``, as
        :func:`~terrain.terramechanics.resistance.compaction_resistance_n` clips its rut
        depth (it gave a negative force, ``0.67 c z K_pc`` < 0, that pulled the wheel into
        its slide); NaN (a missing value) passes as a NaN force, as there.
    wall_width_m : float or ndarray, shape (c,)
        Width of the wall w, m (the contact length for a wheel sliding sideways).
    soil : SoilParams
        Soil.

    Returns
    -------
    float or ndarray, shape (c,)
        N (a float for scalar inputs), >= 0.

    Raises
    ------
    ConfigError
        ``wall_width_m`` holding a value that is not a finite length >= 0 (a negative width
        gave a force that pulls the wheel into its slide, NaN a NaN force), naming the
        first such entry.
    DataFormatError
        ``sinkage_m`` not a number or a numeric array (``True`` was a 1 m wall, None a NaN
        force, text NumPy's bare ValueError), named.
    """
    _check_length_array("bulldozing_force_n", "wall_width_m", wall_width_m)
    if not (type(sinkage_m) is float or type(sinkage_m) is np.ndarray
            and sinkage_m.dtype.kind == "f"):     # (floats: one type test, per step)
        refuse_booleans(DataFormatError, "bulldozing_force_n", sinkage_m=sinkage_m)
        sinkage_m = numeric_array("bulldozing_force_n", "sinkage_m", sinkage_m)
    phi = np.radians(soil.friction_angle_deg)
    n_c, _, n_g = bearing_capacity_factors(soil.friction_angle_deg)
    cos2 = np.cos(phi) ** 2
    k_pc = (n_c - np.tan(phi)) * cos2
    k_pg = (2.0 * n_g / np.tan(phi) + 1.0) * cos2
    z = np.maximum(np.asarray(sinkage_m, dtype=float), 0.0)     # (NaN stays NaN)
    out = np.asarray(wall_width_m, dtype=float) * (0.67 * soil.cohesion_pa * z * k_pc
                                                   + 0.5 * z * z * soil.unit_weight_n_m3 * k_pg)
    return float(out) if np.ndim(out) == 0 else out


def contact_chord_m(sinkage_m: np.ndarray, wheel_radius_m: float,
                    footprint_length_m: float | np.ndarray) -> np.ndarray:
    """Contact length of a rigid wheel sunk by ``z``: ``max(l_0, 2 sqrt(2 r z - z^2))``.

    Parameters
    ----------
    sinkage_m : float or ndarray, shape (c,)
        Sinkage z, m (``0 <= z <= r``).
    wheel_radius_m : float
        Wheel radius r, m.
    footprint_length_m : float or ndarray, shape (c,)
        Footprint length of the tyre on firm ground l_0, m.

    Returns
    -------
    ndarray, shape (c,) (0-d for scalar inputs)
        l, m (Wong ch. 2.2, the chord of the sunk rim).

    Raises
    ------
    ConfigError
        ``wheel_radius_m`` not a finite length > 0 (a negative radius gave the firm
        footprint at any sinkage), or ``footprint_length_m`` holding a value that is not a
        finite length >= 0 (0: a rim without a footprint; a negative one was read as 0).
    """
    check_lengths("contact_chord_m", wheel_radius_m=wheel_radius_m)
    _check_length_array("contact_chord_m", "footprint_length_m", footprint_length_m)
    z = np.asarray(sinkage_m, dtype=float)
    chord = 2.0 * np.sqrt(np.maximum(2.0 * wheel_radius_m * z - z * z, 0.0))
    return np.maximum(footprint_length_m, chord)


def shear_mobilisation(a: np.ndarray, residual_ratio: float | None = None) -> np.ndarray:
    """Mean shear mobilisation over a patch sheared linearly from 0 to ``a K``.

    ``g(a) = (1 / l) int_0^l (1 - exp(-a x / l)) dx = 1 - (1 - exp(-a)) / a``
    (Wong eq. 2.56 integrated along the patch; ``g -> a / 2`` for small ``a``, ``-> 1`` for
    large), or the patch mean of Wong's hump-type curve with a ``residual_ratio``; both are
    :func:`terrain.terramechanics.traction.patch_mobilisation`.

    Parameters
    ----------
    a : ndarray, shape (...)
        Shear displacement at the rear of the patch over K, ``l |tan beta| / K`` (>= 0).
    residual_ratio : float or None
        ``K_r`` of the hump-type curve (:attr:`SoilParams.residual_ratio`); None =
        exponential.

    Returns
    -------
    ndarray, shape (...)
        Dimensionless, in [0, 1) (the hump-type curve itself rises a few per cent above its
        peak strength, 1.016 at ``K_r`` 0.4, but its patch mean stays below 1).
    """
    return patch_mobilisation(a, residual_ratio)[0]


@dataclass(frozen=True)
class SoilContact:
    """Lateral strength of one wheel on a soil as a function of its normal load.

    Parameters
    ----------
    soil : SoilParams
        Soil.
    width_m : float
        Contact width b, m.
    wheel_radius_m : float
        Wheel radius, m.
    load_grid_n : ndarray, shape (k,)
        Normal loads at which the strength is tabulated, N.
    strength_grid_n : ndarray, shape (k,)
        ``c A + N tan phi + R_b`` at those loads, N.
    length_grid_m : ndarray, shape (k,)
        Contact length l at those loads, m.
    sinkage_grid_m : ndarray, shape (k,)
        Sinkage z at those loads, m.
    shear_grid_n : ndarray, shape (k,)
        The Mohr-Coulomb part ``c A + N tan phi`` of ``strength_grid_n`` at those loads
        (:func:`shear_strength_n`), N: 0 in the unloaded row as the strength, so that
        between two rows the interpolated shear never exceeds the interpolated strength
        (the bulldozing left, ``S - shear``, is the interpolation of rows >= 0).
    """

    soil: SoilParams
    width_m: float
    wheel_radius_m: float
    load_grid_n: np.ndarray
    strength_grid_n: np.ndarray
    length_grid_m: np.ndarray
    sinkage_grid_m: np.ndarray
    shear_grid_n: np.ndarray

    def __post_init__(self) -> None:
        # (built directly, a negative width or radius was kept and reached every lateral
        # force of the contact)
        check_lengths("SoilContact", width_m=self.width_m, wheel_radius_m=self.wheel_radius_m)


def soil_contact(soil: SoilParams, width_m: float, footprint_length_m: float,
                 wheel_radius_m: float, max_load_n: float, n_grid: int = 64) -> SoilContact:
    """Tabulate a wheel's lateral strength over normal load (sinkage, shear, bulldozing).

    Parameters
    ----------
    soil : SoilParams
        Soil.
    width_m : float
        Contact width b, m.
    footprint_length_m : float
        Tyre footprint length on firm ground, m.
    wheel_radius_m : float
        Wheel radius, m.
    max_load_n : float
        Largest normal load tabulated, N (> 0).
    n_grid : int
        Grid points (an integer >= 2: the first row is the unloaded wheel).

    Returns
    -------
    SoilContact

    Raises
    ------
    ConfigError
        ``max_load_n`` not a finite load > 0 (a boolean, text or ``None`` included) or
        ``n_grid`` not an integer >= 2 (the table would hold no loaded row, and every
        wheel's load would be clipped to 0: no lateral force at all), or ``width_m``,
        ``footprint_length_m`` or ``wheel_radius_m`` not a finite length > 0 (a negative
        radius made the sinkage negative).
    """
    config_positive("soil_contact", width_m=width_m, footprint_length_m=footprint_length_m,
                    wheel_radius_m=wheel_radius_m)
    config_numbers("soil_contact", max_load_n=max_load_n)
    if not (np.isfinite(max_load_n) and max_load_n > 0.0):
        raise ConfigError(f"soil_contact: max_load_n must be a finite load > 0 N, got "
                          f"{max_load_n}")
    config_integer("soil_contact n_grid", n_grid, 2)
    loads = np.linspace(0.0, max_load_n, n_grid)
    z = np.zeros(n_grid)
    length = np.full(n_grid, footprint_length_m)
    for i, w in enumerate(loads):
        z[i], length[i] = wheel_sinkage_m(w, width_m, footprint_length_m, wheel_radius_m, soil)
    strength = lateral_strength_n(soil, width_m, loads, z, length)
    shear = np.where(loads > 0, shear_strength_n(soil, width_m, loads, length), 0.0)
    return SoilContact(soil, width_m, wheel_radius_m, loads, strength, length, z, shear)


def lateral_strength_n(soil: SoilParams, width_m: float, normal_load_n: np.ndarray,
                       sinkage_m: np.ndarray, contact_length_m: np.ndarray) -> np.ndarray:
    """Lateral strength of a sunk wheel: ``S = c b l + N tan phi + R_b(z, l)``.

    Cohesion over the patch, friction of the load (Mohr-Coulomb, Wong eq. 2.56 at full
    mobilisation) and the bulldozing of the sinkage wall (:func:`bulldozing_force_n`).

    Parameters
    ----------
    soil : SoilParams
        Soil.
    width_m : float
        Contact width b, m.
    normal_load_n, sinkage_m, contact_length_m : ndarray, shape (c,)
        Normal load N (N), sinkage z (m) and contact length l (m) of each wheel.

    Returns
    -------
    ndarray, shape (c,)
        ``S``, N (0 for an unloaded wheel).

    Raises
    ------
    ConfigError
        ``width_m`` not a finite length > 0 (a negative width took the cohesion off the
        strength, ``True`` was a 1 m wide contact), or a ``contact_length_m`` that
        :func:`bulldozing_force_n` refuses.
    """
    check_lengths("lateral_strength_n", width_m=width_m)
    load = np.asarray(normal_load_n, dtype=float)
    length = np.asarray(contact_length_m, dtype=float)
    strength = (shear_strength_n(soil, width_m, load, length)
                + bulldozing_force_n(sinkage_m, length, soil))
    return np.where(load > 0, strength, 0.0)


def shear_strength_n(soil: SoilParams, width_m: float, normal_load_n: np.ndarray,
                     contact_length_m: np.ndarray) -> np.ndarray:
    """Mohr-Coulomb shear strength of a contact patch, ``c b l + N tan phi``.

    The largest shear force the soil under the patch can carry in any direction (Wong,
    *Theory of Ground Vehicles* 4th ed., eq. 2.56 at full mobilisation); the longitudinal
    traction and the lateral shear share it (:func:`combined_shear_shares`).

    Parameters
    ----------
    soil : SoilParams
        Soil.
    width_m : float
        Contact width b, m.
    normal_load_n, contact_length_m : ndarray, shape (c,)
        Normal load N (N) and contact length l (m) of each wheel.

    Returns
    -------
    ndarray, shape (c,)
        N.

    Raises
    ------
    ConfigError
        ``width_m`` not a finite length > 0 (a negative width took the cohesion off the
        strength, NaN gave NaN).
    """
    check_lengths("shear_strength_n", width_m=width_m)
    tan_phi = np.tan(np.radians(soil.friction_angle_deg))
    return (soil.cohesion_pa * (width_m * np.asarray(contact_length_m, dtype=float))
            + np.asarray(normal_load_n, dtype=float) * tan_phi)


def combined_shear_shares(a_long: np.ndarray, a_lat: np.ndarray,
                          residual_ratio: float | None = None
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Share of each direction's own shear left when the patch slips along and across.

    A soil element under a wheel that slips longitudinally and sideways is sheared along
    the resultant of both displacements; its shear stress follows the shear curve of the
    *resultant* displacement and points along it (Mohr-Coulomb bounds the resultant, Wong
    eq. 2.56; the construction of Wong and Chiang's general theory of skid steering, "A
    general theory for skid steering of tracked vehicles on firm ground", Proc. IMechE D 215
    (2001) 343-355, and Wong ch. 7). With both displacements growing linearly along the patch,
    each over its own shear modulus (``a_long = |s| L / K_x``, ``a_lat = l |tan beta| /
    K_y``), the patch means are ``g(a) a_long / a`` and ``g(a) a_lat / a`` with ``a =
    sqrt(a_long^2 + a_lat^2)`` (:func:`shear_mobilisation`), and their resultant never
    exceeds the strength ``g(a) <= 1``. Each direction's force is its one-direction force
    ``g(a_i)`` times the share ``h(a) / h(a_i)``, ``h(u) = g(u) / u`` (``h(0) = 1/2``): 1
    when the other direction does not slip, less otherwise.

    Parameters
    ----------
    a_long, a_lat : float or ndarray, shape (c,)
        Longitudinal and lateral shear displacement at the rear of the patch over their
        moduli (dimensionless, sign ignored); broadcast together (a single number stands
        for every contact).
    residual_ratio : float or None
        ``K_r`` of the hump-type curve (:attr:`SoilParams.residual_ratio`); None =
        exponential.

    Returns
    -------
    share_long, share_lat : ndarray, shape (c,)
        Dimensionless, in (0, 1], for the hump-type curve too (``h`` never rises: the
        shear curve never exceeds twice its patch mean); the broadcast shape of the inputs.

    Raises
    ------
    ShapeError
        ``a_long`` and ``a_lat`` of shapes that do not broadcast (a scalar with an array
        was a bare ValueError of ``np.concatenate``).
    """
    a_x = np.abs(np.asarray(a_long, dtype=float))
    a_y = np.abs(np.asarray(a_lat, dtype=float))
    if a_x.shape != a_y.shape:
        try:
            a_x, a_y = np.broadcast_arrays(a_x, a_y)
        except ValueError:
            raise ShapeError(f"combined_shear_shares: a_long of shape {a_x.shape} and a_lat "
                             f"of shape {a_y.shape} do not broadcast") from None
    shape = a_x.shape
    a_x, a_y = a_x.reshape(-1), a_y.reshape(-1)
    a = np.hypot(a_x, a_y)
    args = np.concatenate([a, a_x, a_y])
    g = shear_mobilisation(args, residual_ratio)
    n = a.size
    pos = args > 1e-12
    h = np.where(pos, g / np.where(pos, args, 1.0), 0.5)
    h_res, h_x, h_y = h[:n], h[n:2 * n], h[2 * n:]
    return (h_res / h_x).reshape(shape), (h_res / h_y).reshape(shape)


def slip_sunk_strength_n(contact: SoilContact, normal_load_n: np.ndarray,
                         slip_ratio: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lateral strength and contact length of wheels sunk deeper by their slip.

    ``z = min(z_0(N) (1 + k_s |s|), z_max)`` (:attr:`SoilParams.slip_sinkage_ratio`), the
    chord ``l(z)`` (:func:`contact_chord_m`) and :func:`lateral_strength_n` at the deeper
    wall, as :func:`soil_contact` tabulates it at the static one.

    Parameters
    ----------
    contact : SoilContact
        Tabulated contact; its soil has a ``slip_sinkage_ratio``.
    normal_load_n : ndarray, shape (c,)
        Normal loads, N (within the table).
    slip_ratio : ndarray, shape (c,)
        Longitudinal (SAE) slip ratio of each wheel, dimensionless.

    Returns
    -------
    strength_n : ndarray, shape (c,)
        ``S``, N (0 for an unloaded wheel).
    contact_length_m : ndarray, shape (c,)
        ``l``, m.
    """
    z = slip_sinkage_m(contact, normal_load_n, slip_ratio)[0]
    length = contact_chord_m(z, contact.wheel_radius_m, contact.length_grid_m[0])
    return lateral_strength_n(contact.soil, contact.width_m, normal_load_n, z, length), length


def slip_sinkage_m(contact: SoilContact, normal_load_n: np.ndarray | float,
                   slip_ratio: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sinkage of wheels that slip, and its slope in ``|s|``.

    ``z = min(z_0(N) (1 + k_s |s|), z_max)`` with the static sinkage ``z_0`` of the
    tabulated contact, ``k_s`` = :attr:`SoilParams.slip_sinkage_ratio` and ``z_max`` the
    wheel radius or the soil's ``layer_depth_m`` (Ding et al. 2010; Lyasko 2010; the
    linear form ASSUMED, see :class:`SoilParams`).

    Parameters
    ----------
    contact : SoilContact
        Tabulated contact; its soil has a ``slip_sinkage_ratio``.
    normal_load_n : float or ndarray, shape (c,)
        Normal loads, N (within the table).
    slip_ratio : ndarray, shape (c,)
        Longitudinal (SAE) slip ratio, dimensionless (sign ignored).

    Returns
    -------
    sinkage_m : ndarray, shape (c,)
        z, m.
    dsinkage_ds_m : ndarray, shape (c,)
        ``d z / d|s|``, m (0 where capped).
    """
    soil = contact.soil
    z0 = np.interp(normal_load_n, contact.load_grid_n, contact.sinkage_grid_m)
    z_max = max_sinkage_m(contact.wheel_radius_m, soil)
    z_free = z0 * (1.0 + soil.slip_sinkage_ratio * np.abs(slip_ratio))
    z = np.minimum(z_free, z_max)
    return z, np.where(z_free < z_max, z0 * soil.slip_sinkage_ratio, 0.0)


@dataclass(frozen=True)
class SlipCompactionResistance:
    """A curve's motion resistance plus the compaction of the rut a slipping wheel digs.

    A wheel that slips sinks deeper (:func:`slip_sinkage_m`), and the soil pressed down to
    the deeper rut resists its motion: the coefficient adds ``(R_c(z(s)) - R_c(z_0)) / W``
    (:func:`terrain.terramechanics.resistance.compaction_resistance_n`, Wong eq. 2.54) to
    the resistance of ``base``, at the wheel load ``W`` the curve is built for (the static
    load, as :func:`longitudinal_curve`); the traction is ``base``'s. Used by physics v2 on
    a soil with :attr:`SoilParams.slip_compaction`.

    Parameters
    ----------
    base : TractionCurve
        Curve giving the traction and the resistance at rest (``coefficients``).
    contact : SoilContact
        Tabulated wheel-soil contact; its soil has a ``slip_sinkage_ratio``.
    load_n : float
        Wheel load, N (> 0).

    Raises
    ------
    ConfigError
        ``load_n`` not a finite load > 0 (the coefficient divides by it: 0 gave NaN at
        every slip), or a ``contact`` whose soil has no ``slip_sinkage_ratio`` (no deeper
        rut to compact).
    """

    base: TractionCurve
    contact: SoilContact
    load_n: float

    def __post_init__(self) -> None:
        config_positive("SlipCompactionResistance", load_n=self.load_n)
        if self.contact.soil.slip_sinkage_ratio is None:
            raise ConfigError(f"SlipCompactionResistance: the soil {self.contact.soil.name!r} "
                              f"has no slip_sinkage_ratio (static sinkage only: no deeper rut "
                              f"to compact)")

    def coefficients(self, abs_slip: np.ndarray, soil_resistance: float) -> CurveCoefficients:
        """``base``'s coefficients with the slip-sinkage compaction added to the resistance.

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].
        soil_resistance : float
            Constant motion resistance coefficient of the terrain (passed to ``base``).

        Returns
        -------
        CurveCoefficients
        """
        c = self.base.coefficients(abs_slip, soil_resistance)
        return CurveCoefficients(c.mu, c.dmu_ds,
                                 *self._compacted(abs_slip, c.resistance, c.dresistance_ds))

    def traction_terms(self, abs_slip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The traction half of :meth:`coefficients`: ``base``'s (which no resistance moves).

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].

        Returns
        -------
        mu, dmu_ds : ndarray, shape (...)
        """
        return curve_traction_terms(self.base, abs_slip, 0.0)

    def resistance_terms(self, abs_slip: np.ndarray, soil_resistance: float
                         ) -> tuple[np.ndarray, np.ndarray]:
        """The resistance half of :meth:`coefficients` (``base``'s traction not computed).

        Parameters
        ----------
        abs_slip : ndarray, shape (...)
            Slip magnitude in [0, 1].
        soil_resistance : float
            Constant motion resistance coefficient of the terrain (passed to ``base``).

        Returns
        -------
        resistance, dresistance_ds : ndarray, shape (...)
        """
        return self._compacted(abs_slip,
                               *curve_resistance_terms(self.base, abs_slip, soil_resistance))

    def _compacted(self, abs_slip: np.ndarray, resistance: np.ndarray,
                   dresistance_ds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``base``'s resistance and slope with the slip-sinkage compaction added."""
        soil, width = self.contact.soil, self.contact.width_m
        z, dz = slip_sinkage_m(self.contact, self.load_n, np.asarray(abs_slip, dtype=float))
        r, dr_dz = compaction_resistance_n(z, width, soil.k_c, soil.k_phi, soil.n)
        return (resistance + (r - self._static_compaction_n) / self.load_n,
                dresistance_ds + dr_dz * dz / self.load_n)

    @cached_property
    def _static_compaction_n(self) -> float:
        """``R_c(z_0)`` of the static rut at ``load_n``, N (fixed by the fields: once)."""
        soil = self.contact.soil
        z0 = float(np.interp(self.load_n, self.contact.load_grid_n,
                             self.contact.sinkage_grid_m))
        return float(compaction_resistance_n(z0, self.contact.width_m, soil.k_c, soil.k_phi,
                                             soil.n)[0])


def rate_weakening_factor(slip_speed_m_s: np.ndarray, soil: SoilParams
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Share of the shear strength left at a slip speed (velocity weakening), and its slope.

    ``f(u) = 1 / (1 + |u| / u_c)`` with ``u_c`` = :attr:`SoilParams.rate_weakening_speed_m_s`
    (``f = 1`` at standstill, ``1/2`` at ``u_c``); a soil without it gives ``f = 1``.

    Parameters
    ----------
    slip_speed_m_s : ndarray, shape (c,)
        Slip speed of each contact, m/s (its sign is ignored).
    soil : SoilParams
        Soil.

    Returns
    -------
    factor : ndarray, shape (c,)
        ``f``, in (0, 1].
    dfactor_du_s_m : ndarray, shape (c,)
        ``d f / d|u|``, s/m (<= 0).
    """
    u = np.abs(np.asarray(slip_speed_m_s, dtype=float))
    if soil.rate_weakening_speed_m_s is None:
        return np.ones_like(u), np.zeros_like(u)
    f = 1.0 / (1.0 + u / soil.rate_weakening_speed_m_s)
    return f, -f * f / soil.rate_weakening_speed_m_s


def soil_lateral_force_and_slope(contact: SoilContact, normal_load_n: np.ndarray,
                                 v_lateral_m_s: np.ndarray, rim_speed_m_s: np.ndarray,
                                 slide_speed_m_s: float = 0.02,
                                 slip_ratio: np.ndarray | None = None,
                                 shear_long: np.ndarray | None = None
                                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lateral soil force of skid-steered wheels and its secant slope (module docstring).

    ``F = -tanh(v_lat / v_slide) S(N) g(l |v_lat| / (K max(|omega r|, v_slide)))`` with the
    tabulated strength ``S(N)`` and contact length ``l(N)`` of :func:`soil_contact`; on a
    soil with slip sinkage, ``S`` and ``l`` of the wall deepened by each wheel's slip
    (:func:`slip_sunk_strength_n`; the slope keeps ``S`` fixed, as the longitudinal slip
    is not a lateral velocity); on a soil with velocity weakening, ``S`` times
    :func:`rate_weakening_factor` of ``v_lat`` (the secant slope includes it).

    Parameters
    ----------
    contact : SoilContact
        Tabulated wheel-soil contact.
    normal_load_n : ndarray, shape (c,)
        Normal load of each wheel, N, taken within the table's ``[0, max_load_n]``
        (:func:`soil_contact`): a negative load is an unloaded wheel (no force) and a load
        above the table gets the strength and contact length of its largest row.
    v_lateral_m_s : ndarray, shape (c,)
        Lateral velocity of each contact, m/s.
    rim_speed_m_s : ndarray, shape (c,)
        Rim speed ``omega r`` of each wheel, m/s (the rate at which soil passes under it).
    slide_speed_m_s : float
        Regularisation speed, m/s: floor of the rim speed (a locked wheel shears the soil
        fully) and scale of the sign smoothing.
    slip_ratio : ndarray, shape (c,), optional
        Longitudinal (SAE) slip ratio of each wheel; used only by a soil with a
        ``slip_sinkage_ratio`` (None: static sinkage).
    shear_long : ndarray, shape (c,), optional
        Longitudinal shear displacement of each patch over K_x, ``|s| L / K_x``: the lateral
        shear strength ``c b l + N tan phi`` (:func:`shear_strength_n`; not the bulldozing)
        is shared with the longitudinal traction by :func:`combined_shear_shares` (a soil
        with :attr:`SoilParams.combined_shear`), taken as ``S`` is: interpolated from the
        table's ``shear_grid_n`` (0 when unloaded, as ``S``), or at the load on a slip-sunk
        wall; the strength left, bulldozing plus the lateral share of the shear, is never
        negative and equals ``S`` at share 1. None: the lateral shear takes the whole
        strength.

    Returns
    -------
    force_n : ndarray, shape (c,)
        Lateral force, N.
    slope_n_s_m : ndarray, shape (c,)
        Secant slope ``F / v_lat`` (N s/m; its limit at ``v_lat = 0``), never positive:
        shallower than the tangent while the shear is mobilising (``F ~ v_lat^2`` near 0),
        steeper once the strength is reached (the tangent falls to 0, or turns positive past
        a hump's peak), which keeps the implicit integrator stable.
    share_long : ndarray, shape (c,) or None
        With ``shear_long``: the share of its one-direction traction left to each wheel's
        longitudinal shear (:func:`combined_shear_shares`, dimensionless); else None.

    Raises
    ------
    ConfigError
        ``slide_speed_m_s`` not a finite value > 0.
    """
    check_slide_speed("soil_lateral_force_and_slope", slide_speed_m_s)
    # np.clip's values bit for bit (-0.0 and NaN kept) for a floor of 0 and a top above it
    # (soil_contact's table tops out at a load > 0), without its Python wrapper (called on
    # every simulator step)
    n_load = np.minimum(np.maximum(0.0, np.asarray(normal_load_n, dtype=float)),
                        contact.load_grid_n[-1])
    sunk = contact.soil.slip_sinkage_ratio is not None and slip_ratio is not None
    if sunk:
        strength, length = slip_sunk_strength_n(contact, n_load,
                                                np.asarray(slip_ratio, dtype=float))
    else:
        strength = np.interp(n_load, contact.load_grid_n, contact.strength_grid_n)
        length = np.interp(n_load, contact.load_grid_n, contact.length_grid_m)
    v = np.asarray(v_lateral_m_s, dtype=float)
    roll = np.maximum(np.abs(np.asarray(rim_speed_m_s, dtype=float)), slide_speed_m_s)
    scale = length / (contact.soil.shear_modulus_y_m * roll)     # a = scale |v|
    a = scale * np.abs(v)
    share_long = None
    if shear_long is not None:
        share_long, share_lat = combined_shear_shares(shear_long, a,
                                                      contact.soil.residual_ratio)
        # the shear part of the strength S, taken where S is: at the load on the slip-sunk
        # wall (both from lateral_strength_n), else from the table as S (0 in its unloaded
        # row); so S - shear, the bulldozing, is >= 0 and the strength left never negative
        if sunk:
            shear = np.where(n_load > 0, shear_strength_n(contact.soil, contact.width_m,
                                                          n_load, length), 0.0)
        else:
            shear = np.interp(n_load, contact.load_grid_n, contact.shear_grid_n)
        strength = strength - shear * (1.0 - share_lat)
    if contact.soil.rate_weakening_speed_m_s is not None:
        strength = strength * rate_weakening_factor(v, contact.soil)[0]
    g = shear_mobilisation(a, contact.soil.residual_ratio)
    x_l = v / slide_speed_m_s
    th = np.tanh(x_l)
    force = -th * strength * g
    # secant F / v = -(tanh(x)/x) (S / v_slide) g, finite (0) at v = 0
    moving = np.abs(x_l) > 1e-9
    ratio = np.where(moving, th / np.where(moving, x_l, 1.0), 1.0)
    return force, -ratio * strength * g / slide_speed_m_s, share_long


def longitudinal_curve(contact: SoilContact, load_n: float) -> JanosiCurve:
    """Longitudinal Janosi-Hanamoto traction curve of the same wheel-soil contact.

    The same soil parameters as the lateral law (one parameter set per terrain; the
    longitudinal shear modulus K_x) on the sunk contact patch at ``load_n``:
    :meth:`terrain.terramechanics.traction.JanosiCurve.from_soil` with ``A = b l(N)``,
    ``L = l(N)``.

    Parameters
    ----------
    contact : SoilContact
        Tabulated wheel-soil contact (:func:`soil_contact`).
    load_n : float
        Normal load of the wheel, N (> 0).

    Returns
    -------
    JanosiCurve
    """
    length = float(np.interp(load_n, contact.load_grid_n, contact.length_grid_m))
    soil = contact.soil
    return JanosiCurve.from_soil(soil.cohesion_pa, soil.friction_angle_deg,
                                 soil.shear_modulus_m, contact.width_m * length, length,
                                 load_n, f"{soil.name}: {soil.source}",
                                 soil.residual_ratio)
