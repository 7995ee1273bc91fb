"""Force model of the simulator: ground-contact forces from state, commands and terrain.

Pure functions, no time stepping (the integrator is :func:`terrain.sim.dynamics.integrate`).
One point of contact per wheel, several per track; for each contact ``i`` with normal load
``N_i`` (static, no load transfer):

* longitudinal force ``N_i [mu(s_i) - f_soil(s_i) tanh(v_long,i / 0.01 m/s)]`` with the SAE
  slip ``s_i`` of the rim speed against the contact's longitudinal velocity
  (:func:`terrain.terramechanics.slip.sae_slip`, floored at
  :data:`SLIP_SPEED_FLOOR_M_S`), the traction curve ``mu`` and the motion resistance
  ``f_soil`` of the terrain (:meth:`terrain.terramechanics.traction.TractionCurve.coefficients`);
* lateral force ``-mu_lat N_i tanh(v_lat,i / 0.02 m/s)``
  (:func:`terrain.terramechanics.resistance.lateral_force_and_slope`: skid-steer turning
  resistance, swerve cornering);
* the ICR expansion ``chi`` (effect ``icr_expansion``) places the *kinematic* longitudinal
  contact lines of a skid-steer at ``chi y_i`` (Mandow et al. 2007), so with pure rolling
  ``yaw_rate = (v_R - v_L) / (chi B)``; forces act at the geometric contacts;
* gravity along the inclined plane (grade resistance, seed 003 eq. 10-11).

Physics ``v2`` (:data:`PHYSICS_VERSIONS`; ``v1`` is the model above, unchanged) adds

* load transfer: per-contact normal loads from the specific force on the body (its
  acceleration less gravity along the plane, :func:`specific_force_m_s2`: accelerating and
  standing on a grade both shift load) and the height of the centre of gravity
  (:func:`transferred_normal_loads`, :class:`LoadTransferParams`), used by
  the longitudinal, lateral and torque laws; the per-side motor current split in curves
  follows from it;
* on deformable soils with a :data:`terrain.terramechanics.lateral.SOILS` entry, the lateral
  wheel-soil law of :mod:`terrain.terramechanics.lateral` (Bekker sinkage, Janosi-Hanamoto
  lateral shear along the slip trajectory, bulldozing of the sinkage wall) instead of the
  Coulomb lateral friction;
* on rigid surfaces (no slip-producing soil resistance,
  :func:`terrain.terramechanics.resistance.is_deformable`), for a vehicle with a
  :data:`COMBINED_SLIP` entry (the Husky), the tyre's combined-slip law
  (:mod:`terrain.terramechanics.combined_slip`, friction ellipse): longitudinal and side
  force share the friction of the resultant slip, instead of the longitudinal curve plus an
  independent Coulomb lateral friction; other vehicles keep the Coulomb law.

:func:`contact_forces` also returns the analytic Jacobian ``dF/dV`` that the linearly implicit
integrator needs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping, NamedTuple

import numpy as np

from terrain.errors import ConfigError, config_flags, config_positive
from terrain.terramechanics.combined_slip import combined_slip_coefficients
from terrain.terramechanics.lateral import (SoilContact, rate_weakening_factor,
                                            soil_lateral_force_and_slope)
from terrain.terramechanics.resistance import (G_M_S2, HYSTERESIS_SPEED_M_S,
                                               lateral_force_and_slope)
from terrain.terramechanics.slip import (sae_slip, sae_slip_and_velocity_slope,
                                         sae_slip_denominator)
from terrain.terramechanics.traction import BurckhardtCurve, traction_peak
from terrain.vehicles.common import ContactGeometry
from terrain.vehicles.swerve import wheel_rim_speed

#: Lateral regularisation speed of the contact friction, m/s (stands for the lateral
#: compliance of tyre and soil).
SLIDE_SPEED_M_S = 0.02
#: Low-speed regularisation of the longitudinal slip, m/s: the SAE slip denominator
#: max(|omega r|, |v|) is floored at this speed, so near standstill the slip is linear in the
#: speed difference instead of jumping between -1 and 1 (without it a wheel held at zero
#: speed while the body creeps makes the contact force chatter; found by the audit, see
#: docs/audit_report.md). Same order as the lateral regularisation speed above.
SLIP_SPEED_FLOOR_M_S = 0.02
#: A contact's traction slope becomes the chord over the slip its step can reach
#: (:func:`reach_chord_contact`) where the curve's tangent is below this fraction of the
#: slope in use (the secant on a concave curve): the curve has flattened there.
FLAT_SLOPE_RATIO = 0.5
#: Regularisation speed of the sign of the soil resistance, m/s.
SOIL_SPEED_M_S = 0.01
#: Physics versions of the simulator: ``v1`` static loads and Coulomb lateral friction on
#: every terrain; ``v2`` load transfer, the lateral wheel-soil model on soils and the tyre's
#: combined-slip law on rigid surfaces.
PHYSICS_VERSIONS = ("v1", "v2")

#: Physics version the simulator and the audit use unless told otherwise (decided from the
#: held-out comparison of docs/physics_v2.md).
DEFAULT_PHYSICS = "v1"
#: Smallest normal load of a contact under load transfer, as a fraction of its static load
#: (a wheel about to lift keeps a little contact; avoids a singular implicit step).
MIN_LOAD_FRACTION = 0.05


@dataclass(frozen=True)
class LoadTransferParams:
    """Height of the centre of gravity for the load transfer of physics v2.

    Parameters
    ----------
    cog_height_m : float
        Height of the centre of gravity above the contact plane, m (finite, >= 0; 0: no
        load transfer).
    source : str
        Where the value comes from.

    Raises
    ------
    ConfigError
        ``cog_height_m`` not a finite real number >= 0 (NaN gave NaN normal loads on every
        step of a v2 run, a negative height loaded the inner wheels of a turn, ``True`` a
        1 m high centre of gravity), named ``LoadTransferParams.cog_height_m``.
    """

    cog_height_m: float
    source: str

    def __post_init__(self) -> None:
        config_positive("LoadTransferParams", allow_zero=True, cog_height_m=self.cog_height_m)


#: Centre-of-gravity heights by vehicle (read-only), for vehicles whose parameters carry
#: none (the tracked vehicle's is ``TrackedParams.cog_height_m``, seed 003 Table 2, which
#: :func:`terrain.sim.dynamics.integrate` reads). The Husky A200 value is an estimate:
#: Clearpath gives no CoG height; the datasheet body is 0.39 m tall with 0.13 m ground
#: clearance and the batteries and drive train sit low in the chassis, so the mass centre is
#: taken at the wheel-axle height plus 0.05 m.
LOAD_TRANSFER: Mapping[str, LoadTransferParams] = MappingProxyType({
    "husky": LoadTransferParams(0.2151, (
        "ASSUMED 0.215 m: Husky A200 datasheet (height 0.39 m, ground clearance 0.13 m, "
        "13 in wheels of radius 0.1651 m); mass centre 0.05 m above the wheel axles "
        "(batteries and motors low in the chassis); no published measurement")),
    "agrimaro": LoadTransferParams(0.0, "no load transfer modelled for AgriMaRo (steered)"),
})


def transferred_normal_loads(static_load_n: np.ndarray, x_m: np.ndarray, y_m: np.ndarray,
                             mass_kg: float, cog_height_m: float, accel_x_m_s2: float,
                             accel_y_m_s2: float) -> np.ndarray:
    """Normal loads with longitudinal and lateral load transfer (quasi-static).

    The in-plane force ``-m f`` acting at the centre of gravity, height ``h``, with the
    specific force ``f = a - g_plane`` (:func:`specific_force_m_s2`: the inertial force and
    the component of gravity along the plane together), is balanced by normal-load changes
    ``dN_i`` with ``sum dN_i = 0``, ``sum dN_i x_i = -m h f_x`` and
    ``sum dN_i y_i = -m h f_y`` (Wong, *Theory of Ground Vehicles*, ch. 3.1 longitudinal
    load transfer, whose axle loads on a grade include ``h W sin(theta)``, and ch. 6.1 lateral
    load transfer); for a layout symmetric in x and y the minimum-norm solution is
    ``dN_i = -m h (f_x x_i / sum x_j^2 + f_y y_i / sum y_j^2)``: under forward acceleration
    and when facing uphill the rear wheels gain load, in a left turn (``f_y > 0``) the right
    (outer) wheels. For two axles at ``x = +-L/2`` at rest on a grade this is Wong's shift
    ``m g sin(theta) h / L`` per axle. Loads are floored at :data:`MIN_LOAD_FRACTION` of the
    static load and rescaled to the static total.

    Parameters
    ----------
    static_load_n : ndarray, shape (c,)
        Static normal loads, N.
    x_m, y_m : ndarray, shape (c,)
        Contact positions relative to the centre of gravity, m.
    mass_kg : float
        Vehicle mass, kg.
    cog_height_m : float
        Height of the centre of gravity, m.
    accel_x_m_s2, accel_y_m_s2 : float
        Body-frame specific force at the centre of gravity (acceleration less gravity along
        the plane, :func:`specific_force_m_s2`), m/s^2.

    Returns
    -------
    ndarray, shape (c,)
        N.
    """
    loads = np.maximum(_unfloored_loads(static_load_n, x_m, y_m, mass_kg, cog_height_m,
                                        accel_x_m_s2, accel_y_m_s2),
                       MIN_LOAD_FRACTION * static_load_n)
    return loads * (static_load_n.sum() / loads.sum())


def _unfloored_loads(static_load_n: np.ndarray, x_m: np.ndarray, y_m: np.ndarray,
                     mass_kg: float, cog_height_m: float, accel_x_m_s2: float,
                     accel_y_m_s2: float) -> np.ndarray:
    """Loads the transfer of :func:`transferred_normal_loads` asks for, before its floor and
    rescaling, N (same arguments)."""
    # dot products instead of np.sum: this runs once per integrator step
    sx = float(x_m @ x_m)
    sy = float(y_m @ y_m)
    mh = mass_kg * cog_height_m
    loads = static_load_n
    if sx > 0:
        loads = loads - (mh * accel_x_m_s2 / sx) * x_m
    if sy > 0:
        loads = loads - (mh * accel_y_m_s2 / sy) * y_m
    return loads


def floored_contacts(static_load_n: np.ndarray, x_m: np.ndarray, y_m: np.ndarray,
                     mass_kg: float, cog_height_m: float, accel_x_m_s2: float,
                     accel_y_m_s2: float) -> np.ndarray:
    """Contacts whose load :func:`transferred_normal_loads` floors.

    Those whose transfer asks for less than :data:`MIN_LOAD_FRACTION` of their static load
    (a wheel about to lift). A load asked for exactly at the floor is not floored, and
    neither is one that only the rescaling to the static total takes below the floor (the
    floor of another contact raised the total).

    Parameters
    ----------
    static_load_n : ndarray, shape (c,)
        Static normal loads, N.
    x_m, y_m : ndarray, shape (c,)
        Contact positions relative to the centre of gravity, m.
    mass_kg : float
        Vehicle mass, kg.
    cog_height_m : float
        Height of the centre of gravity, m.
    accel_x_m_s2, accel_y_m_s2 : float
        Body-frame specific force at the centre of gravity (:func:`specific_force_m_s2`),
        m/s^2.

    Returns
    -------
    ndarray of bool, shape (c,)
        True where the load was raised to the floor.
    """
    return _unfloored_loads(static_load_n, x_m, y_m, mass_kg, cog_height_m, accel_x_m_s2,
                            accel_y_m_s2) < MIN_LOAD_FRACTION * static_load_n


@dataclass(frozen=True)
class CombinedSlipParams:
    """Tyre of the combined-slip law of physics v2 on rigid surfaces.

    Parameters
    ----------
    side_force_factor : float
        ``k_S`` of :func:`terrain.terramechanics.combined_slip.combined_slip_coefficients`,
        in (0, 1]: side over longitudinal friction of the tyre at the same resultant slip.
    source : str
        Where the value comes from.
    hold_at_peak : bool
        Hold the friction at the surface curve's peak past its peak slip (no falling branch;
        ``hold_slip`` of ``combined_slip_coefficients`` = the peak slip of
        :func:`terrain.terramechanics.traction.traction_peak`) instead of following the
        curve to full slip. The falling branch of a Burckhardt curve is the locked wheel of a
        car braking at road speed: rubber friction falls with the *sliding speed* past a peak
        (K. A. Grosch, Proc. R. Soc. A 274, 1963; Burckhardt's velocity factor
        ``exp(-c4 s v)``, Kiencke and Nielsen 2005), and a skid-steer robot turning at
        walking speed slides at 0.1-0.5 m/s, where it has not fallen.
    friction_scale : Mapping[str, float]
        Factor on the friction of the catalogue curve of a rigid surface for this tyre, by
        terrain name (:meth:`surface_curve`; physics v2 only), each finite and > 0; surfaces
        without an entry keep the catalogue curve. Kept as a read-only copy.

    Raises
    ------
    ConfigError
        ``side_force_factor`` not a real number in (0, 1] (NaN gave NaN side forces, a
        negative factor a side force along the slide), ``hold_at_peak`` not ``True`` or
        ``False``, ``friction_scale`` not a mapping of terrain names, or one of its factors
        not a finite real number > 0 (NaN and inf passed :meth:`surface_curve`'s check);
        each named ``CombinedSlipParams.<field>``.
    """

    side_force_factor: float
    source: str
    hold_at_peak: bool = False
    friction_scale: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))

    def __post_init__(self) -> None:
        config_positive("CombinedSlipParams", side_force_factor=self.side_force_factor)
        if not self.side_force_factor <= 1.0:
            raise ConfigError(f"CombinedSlipParams.side_force_factor must be in (0, 1] (side "
                              f"over longitudinal friction), got {self.side_force_factor!r}")
        config_flags("CombinedSlipParams", hold_at_peak=self.hold_at_peak)
        if not isinstance(self.friction_scale, Mapping) or not all(
                isinstance(name, str) for name in self.friction_scale):
            raise ConfigError(f"CombinedSlipParams.friction_scale must be a mapping of terrain "
                              f"names to factors, got {self.friction_scale!r:.80}")
        config_positive("CombinedSlipParams", **{
            f"friction_scale[{name}]": factor for name, factor in self.friction_scale.items()})
        # a read-only copy of the checked factors: the caller's dict stayed the field, so a
        # factor changed there afterwards (NaN, -1) reached surface_curve unchecked
        object.__setattr__(self, "friction_scale", MappingProxyType(dict(self.friction_scale)))

    def __reduce__(self):
        """Copy and pickle through a plain dict of the factors (a mappingproxy does
        neither: copy.deepcopy and pickle of the Husky's tyre failed with a TypeError)."""
        return type(self), (self.side_force_factor, self.source, self.hold_at_peak,
                            dict(self.friction_scale))

    def surface_curve(self, terrain_name: str, curve):
        """Traction-slip curve of this tyre on a rigid surface (``friction_scale`` applied).

        Parameters
        ----------
        terrain_name : str
            Catalogue terrain name.
        curve : TractionCurve
            The catalogue curve of that terrain.

        Returns
        -------
        TractionCurve
            ``curve`` itself without an entry; else a Burckhardt curve with ``c1`` and ``c3``
            multiplied by the factor (the friction at every slip scaled, the peak slip kept).

        Raises
        ------
        ConfigError
            A factor for a curve that is not a Burckhardt curve, or a factor <= 0.
        """
        factor = self.friction_scale.get(terrain_name)
        if factor is None:
            return curve
        if not isinstance(curve, BurckhardtCurve) or not factor > 0:
            raise ConfigError(f"friction_scale of {terrain_name} needs a Burckhardt curve and "
                              f"a factor > 0, got {type(curve).__name__}, {factor}")
        return BurckhardtCurve(factor * curve.c1, curve.c2, factor * curve.c3,
                               f"{curve.source}; friction x {factor:g} for this tyre "
                               f"(terrain.sim.forces.COMBINED_SLIP)")

    def hold_slip(self, curve) -> float:
        """Resultant slip at which the friction on ``curve`` is held (dimensionless).

        Parameters
        ----------
        curve : TractionCurve
            Surface traction-slip curve.

        Returns
        -------
        float
            The peak slip of a curve that falls past an interior peak when
            ``hold_at_peak``; else 1.
        """
        if not self.hold_at_peak:
            return 1.0
        peak = traction_peak(curve)
        return 1.0 if peak.monotonic else float(peak.slip)


#: Tyres with the combined-slip law in physics v2, by vehicle (read-only); a vehicle without
#: an entry keeps the Coulomb lateral friction on rigid surfaces. The Husky's side-force
#: factor was chosen on the *training* half of the measured BorealTC rigid-surface runs
#: (ASPHALT, FLOORING, ICE; docs/physics_v2.md, ``benchmarks/sweep_soil_params.py
#: --side-force-factors``), one value for its tyres on every rigid surface.
COMBINED_SLIP: Mapping[str, CombinedSlipParams] = MappingProxyType({
    "husky": CombinedSlipParams(0.6, (
        "CHOSEN on training runs: 0.6 of the grid 0.5-1.0 minimises the summed yaw-rate and "
        "current RMSE ratios to v1 over the training halves of the BorealTC ASPHALT, "
        "FLOORING and ICE runs, with the friction held at the peak (docs/physics_v2.md; "
        "0.7 without the hold); Kiencke & Nielsen (2005) give k_S below 1 for car tyres; "
        "lugged 13 in Husky tyres, no published value. Held at the peak: rubber friction "
        "falls with sliding speed only well above the 0.1-0.5 m/s of a turning robot "
        "(Grosch 1963). Friction on ICE x 5 (0.25 instead of Burckhardt's 0.05 for ice): "
        "CHOSEN on the training half of the BorealTC ICE runs by the same criterion over the "
        "factors 1-6 (docs/physics_v2.md, section 'ICE'); no measurement of that ice exists, "
        "Burckhardt's value is a car tyre on ice at road speed"),
        hold_at_peak=True, friction_scale=MappingProxyType({"ICE": 5.0})),
})


@dataclass(frozen=True)
class ContactLayout:
    """Contacts of a vehicle on the ground plane (constant during a run; c contacts).

    Parameters
    ----------
    x_m : ndarray, shape (c,)
        Longitudinal contact positions in the body frame, m.
    y_m : ndarray, shape (c,)
        Lateral contact positions (where the forces act), m.
    y_kinematic_m : ndarray, shape (c,)
        Lateral positions of the kinematic contact lines, m (``chi y`` for a skid-steer with
        the ICR expansion ``chi``, ``y`` otherwise).
    motor_of : ndarray of int, shape (c,)
        Motor driving each contact.
    n_motors : int
        Number of motors m.
    wheel_radius_m : float
        Rolling radius of wheels (sprocket radius of tracks), m.
    normal_load_n : ndarray, shape (c,)
        Static normal load of each contact, N.
    steered : bool
        Whether the contacts steer (swerve drive).
    """

    x_m: np.ndarray
    y_m: np.ndarray
    y_kinematic_m: np.ndarray
    motor_of: np.ndarray
    n_motors: int
    wheel_radius_m: float
    normal_load_n: np.ndarray
    steered: bool


def contact_layout(geometry: ContactGeometry, mass_kg: float, slope_rad: float,
                   chi: float) -> ContactLayout:
    """Contact layout of a vehicle on a plane of inclination ``slope_rad``.

    Parameters
    ----------
    geometry : ContactGeometry
        Contact positions, load shares and motor map of the vehicle.
    mass_kg : float
        Vehicle mass, kg.
    slope_rad : float
        Inclination of the plane, rad (normal loads scale with its cosine).
    chi : float
        ICR expansion (>= 1; ignored for steered vehicles).

    Returns
    -------
    ContactLayout
    """
    pos = geometry.positions_m
    x_c, y_c = pos[:, 0].copy(), pos[:, 1].copy()
    return ContactLayout(
        x_m=x_c, y_m=y_c, y_kinematic_m=y_c * (1.0 if geometry.steered else chi),
        motor_of=geometry.motor_of_contact, n_motors=geometry.n_motors,
        wheel_radius_m=geometry.wheel_radius_m,
        normal_load_n=geometry.load_share * mass_kg * G_M_S2 * np.cos(slope_rad),
        steered=geometry.steered)


class VelocityMaps(NamedTuple):
    """Linear maps of the body twist ``V = (v_x, v_y, yaw_rate)`` onto contact velocities.

    Attributes
    ----------
    long_kinematic : ndarray, shape (c, 3)
        ``V -> v_long`` at the kinematic contact lines (what the slip sees).
    long_force : ndarray, shape (c, 3)
        ``V -> v_long`` at the geometric contacts (transpose: where the forces act).
    lateral : ndarray, shape (c, 3)
        ``V -> v_lat`` at the geometric contacts.
    """

    long_kinematic: np.ndarray
    long_force: np.ndarray
    lateral: np.ndarray


def velocity_maps(layout: ContactLayout, delta_rad: np.ndarray) -> VelocityMaps:
    """Contact velocity maps for the current steering angles.

    The rim-speed kinematics (seed 001 eq. 4.20) have one home,
    :func:`terrain.vehicles.swerve.wheel_rim_speed`; it is linear in the body twist, so its
    value at the three unit twists gives the columns of each map: ``long_kinematic`` at the
    kinematic contact lines ``(x, y_kinematic)`` along the rolling direction ``delta``,
    ``long_force`` at the geometric contacts, ``lateral`` at the geometric contacts along
    ``delta + pi / 2`` (the velocity across the wheel, ``-v_x sin delta + v_y cos delta``).

    Parameters
    ----------
    layout : ContactLayout
        Contacts.
    delta_rad : ndarray, shape (c,)
        Steering angle of each contact, rad (0 for fixed wheels).

    Returns
    -------
    VelocityMaps
    """
    d = np.asarray(delta_rad, dtype=float)
    y = np.stack([layout.y_kinematic_m, layout.y_m, layout.y_m])[:, :, None]   # (3, c, 1)
    ang = np.stack([d, d, d + 0.5 * np.pi])[:, :, None]
    unit = np.eye(3)                                                           # columns
    maps = wheel_rim_speed(unit[0], unit[1], unit[2], layout.x_m[None, :, None], y, ang)
    return VelocityMaps(maps[0], maps[1], maps[2])


class ContactForces(NamedTuple):
    """Ground-contact forces on the body and what the integrator needs of them.

    Attributes
    ----------
    force : ndarray, shape (3,)
        ``(F_x, F_y, M_z)`` in the body frame, N, N, N m (contacts only).
    jacobian : ndarray, shape (3, 3)
        ``d force / d V``, the analytic Jacobian (secant slopes where the tangent would let
        a Newton step overshoot).
    mu : ndarray, shape (c,)
        Traction coefficient of each contact (signed), at the twist given.
    rim_speed_m_s : ndarray, shape (c,)
        ``omega r`` of each contact, m/s.
    dmu_dv_s_m : ndarray, shape (c,)
        ``d mu / d v_long`` of each contact along the slope the Jacobian uses, s/m: the
        linearly implicit step gives the body ``force + jacobian dV``, whose traction
        coefficients are ``mu + dmu_dv_s_m (long_kinematic dV)``
        (:func:`step_traction_coefficient`).
    v_long_m_s, slip, dslip_dv_s_m, dmu_ds_tangent, dmu_ds : ndarray, shape (c,) or None
        The longitudinal law's intermediate values, for :func:`reach_chord_contact`:
        longitudinal contact speed (m/s), SAE slip and its ``d / d v_long`` (s/m), the
        traction curve's tangent at ``|slip|`` and the slope the Jacobian uses
        (dimensionless). None under the tyre's combined-slip law (its own slopes).
    """

    force: np.ndarray
    jacobian: np.ndarray
    mu: np.ndarray
    rim_speed_m_s: np.ndarray
    dmu_dv_s_m: np.ndarray
    v_long_m_s: np.ndarray | None = None
    slip: np.ndarray | None = None
    dslip_dv_s_m: np.ndarray | None = None
    dmu_ds_tangent: np.ndarray | None = None
    dmu_ds: np.ndarray | None = None
    shear_share: np.ndarray | None = None


def contact_forces(layout: ContactLayout, maps: VelocityMaps, terrain, twist: np.ndarray,
                   omega: np.ndarray, normal_load_n: np.ndarray | None = None,
                   soil: SoilContact | None = None,
                   side_force_factor: float | None = None,
                   hold_slip: float = 1.0) -> ContactForces:
    """Contact forces of all wheels/tracks and their Jacobian (the force model).

    Parameters
    ----------
    layout : ContactLayout
        Contacts.
    maps : VelocityMaps
        Contact velocity maps for the current steering (:func:`velocity_maps`).
    terrain : TerrainParams
        Terrain under the vehicle (traction curve, resistances, lateral friction).
    twist : ndarray, shape (3,)
        Body twist ``(v_x, v_y, yaw_rate)``, m/s, m/s, rad/s.
    omega : ndarray, shape (m,)
        Motor (wheel) speeds, rad/s.
    normal_load_n : ndarray, shape (c,), optional
        Normal loads (physics v2 load transfer, :func:`transferred_normal_loads`); None =
        the static loads of ``layout`` (v1).
    soil : SoilContact, optional
        Lateral wheel-soil contact of physics v2 on deformable soil
        (:func:`terrain.terramechanics.lateral.soil_lateral_force_and_slope`); None = the
        Coulomb lateral friction of the terrain (v1, and rigid surfaces in v2).
    side_force_factor : float, optional
        With ``soil`` None: the tyre's combined-slip law
        (:func:`terrain.terramechanics.combined_slip.combined_slip_coefficients`, physics v2
        on rigid surfaces, :data:`COMBINED_SLIP`) with this side-force factor: longitudinal
        and lateral force from the terrain's curve at the resultant of the longitudinal slip
        and the side slip ``v_lat / max(|omega r|, |v_long|, floor)``; the Jacobian keeps
        each direction's own slope (tangent, or the secant where that is steeper, as for
        the longitudinal law) and drops the cross terms. None: the laws above.
    hold_slip : float
        Resultant slip past which the combined-slip friction is held
        (:meth:`CombinedSlipParams.hold_slip`); 1 = the curve up to full slip.

    Returns
    -------
    ContactForces
    """
    normal = layout.normal_load_n if normal_load_n is None else normal_load_n
    a_mat, a_force, b_mat = maps
    v_long = a_mat @ twist
    v_lat = b_mat @ twist
    wr = omega[layout.motor_of] * layout.wheel_radius_m
    slip, ds_dv = sae_slip_and_velocity_slope(wr, v_long, SLIP_SPEED_FLOOR_M_S)
    abs_s = np.abs(slip)
    sign_s = np.sign(slip)
    coef = terrain.curve.coefficients(abs_s, terrain.soil_resistance)
    if soil is not None and soil.soil.rate_weakening_speed_m_s is not None:
        coef = _rate_weakened(coef, wr, v_long, soil.soil)
    share = None
    if soil is not None:
        a_long = (abs_s / terrain.curve.traction.shear_slip if soil.soil.combined_shear
                  else None)
        f_lat, k_lat, share = soil_lateral_force_and_slope(
            soil, normal, v_lat, wr, SLIDE_SPEED_M_S, slip_ratio=slip, shear_long=a_long)
        if share is not None:   # the soil's strength shared by both directions
            coef = coef._replace(mu=coef.mu * share, dmu_ds=coef.dmu_ds * share)
    f_soil = coef.resistance
    th_s = np.tanh(v_long / SOIL_SPEED_M_S)
    combined = soil is None and side_force_factor is not None
    if combined:
        den = sae_slip_denominator(wr, v_long, SLIP_SPEED_FLOOR_M_S)
        slip_side = v_lat / den
        comb = combined_slip_coefficients(terrain.curve, slip, slip_side, side_force_factor,
                                          hold_slip)
        mu = comb.mu_long
        # each direction's slope of the ellipse at the other's fixed slip,
        # g + (s_i / s_res)^2 (mu' - g), floored at the secant g (no overshoot past the peak)
        r2 = np.where(comb.resultant_slip > 1e-12, comb.resultant_slip, 1.0) ** 2
        excess = (comb.tangent - comb.secant) / r2
        dmu = comb.secant + np.maximum(slip * slip * excess, 0.0)
        slope_side = comb.secant + np.maximum(slip_side * slip_side * excess, 0.0)
    else:
        mu = sign_s * coef.mu
        dmu = coef.dmu_ds
        # secant slope mu(s)/s where it exceeds the tangent: keeps the Newton step from
        # overshooting past the traction peak (no limit cycles on stiff, peaked curves)
        slipping = abs_s > 1e-6
        secant = np.where(slipping, mu / np.where(slipping, slip, 1.0), dmu)
        dmu = np.maximum(dmu, secant)
    dmu_dv = dmu * ds_dv
    f_long = normal * (mu - f_soil * th_s)
    k_long = normal * (dmu_dv - f_soil * (1.0 - th_s * th_s) / SOIL_SPEED_M_S)
    k_long = k_long - normal * th_s * coef.dresistance_ds * sign_s * ds_dv
    if combined:
        f_lat = normal * comb.mu_side
        k_lat = -normal * side_force_factor * slope_side / den
    elif soil is None:
        f_lat, k_lat = lateral_force_and_slope(terrain.lateral_friction, normal, v_lat,
                                               SLIDE_SPEED_M_S)
    force = a_force.T @ f_long + b_mat.T @ f_lat
    jac = (a_force.T * k_long) @ a_mat + (b_mat.T * k_lat) @ b_mat
    if combined:
        return ContactForces(force, jac, mu, wr, dmu_dv)
    return ContactForces(force, jac, mu, wr, dmu_dv, v_long, slip, ds_dv, coef.dmu_ds, dmu, share)


def _rate_weakened(coef, rim_speed_m_s: np.ndarray, v_long_m_s: np.ndarray, soil):
    """Traction coefficients of a velocity-weakening soil at the contacts' slip speeds.

    ``mu f(u)`` with ``u = |omega r - v_long|`` (:func:`terrain.terramechanics.lateral.
    rate_weakening_factor`); the slope in ``|s|`` adds ``mu f'(u) du/d|s|``, ``du/d|s| =
    max(|omega r|, |v_long|, floor)`` (the SAE denominator held fixed).
    """
    u = np.abs(rim_speed_m_s - v_long_m_s)
    f, df_du = rate_weakening_factor(u, soil)
    den = sae_slip_denominator(rim_speed_m_s, v_long_m_s, SLIP_SPEED_FLOOR_M_S)
    return coef._replace(mu=coef.mu * f, dmu_ds=coef.dmu_ds * f + coef.mu * df_du * den)


def reach_chord_contact(contact: ContactForces, layout: ContactLayout, maps: VelocityMaps,
                        terrain, dv_reach: np.ndarray,
                        normal_load_n: np.ndarray | None = None,
                        soil: SoilContact | None = None) -> ContactForces:
    """The contact forces with each traction slope taken over the slip the step can reach.

    :func:`contact_forces` linearises the longitudinal law with the larger of the tangent and
    the secant ``mu(s) / s`` of the traction curve: the secant line passes through zero slip,
    so a linearly implicit step cannot carry the body past the rim speed, but where the curve
    is flat it also brakes every step. On ice (Burckhardt, ``c2`` = 306: flat beyond 2 %
    slip) a Husky held at the friction limit while its rims ramp at 0.5 m/s^2 accelerated at
    0.44 m/s^2 with 100 Hz physics and 0.47 with 1 kHz, and its slip was 0.13-0.17 against
    0.05: the secant's damping ``dt N mu / (s omega r)`` adds 10-20 % to the mass there.

    Here the slope is the chord of the curve over the slip interval the step can reach: from
    the slip at the start of the step to the slip after ``dv_reach``, the explicit step (the
    forces held at their start values: as far as the step can carry a contact whose force
    falls as its slip falls). Where that interval reaches or crosses zero slip the secant is
    kept (no overshoot past the rim speed, as before); elsewhere the chord is floored at 0 (a
    falling branch past a peak would make the step anti-damped). On a concave curve the chord
    lies between the tangent and the secant, equals the tangent as the step shrinks, and is
    the exact slope of a step that ends at the interval's far end. It is applied where the
    curve has flattened, its tangent below :data:`FLAT_SLOPE_RATIO` of the slope in use (ice
    beyond 0.5 % slip, Wong's snow beyond 53 %): where the tangent is within a factor of 2 of
    the secant the curve itself pulls the slip back to its balance and the secant only slows
    the way there (the soils' start-ups moved by at most 0.004 of slip with the chord applied
    everywhere, at 30 % more time per step on v2's soils). Only the longitudinal traction
    slope changes (the soil resistance, the lateral law and the forces themselves do not); the
    tyre's combined-slip law of physics v2 on rigid surfaces keeps its own slopes.

    Parameters
    ----------
    contact : ContactForces
        :func:`contact_forces` at the start of the step, with the same maps, terrain and loads.
    layout : ContactLayout
        Contacts.
    maps : VelocityMaps
        Contact velocity maps of the step.
    terrain : TerrainParams
        Terrain under the vehicle (its traction curve).
    dv_reach : ndarray, shape (3,)
        Twist change of the explicit step, ``dt M^-1 (force + gravity + Coriolis)``,
        ``(dv_x, dv_y, d yaw_rate)``, m/s, m/s, rad/s.
    normal_load_n : ndarray, shape (c,), optional
        Normal loads used for ``contact`` (None: the static loads of ``layout``), N.
    soil : SoilContact, optional
        The soil contact ``contact`` was computed with (a velocity-weakening soil's curve
        is weakened at the reached slip speed too).

    Returns
    -------
    ContactForces
        ``contact`` with the Jacobian, ``dmu_dv_s_m`` and ``dmu_ds`` of the chord slopes.
    """
    if contact.slip is None:
        return contact
    old = contact.dmu_ds
    tangent = contact.dmu_ds_tangent
    flat = tangent < FLAT_SLOPE_RATIO * old
    if not flat.any():                        # no contact where the curve has flattened
        return contact
    normal = layout.normal_load_n if normal_load_n is None else normal_load_n
    a_mat, a_force, _ = maps
    slip, ds_dv = contact.slip, contact.dslip_dv_s_m
    reach = sae_slip(contact.rim_speed_m_s, contact.v_long_m_s + a_mat @ dv_reach,
                     speed_floor_m_s=SLIP_SPEED_FLOOR_M_S, dead_band_m_s=0.0)
    abs_s, abs_r = np.abs(slip), np.abs(reach)
    mu_s = np.abs(contact.mu)
    coef_r = terrain.curve.coefficients(abs_r, terrain.soil_resistance)
    if soil is not None and soil.soil.rate_weakening_speed_m_s is not None:
        coef_r = _rate_weakened(coef_r, contact.rim_speed_m_s,
                                contact.v_long_m_s + a_mat @ dv_reach, soil.soil)
    mu_r = coef_r.mu if contact.shear_share is None else coef_r.mu * contact.shear_share
    gap = abs_s - abs_r
    wide = np.abs(gap) > 1e-9
    chord = np.where(wide, (mu_s - mu_r) / np.where(wide, gap, 1.0), tangent)
    # the reach meets or crosses zero slip: the secant keeps the step on this side of it
    to_zero = (abs_r <= 1e-9) | (np.sign(reach) != np.sign(slip))
    dmu = np.where(to_zero | ~flat, old, np.maximum(chord, 0.0))
    dk = normal * (dmu - old) * ds_dv
    jacobian = contact.jacobian + (a_force.T * dk) @ a_mat
    return contact._replace(jacobian=jacobian, dmu_dv_s_m=dmu * ds_dv, dmu_ds=dmu)


def step_traction_coefficient(contact: ContactForces, maps: VelocityMaps,
                              dv: np.ndarray) -> np.ndarray:
    """Traction coefficient of each contact over a linearly implicit step.

    The step gives the body the contact force linearised at the start of the step,
    ``force + jacobian dV``; the traction the motors pay for is the same linearisation,
    ``mu + (d mu / d v_long) dv_long`` with ``dv_long = long_kinematic dV``. The coefficient
    at the start of the step (:attr:`ContactForces.mu`) is evaluated with the new wheel
    speed and the old body velocity: in an acceleration it charges the motors for slip the
    body never sees (a Husky ramping at 0.5 m/s^2 on ASPHALT: 264 N of traction for a
    25 N body force at 100 Hz physics, 31 N at 5 kHz).

    Parameters
    ----------
    contact : ContactForces
        Contact forces at the start of the step (:func:`contact_forces`).
    maps : VelocityMaps
        The maps they were computed with.
    dv : ndarray, shape (3,)
        Twist change of the step, ``(dv_x, dv_y, d yaw_rate)``, m/s, m/s, rad/s.

    Returns
    -------
    ndarray, shape (c,)
        Signed traction coefficients.
    """
    return contact.mu + contact.dmu_dv_s_m * (maps.long_kinematic @ dv)


def gravity_force(mass_kg: float, slope_rad: float, yaw_rad: float,
                  cog_m: np.ndarray | None = None) -> np.ndarray:
    """Gravity along an inclined plane rising along world +x, in the body frame.

    Grade resistance ``m g sin(slope)`` (seed 003 eq. 10-11) resolved on the body axes,
    acting at the centre of gravity ``c``: its yaw moment about the body origin is
    ``c_x F_y - c_y F_x``.

    Parameters
    ----------
    mass_kg : float
        Vehicle mass, kg.
    slope_rad : float
        Inclination of the plane, rad.
    yaw_rad : float
        Heading of the body on the plane, rad (0 = facing uphill).
    cog_m : ndarray, shape (2,), optional
        Centre of gravity in the body frame, m (:attr:`ContactGeometry.cog_m
        <terrain.vehicles.common.ContactGeometry.cog_m>`); None: the body origin.

    Returns
    -------
    ndarray, shape (3,)
        ``(F_x, F_y, M_z)``, N, N, N m (``M_z`` about the body origin).
    """
    g_plane = G_M_S2 * np.sin(slope_rad)
    cy, sy = np.cos(yaw_rad), np.sin(yaw_rad)
    f_x, f_y = -mass_kg * g_plane * cy, mass_kg * g_plane * sy
    m_z = 0.0 if cog_m is None else float(cog_m[0] * f_y - cog_m[1] * f_x)
    return np.array([f_x, f_y, m_z])


def rigid_body_terms(mass_kg: float, yaw_inertia_kg_m2: float, cog_m: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Mass matrix and velocity terms of a planar rigid body, in the body-origin twist.

    The state is the twist of the body origin ``V = (v_x, v_y, r)``; the mass sits at the
    centre of gravity ``c`` (body frame). Newton at the c.o.g., ``m a_G = F`` with
    ``a_G = dv/dt + r x v + dr/dt x c - r^2 c``, and Euler about it,
    ``I_G dr/dt = M_O - c x F`` (``M_O``: moment of the forces about the origin), give
    ``M dV/dt = F + q(V)`` with::

        M = [[m, 0, -m c_y], [0, m, m c_x], [-m c_y, m c_x, I_G + m |c|^2]]
        q = m r T V,  T = [[0, 1, c_x], [-1, 0, c_y], [-c_x, -c_y, 0]]

    i.e. ``q = (m r v_y + m r^2 c_x, -m r v_x + m r^2 c_y, -m r (c_x v_x + c_y v_y))``
    (Greenwood, *Principles of Dynamics*, ch. 7: a rigid body about a point other than its
    mass centre). With ``c = 0`` this is ``diag(m, m, I)`` and the Coriolis terms
    ``(m r v_y, -m r v_x, 0)``. Both matrices are constant over a run: the integrator
    builds them once and evaluates ``q`` as ``(m r) (T @ V)`` every step.

    Parameters
    ----------
    mass_kg : float
        Mass, kg.
    yaw_inertia_kg_m2 : float
        Yaw inertia about the centre of gravity, kg m^2.
    cog_m : ndarray, shape (2,)
        Centre of gravity in the body frame, m.

    Returns
    -------
    mass_matrix : ndarray, shape (3, 3)
        ``M`` (kg, kg m, kg m^2).
    transport : ndarray, shape (3, 3)
        ``T`` (1, m): the velocity terms are ``m r (T @ V)``, N, N, N m.
    """
    cx, cy = float(cog_m[0]), float(cog_m[1])
    m = float(mass_kg)
    mass_matrix = np.array([[m, 0.0, -m * cy], [0.0, m, m * cx],
                            [-m * cy, m * cx, yaw_inertia_kg_m2 + m * (cx * cx + cy * cy)]])
    transport = np.array([[0.0, 1.0, cx], [-1.0, 0.0, cy], [-cx, -cy, 0.0]])
    return mass_matrix, transport


def specific_force_m_s2(accel_body_m_s2: np.ndarray, gravity_force_n: np.ndarray,
                        mass_kg: float) -> np.ndarray:
    """In-plane specific force on the body: its acceleration less gravity, body axes.

    ``f = a - F_g / m`` with the gravity force along the plane ``F_g`` of
    :func:`gravity_force`: what an accelerometer on the body senses in the plane (the same
    quantity :func:`terrain.sim.sensors.gravity_specific_force` adds to the simulated IMU),
    and what drives the load transfer (:func:`transferred_normal_loads`). At rest facing
    uphill on a grade ``theta`` it is ``(g sin(theta), 0)``.

    Parameters
    ----------
    accel_body_m_s2 : ndarray, shape (2,)
        Body-frame kinematic acceleration ``dV/dt + r x V``, m/s^2.
    gravity_force_n : ndarray, shape (2,) or (3,)
        Gravity along the plane in the body frame (:func:`gravity_force`; a yaw moment, if
        given, is ignored), N.
    mass_kg : float
        Vehicle mass, kg.

    Returns
    -------
    ndarray, shape (2,)
        m/s^2.
    """
    return accel_body_m_s2 - gravity_force_n[:2] / mass_kg


def contact_torque_nm(layout: ContactLayout, terrain, mu: np.ndarray,
                      rim_speed_m_s: np.ndarray, normal_load_n: np.ndarray | None = None
                      ) -> np.ndarray:
    """Torque each contact asks of its motor: traction plus torque-only rolling loss.

    ``r N_i (mu_i + h tanh(omega r / 0.05 m/s))`` with the terrain's hysteresis ``h``
    (calibrated to the measured Husky currents, :mod:`terrain.terramechanics.calibration`).

    Parameters
    ----------
    layout : ContactLayout
        Contacts.
    terrain : TerrainParams
        Terrain under the vehicle.
    mu : ndarray, shape (c,)
        Signed traction coefficients (:attr:`ContactForces.mu`).
    rim_speed_m_s : ndarray, shape (c,)
        Rim speeds, m/s.
    normal_load_n : ndarray, shape (c,), optional
        Normal loads (v2 load transfer); None = the static loads of ``layout``.

    Returns
    -------
    ndarray, shape (c,)
        N m.
    """
    normal = layout.normal_load_n if normal_load_n is None else normal_load_n
    return layout.wheel_radius_m * normal * (
        mu + terrain.hysteresis * np.tanh(rim_speed_m_s / HYSTERESIS_SPEED_M_S))


def check_physics(physics: str) -> None:
    """Refuse a physics version the simulator does not have.

    Parameters
    ----------
    physics : str
        A version name (:data:`PHYSICS_VERSIONS`).

    Raises
    ------
    ConfigError
        ``physics`` not one of :data:`PHYSICS_VERSIONS` (the message lists them).
    """
    if physics not in PHYSICS_VERSIONS:
        raise ConfigError(f"unknown physics {physics!r}; valid choices: "
                          f"{', '.join(PHYSICS_VERSIONS)}")


def reported_current_a(motor, wheel_torque_nm: np.ndarray, omega_rad_s: np.ndarray,
                       physics: str = "v1") -> np.ndarray:
    """Motor current magnitude the drive reports, from wheel torque and speed.

    ``v1``: ``|I|`` of the motor law :meth:`terrain.vehicles.common.MotorParams.current_from_torque`
    in every quadrant. ``v2``: the same while the motor drives (torque and speed of the same
    sign); while it brakes (torque against the speed, the motor absorbs power) the report is
    the no-load current only, ``I_0 m`` with ``m = |tanh(omega / 0.05)|``: the Husky's current
    reading follows the power drawn, not the braking current circulating in the bridge. Near
    rest the torque that holds the wheel is reported as is, blended in with weight ``1 - m``
    (``k = N k_t eta``)::

        I = I_0 m + m max(T sgn(omega), 0) / k + (1 - m) |T| / k

    so a wheel braked at a speed under about 0.05 rad/s reports part of its holding current
    as well. This is a sensor
    model identified by the audit on the measured runs (docs/physics_v2.md: with ``|I|`` the
    replay over-predicts the current by 6 A on ASPHALT while the wheels decelerate faster
    than 0.3 m/s^2, and the 2 Hz output filter smears that into the stand-still samples).

    Parameters
    ----------
    motor : MotorParams
        Motor of the vehicle (no-load current, gear ratio, torque constant, efficiency).
    wheel_torque_nm : ndarray, shape (...)
        Torque at the wheel, N m.
    omega_rad_s : ndarray, shape (...)
        Wheel speed, rad/s.
    physics : str
        ``v1`` or ``v2`` (:data:`PHYSICS_VERSIONS`).

    Returns
    -------
    ndarray, shape (...)
        Current magnitude, A.

    Raises
    ------
    ConfigError
        ``physics`` not one of :data:`PHYSICS_VERSIONS`.
    """
    check_physics(physics)
    if physics == "v1":
        return np.abs(motor.current_from_torque(wheel_torque_nm, omega_rad_s))
    direction = motor.rotation_direction(omega_rad_s)
    drive = np.asarray(wheel_torque_nm, dtype=float) * np.sign(direction)
    k = motor.wheel_torque_per_amp_nm
    moving = np.abs(direction)
    motoring = np.maximum(drive, 0.0) / k
    # at rest (direction 0) the torque that holds the wheel is reported as is
    return motor.no_load_current_a * moving + moving * motoring + (1.0 - moving) * np.abs(
        np.asarray(wheel_torque_nm, dtype=float)) / k
