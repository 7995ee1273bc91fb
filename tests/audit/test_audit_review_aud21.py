"""Audit review (aud21): run ids of the runs given beside prepared frames, and the
ceiling and gain tables on samples a model column covers only in part."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from audit_helpers import synthetic_frame
from terrain.audit import AuditSettings, run_audit
from terrain.audit.selection import SelectionSettings
from terrain.errors import ConfigError, DataFormatError

SETTINGS = AuditSettings(selection=SelectionSettings(n_bootstrap=50, n_param_bootstrap=0),
                         pooled=False)


def test_runs_sharing_a_run_id_beside_prepared_frames_are_refused():
    # before: with the frames given, only the frames' ids were checked, so two runs of one
    # id (one replayed into the frame, its twin skipped by the caller) passed, and the
    # lateral-friction sweep replayed both under that one id
    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i) for i in range(3)]
    runs = [SimpleNamespace(run_id="s/ASPHALT/0"), SimpleNamespace(run_id="s/ASPHALT/0")]
    with pytest.raises(ConfigError, match=r"run ids must be unique.*s/ASPHALT/0 \(2 runs\)"):
        run_audit(runs, SETTINGS, frames=frames)


def test_ceiling_table_refuses_a_model_column_holding_values_on_some_samples_only():
    # before: sample tables of two terrains concatenated, one with candidate frames and one
    # without, gave rmse_candidate and gain_candidate NaN in every scope, silently (the mean
    # of the squared errors over NaN rows); a column wholly absent still gets no figures
    import pandas as pd

    from terrain.audit.ceiling import ceiling_table, yaw_rate_ceiling_samples
    from terrain.errors import NonFiniteInputError
    a = [synthetic_frame(f"a/{i}", "ASPHALT", seed=i, chi=1.5) for i in range(2)]
    g = [synthetic_frame(f"g/{i}", "GRASS", seed=i + 5, chi=1.8) for i in range(2)]
    with_candidate = yaw_rate_ceiling_samples(a, candidates=a)
    without = yaw_rate_ceiling_samples(g)
    with pytest.raises(NonFiniteInputError, match=r"ceiling_table: candidate holds 2320 "
                                                  r"missing value\(s\).*first at index 2320"):
        ceiling_table(pd.concat([with_candidate, without], ignore_index=True))
    tab = ceiling_table(pd.concat([without, yaw_rate_ceiling_samples(a)], ignore_index=True))
    assert "rmse_candidate" not in tab and tab.rmse_shared.notna().all()
    both = ceiling_table(pd.concat([with_candidate, yaw_rate_ceiling_samples(
        g, candidates=g)], ignore_index=True))
    assert both.rmse_candidate.notna().all()


@pytest.mark.parametrize("extra", [-5, 1])
def test_a_replayed_yaw_rate_not_on_the_wheel_clock_is_refused_by_name(extra):
    # before: numpy's bare IndexError (boolean index did not match) from the first window
    import numpy as np

    from terrain.audit.timing import estimate_lag_track
    from terrain.errors import DataFormatError
    t = np.arange(0.0, 60.0, 0.1)
    x = np.sin(t / 3.0)
    alternative = np.resize(x, len(t) + extra)
    with pytest.raises(DataFormatError, match=rf"estimate_lag_track: alternative has "
                                              rf"{len(t) + extra} samples, its clock t_s "
                                              rf"{len(t)}"):
        estimate_lag_track(t, x, t, x, alternative=alternative)
    assert estimate_lag_track(t, x, t, x, alternative=x).identifiable


def _sweep(chi, measured):
    import pandas as pd
    return pd.DataFrame({"lateral_friction": [0.25, 0.5, 1.0, 2.0][:len(chi)],
                         "replay_chi": chi, "measured_chi": measured})


@pytest.mark.parametrize("chi, measured, text", [
    # before: a friction without a replayed chi (None in the JSON records) broke the
    # bracketing, and the fall-through compared with NaN: "above 2" for a measured chi
    # below every replayed one, "above 2" for one between two replayed ones
    ([None, 1.2, 1.5, 1.8], 1.1, "below 0.5"),
    ([1.2, None, 1.5, 1.8], 1.3, "~0.50"),
    ([1.2, 1.5, None, 1.8], 2.0, "above 2"),
    ([1.2, 1.5, 1.8, 2.0], 1.1, "below 0.25"),
    ([1.2, 1.5, 1.8, 2.0], 1.35, "~0.38"),
    ([None, None, None, None], 1.3, "-"),
])
def test_matching_lateral_friction_leaves_out_frictions_without_a_chi(chi, measured, text):
    from terrain.audit.report import matching_lateral_friction
    assert matching_lateral_friction(_sweep(chi, measured)) == text


def test_matching_lateral_friction_of_an_empty_sweep_is_no_match():
    # before: pandas' bare IndexError (single positional indexer is out-of-bounds)
    from terrain.audit.report import matching_lateral_friction
    assert matching_lateral_friction(_sweep([], [])) == "-"


def test_gain_table_refuses_a_run_listed_twice_for_one_signal_and_scope():
    # before: a run's row given twice counted as two runs (n_runs 3 of 2 runs), its samples
    # twice in the RMSEs, and the interval resampled it as two independent runs
    import pandas as pd

    from terrain.audit.physics import PhysicsComparisonSettings, gain_table
    per_run = pd.DataFrame({"run_id": ["r0", "r1", "r0"], "terrain": "ASPHALT",
                            "signal": "wz", "scope": "moving", "n": [100, 200, 100],
                            "sse_ref": [4.0, 9.0, 4.0], "sse_new": [1.0, 4.0, 1.0]})
    settings = PhysicsComparisonSettings(n_bootstrap=50)
    with pytest.raises(DataFormatError, match=r"gain_table: run r0 is listed 2 times for "
                                              r"signal wz, scope moving"):
        gain_table(per_run, settings)
    assert gain_table(per_run.iloc[:2], settings).n_runs.tolist() == [2, 2]


@pytest.mark.parametrize("n_parts", [2.5, float("nan"), True, "3", None])
def test_split_frame_refuses_a_segment_count_that_is_no_integer(n_parts):
    # before: 2.5 cut the run into 2 segments silently, True into 1 (the frame itself),
    # NaN gave NumPy's bare ValueError (cannot convert float NaN to integer)
    import numpy as np

    from terrain.audit.frames import split_frame
    frame = synthetic_frame("a/0")
    with pytest.raises(ConfigError, match=r"split_frame: n_parts must be an integer, got "):
        split_frame(frame, n_parts)
    assert len(split_frame(frame, np.int64(3))) == 3 and split_frame(frame, 0) == [frame]


def _sums(draw, n):
    from hypothesis import strategies as st
    return [draw(st.floats(0.01, 100.0)) for _ in range(n)]


def test_bootstrap_gain_is_seeded_signed_and_ordered():
    # properties: one seed, one interval; lower <= upper; a candidate that lowers every
    # unit's error has a positive gain, one that raises every unit's a negative gain
    import numpy as np
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from terrain.audit.selection import bootstrap_gain

    @settings(max_examples=60, deadline=None)
    @given(st.data(), st.integers(2, 6), st.floats(0.1, 0.9), st.integers(0, 2**32 - 1))
    def check(data, n, factor, seed):
        ref = np.asarray(_sums(data.draw, n))
        base = ref * 1.5
        for new, sign in ((ref * factor, 1.0), (ref / factor, -1.0)):
            g1, ci1 = bootstrap_gain(ref, new, base, np.random.default_rng(seed), 40)
            g2, ci2 = bootstrap_gain(ref, new, base, np.random.default_rng(seed), 40)
            assert (g1, ci1) == (g2, ci2)
            assert sign * g1 > 0 and sign * ci1[0] > 0 and sign * ci1[1] > 0
            assert ci1[0] <= ci1[1]
    check()
