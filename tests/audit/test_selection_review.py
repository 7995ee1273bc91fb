"""Review tests of held-out selection (terrain.audit.selection): units, intervals, reports."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit import selection
from terrain.audit.selection import SelectionSettings, make_units, select_group
from terrain.errors import ConfigError

FAST = SelectionSettings(n_bootstrap=100, n_param_bootstrap=10)


def test_segments_without_the_needed_signal_are_not_units():
    # the first half of the run has no scored gyro sample: cut in two, only the second half
    # can be scored, so it is the only unit
    f = synthetic_frame("s/ASPHALT/0")
    half = np.arange(f.n) >= f.n // 2
    g = replace(f, score_imu=f.score_imu & half)
    units, segmented = make_units([g], 2, lambda u: bool(u.score_imu.any()))
    assert segmented and [u[0].group for u in units] == ["s/ASPHALT/0#1"]


def test_one_unit_per_terrain_gives_no_gain_interval_and_no_support():
    # two units, each the only one of its terrain: resampling within terrains cannot vary,
    # so no effect has an interval (and none is supported), however large its gain
    units = [[synthetic_frame("s/ASPHALT/0", terrain="ASPHALT", seed=0, bias_rad_s=0.05)],
             [synthetic_frame("s/SNOW/0", terrain="SNOW", seed=1, bias_rad_s=0.05)]]
    g = select_group(units, "yaw", "all", FAST)
    bias = next(e for e in g.effects if e.name == "gyro_bias")
    assert bias.heldout_gain > 0.5
    assert bias.heldout_gain_ci95 is None and "no_gain_interval" in bias.details
    assert not bias.supported and g.selected == ()


def test_an_unsupported_effect_reports_its_own_fitted_size():
    # a 0.001 rad/s gyro bias is below its 0.002 floor: not supported, and reported with the
    # value fitted with it in the model (not the final model's, which has no bias at all)
    units = [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, bias_rad_s=0.001, noise=0.0005)]
             for i in range(4)]
    g = select_group(units, "yaw", "ASPHALT", FAST)
    bias = next(e for e in g.effects if e.name == "gyro_bias")
    assert not bias.supported and "negligible" in bias.details
    assert bias.params["bias_rad_s"] == pytest.approx(0.001, abs=2e-4)


def test_selection_needs_two_units():
    with pytest.raises(ConfigError, match="at least 2"):
        select_group([[synthetic_frame("s/ASPHALT/0")]], "yaw", "ASPHALT", FAST)
    with pytest.raises(ConfigError, match="unknown group"):
        select_group([[synthetic_frame("s/ASPHALT/0")]] * 2, "pitch", "ASPHALT", FAST)
    with pytest.raises(ConfigError, match="min_units"):
        SelectionSettings(min_units=1)
    assert selection.has_spread(np.array(["A", "B", "B"]))
    assert not selection.has_spread(np.array(["A", "B"]))


def test_a_parameter_interval_needs_a_quarter_of_its_refits(monkeypatch):
    # an interval from a handful of successful refits is no interval: fewer than
    # max(5, n / 4) of them give none (EffectResult.ci95 empty)
    from terrain.audit.effects import GROUP_MODELS, EffectSettings, NotIdentifiable
    yaw = GROUP_MODELS["yaw"]
    units = [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, bias_rad_s=0.01)] for i in range(4)]

    def interval(successes):
        calls = []

        def fit(frames, spec, settings, form=None):
            calls.append(1)
            if len(calls) > successes:
                raise NotIdentifiable("planted")
            return yaw.fit(frames, spec, settings, form)
        monkeypatch.setattr(selection, "GROUP_MODELS", {"yaw": replace(yaw, fit=fit)}
                            if hasattr(yaw, "__dataclass_fields__")
                            else {"yaw": yaw._replace(fit=fit)})
        return selection._param_ci(units, "yaw", ["gyro_bias"], "gyro_bias", None,
                                   EffectSettings(), np.random.default_rng(0), 40)
    assert interval(9) == {}                           # 9 of 40: below 40 / 4
    lo, hi = interval(10)["bias_rad_s"]
    assert lo <= 0.01 <= hi
