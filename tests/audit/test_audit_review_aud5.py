"""Audit review (aud5): selection settings that are no counts, the Findings sentences of
effects fitted with a negative sign, and the learned transfer's history lags."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit.ceiling import history_features
from terrain.audit.report import to_markdown
from terrain.audit.selection import SelectionSettings
from terrain.errors import ConfigError

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.mark.parametrize("kwargs, match", [
    (dict(n_bootstrap=10.5), r"n_bootstrap must be an integer in \[10, 100000\], got 10.5"),
    (dict(n_param_bootstrap=True), r"n_param_bootstrap must be an integer in \[0, 10000\]"),
    (dict(n_param_bootstrap=20.0), r"n_param_bootstrap must be an integer"),
    (dict(min_units=2.5), r"min_units must be an integer >= 2, got 2.5"),
    (dict(min_units=float("inf")), r"min_units must be an integer >= 2, got inf"),
    (dict(seed=float("nan")), r"seed must be an integer >= 0, got nan"),
    (dict(seed=1.5), r"seed must be an integer >= 0, got 1.5"),
    (dict(min_gain="0.1"), r"min_gain"),
])
def test_selection_settings_refuse_counts_and_seeds_that_are_no_integers(kwargs, match):
    # before: accepted, then numpy's TypeError at the first bootstrap draw (n_bootstrap
    # 10.5, seed NaN or 1.5), an OverflowError cutting runs into segments (min_units inf),
    # one parameter resample for True, a TypeError comparing text (min_gain "0.1")
    with pytest.raises(ConfigError, match=match):
        SelectionSettings(**kwargs)


def test_selection_settings_take_numpy_integers_and_the_documented_bounds():
    s = SelectionSettings(n_bootstrap=np.int64(10), n_param_bootstrap=0, min_units=2,
                          seed=np.int64(7), min_gain=0.0)
    assert (s.n_bootstrap, s.n_param_bootstrap, s.min_units, s.seed) == (10, 0, 2, 7)
    SelectionSettings(n_bootstrap=100_000, n_param_bootstrap=10_000)


@pytest.fixture(scope="module")
def shipped_json():
    """The committed JSON report (read only; tests change deep copies)."""
    return json.loads((DOCS / "audit_report.json").read_text())


def _findings(report):
    page = to_markdown(report)
    return page.split("## Findings", 1)[1].split("## Error per signal", 1)[0]


def test_a_negative_current_offset_is_told_as_the_left_motor_reading_more(shipped_json):
    report = copy.deepcopy(shipped_json)
    e = next(e for e in report["effects"]
             if e["terrain"] == "ASPHALT" and e["name"] == "current_offset")
    assert e["supported"] and e["params"]["offset_a"] > 0
    assert ("driving straight, the right motor reads 1.05 A more than the left"
            in _findings(report))
    e["params"]["offset_a"] = -0.83
    text = _findings(report)
    # before: "the right motor reads -0.83 A more than the left"
    assert "driving straight, the left motor reads 0.83 A more than the right" in text
    assert "-0.83" not in text


def test_a_negative_wheel_lag_is_told_as_early(shipped_json):
    report = copy.deepcopy(shipped_json)
    e = next(e for e in report["effects"]
             if e["terrain"] == "ICE" and e["name"] == "wheel_lag")
    e.update(supported=True, step=1, params={"lag_s": -0.3}, heldout_gain=0.12)
    # before: "the wheel stream is -0.30 s late on every run"
    assert "the wheel stream is 0.30 s early on every run (held-out gain 12 %)" \
        in _findings(report)
    e["params"]["lag_s"] = 0.25
    assert "the wheel stream is 0.25 s late on every run" in _findings(report)


@pytest.mark.parametrize("lags", [(0,), (1, -2), (1.5,), (True,)])
def test_history_lags_must_be_whole_samples_back(lags):
    frame = synthetic_frame("s/ASPHALT/0")
    # before: lag 0 built an empty column (numpy's ValueError from column_stack), -2 a
    # negative dimension, 1.5 a float slice index (TypeError), True a lag of one sample
    with pytest.raises(ConfigError, match="lags"):
        history_features(frame, frame.sim_wz, lags)


def test_history_lags_shift_the_command_back_by_whole_samples():
    frame = synthetic_frame("s/ASPHALT/0")
    feats = history_features(frame, frame.sim_wz, (1, 3))
    x = frame.commanded_yaw_rate
    assert feats.shape == (frame.n, 6 + 2 * 2 + 1)
    np.testing.assert_array_equal(feats[:, 4], np.r_[x[0], x[:-1]])
    np.testing.assert_array_equal(feats[:, 6], np.r_[[x[0]] * 3, x[:-3]])


def test_a_parameter_interval_counts_only_refits_with_a_finite_parameter(monkeypatch):
    # a refit whose parameter is NaN (a yaw fit without a chi) is no draw: before, it
    # counted towards the max(5, n / 4) refits an interval needs and was then dropped by
    # nanpercentile, so 3 finite draws of 40 made a "95 % interval", and 0 a NaN one
    from dataclasses import replace

    from terrain.audit import selection
    from terrain.audit.effects import GROUP_MODELS, EffectSettings
    yaw = GROUP_MODELS["yaw"]
    units = [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, bias_rad_s=0.01)] for i in range(4)]

    def interval(finite):
        calls = []

        def fit(frames, spec, settings, form=None):
            calls.append(1)
            p = yaw.fit(frames, spec, settings, form)
            return p if len(calls) <= finite else replace(p, bias_rad_s=float("nan"))
        monkeypatch.setattr(selection, "GROUP_MODELS", {"yaw": replace(yaw, fit=fit)})
        return selection._param_ci(units, "yaw", ["gyro_bias"], "gyro_bias", None,
                                   EffectSettings(), np.random.default_rng(0), 40)
    assert interval(0) == {}
    assert interval(3) == {}
    assert interval(9) == {}                           # 9 of 40: below 40 / 4
    lo, hi = interval(10)["bias_rad_s"]
    assert np.isfinite([lo, hi]).all() and lo <= 0.01 <= hi


def test_runs_sharing_a_run_id_are_refused_not_merged():
    # before: the sample table keyed each frame by (run id, first time), so a second run
    # with the same id and start replaced the first one's samples in every residual
    # statistic (pooled wz n 4640 of 5800) while the selection scored both as units
    from terrain.audit import AuditSettings, run_audit
    settings = AuditSettings(selection=SelectionSettings(n_bootstrap=50, n_param_bootstrap=0),
                             pooled=False)
    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i) for i in range(4)]
    twin = synthetic_frame("s/ASPHALT/0", seed=9)
    with pytest.raises(ConfigError, match=r"run ids must be unique.*s/ASPHALT/0 \(2 runs\)"):
        run_audit([], settings, frames=frames + [twin])
    result = run_audit([], settings, frames=frames)
    r = result.residuals
    pooled = r[(r.signal == "wz") & (r.model == "replay") & (r.run_id == "*")
               & (r.manoeuvre == "all")]
    assert int(pooled.n.iloc[0]) == sum(int(f.score_imu.sum()) for f in frames)


def test_the_physics_gain_interval_is_a_point_when_every_run_gains_alike():
    # each run's candidate error is a quarter of its reference error, on runs of different
    # lengths: every resample's gain is 1 - sqrt(1/4) = 0.5 exactly, so the interval is
    # [0.5, 0.5] (a resample's two RMSEs must share its own sample count)
    import pandas as pd

    from terrain.audit.physics import PhysicsComparisonSettings, gain_table
    n = np.array([50, 400, 120, 900])
    sse_ref = np.array([3.0, 10.0, 7.0, 40.0])
    per_run = pd.DataFrame({"run_id": [f"r{i}" for i in range(4)], "terrain": "ASPHALT",
                            "signal": "wz", "scope": "moving", "n": n, "sse_ref": sse_ref,
                            "sse_new": sse_ref / 4.0})
    row = gain_table(per_run, PhysicsComparisonSettings(n_bootstrap=200)).iloc[0]
    assert row.gain == pytest.approx(0.5)
    assert (row.gain_lo, row.gain_hi) == (pytest.approx(0.5), pytest.approx(0.5))
    assert row.rmse_ref == pytest.approx(np.sqrt(sse_ref.sum() / n.sum()))


def test_a_measured_chi_below_a_replay_that_digs_in_is_matched_between_two_frictions():
    # the replayed chi grows from 1.6 at mu 0.5 to inf (digs in) at mu 1.0: a measured chi
    # of 2.0 is matched between them; before: 'above 1', a friction beyond the sweep
    import pandas as pd

    from terrain.audit.report import matching_lateral_friction

    def sweep(chis, target=2.0):
        return pd.DataFrame({"lateral_friction": [0.25, 0.5, 1.0], "replay_chi": chis,
                             "measured_chi": [target] * 3})
    assert matching_lateral_friction(sweep([1.2, 1.6, np.inf])) == "between 0.5 and 1"
    assert matching_lateral_friction(sweep([1.2, 1.6, 2.4])) == "~0.75"
    assert matching_lateral_friction(sweep([1.2, 1.6, 1.8])) == "above 1"
    assert matching_lateral_friction(sweep([2.2, 2.6, np.inf])) == "below 0.25"
    assert matching_lateral_friction(sweep([1.2, 1.6, 1.9], target=None)) == "-"


def test_the_grade_term_acts_on_moving_samples_only():
    # fit_current: "the model adds, on moving samples, ... k_a_per_rad |pitch| to both
    # sides"; a robot at rest on a slope draws no climbing current
    from dataclasses import replace

    from terrain.audit.effects import CurrentParams, predict_current
    from terrain.audit.frames import STOP
    f = synthetic_frame("s/ASPHALT/0")
    man = f.manoeuvre.copy()
    man[:100] = STOP                                   # the first straight stretch at rest
    f = replace(f, pitch=np.full(f.n, 0.1), manoeuvre=man)
    stop = f.manoeuvre == STOP
    assert stop.any() and (~stop).any()
    pred = predict_current(f, CurrentParams(k_a_per_rad=20.0))
    np.testing.assert_allclose(pred[stop], f.sim_cur[stop])
    np.testing.assert_allclose(pred[~stop], f.sim_cur[~stop] + 2.0)


def test_the_physics_comparison_page_leaves_out_the_stop_rows():
    import pandas as pd

    from terrain.audit.physics import comparison_markdown
    rows = [("ASPHALT", "cur", scope, 2, 100, 2.0, 1.5, 0.25, 0.1, 0.4)
            for scope in ("moving", "stop")]
    table = pd.DataFrame(rows, columns=["terrain", "signal", "scope", "n_runs", "n",
                                        "rmse_ref", "rmse_new", "gain", "gain_lo", "gain_hi"])
    page = comparison_markdown(table, {"reference": "v1", "candidate": "v2"})
    assert "| ASPHALT | cur | moving | 2 | 100 | 2 | 1.5 | +0.250 [+0.100, +0.400] |" in page
    assert "| stop |" not in page


def test_replay_and_audit_settings_refuse_text_and_numbers_as_switches_and_rates():
    # a config file's text: merge_subresolution="no" and pooled="no" were read by
    # truthiness (on), physics_rate_hz="100" passed float() and ran at 100 Hz
    from terrain.audit.core import AuditSettings
    from terrain.audit.replay import ReplaySettings

    with pytest.raises(ConfigError, match="merge_subresolution"):
        ReplaySettings(merge_subresolution="no")
    with pytest.raises(ConfigError, match="physics_rate_hz"):
        ReplaySettings(physics_rate_hz="100")
    with pytest.raises(ConfigError, match="physics_rate_hz"):
        ReplaySettings(physics_rate_hz=True)
    with pytest.raises(ConfigError, match="pooled"):
        AuditSettings(pooled="no")
    with pytest.raises(ConfigError, match="pooled"):
        AuditSettings(pooled=1)
    replay = ReplaySettings(merge_subresolution=np.bool_(False), physics_rate_hz=200)
    assert replay.physics_rate_hz == 200
    assert AuditSettings(pooled=np.bool_(False)).pooled == np.bool_(False)
