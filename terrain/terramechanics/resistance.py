"""Motion, grade, lateral and turning resistance of wheels and tracks.

References
----------
J. Y. Wong, *Theory of Ground Vehicles*, 4th ed., Wiley 2008: rolling/compaction resistance
(ch. 2.2, Bekker pressure-sinkage), skid-steering turning resistance moment
``M_r = mu_t W l / 4`` of a tracked vehicle (ch. 7.2).
Seed 003 (``003_557e4138a8e06c5e.txt``) eq. 10: grade resistance ``W sin(theta_pitch)``.
Brixius (1987), motion resistance ratio ``1/Bn + 0.04 + 0.5 s / sqrt(Bn)``.
"""

from __future__ import annotations

import math

import numpy as np

from terrain.errors import ConfigError, config_numbers, config_positive, refuse_infinite
from terrain.terramechanics.traction import check_numeric_pair, numeric_array, traction_peak

G_M_S2 = 9.80665
#: Regularisation speed of the sign of the torque-only rolling loss (hysteresis), m/s: the
#: loss torque is ``r N h tanh(omega r / HYSTERESIS_SPEED_M_S)``
#: (:func:`terrain.sim.forces.contact_torque_nm`, inverted by
#: :func:`terrain.terramechanics.calibration.husky_hysteresis_for_current`).
HYSTERESIS_SPEED_M_S = 0.05


def soil_resistance_coefficient(terrain, slip: np.ndarray | float) -> np.ndarray:
    """Slip-producing motion resistance over normal load (soil compaction / bulldozing).

    The terrain's curve says which law applies (:meth:`TractionCurve.coefficients`): for
    Brixius terrains ``1/Bn + 0.5 |s| / sqrt(Bn)`` (the 0.04 tyre-hysteresis term of
    Brixius is part of :attr:`TerrainParams.hysteresis`); otherwise the constant
    ``terrain.soil_resistance``.

    Parameters
    ----------
    terrain : TerrainParams
        Terrain (its ``curve`` and ``soil_resistance``).
    slip : float or ndarray, shape (...)
        SAE slip, clipped to [-1, 1] (dimensionless).

    Returns
    -------
    ndarray, shape (...)
        Dimensionless coefficient (force = coefficient x normal load).

    Raises
    ------
    DataFormatError
        A slip that is not a number or a numeric array (booleans, text, None;
        :func:`~terrain.terramechanics.traction.numeric_array`).
    """
    s = np.abs(np.clip(numeric_array("soil_resistance_coefficient", "slip", slip), -1.0, 1.0))
    return terrain.curve.coefficients(s, terrain.soil_resistance).resistance


def is_deformable(terrain) -> bool:
    """Whether the ground itself deforms: slip-producing soil resistance anywhere on [0, 1].

    Decides from the physics of the entry, not from the curve's type: compaction /
    bulldozing resistance (:func:`soil_resistance_coefficient`) > 0 marks a deformable soil
    (Janosi-Hanamoto and Brixius entries of the catalogue), none a rigid surface (Burckhardt
    road curves, including ice). The desired-slip table
    (:mod:`terrain.control.desired_slip`) picks its target rule by it, and physics v2 of the
    simulator its rigid-surface tyre law (:mod:`terrain.sim.forces`).

    Parameters
    ----------
    terrain : TerrainParams
        Catalogue entry.

    Returns
    -------
    bool
    """
    rho = soil_resistance_coefficient(terrain, np.linspace(0.0, 1.0, 101))
    return bool(np.any(rho > 0.0))


def grade_resistance_n(mass_kg: float, pitch_rad: np.ndarray | float) -> np.ndarray:
    """Grade resistance ``m g sin(pitch)`` (seed 003 eq. 10 with zero roll).

    Parameters
    ----------
    mass_kg : float
        Vehicle mass, kg.
    pitch_rad : float or ndarray, shape (...)
        Nose-up inclination of the vehicle, rad (positive when climbing); NaN (a missing
        sample) passes as a NaN force.

    Returns
    -------
    ndarray, shape (...)
        Force opposing forward motion, N.

    Raises
    ------
    ConfigError
        ``mass_kg`` not a finite real number > 0 (a negative mass gave a grade force that
        pushes uphill, NaN a NaN force, ``True`` a 1 kg vehicle).
    DataFormatError
        ``pitch_rad`` not a number or a numeric array (None was a NaN force, ``True`` the
        grade of a 1 rad slope, text NumPy's bare ValueError;
        :func:`~terrain.terramechanics.traction.numeric_array`).
    NonFiniteInputError
        An infinite ``pitch_rad`` (``sin`` of it was a NaN force and a RuntimeWarning),
        named with its flat index (:func:`terrain.errors.refuse_infinite`).
    """
    config_numbers("grade_resistance_n", mass_kg=mass_kg)
    config_positive("grade_resistance_n", mass_kg=mass_kg)
    pitch = numeric_array("grade_resistance_n", "pitch_rad", pitch_rad)
    refuse_infinite("grade_resistance_n", pitch, name="pitch_rad", flat=True)
    return mass_kg * G_M_S2 * np.sin(pitch)


def check_lengths(owner: str, **lengths: float) -> None:
    """Refuse geometric arguments that are not finite lengths > 0, m (a contact width, a
    wheel radius, a footprint length): a negative one flipped the sign of a force or a
    sinkage, 0 divided by zero, NaN gave NaN, ``True`` was a length of 1 m.

    Called on the simulator's soil-contact steps: floats in range (NumPy's too) pass on
    ``isinstance`` tests; anything else goes through :func:`terrain.errors.config_positive`.

    Parameters
    ----------
    owner : str
        The relation's name, for the message.
    **lengths : float
        Argument name -> length, m.

    Raises
    ------
    ConfigError
        A length that is not a finite real number > 0, named ``owner.argument``.
    """
    for value in lengths.values():
        if not (isinstance(value, float) and 0.0 < value < math.inf):
            config_positive(owner, **lengths)
            return


def check_slide_speed(owner: str, slide_speed_m_s: float) -> None:
    """Refuse a lateral law's slide speed that is not a finite value > 0, m/s (0 divides by
    zero, a negative one turns the friction into a pushing force).

    Called on every simulator step: a float in range passes on one ``isinstance`` test;
    anything else goes through :func:`terrain.errors.config_positive`.

    Parameters
    ----------
    owner : str
        The law's name, for the message.
    slide_speed_m_s : float
        Smoothing (regularisation) speed, m/s.

    Raises
    ------
    ConfigError
        ``slide_speed_m_s`` not a finite value > 0, named ``owner.slide_speed_m_s``.
    """
    if not (isinstance(slide_speed_m_s, float) and 0.0 < slide_speed_m_s < math.inf):
        config_positive(owner, slide_speed_m_s=slide_speed_m_s)


def lateral_force_and_slope(mu_lateral: float, normal_load_n: np.ndarray,
                            v_lateral_m_s: np.ndarray, slide_speed_m_s: float = 0.02
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Lateral (sideways) friction of a skidding wheel or track segment, and its slope.

    Coulomb friction ``-mu_lat N sign(v_lat)`` smoothed as ``tanh(v_lat / v_slide)``; the
    smoothing speed stands for the lateral compliance of tyre and soil (Wong, *Theory of
    Ground Vehicles*, ch. 7.2: lateral resistance of skid-steered vehicles). The slope is the
    secant ``F / v_lat`` (``-mu_lat N / v_slide`` at 0), never positive and never shallower
    than the tangent (``tanh(x) / x >= 1 / cosh^2(x)``), which keeps an implicit integrator
    stable where the tangent of the saturated friction falls to 0.

    Parameters
    ----------
    mu_lateral : float
        Lateral resistance coefficient (friction plus bulldozing of sunk wheels),
        dimensionless, finite and >= 0.
    normal_load_n : ndarray, shape (n,)
        Normal load of each contact, N; a negative one is a lifted contact, no force
        (:func:`terrain.terramechanics.lateral.soil_lateral_force_and_slope` likewise).
    v_lateral_m_s : ndarray, shape (n,)
        Lateral velocity of each contact, m/s.
    slide_speed_m_s : float
        Smoothing speed, m/s (> 0).

    Returns
    -------
    force_n : ndarray, shape (n,)
        Lateral force, N.
    slope_n_s_m : ndarray, shape (n,)
        Secant slope ``d F / d v_lat``, N s/m.

    Raises
    ------
    ConfigError
        ``slide_speed_m_s`` not a finite value > 0 (0 divides by zero, a negative one turns
        the friction into a pushing force), or ``mu_lateral`` not a finite real number
        >= 0 (a negative one pushed the wheel along its slide, NaN gave NaN forces).
    DataFormatError
        ``normal_load_n`` or ``v_lateral_m_s`` not numbers or numeric arrays (None raised a
        bare TypeError, text NumPy's UFuncTypeError, ``True`` was a speed of 1 m/s).
    ShapeError
        ``normal_load_n`` and ``v_lateral_m_s`` of shapes that do not broadcast.
    """
    check_slide_speed("lateral_force_and_slope", slide_speed_m_s)
    # called on every simulator step: a float in range passes on one isinstance test
    if not (isinstance(mu_lateral, float) and 0.0 <= mu_lateral < math.inf):
        config_positive("lateral_force_and_slope", allow_zero=True, mu_lateral=mu_lateral)
    normal = np.asarray(normal_load_n)
    v = np.asarray(v_lateral_m_s)
    # (float or integer arrays of one shape pass on three tests; dtypes kept as given)
    if normal.dtype.kind not in "iuf" or v.dtype.kind not in "iuf" or normal.shape != v.shape:
        check_numeric_pair("lateral_force_and_slope", normal_load_n=normal_load_n,
                           v_lateral_m_s=v_lateral_m_s)
    # a lifted contact carries no load: a negative one flipped the friction into a force
    # along the slide (the soil law clips its load at 0 as well); 0 and -0.0 kept as given
    normal = np.where(normal < 0.0, 0.0, normal)
    x_l = v / slide_speed_m_s
    th_l = np.tanh(x_l)
    minus_mu_n = -mu_lateral * normal     # (-mu) N, once for the force and the slope
    force = minus_mu_n * th_l
    big = np.abs(x_l) > 1e-6
    secant = np.where(big, th_l / np.where(big, x_l, 1.0), 1.0)
    return force, minus_mu_n * secant / slide_speed_m_s


def lateral_force_n(mu_lateral: float, normal_load_n: np.ndarray, v_lateral_m_s: np.ndarray,
                    slide_speed_m_s: float = 0.02) -> np.ndarray:
    """Lateral (sideways) friction of a skidding wheel or track segment.

    The force of :func:`lateral_force_and_slope`.

    Parameters
    ----------
    mu_lateral : float
        Lateral resistance coefficient (friction plus bulldozing of sunk wheels).
    normal_load_n : ndarray, shape (n,)
        Normal load of each contact, N.
    v_lateral_m_s : ndarray, shape (n,)
        Lateral velocity of each contact, m/s.
    slide_speed_m_s : float
        Smoothing speed, m/s (> 0).

    Returns
    -------
    ndarray, shape (n,)
        Lateral force, N.

    Raises
    ------
    ConfigError
        ``slide_speed_m_s`` not a finite value > 0, or ``mu_lateral`` not a finite value
        >= 0.
    DataFormatError, ShapeError
        As :func:`lateral_force_and_slope`.
    """
    return lateral_force_and_slope(mu_lateral, normal_load_n, v_lateral_m_s,
                                   slide_speed_m_s)[0]


def turning_resistance_moment_nm(mu_lateral: float, weight_n: float,
                                 contact_length_m: float) -> float:
    """Wong's turning resistance moment of a skid-steer vehicle ``M_r = mu_t W l / 4``.

    Valid for uniform pressure along two contacts of length ``l`` (Wong, ch. 7.2). For the
    Husky's four wheels at ``x = +-a`` the same reasoning gives ``mu_t W a`` (use
    ``contact_length_m = 4 a``).

    Parameters
    ----------
    mu_lateral : float
        Lateral resistance coefficient (dimensionless).
    weight_n : float
        Vehicle weight W, N.
    contact_length_m : float
        Contact length l of each track, m.

    Returns
    -------
    float
        Moment resisting yaw, N m (>= 0).

    Raises
    ------
    ConfigError
        An input that is not a finite real number >= 0 (a negative one gave a moment that
        helps the yaw, NaN a NaN moment), named.
    """
    config_positive("turning_resistance_moment_nm", allow_zero=True, mu_lateral=mu_lateral,
                    weight_n=weight_n, contact_length_m=contact_length_m)
    return mu_lateral * weight_n * contact_length_m / 4.0


def can_turn_in_place(geometry, terrain) -> bool:
    """Whether a skid-steer vehicle can spin in place on a terrain, or digs in.

    Spinning needs the moment of the longitudinal forces (at most ``mu_peak N_i |y_i|`` per
    contact, less the soil resistance) to exceed the lateral friction moment
    ``sum mu_lat N_i |x_i|``. When it does not, the vehicle stops turning while its wheels keep
    spinning (slip -> +-1).

    Parameters
    ----------
    geometry : terrain.vehicles.ContactGeometry
        Contact positions and load shares of the vehicle.
    terrain : TerrainParams
        Terrain (traction peak, soil and lateral resistance).

    Returns
    -------
    bool
    """
    pos = geometry.positions_m
    share = geometry.load_share
    mu_long = traction_peak(terrain.curve).mu_max - float(soil_resistance_coefficient(terrain, 1.0))
    drive = float(np.sum(share * mu_long * np.abs(pos[:, 1])))
    resist = float(np.sum(share * terrain.lateral_friction * np.abs(pos[:, 0])))
    return drive > resist


def _check_bekker_plate(owner: str, load_n: float, width_m: float, length_m: float,
                        k_c: float, k_phi: float, n: float) -> None:
    """Refuse a load, plate or soil for which Bekker's relation has no sinkage (ConfigError
    naming ``owner``, the public function called: :func:`bekker_compaction_coefficient`'s
    errors were named ``bekker_sinkage_m``): a load that is not a finite real number (any
    sign: an unloaded plate does not sink).

    Called some 4000 times by each simulator run's soil tables (the fixed point of
    :func:`terrain.terramechanics.lateral.wheel_sinkage_m`): floats (NumPy's too) that pass
    every check below return on the first test; anything else takes the checks.
    """
    if (isinstance(load_n, float) and isinstance(length_m, float)
            and math.isfinite(load_n) and 0.0 < length_m < math.inf
            and _bekker_soil_in_range(width_m, k_c, k_phi, n)):
        return
    config_numbers(owner, load_n=load_n, k_c=k_c, k_phi=k_phi)
    if not math.isfinite(load_n):
        raise ConfigError(f"{owner}.load_n must be a finite load, N, got {load_n!r}")
    config_positive(owner, width_m=width_m, length_m=length_m, n=n)
    _refuse_bekker_soil(owner, width_m, k_c, k_phi, n)


def _check_bekker_soil(owner: str, width_m: float, k_c: float, k_phi: float,
                       n: float) -> None:
    """Refuse a contact width or Bekker soil for which the pressure-sinkage relation has no
    meaning (ConfigError naming ``owner``): floats in range return on the first test (the
    compaction of a slip-sunk rut is evaluated on every simulator step)."""
    if _bekker_soil_in_range(width_m, k_c, k_phi, n):
        return
    config_numbers(owner, k_c=k_c, k_phi=k_phi)
    config_positive(owner, width_m=width_m, n=n)
    _refuse_bekker_soil(owner, width_m, k_c, k_phi, n)


def _bekker_soil_in_range(width_m, k_c, k_phi, n) -> bool:
    """Whether a contact width and Bekker soil are floats (NumPy's too) that every check of
    :func:`_check_bekker_soil` passes: the one fast test of both Bekker checks."""
    return (isinstance(width_m, float) and isinstance(k_c, float) and isinstance(k_phi, float)
            and isinstance(n, float) and 0.0 < width_m < math.inf and 0.0 < n < math.inf
            and 0.0 < k_c / width_m + k_phi < math.inf)


def _refuse_bekker_soil(owner: str, width_m: float, k_c: float, k_phi: float,
                        n: float) -> None:
    """Refuse a pressure-sinkage modulus ``k_c / b + k_phi`` that is not finite and > 0."""
    modulus = k_c / width_m + k_phi
    if not (math.isfinite(modulus) and modulus > 0.0):
        raise ConfigError(f"{owner}: k_c / width_m + k_phi must be a finite modulus "
                          f"> 0 N/m^(n+2), got {k_c} / {width_m} + {k_phi} = {modulus}")


def bekker_sinkage_m(load_n: float, width_m: float, length_m: float, k_c: float,
                     k_phi: float, n: float) -> float:
    """Static sinkage of a flat plate, Bekker ``p = (k_c / b + k_phi) z^n`` (Wong eq. 2.33).

    Parameters
    ----------
    load_n : float
        Normal load on the plate, N.
    width_m, length_m : float
        Contact width b (smaller dimension) and length, m.
    k_c : float
        Cohesive modulus, N/m^(n+1).
    k_phi : float
        Frictional modulus, N/m^(n+2).
    n : float
        Sinkage exponent.

    Returns
    -------
    float
        Sinkage z, m (0 for a load <= 0: a wheel off the ground does not sink, the limit
        of ``z ~ W^(1/n)`` as ``W -> 0``).

    Raises
    ------
    ConfigError
        ``load_n`` not a finite real number (NaN gave a NaN sinkage, ``True`` a 1 N load),
        ``k_c`` or ``k_phi`` not a real number, ``width_m``, ``length_m`` or ``n`` not a
        finite value > 0, or a pressure-sinkage modulus ``k_c / width_m + k_phi`` that is
        not finite and > 0 (no sinkage solves ``p = (k_c / b + k_phi) z^n``: a negative
        one made the sinkage complex, zero divided by it).
    """
    _check_bekker_plate("bekker_sinkage_m", load_n, width_m, length_m, k_c, k_phi, n)
    if load_n <= 0:
        return 0.0
    p = load_n / (width_m * length_m)
    return float((p / (k_c / width_m + k_phi)) ** (1.0 / n))


def bekker_compaction_coefficient(load_n: float, width_m: float, length_m: float,
                                  k_c: float, k_phi: float, n: float) -> float:
    """Compaction resistance over load ``R_c / W``, ``R_c = b (k_c/b + k_phi) z^(n+1)/(n+1)``.

    Wong eq. 2.54 for a track of uniform pressure; used here as the literature estimate of
    the soil part of motion resistance.

    Parameters
    ----------
    load_n, width_m, length_m, k_c, k_phi, n : float
        As in :func:`bekker_sinkage_m`.

    Returns
    -------
    float
        Dimensionless; 0 for a load <= 0 (the limit of ``R_c / W ~ W^(1/n)`` as ``W -> 0``).

    Raises
    ------
    ConfigError
        As :func:`bekker_sinkage_m`, named ``bekker_compaction_coefficient``.
    """
    _check_bekker_plate("bekker_compaction_coefficient", load_n, width_m, length_m, k_c, k_phi,
                        n)
    if load_n <= 0:
        return 0.0
    z = bekker_sinkage_m(load_n, width_m, length_m, k_c, k_phi, n)
    return float(compaction_resistance_n(z, width_m, k_c, k_phi, n)[0] / load_n)


def compaction_resistance_n(sinkage_m: np.ndarray | float, width_m: float, k_c: float,
                            k_phi: float, n: float) -> tuple[np.ndarray, np.ndarray]:
    """Compaction resistance of a rut of depth z, ``R_c = b (k_c/b + k_phi) z^(n+1)/(n+1)``.

    The work of pressing the soil down to ``z`` per unit travel (Wong, *Theory of Ground
    Vehicles* 4th ed., eq. 2.54, Bekker's pressure-sinkage relation integrated over depth).

    Parameters
    ----------
    sinkage_m : float or ndarray, shape (...)
        Rut depth z, m; a negative one (a wheel above the surface) is taken as 0, no rut,
        the limit of ``R_c`` as ``z -> 0``, as :func:`~terrain.terramechanics.lateral.
        bulldozing_force_n` takes it; NaN (a missing value) passes as NaN.
    width_m : float
        Contact width b, m.
    k_c, k_phi, n : float
        Bekker moduli (N/m^(n+1), N/m^(n+2)) and exponent, as in :func:`bekker_sinkage_m`.

    Returns
    -------
    resistance_n : ndarray, shape (...)
        ``R_c``, N.
    dresistance_dz_n_m : ndarray, shape (...)
        ``d R_c / d z = b (k_c/b + k_phi) z^n``, N/m.

    Raises
    ------
    ConfigError
        ``width_m`` or ``n`` not a finite value > 0 (a negative width gave a resistance
        that pushes the wheel, 0 divided by zero, ``True`` was a 1 m wide contact),
        ``k_c`` or ``k_phi`` not a real number, or a modulus ``k_c / width_m + k_phi``
        that is not finite and > 0, as :func:`bekker_sinkage_m`; the message names the
        argument.
    """
    _check_bekker_soil("compaction_resistance_n", width_m, k_c, k_phi, n)
    z = np.maximum(np.asarray(sinkage_m, dtype=float), 0.0)
    modulus = width_m * (k_c / width_m + k_phi)
    return modulus * z ** (n + 1.0) / (n + 1.0), modulus * z ** n
