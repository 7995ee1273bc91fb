"""Review fixslip of the slip targets: a window holding no truth sample (past the truth's
end, before its start, in a gap of it) was labelled with a terrain it was not measured on
(past the end: the truth's last terrain). Its terrain is now missing, as its targets are
NaN, and such windows are counted in a warning; slip_table leaves them out, counted."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from features.slip_features import SLIP_CHANNELS, slip_targets
from features.windows import WindowSet
from terrain.errors import DataWarning
from terrain.run import TIME, Run
from terrain.vehicles import HUSKY


def _truth(t0=0.0, t1=5.0, hole=None):
    tt = np.round(np.arange(t0, t1, 0.01), 10)
    if hole is not None:
        tt = tt[(tt < hole[0]) | (tt >= hole[1])]
    return pd.DataFrame({TIME: tt, "slip_1": 0.1, "slip_2": 0.2, "yaw_rate": 0.5,
                         "v_by": 0.01, "terrain": np.where(tt < 3.0, "GRASS", "SNOW")})


def _targets(truth, starts, window_s=2.0):
    starts = np.asarray(starts, dtype=float)
    n = starts.size
    rng = np.random.default_rng(0)
    X = rng.normal(size=(n, len(SLIP_CHANNELS), int(50 * window_s)))
    ids = np.full(n, "sim", dtype=object)
    ws = WindowSet(X, SLIP_CHANNELS, ids, ids, np.full(n, "GRASS", dtype=object), starts,
                   starts + window_s, 50.0)
    run = Run("sim", "sim", "GRASS", {"truth": truth})
    return slip_targets([run], ws, HUSKY.track_m)


def test_windows_past_the_truths_end_get_no_terrain_and_are_counted():
    # windows [0, 2) ... [6, 8) s on a truth of [0, 5) s: GRASS before 3 s, SNOW after
    with pytest.warns(DataWarning, match=r"slip_targets: 2 of 7 windows hold no truth sample "
                                         r"\(windows 5, 6; run\(s\) \['sim'\]\)"):
        Y = _targets(_truth(t1=5.0), np.arange(7.0))
    past = np.arange(7) >= 5
    assert Y["terrain"][past].isna().all()                  # not the last truth's SNOW
    assert Y.loc[past, ["slip_1", "slip_2", "v_by", "yaw_rate", "chi"]].isna().all().all()
    # [4, 6) holds the truth of [4, 5): its own samples' SNOW and their means
    assert list(Y["terrain"][:5]) == ["GRASS", "GRASS", "SNOW", "SNOW", "SNOW"]
    np.testing.assert_allclose(Y["slip_1"][:5], 0.1)


def test_windows_before_the_truths_start_or_in_a_gap_of_it_get_no_terrain():
    with pytest.warns(DataWarning, match=r"1 of 4 windows hold no truth sample \(window 0;"):
        Y = _targets(_truth(t0=2.5, t1=9.0), [0.0, 1.0, 2.0, 4.0])
    assert pd.isna(Y["terrain"][0]) and list(Y["terrain"][1:]) == ["GRASS", "SNOW", "SNOW"]
    with pytest.warns(DataWarning, match=r"1 of 3 windows hold no truth sample \(window 1;"):
        Y = _targets(_truth(t1=9.0, hole=(3.5, 6.5)), [1.0, 4.0, 7.0])
    assert pd.isna(Y["terrain"][1]) and Y["terrain"][0] == "GRASS"


def test_a_window_half_in_a_gap_takes_the_terrain_of_its_own_samples():
    """Its middle in the gap, the first sample after it lies past the window's end: the
    window is labelled by its own last sample (GRASS), not by the terrain after the gap."""
    truth = _truth(t1=9.0, hole=(2.5, 6.0))       # GRASS until 2.5 s, SNOW from 6 s
    with warnings.catch_warnings():
        warnings.simplefilter("error")             # it holds truth: not counted
        Y = _targets(truth, [1.5])                  # [1.5, 3.5): samples of [1.5, 2.5)
    assert Y["terrain"][0] == "GRASS"
    np.testing.assert_allclose(Y["slip_1"], 0.1)


def test_windows_covered_by_the_truth_keep_the_terrain_at_their_middle_without_a_warning():
    truth = _truth(t1=12.0)
    starts = np.arange(0.0, 10.0, 0.35)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Y = _targets(truth, starts, window_s=1.7)
    mid = starts + 0.85
    t = truth[TIME].to_numpy()
    expected = truth["terrain"].to_numpy()[np.searchsorted(t, mid)]
    assert list(Y["terrain"]) == list(expected)


def test_slip_table_leaves_the_windows_without_truth_out_and_says_so():
    from dataclasses import replace as replace_run

    from features.slip_features import slip_table, slip_windows
    from terrain.sim import SimConfig, simulate

    run = simulate(SimConfig(terrains=("GRASS",), scenario="straight_accel", duration_s=10.0,
                             seed=0))
    truth = run.streams["truth"]
    short = replace_run(run, streams={**run.streams,
                                      "truth": truth[truth[TIME] < 6.0].reset_index(drop=True)})
    ws = slip_windows([short])
    none = ws.t_start_s >= 6.0 - 1e-9
    assert none.sum() >= 2
    with pytest.warns(DataWarning, match=rf"slip_table: {none.sum()} of {len(ws)} windows hold "
                                         r"no truth sample .*left out of X, Y and meta"):
        X, Y, meta = slip_table([short], HUSKY, ["GRASS", "SNOW"])
    assert len(X) == len(Y) == len(meta) == len(ws) - none.sum()
    np.testing.assert_allclose(meta["t_start_s"], ws.t_start_s[~none])
    assert (meta["terrain"] == "GRASS").all() and np.isfinite(Y["slip_1"]).all()
    full_X, full_Y, full_meta = slip_table([run], HUSKY, ["GRASS", "SNOW"])
    pd.testing.assert_frame_equal(X, full_X[~none].reset_index(drop=True), check_exact=True)
