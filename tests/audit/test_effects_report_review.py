"""Review tests of the audit's effects, its sample table and its report (auditfx pass)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit import AuditSettings, SelectionSettings, run_audit
from terrain.audit.effects import predict_yaw
from terrain.audit.report import signal_table
from terrain.audit.selection import loro

FAST = AuditSettings(selection=SelectionSettings(n_bootstrap=200, n_param_bootstrap=20),
                     pooled=False)


def _pooled_rmse(pairs):
    r = np.concatenate([m - p for m, p in pairs])
    return float(np.sqrt(np.mean(r * r)))


@pytest.fixture(scope="module")
def chi_audit():
    """Four synthetic runs of a robot turning 1.5 times slower than ideal drive (the
    replay's chi is 1.2), measured lateral acceleration ``v wz``, audited."""
    frames = []
    for i in range(4):
        f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, noise=0.002)
        frames.append(replace(f, ay=f.commanded_speed * f.commanded_yaw_rate / 1.5,
                              sim_ay=f.sim_vx * f.sim_wz))
    return frames, run_audit([], FAST, frames=frames)


def test_the_extended_lateral_acceleration_follows_the_fitted_yaw_rate(chi_audit):
    """A robot turning 1.5 times slower than ideal drive (chi 1.5, the replay's 1.2): its
    lateral acceleration is ``v wz``. The extended model's ``ay`` is the replay's plus
    ``(wz_ext - wz_replay) v``, so it moves towards the measured one and its error is the
    hand-computed one."""
    frames, result = chi_audit
    assert "icr_expansion" in result.supported("ASPHALT")
    table = signal_table(result).set_index("signal")
    units = [[f] for f in frames]
    spec = list(result.groups[("ASPHALT", "yaw")].selected)
    held = loro(units, "yaw", spec, [], result.settings.effects)
    m = [f.score_imu for f in frames]
    ext = _pooled_rmse(
        (f.ay[k], (f.sim_ay + (predict_yaw(f, p) - p.bias_rad_s - f.sim_wz) * f.sim_vx)[k])
        for f, k, p in zip(frames, m, held))
    rep = _pooled_rmse((f.ay[k], f.sim_ay[k]) for f, k in zip(frames, m))
    assert table.loc["ay", "replay_rmse"] == pytest.approx(rep, rel=1e-9)
    assert table.loc["ay", "extended_rmse"] == pytest.approx(ext, rel=1e-9)
    assert table.loc["ay", "extended_rmse"] < 0.5 * table.loc["ay", "replay_rmse"]


def test_current_offsets_are_the_median_straight_residuals_and_keep_their_sides():
    """Offsets -0.3 A (left) and 0.5 A (right) planted while moving, and a 10 A spike on the
    right in one straight sample out of ten (the replay fighting a sub-resolution speed
    difference): the median straight residuals are the planted offsets, unmoved by the
    spikes, and the details keep each side's offset on its side."""
    from terrain.audit.effects import effect_details, fit_current
    from terrain.audit.frames import STRAIGHT

    f = synthetic_frame("s/ASPHALT/0", offsets_a=(-0.3, 0.5), noise=0.0)
    straight = np.flatnonzero(f.score_cur & (f.manoeuvre == STRAIGHT))
    cur = f.cur.copy()
    cur[straight[::10], 1] += 10.0
    p = fit_current([replace(f, cur=cur)], ["current_offset"])
    assert (p.offset_left_a, p.offset_right_a) == pytest.approx((-0.3, 0.5), abs=1e-12)
    assert p.offset_a == pytest.approx(0.8, abs=1e-12)
    d = effect_details("current_offset", p)
    assert (d["offset_left_a"], d["offset_right_a"], d["common_a"]) == pytest.approx(
        (-0.3, 0.5, 0.1), abs=1e-12)


def test_the_turning_form_with_the_lower_training_error_is_kept():
    """1 A more current per side in every turn, whatever its rate (the curves at 0.5 rad/s
    and the spins at 0.8 rad/s alike): the Coulomb form (about 1 at both rates) explains it,
    the proportional one (1 and 1.6) cannot; with 1.6 A in the spins it is the other way
    round."""
    from terrain.audit.effects import fit_current
    from terrain.audit.frames import CURVE, SPIN

    f = synthetic_frame("s/ASPHALT/0", noise=0.0)
    for spin_extra, form in ((1.0, "coulomb"), (1.6, "proportional")):
        extra = np.select([f.manoeuvre == CURVE, f.manoeuvre == SPIN], [1.0, spin_extra], 0.0)
        p = fit_current([replace(f, cur=f.cur + extra[:, None])], ["turning_resistance"])
        assert p.form == form
        assert p.k_a == pytest.approx(1.0, abs=2e-3)


def test_the_rate_dependent_form_is_refused_when_slow_turns_dig_in_more():
    """The robot digs in during every slow curve (0.5 rad/s) and never in its fast spins
    (0.8 rad/s): sinkage that grows with the slip velocity cannot do that, so the
    ``rate_dependent`` form (more immobile above the threshold) is not taken; the uniform
    form keeps the turning-time fraction."""
    from terrain.audit.effects import fit_yaw
    from terrain.audit.frames import CURVE

    frames = []
    for i in range(2):
        f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, noise=0.0)
        frames.append(replace(f, wz=np.where(f.manoeuvre == CURVE, 0.0, f.wz)))
    p = fit_yaw(frames, ["immobilised"])
    assert p.form == "uniform" and not np.isfinite(p.threshold_rad_s)
    assert p.fractions[0] == pytest.approx(p.fraction) and p.fraction > 0.4


def test_the_replays_own_chi_is_taken_on_the_mobile_turns_only():
    """The gyro reads nothing in every curve (dug in) and turns with chi 1.5 in the spins,
    where the replay turns with chi 1.2 (and with chi 3 in the curves): the replay's own
    chi, the yardstick of the fitted chi's practical floor, is measured on the same mobile
    (spin) samples as the fitted chi, so it is 1.2, not a mix with the dug-in curves."""
    from terrain.audit.effects import fit_yaw
    from terrain.audit.frames import CURVE

    frames = []
    for i in range(2):
        f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, noise=0.0)
        curve = f.manoeuvre == CURVE
        frames.append(replace(f, wz=np.where(curve, 0.0, f.wz),
                              sim_wz=np.where(curve, f.commanded_yaw_rate / 3.0, f.sim_wz)))
    p = fit_yaw(frames, ["icr_expansion"])
    assert p.chi == pytest.approx(1.5, rel=1e-9)
    assert p.chi_replay == pytest.approx(1.2, rel=1e-9)


def test_the_gyro_bias_beside_chi_is_fitted_on_quiet_samples_only():
    """A gyro offset of 0.01 rad/s and a robot dug in during every curve (the gyro reads
    only its offset there) with chi 1.5 in the spins: the bias comes from the quiet
    samples, far from any turn, where no yaw-rate model error leaks into it, not from the
    turns that the mobile model cannot explain."""
    from terrain.audit.effects import fit_yaw
    from terrain.audit.frames import CURVE

    frames = []
    for i in range(2):
        f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, bias_rad_s=0.01, noise=0.0)
        frames.append(replace(f, wz=np.where(f.manoeuvre == CURVE, 0.01, f.wz)))
    p = fit_yaw(frames, ["icr_expansion", "gyro_bias"])
    assert p.bias_rad_s == pytest.approx(0.01, abs=1e-12)
    assert p.chi == pytest.approx(1.5, rel=1e-9)


def test_a_supported_immobilised_effect_without_a_mobile_chi_is_rendered():
    """``immobilised`` with the replay as its mobile model takes the replay's own chi, which
    is ``inf`` (JSON ``null``) when the replayed robot does not turn: the page says the robot
    digs in and its held-out gain, and leaves the unknown mobile chi out instead of failing
    to render."""
    import copy
    import json
    from pathlib import Path

    from terrain.audit.report import to_markdown

    docs = Path(__file__).resolve().parents[2] / "docs"
    report = json.loads((docs / "audit_report.json").read_text())
    e = next(x for x in report["effects"] if x["name"] == "immobilised" and x["supported"])
    assert e["details"]["chi_mobile"] is not None
    known = to_markdown(report)
    assert f"mobile turns have chi {e['details']['chi_mobile']:.2f}" in known
    report = copy.deepcopy(report)
    e = next(x for x in report["effects"] if x["name"] == "immobilised" and x["supported"])
    e["details"].update(chi_mobile=None, mobile_model="replay")
    page = to_markdown(report)
    line = next(s for s in page.splitlines() if s.startswith(f"- **{e['terrain']}**"))
    assert f"during {100 * e['params']['fraction']:.0f} % of its turning time" in line
    assert "mobile turns have chi" not in line
    assert f"removes {100 * e['heldout_gain']:.0f} % of the replay's yaw-rate error" in line


def test_the_json_groups_carry_the_held_out_replay_and_final_errors(chi_audit):
    """Each ``groups`` record of the JSON report: the held-out RMSE of the replay
    (``baseline_rmse``) and of the selected model (``final_rmse``, lower once an effect is
    selected), the signals it is scored on and its number of cross-validation units."""
    from terrain.audit import to_dict

    frames, result = chi_audit
    groups = {(g["terrain"], g["group"]): g for g in to_dict(result)["groups"]}
    yaw = groups[("ASPHALT", "yaw")]
    res = result.groups[("ASPHALT", "yaw")]
    assert yaw["selected"] == list(res.selected) and "icr_expansion" in yaw["selected"]
    assert yaw["baseline_rmse"] == pytest.approx(res.baseline_rmse, abs=1e-5)
    assert yaw["final_rmse"] == pytest.approx(res.final_rmse, abs=1e-5)
    assert yaw["final_rmse"] < 0.5 * yaw["baseline_rmse"]
    assert yaw["signals"] == ["wz"] and groups[("ASPHALT", "current")]["signals"] == [
        "cur_l", "cur_r"]
    assert yaw["n_units"] == len(frames) == 4
