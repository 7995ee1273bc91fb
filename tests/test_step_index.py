"""The project's one sample-to-step rule (terrain.run.step_index), used by the filters and the
simulator alike, and its one time-order rule (terrain.run.times_out_of_order)."""

from __future__ import annotations

import numpy as np

from terrain.estimation.runner import sample_steps
from terrain.run import step_index
from terrain.sim.sensors import physics_step_index


def test_a_sample_belongs_to_the_first_step_at_or_after_it():
    grid = np.arange(5) * 0.01                       # 0, 0.01, ..., 0.04 s
    t = np.array([-0.5, 0.0, 0.004, 0.01, 0.03 - 1e-12, 0.03 + 1e-12, 0.0400001, 7.0])
    np.testing.assert_array_equal(step_index(grid, t), [0, 0, 1, 1, 3, 3, 5, 5])
    # clipped: a sample past the last step reads the last one
    np.testing.assert_array_equal(step_index(grid, t, clip=True), [0, 0, 1, 1, 3, 3, 4, 4])
    # the rounding tolerance is 1e-9 s, not more
    assert step_index(grid, [0.02 + 2e-9])[0] == 3
    # and 1e-9 s itself is within it: a sample 1e-9 s after step 0 belongs to step 0
    # (searchsorted's side "right" gave step 1)
    assert step_index(grid, [1e-9])[0] == 0


def test_a_sample_on_a_step_of_an_epoch_clock_belongs_to_that_step():
    # one rounding of a time near 1.7e9 s is 2.4e-7 s, far more than 1 ns: a sample stamped
    # on a 100 Hz step by another arithmetic (t0 + k / rate against the grid's t0 + k * step)
    # or one unit in the last place late went to the next step under a fixed 1 ns tolerance
    t0 = 1.7e9
    k = np.arange(2000)
    grid = t0 + k * 0.01
    on_step = t0 + k / 100.0
    late = np.nextafter(grid, np.inf)
    assert step_index(grid, late).tolist() == k.tolist()
    assert step_index(grid, on_step).tolist() == k.tolist()
    # a sample half a step late still belongs to the next step
    assert step_index(grid, grid[:-1] + 0.005).tolist() == (k[:-1] + 1).tolist()


def test_the_filters_and_the_simulator_share_the_rule():
    rng = np.random.default_rng(0)
    grid = np.cumsum(rng.uniform(0.005, 0.02, 200))
    t = np.sort(rng.uniform(grid[0] - 0.1, grid[-1] + 0.1, 500))
    t[::7] = grid[rng.integers(0, grid.size, t[::7].size)]   # samples on steps
    np.testing.assert_array_equal(sample_steps(grid, t), step_index(grid, t))
    np.testing.assert_array_equal(physics_step_index(grid, t), step_index(grid, t, clip=True))


def test_times_out_of_order_names_every_row_that_breaks_the_time_contract():
    from terrain.run import times_out_of_order
    assert times_out_of_order([0.0, 0.1, 0.2]).size == 0
    assert times_out_of_order([]).size == 0
    # a repeat breaks the strict rule only; a step back breaks both
    np.testing.assert_array_equal(times_out_of_order([0.0, 0.1, 0.1, 0.05]), [2, 3])
    np.testing.assert_array_equal(times_out_of_order([0.0, 0.1, 0.1, 0.05], strict=False),
                                  [3])
    # a NaN row is named; the row after it is not counted again (NaN compares False)
    np.testing.assert_array_equal(times_out_of_order([0.0, np.nan, 0.2, np.inf]), [1, 3])
    assert times_out_of_order([np.nan, 0.0])[0] == 0
