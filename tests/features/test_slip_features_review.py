"""Slip features review: the terrain columns are every column the terrain changes."""

from __future__ import annotations

import numpy as np

from features.slip_features import SLIP_CHANNELS, slip_feature_matrix, terrain_columns
from terrain.vehicles import HUSKY


def test_terrain_columns_are_exactly_the_columns_the_terrain_probabilities_move():
    # leave-one-terrain-out drops terrain_columns (pipelines/slip_fit.py): a column that
    # depends on the terrain probabilities (p__*, and the physics slip computed under them)
    # and is not among them would hand the held-out terrain to the model
    rate = 50.0
    rng = np.random.default_rng(3)
    t = np.arange(100) / rate
    vel_l = 0.5 + 0.05 * rng.standard_normal((2, t.size))
    vel_r = 0.6 + 0.05 * rng.standard_normal((2, t.size))
    values = {c: 0.1 * rng.standard_normal((2, t.size)) for c in SLIP_CHANNELS}
    values.update(vel_l=vel_l, vel_r=vel_r, vel_diff=vel_r - vel_l,
                  cur_l=8.0 + rng.standard_normal((2, t.size)),
                  cur_r=9.0 + rng.standard_normal((2, t.size)),
                  az=9.81 + 0.1 * rng.standard_normal((2, t.size)))
    x = np.stack([values[c] for c in SLIP_CHANNELS], axis=1)
    sand = {"SANDY_LOAM": np.ones(2), "SNOW": np.zeros(2)}
    snow = {"SANDY_LOAM": np.zeros(2), "SNOW": np.ones(2)}
    names, a = slip_feature_matrix(x, SLIP_CHANNELS, rate, HUSKY, sand)
    names_b, b = slip_feature_matrix(x, SLIP_CHANNELS, rate, HUSKY, snow)
    assert names == names_b
    moved = [n for j, n in enumerate(names) if not np.array_equal(a[:, j], b[:, j])]
    assert sorted(moved) == sorted(terrain_columns(names))
    assert {"p__SNOW", "phys_slip_l", "phys_slip_r", "phys_std"} <= set(moved)
    # without probabilities no column carries the terrain
    plain, _ = slip_feature_matrix(x, SLIP_CHANNELS, rate, HUSKY)
    assert terrain_columns(plain) == [] and set(plain) == set(names) - set(moved)
