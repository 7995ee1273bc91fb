"""Per-wheel longitudinal slip from EKF states and raw encoders (seed 001 ch. 7.1-7.2).

Public API: :func:`sae_slip`, :func:`wheel_longitudinal_velocity`, :func:`wheel_slip`,
:func:`skid_steer_side_slip`, :data:`DEAD_BAND_M_S` (:mod:`.core`); :func:`estimate_lag`, :class:`LagEstimate`
(:mod:`.alignment`); :func:`estimate_run`, :class:`RunEstimate` (:mod:`.estimate`).
"""

from __future__ import annotations

from terrain.slip.alignment import LagEstimate, estimate_lag
from terrain.slip.core import (DEAD_BAND_M_S, sae_slip, skid_steer_side_slip,
                               wheel_longitudinal_velocity, wheel_slip)
from terrain.slip.estimate import LAG_MODES, TUNINGS, RunEstimate, agrimaro_settings, estimate_run

__all__ = ["LagEstimate", "estimate_lag", "DEAD_BAND_M_S", "sae_slip", "skid_steer_side_slip",
           "wheel_longitudinal_velocity", "wheel_slip", "LAG_MODES", "TUNINGS", "RunEstimate",
           "agrimaro_settings", "estimate_run"]
