"""State of the audit (aud24): what the caller passes in is left as it was, nothing
process-wide is changed (NumPy's global generator, warnings filters, matplotlib), and the
same inputs audited again give the same report."""

from __future__ import annotations

import copy
import warnings
from dataclasses import fields

import numpy as np
import pandas as pd
import pytest

from audit_helpers import synthetic_frame
from terrain.audit import AuditSettings, SelectionSettings, run_audit, to_dict

SETTINGS = AuditSettings(selection=SelectionSettings(n_bootstrap=50, n_param_bootstrap=5,
                                                     min_units=2), pooled=True)


def _frames():
    return ([synthetic_frame(f"ice{i}", terrain="ICE", chi=1.5, seed=i, n_cycles=2,
                             offsets_a=(0.3, -0.2)) for i in range(3)]
            + [synthetic_frame(f"snow{i}", terrain="SNOW", seed=10 + i, n_cycles=2)
               for i in range(2)])


def _assert_same_frames(frames, before):
    assert [f.run_id for f in frames] == [f.run_id for f in before]
    for f, g in zip(frames, before):
        for field in fields(f):
            a, b = getattr(f, field.name), getattr(g, field.name)
            if isinstance(a, np.ndarray):
                np.testing.assert_array_equal(a, b, err_msg=f"{f.run_id}.{field.name}")
                assert a.dtype == b.dtype
            elif field.name != "lag":
                assert a == b


def _report(result):
    out = to_dict(result)
    out.pop("timings_s")
    return out


@pytest.fixture(scope="module")
def audited():
    frames = _frames()[::-1]          # not in run-id order: the audit sorts its own list
    skipped = {"zz": "no wheel stream"}
    before = (copy.deepcopy(frames), dict(skipped))
    state = np.random.get_state()
    filters = list(warnings.filters)
    result = run_audit([], SETTINGS, frames=frames, skipped=skipped)
    after = (np.random.get_state(), list(warnings.filters))
    return frames, skipped, before, result, (state, filters), after


def test_the_audit_leaves_the_given_frames_and_skipped_runs_as_they_were(audited):
    frames, skipped, (frames0, skipped0), result, _, _ = audited
    _assert_same_frames(frames, frames0)
    assert skipped == skipped0
    # the result's list is its own: changing it leaves the caller's as it was
    result.skipped["other"] = "x"
    assert skipped == skipped0


def test_the_audit_changes_no_process_wide_state(audited):
    *_, (state, filters), (state_after, filters_after) = audited
    assert state[0] == state_after[0] and state[2:] == state_after[2:]
    np.testing.assert_array_equal(state[1], state_after[1])
    assert filters_after == filters


@pytest.mark.slow
def test_the_same_frames_audited_again_give_the_same_report(audited):
    frames, _, _, result, _, _ = audited
    again = run_audit([], SETTINGS, frames=frames, skipped={"zz": "no wheel stream"})
    first = _report(result)
    first["runs"]["skipped"].pop("other", None)   # (added by the test above)
    assert _report(again) == first


def test_a_report_changed_by_its_reader_leaves_the_result_as_it_was(audited):
    *_, result, _, _ = audited
    before = _report(result)
    report = to_dict(result)
    for scope in report["facts"].values():
        scope.clear()
    report["effects"][0]["params"].clear()
    report["effects"][0]["details"].clear()
    report["runs"]["audited"].clear()
    assert _report(result) == before


@pytest.mark.slow
def test_the_figures_leave_matplotlib_as_it_was(audited):
    import matplotlib
    import matplotlib.pyplot as plt

    from terrain.audit import make_figures

    *_, result, _, _ = audited
    rc = copy.deepcopy(dict(matplotlib.rcParams))
    open_before = set(plt.get_fignums())
    figures = make_figures(result)
    assert figures and set(plt.get_fignums()) == open_before
    assert dict(matplotlib.rcParams) == rc


def test_the_ceiling_tables_leave_the_frames_as_they_were():
    from terrain.audit.ceiling import (current_ceiling_samples, online_current_samples,
                                       online_yaw_rate_samples, yaw_rate_ceiling_samples)

    frames = [f for f in _frames() if f.terrain == "ICE"]
    before = copy.deepcopy(frames)
    yaw_rate_ceiling_samples(frames[1:], train_frames=frames[:1])
    current_ceiling_samples(frames[1:], train_frames=frames[:1])
    online_yaw_rate_samples(frames)
    online_current_samples(frames)
    _assert_same_frames(frames, before)


def test_the_physics_gain_table_leaves_the_per_run_table_as_it_was():
    from terrain.audit.physics import PhysicsComparisonSettings, gain_table

    rng = np.random.default_rng(3)
    per_run = pd.DataFrame({
        "run_id": ["r3", "r1", "r2", "r0"] * 2, "terrain": ["ICE", "ICE", "SNOW", "SNOW"] * 2,
        "signal": ["wz"] * 4 + ["cur"] * 4, "scope": "moving", "n": 50,
        "sse_ref": rng.uniform(1, 2, 8), "sse_new": rng.uniform(0.5, 1.5, 8)},
        index=[7, 5, 3, 1, 6, 4, 2, 0])
    before = per_run.copy(deep=True)
    gain_table(per_run, PhysicsComparisonSettings(n_bootstrap=20))
    pd.testing.assert_frame_equal(per_run, before)
