"""The physics slip columns keep their sides (review ftr32, mutant survivor).

``phys_slip_l`` / ``phys_slip_r`` swapped passed the default suite: its mirror test swaps
both sides of the input and of the output alike. The side that draws more current at the same
rim speed slips more (traction-slip curve inverted, :func:`terrain.slip.physics.physics_slip`).
"""

import numpy as np
import pytest

from features.slip_features import SLIP_CHANNELS, slip_feature_matrix
from terrain.vehicles import HUSKY

CH = {c: i for i, c in enumerate(SLIP_CHANNELS)}


@pytest.mark.parametrize("cur_l, cur_r", [(6.0, 2.0), (2.0, 6.0), (20.0, 5.0)])
def test_the_side_drawing_more_current_shows_the_larger_physics_slip(cur_l, cur_r):
    x = np.zeros((1, len(SLIP_CHANNELS), 85))
    x[0, CH["az"]] = 9.81                       # level, straight at 0.5 m/s on both sides
    x[0, CH["vel_l"]] = x[0, CH["vel_r"]] = 0.5
    x[0, CH["cur_l"]], x[0, CH["cur_r"]], x[0, CH["cur_diff"]] = cur_l, cur_r, cur_r - cur_l
    names, f = slip_feature_matrix(x, SLIP_CHANNELS, 50.0, HUSKY, {"ASPHALT": np.ones(1)})
    col = dict(zip(names, f[0]))
    assert (col["phys_slip_l"] > col["phys_slip_r"]) == (cur_l > cur_r)
    # the mirror image: the same two slips, sides swapped
    x[0, CH["cur_l"]], x[0, CH["cur_r"]], x[0, CH["cur_diff"]] = cur_r, cur_l, cur_l - cur_r
    _, g = slip_feature_matrix(x, SLIP_CHANNELS, 50.0, HUSKY, {"ASPHALT": np.ones(1)})
    mirror = dict(zip(names, g[0]))
    assert (mirror["phys_slip_l"], mirror["phys_slip_r"]) == (col["phys_slip_r"],
                                                              col["phys_slip_l"])
