"""Combined longitudinal and side slip of a tyre on a rigid surface (friction ellipse).

A tyre that slips along and across its rolling direction at once has one friction to share
between the two directions. Burckhardt's model, extended to combined slip as in U. Kiencke and
L. Nielsen, *Automotive Control Systems* (2nd ed., Springer 2005, the tyre-road friction
model), takes the friction of the *resultant* slip from the longitudinal curve and points the
force along the slip:

``s_res = sqrt(s_L^2 + s_S^2)``, ``mu_L = mu(s_res) s_L / s_res``,
``mu_S = -k_S mu(s_res) s_S / s_res``,

with the longitudinal (SAE) slip ``s_L``, the side slip ``s_S`` (side velocity of the contact
over the same denominator, ``max(|omega r|, |v_long|)``), the surface's traction-slip curve
``mu(s)`` (:mod:`terrain.terramechanics.traction`) and the side-force factor ``k_S`` of the
tyre (Kiencke and Nielsen: below 1, the tyre is weaker across than along; J. Y. Wong, *Theory
of Ground Vehicles*, 4th ed., Wiley 2008, ch. 1, calls the same bound the friction ellipse).
``k_S = 1`` is an isotropic contact.

For a skid-steer vehicle this is what makes turning on a rigid surface cost longitudinal
slip: the wheels of a turning skid-steer slide sideways, the resultant slip is large, and the
drive force a wheel can give at a longitudinal slip falls with its side slip. In a steady
spin in place with every contact sliding (equal normal loads, contacts at ``(+-a, +-b)``), the
moment balance ``b mu_L = a |mu_S|`` gives ``s_L / s_S = k_S a / b`` and with it the ICR
expansion factor ``chi = 1 + k_S (a / b)^2``, whatever the friction level
(``tests/terramechanics/test_combined_slip.py`` checks the simulator against it).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from terrain.errors import ConfigError, config_numbers
from terrain.terramechanics.traction import check_numeric_pair


class CombinedSlip(NamedTuple):
    """Force coefficients of contacts under combined slip (arrays of one shape).

    Attributes
    ----------
    mu_long : ndarray
        Longitudinal force over normal load, signed like the longitudinal slip.
    mu_side : ndarray
        Side force over normal load, opposing the side slip.
    secant : ndarray
        ``mu(s_res) / s_res`` (the slope ``d mu / d s`` of the curve at 0 where
        ``s_res = 0``), >= 0: force coefficient per unit slip along the slip direction.
    tangent : ndarray
        ``d mu / d s`` of the curve at ``s_res`` (0 beyond the hold slip, 1 by default,
        where the curve is held at its value there).
    resultant_slip : ndarray
        ``s_res``, >= 0 (dimensionless; may exceed 1 when the side slip is large).
    """

    mu_long: np.ndarray
    mu_side: np.ndarray
    secant: np.ndarray
    tangent: np.ndarray
    resultant_slip: np.ndarray


def combined_slip_coefficients(curve, slip_long: np.ndarray, slip_side: np.ndarray,
                               side_force_factor: float, hold_slip: float = 1.0
                               ) -> CombinedSlip:
    """Longitudinal and side force coefficients of the friction ellipse (module docstring).

    Parameters
    ----------
    curve : TractionCurve
        Traction-slip curve of the surface (:mod:`terrain.terramechanics.traction`); it is
        evaluated at ``min(s_res, hold_slip)``.
    slip_long : ndarray, shape (...)
        Longitudinal SAE slip ``s_L`` in [-1, 1] (dimensionless).
    slip_side : ndarray, shape (...)
        Side slip ``s_S``: side velocity of the contact over ``max(|omega r|, |v_long|)``
        (dimensionless, any sign and size).
    side_force_factor : float
        ``k_S`` of the tyre, in (0, 1] (1: isotropic).
    hold_slip : float
        Resultant slip in (0, 1] beyond which the friction is held at its value there
        (dimensionless). 1: the curve up to full slip, then constant. The curve's peak slip
        (:func:`terrain.terramechanics.traction.traction_peak`): no falling branch, the
        friction of a tyre sliding slowly (:data:`terrain.sim.forces.COMBINED_SLIP`).

    Returns
    -------
    CombinedSlip

    Raises
    ------
    ConfigError
        ``side_force_factor`` or ``hold_slip`` not a real number (a boolean, text,
        ``None``) or outside (0, 1].
    DataFormatError
        ``slip_long`` or ``slip_side`` not numbers or numeric arrays (None gave NaN forces,
        ``True`` a full slip, text a bare ValueError;
        :func:`~terrain.terramechanics.traction.numeric_array`).
    ShapeError
        ``slip_long`` and ``slip_side`` of shapes that do not broadcast.
    """
    # called on every simulator step: floats in range pass on two isinstance tests
    if not (isinstance(side_force_factor, float) and isinstance(hold_slip, float)):
        config_numbers("combined_slip_coefficients", side_force_factor=side_force_factor,
                       hold_slip=hold_slip)
    if not 0.0 < side_force_factor <= 1.0:
        raise ConfigError(f"side_force_factor must be in (0, 1], got {side_force_factor}")
    if not 0.0 < hold_slip <= 1.0:
        raise ConfigError(f"hold_slip must be in (0, 1], got {hold_slip}")
    s_x = np.asarray(slip_long)
    s_y = np.asarray(slip_side)
    # (float or integer arrays of one shape pass on three tests)
    if s_x.dtype.kind not in "iuf" or s_y.dtype.kind not in "iuf" or s_x.shape != s_y.shape:
        check_numeric_pair("combined_slip_coefficients", slip_long=slip_long,
                           slip_side=slip_side)
    s_x = s_x.astype(float, copy=False)
    s_y = s_y.astype(float, copy=False)
    s_res = np.hypot(s_x, s_y)
    mu_res, dmu = curve.coefficients(np.minimum(s_res, hold_slip), 0.0)[:2]
    at_zero = s_res < 1e-12
    secant = np.where(at_zero, dmu, mu_res / np.where(at_zero, 1.0, s_res))
    tangent = np.where(s_res > hold_slip, 0.0, dmu)
    return CombinedSlip(secant * s_x, -side_force_factor * secant * s_y, secant, tangent, s_res)
