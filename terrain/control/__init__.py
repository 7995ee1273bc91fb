"""Traction control: the desired-slip table and the traction controller (seed 001 ch. 8.2-8.3).

Public API: :func:`build_slip_table`, :func:`select_target`, :func:`classifier_classes`,
:class:`DesiredSlipConfig`, :class:`DesiredSlip`, :class:`SlipTable` (the table, from the
terrain catalogue's traction-slip curves); :func:`traction_control_step` (one pure step over
:class:`TractionControlConfig` and :class:`TractionState`), :class:`TractionController` (its
stateful wrapper), :func:`config_for_vehicle`, :class:`SlipTargets`, :class:`TractionOutput`;
:func:`feedforward_step` and :func:`traction_acceleration_limit` (the feed-forward slip limit).
"""

from __future__ import annotations

from terrain.control.desired_slip import (DesiredSlip, DesiredSlipConfig, SlipTable,
                                          build_slip_table, classifier_classes, select_target)
from terrain.control.feedforward import feedforward_step, traction_acceleration_limit
from terrain.control.traction import (SlipTargets, TractionControlConfig, TractionController,
                                      TractionOutput, TractionState, config_for_vehicle,
                                      traction_control_step)

__all__ = [
    "DesiredSlip", "DesiredSlipConfig", "SlipTable", "build_slip_table", "classifier_classes",
    "select_target", "SlipTargets", "TractionControlConfig", "TractionController",
    "TractionOutput", "TractionState", "config_for_vehicle", "traction_control_step",
    "feedforward_step", "traction_acceleration_limit",
]
