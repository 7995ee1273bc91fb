"""Per-wheel longitudinal slip from EKF states and raw encoders (seed 001 ch. 7.1-7.2).

Public API: :func:`sae_slip`, :func:`wheel_longitudinal_velocity`, :func:`wheel_slip`,
:func:`skid_steer_side_slip`, :data:`DEAD_BAND_M_S` (:mod:`.core`); :func:`estimate_lag`,
:func:`gated_lag`, :class:`LagGate`, :class:`LagEstimate` (:mod:`.alignment`);
:func:`estimate_run` (vehicle dispatch),
:func:`estimate_agrimaro_run`, :func:`estimate_skid_steer_run` and their pieces
(:func:`agrimaro_wheel_speeds`, :func:`agrimaro_encoder_lag`, :func:`skid_steer_encoder_lag`,
:func:`with_camera_ema`, :func:`resample`), :class:`RunEstimate`; the fused skid-steer slip
:func:`estimate_skid_steer_slip_run`,
:func:`pseudo_measurement`, :class:`FusionSettings`, :data:`BATCH_FUSION`,
:data:`SLIP_MODELS` (:mod:`.estimate`).
"""

from __future__ import annotations

from terrain.slip.alignment import LagEstimate, LagGate, estimate_lag, gated_lag
from terrain.slip.core import (DEAD_BAND_M_S, sae_slip, skid_steer_side_slip,
                               wheel_longitudinal_velocity, wheel_slip)
from terrain.slip.estimate import (LAG_MODES, TUNINGS, RunEstimate, agrimaro_encoder_lag,
                                   agrimaro_settings, agrimaro_wheel_speeds,
                                   estimate_agrimaro_run, estimate_run, estimate_skid_steer_run,
                                   resample, skid_steer_encoder_lag, with_camera_ema)
from terrain.slip.estimate import (BATCH_FUSION, SLIP_MODELS,
                                   FusionSettings, estimate_skid_steer_slip_run,
                                   pseudo_measurement)

__all__ = ["LagEstimate", "LagGate", "estimate_lag", "gated_lag", "DEAD_BAND_M_S", "sae_slip",
           "skid_steer_side_slip",
           "wheel_longitudinal_velocity", "wheel_slip", "LAG_MODES", "TUNINGS", "RunEstimate",
           "agrimaro_settings", "estimate_run", "agrimaro_encoder_lag", "agrimaro_wheel_speeds",
           "estimate_agrimaro_run", "estimate_skid_steer_run", "resample",
           "skid_steer_encoder_lag", "with_camera_ema", "SLIP_MODELS", "BATCH_FUSION",
           "FusionSettings", "estimate_skid_steer_slip_run",
           "pseudo_measurement"]
