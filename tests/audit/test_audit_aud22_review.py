"""Metamorphic properties of the audit (aud22): run order, run names, clock shifts, planted
effect sizes, and the report's signal table against the residuals it summarises."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from audit_helpers import synthetic_frame
from terrain.audit import SelectionSettings
from terrain.audit.selection import select_group

PROPS = settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
CI = SelectionSettings(n_bootstrap=100, n_param_bootstrap=10)
NO_CI = SelectionSettings(n_bootstrap=100, n_param_bootstrap=0)


def _chi_frames(seed: int, chi: float | None, n: int = 4, terrain: str = "ASPHALT",
                prefix: str = "run"):
    return [synthetic_frame(f"{prefix}{i}", terrain=terrain, chi=chi, seed=seed * 10 + i,
                            n_cycles=2)
            for i in range(n)]


@pytest.mark.parametrize("perm", [(3, 2, 1, 0), (1, 3, 0, 2)])
def test_the_gain_and_parameter_intervals_do_not_depend_on_the_order_of_the_runs(perm):
    # the bootstraps drew unit positions: the same runs listed in another order got another
    # interval (gyro_bias's gain interval (-7.1e-05, -1.6e-05) reversed (-6.8e-05, -1.0e-05))
    # and, near the rule's edge, another verdict
    frames = _chi_frames(1, 1.6)
    a = select_group([[f] for f in frames], "yaw", "ASPHALT", CI)
    b = select_group([[frames[i]] for i in perm], "yaw", "ASPHALT", CI)
    assert b.selected == a.selected == ("icr_expansion",)
    for ea, eb in zip(a.effects, b.effects):
        assert eb.heldout_gain_ci95 == ea.heldout_gain_ci95, ea.name
        assert eb.ci95 == ea.ci95, ea.name
        assert eb.supported == ea.supported
    assert [u[0].run_id for u in b.units] == [u[0].run_id for u in a.units]


def test_pooled_intervals_do_not_depend_on_the_order_of_the_terrains():
    frames = (_chi_frames(2, 1.6, n=3) + _chi_frames(3, 1.8, n=3, terrain="ICE",
                                                     prefix="ice/run"))
    a = select_group([[f] for f in frames], "yaw", "all", CI)
    b = select_group([[f] for f in frames[3:] + frames[:3]], "yaw", "all", CI)
    assert [e.as_dict() for e in b.effects] == [e.as_dict() for e in a.effects]


def _two_terrains():
    return (_chi_frames(4, 1.6, n=2) + _chi_frames(5, 1.8, n=2, terrain="ICE",
                                                   prefix="ice/run"))


def _report(frames):
    from terrain.audit import AuditSettings, run_audit, to_dict

    s = AuditSettings(selection=SelectionSettings(n_bootstrap=50, n_param_bootstrap=0,
                                                  min_units=2))
    return to_dict(run_audit([], s, frames=frames))


def test_the_reported_signal_errors_are_those_of_the_scored_samples():
    frames = _two_terrains()
    report = _report(frames)
    seen = set()
    for rec in report["signals"]:
        scope = [f for f in frames if rec["terrain"] in ("all", f.terrain)]
        meas, pred = [], []
        for f in scope:
            if rec["signal"] in ("cur_l", "cur_r"):
                j = ("cur_l", "cur_r").index(rec["signal"])
                meas.append(f.cur[f.score_cur, j])
                pred.append(f.sim_cur[f.score_cur, j])
            else:
                m = f.score_imu
                meas.append(getattr(f, rec["signal"])[m])
                pred.append(getattr(f, f"sim_{rec['signal']}")[m])
        r = np.concatenate(meas) - np.concatenate(pred)
        assert rec["n"] == r.size, rec
        # (the report keeps 3 significant digits)
        assert rec["replay_rmse"] == pytest.approx(np.sqrt(np.mean(r * r)), rel=5e-3), rec
        seen.add((rec["signal"], rec["terrain"]))
    assert seen == {(s, t) for s in ("wz", "ax", "ay", "cur_l", "cur_r")
                    for t in ("ASPHALT", "ICE", "all")}


@pytest.mark.slow
@pytest.mark.parametrize("shift_s", [1234.5])
def test_the_report_does_not_depend_on_the_clocks_origin(shift_s):
    from terrain.audit.timing import LagTrack

    frames = _two_terrains()
    moved = [replace(f, t_s=f.t_s + shift_s, imu_t_s=f.imu_t_s + shift_s,
                     lag=LagTrack(f.lag.centres_s + shift_s, f.lag.lags_s, f.lag.r2,
                                  f.lag.n_windows))
             for f in frames]
    a, b = _report(frames), _report(moved)
    for key in ("supported", "effects", "groups", "signals", "residuals_by_manoeuvre",
                "residuals_by_run", "facts"):
        assert b[key] == a[key], key


def _offset_frames(seed: int, offset_a: float = 0.0, bias_rad_s: float = 0.0):
    return [synthetic_frame(f"run{i}", seed=seed * 10 + i, n_cycles=2, bias_rad_s=bias_rad_s,
                            offsets_a=(-0.5 * offset_a, 0.5 * offset_a))
            for i in range(4)]


@PROPS
@given(seed=st.integers(0, 1000), size=st.floats(0.4, 1.5), negative=st.booleans())
def test_a_current_offset_planted_twice_as_strong_fits_twice_as_large(seed, size, negative):
    size = -size if negative else size
    fits = []
    for k in (1.0, 2.0):
        res = select_group([[f] for f in _offset_frames(seed, k * size)], "current",
                           "ASPHALT", NO_CI)
        assert res.selected == ("current_offset",)
        e = next(e for e in res.effects if e.name == "current_offset")
        fits.append(e.params["offset_a"])
        assert fits[-1] == pytest.approx(k * size, abs=0.05 * abs(size))
    assert abs(fits[1]) > abs(fits[0]) and np.sign(fits[1]) == np.sign(fits[0])


@PROPS
@given(seed=st.integers(0, 1000), bias=st.floats(0.01, 0.04), negative=st.booleans())
def test_a_gyro_bias_planted_twice_as_strong_fits_twice_as_large(seed, bias, negative):
    bias = -bias if negative else bias
    fits = []
    for k in (1.0, 2.0):
        res = select_group([[f] for f in _offset_frames(seed, bias_rad_s=k * bias)], "yaw",
                           "ASPHALT", NO_CI)
        assert "gyro_bias" in res.selected
        e = next(e for e in res.effects if e.name == "gyro_bias")
        fits.append(e.params["bias_rad_s"])
        assert fits[-1] == pytest.approx(k * bias, abs=0.1 * abs(bias))
    assert abs(fits[1]) > abs(fits[0]) and np.sign(fits[1]) == np.sign(fits[0])


def test_the_markdown_signal_table_states_the_jsons_numbers():
    from terrain.audit import to_markdown
    from terrain.audit.report import _fmt

    report = _report(_two_terrains())
    text = to_markdown(report)
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 10:
            rows[(cells[0], cells[1])] = cells
    for rec in report["signals"]:
        cells = rows[(rec["signal"], rec["terrain"])]
        assert cells[4] == _fmt(rec["replay_rmse"]), rec
        assert cells[7] == _fmt(rec.get("extended_rmse")), rec
        assert cells[2] == _fmt(rec.get("ideal_rmse")), rec


@pytest.mark.slow
def test_the_whole_report_does_not_depend_on_the_order_of_the_runs():
    # the audited-run list, the lag table (and the figures drawn over result.frames, e.g.
    # the yaw figure's sample draw) followed the caller's order
    frames = _two_terrains()
    a = _report(frames)
    b = _report([frames[i] for i in (3, 1, 0, 2)])
    for key in ("runs", "lags", "effects", "groups", "signals", "residuals_by_manoeuvre",
                "residuals_by_run", "facts", "supported"):
        assert b[key] == a[key], key
    assert a["runs"]["audited"] == sorted(a["runs"]["audited"])


def test_nothing_planted_names_nothing_on_any_terrain_nor_pooled():
    frames = (_chi_frames(6, None, n=2) + _chi_frames(7, None, n=2, terrain="ICE",
                                                      prefix="ice/run"))
    assert _report(frames)["supported"] == {"ASPHALT": ["none"], "ICE": ["none"],
                                            "all": ["none"]}


@pytest.mark.parametrize("chi", [1.5, 1.8])
def test_a_wider_planted_icr_expansion_fits_a_larger_chi(chi):
    fits = []
    for c in (chi, 2.0 * chi):
        res = select_group([[f] for f in _chi_frames(8, c)], "yaw", "ASPHALT", NO_CI)
        assert res.selected == ("icr_expansion",)
        e = next(e for e in res.effects if e.name == "icr_expansion")
        assert e.params["chi"] == pytest.approx(c, rel=0.03)
        fits.append(e.params["chi"])
    assert fits[1] > fits[0]


def test_the_skipped_runs_given_with_frames_are_listed_in_run_id_order():
    """`terrain audit`'s progress path prepared the frames run by run and put its own skipped
    list back in the order the runs came (aud22's left-alone); run_audit now takes it with
    the frames and lists it in run-id order, as a replay inside run_audit does; skipped
    without frames is refused."""
    from terrain.audit import AuditSettings, run_audit
    from terrain.errors import ConfigError

    s = AuditSettings(selection=SelectionSettings(n_bootstrap=50, n_param_bootstrap=0,
                                                  min_units=2))
    given = {"z/run": "too short", "a/run": "no imu"}
    result = run_audit([], s, frames=_two_terrains(), skipped=given)
    assert list(result.skipped) == ["a/run", "z/run"]
    assert dict(result.skipped) == given
    with pytest.raises(ConfigError, match="give frames with it"):
        run_audit([], s, skipped=given)
