"""Review ctl20: metamorphic relations between the control layer's public entry points."""

import itertools

import pytest
from hypothesis import given, settings, strategies as st

from terrain.control import grid
from terrain.control.closed_loop import fallback_basis
from terrain.control.desired_slip import build_slip_table
from terrain.control.feedforward import traction_acceleration_limit
from terrain.terramechanics import get_terrain


def _fake_loop(cost_of):
    """A stand-in for run_closed_loop whose controlled runs score ``cost_of(kp, ki)``."""
    def run(vehicle, terrain, scenario, on, seed, duration_s, gains=None, **kwargs):
        rmse = cost_of(*gains) if on else 0.5
        return None, None, {"time_to_speed_s": 2.0, "slip_rmse": rmse,
                            "steady_slip_within_0_02": 1.0}
    return run


@settings(max_examples=40, deadline=None)
@given(kp=st.lists(st.sampled_from([0.5, 1.0, 2.0, 5.0, 10.0, 20.0]), min_size=1, max_size=4,
                   unique=True),
       ki=st.lists(st.sampled_from([0.0, 1.0, 10.0]), min_size=1, max_size=3, unique=True),
       data=st.data())
def test_tuned_gains_do_not_depend_on_the_order_of_the_grids(kp, ki, data):
    """Tied candidates (docs: every Husky candidate costs the same once the feed-forward
    does the work) gave the first of the grid's order: kp grid (5, 2) tuned kp 5, (2, 5)
    kp 2. The best pair must not depend on the order the candidates are listed in."""
    flat = data.draw(st.booleans())
    cost = (lambda kp_, ki_: 0.09) if flat else (lambda kp_, ki_: 0.09 + 0.001 * (ki_ > 5))
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(grid, "run_closed_loop", _fake_loop(cost))
        best, table = grid.tune_gains("husky", ["ICE"], kp, ki)
        best_rev, table_rev = grid.tune_gains("husky", ["ICE"], kp[::-1], ki[::-1])
    finally:
        mp.undo()
    assert best == best_rev
    costs = {(r.kp, r.ki): r.cost for r in table.itertuples()}
    assert costs[best] == min(costs.values())
    # ties: the smallest gains, as the default gains were kept (closed_loop.DEFAULT_GAINS)
    tied = [k for k, c in costs.items() if c == costs[best]]
    assert best == min(tied)
    assert sorted(itertools.product(kp, ki)) == sorted(costs)


# --- the fallback's terrain does not depend on the order of the table's classes ---------------

TIED = ("SNOW", "SANDY_LOAM", "GRASS", "GRAVEL")   # traction target 0.30 each (the cap)


@settings(max_examples=30, deadline=None)
@given(classes=st.permutations(TIED + ("DIRT_ROAD", "PLOUGHED")),
       size=st.integers(2, 6))
def test_the_fallback_basis_does_not_depend_on_the_order_of_the_classes(classes, size):
    """A table of SANDY_LOAM and GRAVEL (both at the 0.30 cap) assumed SANDY_LOAM's curve
    while undecided (feed-forward a_max 1.59 m/s^2), GRAVEL and SANDY_LOAM GRAVEL's
    (0.56 m/s^2): the first listed. The conservative case is the terrain of the fallback's
    traction target that lets the robot accelerate least, in any order."""
    chosen = list(classes[:size])
    basis = fallback_basis(build_slip_table(chosen))
    assert basis == fallback_basis(build_slip_table(chosen[::-1]))
    table = build_slip_table(chosen)
    assert table.entries[basis].traction == table.fallback.traction
    tied = [e for e in table.entries.values() if e.traction == table.fallback.traction]
    limits = {e.terrain: traction_acceleration_limit(get_terrain(e.terrain), e.traction)
              for e in tied}
    assert limits[basis] == min(limits.values())
