"""Review svc11: a timestamp gap flags the windows whose grid it cuts, not one that only
ends at the window's first grid point (a hand mutant turning ``ts[1:] > tail[0]`` into
``>=`` in ``StreamService._window`` survived every test)."""

from __future__ import annotations

import numpy as np
from test_service import _two_stream_service

from terrain.run import IMU_CHANNELS


def test_a_gap_ending_exactly_at_the_windows_first_grid_point_leaves_it_whole():
    # 8 Hz streams on binary-exact stamps, the wheels silent between 7 s and 8 s (a step
    # of 1 s, eight usual steps: a gap). The window of the decision at 10 s is the grid
    # 8.0, 8.125, ..., 9.875 s: the gap ends on its first point, so every point is read
    # from samples around it and the window is classified; the window of 9.5 s
    # (7.5 ... 9.375 s) holds the gap.
    svc = _two_stream_service(0.5)
    t = np.arange(0, 112) * 0.125
    out = []
    for ti in t:
        live = 0.01 * np.sin(7.0 * ti)
        out += svc.push("imu", ti, {c: live for c in IMU_CHANNELS})
        if not 7.0 < ti < 8.0:
            out += svc.push("wheels", ti, {"vel_l": 0.25, "vel_r": 0.25 + live,
                                           "cur_l": 1.0 + live, "cur_r": 1.0 - live})
    by_t = {d.t_s: d for d in out}
    # (no filter: a window not classified is uniform, so low_confidence too)
    assert by_t[9.5].flags == by_t[9.0].flags == "gap|low_confidence"
    assert by_t[10.0].flags == "" and by_t[10.0].terrain == "SNOW"
    assert by_t[10.0].window_age_s == 0.0
