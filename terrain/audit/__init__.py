"""Audit: what the simulation gets wrong on measured data, why, and what fixing it gains.

Steps (the report they produce is ``docs/audit_report.md``): :mod:`~terrain.audit.replay`
drives the simulator's Husky model with each measured run's own wheel speeds;
:mod:`~terrain.audit.frames` puts predictions and measurements on one clock (the run's own
``wheel_lag`` track from :mod:`~terrain.audit.timing`); :mod:`~terrain.audit.effects` holds
the named model extensions (fixed vocabulary) and their fits;
:mod:`~terrain.audit.selection` scores them on held-out runs with bootstrap support;
:mod:`~terrain.audit.core` chains it all (:func:`run_audit`); :mod:`~terrain.audit.report`
and :mod:`~terrain.audit.figures` write the report.

Public API: :class:`AuditSettings`, :func:`run_audit`, :class:`AuditResult`,
:func:`prepare_frames`, :func:`replay_run`, :class:`ReplaySettings`,
:func:`estimate_lag_track`, :class:`LagSettings`, :class:`EffectSettings`,
:class:`SelectionSettings`, :class:`FrameSettings`, :data:`EFFECT_VOCABULARY` (of
:class:`EffectSpec`), :data:`EFFECT_NAMES`, :func:`to_dict`, :func:`to_markdown`,
:func:`make_figures`.
"""

from __future__ import annotations

from terrain.audit.core import POOLED, AuditResult, AuditSettings, prepare_frames, run_audit
from terrain.audit.effects import EFFECT_NAMES, EFFECT_VOCABULARY, EffectSettings, EffectSpec
from terrain.audit.frames import FrameSettings
from terrain.audit.replay import ReplaySettings, replay_run
from terrain.audit.report import to_dict, to_markdown
from terrain.audit.selection import SelectionSettings
from terrain.audit.timing import LagSettings, estimate_lag_track


def make_figures(result: AuditResult) -> dict:
    """The report's figures by key (see :mod:`terrain.audit.figures`; imports matplotlib).

    Parameters
    ----------
    result : AuditResult
        Output of :func:`run_audit`.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        ``yaw``, ``rmse``, ``currents``, ``example`` and, when any run has an identifiable
        lag, ``lags``.
    """
    from terrain.audit.figures import make_figures as _make

    return _make(result)


__all__ = ["POOLED", "AuditResult", "AuditSettings", "prepare_frames", "run_audit",
           "EFFECT_NAMES", "EFFECT_VOCABULARY", "EffectSpec", "EffectSettings", "FrameSettings",
           "ReplaySettings",
           "replay_run", "to_dict", "to_markdown", "SelectionSettings", "LagSettings",
           "estimate_lag_track", "make_figures"]
