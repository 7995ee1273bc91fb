"""Review aud28: the current offsets are read on straight driving only.

Mutation review of the simulation audit: the mutant that took the offsets' medians over
every moving sample (turns included) instead of the straight ones passed the whole audit
suite. The tests here give turns a current of their own and require the offsets to be the
straight medians, by hand.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit.effects import fit_current
from terrain.audit.frames import CURVE, SPIN, STRAIGHT


def _frame_with_costly_turns(turn_extra_a: float, seed: int = 0):
    """A noiseless synthetic frame: offsets (0.3, 0.9) A while moving, plus
    ``turn_extra_a`` on both sides in turns; only 40 straight samples scored, so that turns
    are most of the moving samples."""
    f = synthetic_frame("s/ASPHALT/0", offsets_a=(0.3, 0.9), noise=0.0, seed=seed)
    turn = np.isin(f.manoeuvre, (CURVE, SPIN))
    cur = f.cur + np.where(turn, turn_extra_a, 0.0)[:, None]
    straight_idx = np.flatnonzero(f.score_cur & (f.manoeuvre == STRAIGHT))
    score = f.score_cur & ~(f.manoeuvre == STRAIGHT)
    score[straight_idx[:40]] = True
    assert (score & turn).sum() > 40           # turns: most of the scored moving samples
    return replace(f, cur=cur, score_cur=score)


@pytest.mark.parametrize("turn_extra_a", [4.0, -3.0])
def test_offsets_are_the_straight_medians_whatever_the_turns_cost(turn_extra_a):
    frame = _frame_with_costly_turns(turn_extra_a)
    p = fit_current([frame], ["current_offset"])
    # by hand: the straight residuals are exactly (0.3, 0.9) A
    assert p.offset_left_a == pytest.approx(0.3, abs=1e-12)
    assert p.offset_right_a == pytest.approx(0.9, abs=1e-12)
    assert p.offset_a == pytest.approx(0.6, abs=1e-12)
    assert p.n_straight == 40


def test_the_turning_current_goes_to_turning_resistance_not_to_the_offsets():
    frame = _frame_with_costly_turns(4.0)
    p = fit_current([frame], ["current_offset", "turning_resistance"])
    assert p.offset_left_a == pytest.approx(0.3, abs=1e-9)
    assert p.offset_right_a == pytest.approx(0.9, abs=1e-9)
    assert p.k_a > 0.0
