"""Boundaries of the manoeuvre classes and the scored span (terrain.audit.frames), review
aud23: values exactly at a threshold and one ulp either side land where the module
docstring's table puts them."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from terrain.audit.effects import scope_mask
from terrain.audit.frames import (CURVE, SPIN, STOP, STRAIGHT, FrameSettings, _quiet,
                                  classify_manoeuvres, scored_span)

S = FrameSettings()
B = 0.5


def _one(x, v=1.0, vel_l=1.0, vel_r=1.0):
    return int(classify_manoeuvres(np.array([x]), np.array([v]), np.array([vel_l]),
                                   np.array([vel_r]), B, S)[0])


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_turn_threshold_exactly_is_a_turn(sign):
    """``|x| >= turn_rad_s`` turns (curve), one ulp below is straight, either sign."""
    at = sign * S.turn_rad_s
    assert _one(at) == CURVE
    assert _one(np.nextafter(at, 0.0)) == STRAIGHT
    assert _one(np.nextafter(at, 2 * at)) == CURVE


def test_moving_threshold_exactly_is_moving():
    """A side at exactly ``moving_m_s`` moves; both one ulp below it is a stop."""
    below = np.nextafter(S.moving_m_s, 0.0)
    assert _one(0.0, v=S.moving_m_s / 2, vel_l=0.0, vel_r=S.moving_m_s) == STRAIGHT
    assert _one(0.0, v=-S.moving_m_s, vel_l=-S.moving_m_s, vel_r=-below) == STRAIGHT
    assert _one(0.0, v=below, vel_l=below, vel_r=-below) == STOP


def test_icr_on_the_wheel_is_a_curve_and_inside_the_track_a_spin():
    """``|v| = |x| B / 2`` (ICR on a wheel: one side at rest) is a curve; one ulp slower is
    a spin (ICR between the wheels), whatever the turn's sign."""
    x = 0.8
    edge = 0.5 * x * B
    assert _one(x, v=edge) == CURVE
    assert _one(-x, v=-edge) == CURVE
    assert _one(x, v=np.nextafter(edge, 0.0)) == SPIN
    assert _one(-x, v=-np.nextafter(edge, 0.0)) == SPIN


@pytest.mark.parametrize("t0", [0.0, 1.7e9])
def test_scored_span_keeps_samples_exactly_edge_s_from_either_end(t0):
    """Samples exactly ``edge_s`` from either end are scored (closer ones are not), also on
    an epoch clock."""
    t = t0 + np.arange(0.0, 10.25, 0.25)          # 0.25 s steps: exact in binary
    span = scored_span(t, S)
    inside = t[span] - t0
    assert inside[0] == S.edge_s and inside[-1] == 10.0 - S.edge_s
    assert span.sum() == int((10.0 - 2 * S.edge_s) / 0.25) + 1


def test_quiet_needs_x_below_quiet_rad_s_and_no_turn_within_the_margin_included():
    """|x| exactly quiet_rad_s is not quiet (one ulp below is); a sample exactly
    quiet_margin_s (1.5 s, exact on a 0.25 s clock) from a turning sample is not quiet, one
    step further is; scope 'active' is the complement."""
    t = np.arange(0.0, 20.0, 0.25)
    x = np.zeros_like(t)
    x[8], x[9] = S.quiet_rad_s, np.nextafter(S.quiet_rad_s, 0.0)
    x[60] = S.turn_rad_s                           # t = 15 s
    quiet = _quiet(t, x, S)
    assert not quiet[8] and quiet[9]
    assert t[60] - t[54] == S.quiet_margin_s
    assert not quiet[54] and quiet[53] and not quiet[66] and quiet[67]
    frame = SimpleNamespace(n=len(t), quiet=quiet)
    np.testing.assert_array_equal(scope_mask(frame, "active"), ~quiet)
