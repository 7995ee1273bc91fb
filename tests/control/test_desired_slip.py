"""Desired-slip table: physical invariants, closed-form peaks, fallback (issue 11)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrain.control.desired_slip import (FALLBACK_LABEL, THESIS_CLASSES, DesiredSlip,
                                          DesiredSlipConfig, build_slip_table,
                                          classifier_classes, desired_slip, fallback_entry,
                                          is_deformable, select_target)
from terrain.errors import ConfigError
from terrain.models.ensemble import normalised_weights
from terrain.io.shipped import read_manifest
from terrain.terramechanics import (BrixiusCurve, BurckhardtCurve, get_terrain,
                                    soil_resistance_coefficient, steady_slip,
                                    traction_coefficient,
                                    traction_curve_and_slope)
from terrain.terramechanics.catalogue import TERRAINS
from terrain.terramechanics.efficiency import max_tractive_efficiency, tractive_efficiency
from terrain.terramechanics.inverse import (slip_at_peak_fraction, slip_from_traction,
                                            stable_side_end)

CFG = DesiredSlipConfig()


@pytest.fixture(scope="module")
def table():
    manifest = read_manifest()
    measured = [t for ds in manifest["datasets"].values() for t in ds["terrains"]]
    return build_slip_table(classifier_classes(measured), CFG)


def test_every_class_the_classifier_can_emit_has_an_entry(table):
    manifest = read_manifest()
    measured = {t for ds in manifest["datasets"].values() for t in ds["terrains"]}
    assert len(measured) == 9
    assert set(table.entries) == measured | set(THESIS_CLASSES)
    assert list(table.frame()["terrain"])[-1] == FALLBACK_LABEL


def test_signs_and_ordering(table):
    for e in table.entries.values():
        assert e.braking < 0.0 < e.traction, e
        assert 0.0 <= e.steady <= e.traction, e
        assert abs(e.braking) >= e.traction, e   # braking target larger (ch. 8.3.2)


def test_targets_on_the_stable_side_of_the_peak(table):
    for name, e in table.entries.items():
        curve = get_terrain(name).curve
        for s in (e.traction, e.braking):
            assert float(traction_curve_and_slope(curve, s)[1]) > 0.0, (name, s)
        if isinstance(curve, BurckhardtCurve) and curve.c3 > 0:
            s_peak = math.log(curve.c1 * curve.c2 / curve.c3) / curve.c2   # closed form
            assert e.traction < abs(e.braking) < s_peak, name


def test_rigid_traction_target_is_95_percent_of_the_closed_form_peak(table):
    for name in ("ASPHALT", "CONCRETE", "TILES", "FLOORING"):
        c = get_terrain(name).curve
        s_peak = math.log(c.c1 * c.c2 / c.c3) / c.c2
        mu_peak = c.c1 * (1 - math.exp(-c.c2 * s_peak)) - c.c3 * s_peak
        s = table.entries[name].traction
        assert c.c1 * (1 - math.exp(-c.c2 * s)) - c.c3 * s == pytest.approx(0.95 * mu_peak,
                                                                            rel=1e-9)


def test_ice_target_from_its_closed_form():
    c = get_terrain("ICE").curve          # c3 = 0: rising curve, maximum at s = 1
    expected = -math.log(1 - 0.95 * (1 - math.exp(-c.c2))) / c.c2
    assert desired_slip(get_terrain("ICE")).traction == pytest.approx(expected, rel=1e-9)


def test_deformable_soils_at_max_tractive_efficiency_capped(table):
    grid = np.linspace(0.0, 1.0, 4001)
    for name in ("SNOW", "SANDY_LOAM", "DIRT_ROAD", "PLOUGHED", "UNPLOUGHED", "GRASS",
                 "GRAVEL"):
        terrain, e = get_terrain(name), table.entries[name]
        eta = tractive_efficiency(terrain, grid)
        s_best = grid[np.argmax(eta)]
        assert e.traction <= CFG.deformable_cap + 1e-12
        assert abs(e.braking) <= CFG.deformable_cap + 1e-12
        assert e.traction == pytest.approx(min(s_best, CFG.deformable_cap), abs=1e-3), name
        # the net-pull peak lies far beyond the target: no usable set point there (the
        # docstrings said 40-60 % slip: Brixius soils 54-73 %, Janosi-Hanamoto ones at s = 1)
        net = traction_coefficient(terrain.curve, grid) - soil_resistance_coefficient(terrain,
                                                                                      grid)
        s_net = grid[np.argmax(net)]
        assert s_net > e.traction + 0.1, name
        if isinstance(terrain.curve, BrixiusCurve):
            assert 0.53 < s_net < 0.74, (name, s_net)
        else:
            assert s_net == 1.0, (name, s_net)
    assert table.entries["SANDY_LOAM"].traction == CFG.deformable_cap   # its optimum is 0.34


def test_steady_target_balances_the_soil_resistance(table):
    for name in ("SNOW", "GRASS", "GRAVEL", "SANDY_LOAM"):
        t, s = get_terrain(name), table.entries[name].steady
        assert float(traction_coefficient(t.curve, s)) == pytest.approx(
            float(soil_resistance_coefficient(t, s)), abs=1e-6)
    assert table.entries["ASPHALT"].steady == 0.0   # rigid: no slip-producing resistance


def test_source_and_basis_recorded(table):
    assert table.entries["TILES"].method.endswith("[analogy]")
    assert table.entries["FLOORING"].method.endswith("[analogy]")
    assert table.entries["ASPHALT"].method.endswith("[direct]")
    assert table.entries["GRASS"].method.endswith("[calibrated]")
    # Janosi-Hanamoto K or Brixius cone index ASSUMED in the catalogue
    assert table.entries["SNOW"].method.endswith("[direct, one parameter assumed]")
    assert table.entries["UNPLOUGHED"].method.endswith("[direct, one parameter assumed]")
    assert table.entries["ASPHALT"].source.endswith("interior friction peak (Burckhardt: "
                                                    "ln(c1 c2/c3)/c2)")
    assert table.entries["ICE"].source.endswith("curve without interior peak: peak = max on "
                                                "[0, 1]")
    for name, e in table.entries.items():
        assert e.source.startswith(f"catalogue {name}:")


def test_targets_follow_the_rule_settings():
    loose = desired_slip(get_terrain("ASPHALT"), DesiredSlipConfig(traction_fraction=0.9))
    assert loose.traction < desired_slip(get_terrain("ASPHALT")).traction
    tight = desired_slip(get_terrain("GRASS"), DesiredSlipConfig(deformable_cap=0.2))
    assert tight.traction == 0.2
    # SNOW's resistances balance at 0.167 slip, above a 0.1 cap: the steady target (a limit
    # of the one-sided controller too) is held at the traction target, never above it
    assert steady_slip(get_terrain("SNOW")) > 0.1
    capped = desired_slip(get_terrain("SNOW"), DesiredSlipConfig(deformable_cap=0.1))
    assert capped.traction == 0.1 and capped.steady == 0.1


def test_fallback_is_the_most_conservative_entry(table):
    fb = table.fallback
    assert fb.traction == min(e.traction for e in table.entries.values())
    assert fb.braking == max(e.braking for e in table.entries.values())
    assert fb.braking < 0 < fb.traction and 0 <= fb.steady <= fb.traction


def test_fallback_takes_each_target_from_its_own_most_conservative_entry():
    """Hand-built rows: the smallest traction (A), the braking closest to 0 (B, not the
    most negative -0.3 of A) and the smallest steady (B), each from another row where they
    differ; on the catalogue's table every steady minimum is 0 and cannot tell."""
    a = DesiredSlip("A", traction=0.05, braking=-0.3, steady=0.04, source="", method="")
    b = DesiredSlip("B", traction=0.2, braking=-0.1, steady=0.01, source="", method="")
    fb = fallback_entry([a, b])
    assert (fb.terrain, fb.traction, fb.braking, fb.steady) == (FALLBACK_LABEL, 0.05, -0.1,
                                                                0.01)
    assert "traction from A, braking from B, steady from B" in fb.source


@pytest.mark.parametrize("terrain,confidence,age,expect", [
    ("GRASS", 0.9, 0.5, "GRASS"), ("grass", 0.9, 0.0, "GRASS"),
    ("MARS_REGOLITH", 0.9, 0.0, FALLBACK_LABEL), (None, 1.0, 0.0, FALLBACK_LABEL),
    ("GRASS", 0.3, 0.0, FALLBACK_LABEL), ("GRASS", float("nan"), 0.0, FALLBACK_LABEL),
    ("GRASS", 0.9, 10.0, FALLBACK_LABEL), ("GRASS", 0.9, float("inf"), FALLBACK_LABEL),
    ("GRASS", 1.0, 0.0, "GRASS"),
    ("GRASS", 45.0, 0.0, FALLBACK_LABEL),   # a percentage: 45 % is below the threshold
    ("GRASS", 0.9, -0.1, FALLBACK_LABEL),   # stamped after its use: clocks disagree
    ("GRASS", 0.9, 4.0, "GRASS"),           # exactly max_decision_age_s is not older
    ("GRASS", 0.5, 0.0, "GRASS"),           # exactly min_confidence is not below it
    ("GRASS", 0.49, 0.0, FALLBACK_LABEL),   # min_confidence 0.5: the majority of the mass
    ("GRASS", 0.9, 4.01, FALLBACK_LABEL),   # max age 4 s: two 2 s classification windows
    ("GRASS", None, 0.0, FALLBACK_LABEL),   # a decision without a confidence (was TypeError)
    ("GRASS", 0.9, None, FALLBACK_LABEL),   # or without a stamp
])
def test_select_target_falls_back_when_untrusted(table, terrain, confidence, age, expect):
    assert select_target(table, terrain, confidence, age).terrain == expect


def test_a_certain_weighted_vote_one_ulp_above_one_is_trusted(table):
    # an ensemble whose members are all certain, weighted 0.6 / 0.3 / 0.1, sums its float
    # weights to 1.0000000000000002: rounding, not a percentage
    confidence = float(normalised_weights((0.6, 0.3, 0.1), 3) @ np.ones(3))
    assert confidence > 1.0
    assert select_target(table, "GRASS", confidence, 0.0).terrain == "GRASS"
    assert select_target(table, "GRASS", 1.01, 0.0).terrain == FALLBACK_LABEL


def test_unknown_class_and_bad_settings_are_typed_errors():
    # the message says why a class needs the catalogue (a model trained on a folder named
    # SNOW2 was refused by terrain stream with only "unknown terrain 'SNOW2'")
    with pytest.raises(ConfigError, match=r"no desired slip for class\(es\) \['LAVA'\]: a "
                                          r"target comes from the class's traction-slip curve"):
        build_slip_table(["ASPHALT", "LAVA"])
    with pytest.raises(ConfigError):
        DesiredSlipConfig(traction_fraction=0.99, braking_fraction=0.9)
    with pytest.raises(ConfigError):
        DesiredSlipConfig(deformable_cap=1.5)
    with pytest.raises(ConfigError, match="max_decision_age_s > 0"):
        DesiredSlipConfig(max_decision_age_s=0.0)   # every decision would be stale
    # equal fractions are allowed (0 < traction_fraction <= braking_fraction < 1)
    assert DesiredSlipConfig(traction_fraction=0.99).braking_fraction == 0.99
    with pytest.raises(ConfigError, match="the desired-slip table has no entries"):
        build_slip_table([])                         # no fallback without rows


def test_rigid_braking_target_is_99_percent_of_the_friction_peak(table):
    """ch. 8.3.2 eq. 8.8: braking "at the peak of the braking curve", kept 1 % on the stable
    side: mu(|braking|) = 0.99 mu_peak, the peak in closed form (Burckhardt
    ln(c1 c2 / c3) / c2; ICE, c3 = 0, at s = 1). The deformable soils' braking targets all
    sit at the 0.30 cap instead."""
    for name in ("ASPHALT", "CONCRETE", "TILES", "FLOORING", "PACKED_SNOW", "ICE"):
        c = get_terrain(name).curve
        s_peak = math.log(c.c1 * c.c2 / c.c3) / c.c2 if c.c3 > 0 else 1.0
        mu = (lambda s: c.c1 * (1 - math.exp(-c.c2 * s)) - c.c3 * s)  # noqa: E731
        b = desired_slip(get_terrain(name)).braking
        assert mu(-b) == pytest.approx(0.99 * mu(s_peak), rel=1e-9), name
    for name in ("SNOW", "SANDY_LOAM", "DIRT_ROAD", "PLOUGHED", "UNPLOUGHED", "GRASS",
                 "GRAVEL"):
        assert table.entries[name].braking == -CFG.deformable_cap, name
    # the fallback is the ice row's: the smallest traction and the braking closest to 0
    ice = table.entries["ICE"]
    assert (table.fallback.traction, table.fallback.braking) == (ice.traction, ice.braking)


def test_class_labels_are_case_insensitive_and_thesis_classes_not_repeated():
    """A classifier trained on lower-case folders ('grass', 'ice') gets the same table; a
    measured class that is also a thesis class appears once."""
    assert classifier_classes(["ice", "grass", "Asphalt"]) == ("ASPHALT", "GRASS", "ICE",
                                                               "TILES", "GRAVEL")
    table = build_slip_table(["grass", "Ice"])
    assert list(table.entries) == ["GRASS", "ICE"]
    assert table.entries["ICE"] == desired_slip(get_terrain("ICE"))


def test_tractive_efficiency_matches_brixius_textbook_form():
    """With the 0.04 hysteresis of Brixius (1987): TE = (GT - MR)/GT (1 - s)."""
    from dataclasses import replace
    bn = 30.0
    terrain = replace(get_terrain("DIRT_ROAD"), curve=BrixiusCurve(bn), hysteresis=0.04)
    s = np.linspace(0.02, 0.6, 30)
    gt = 0.88 * (1 - np.exp(-0.1 * bn)) * (1 - np.exp(-7.5 * s)) + 0.04
    mr = 1 / bn + 0.04 + 0.5 * s / np.sqrt(bn)
    np.testing.assert_allclose(tractive_efficiency(terrain, s), (gt - mr) / gt * (1 - s),
                               rtol=1e-12)
    assert tractive_efficiency(terrain, -0.2) == pytest.approx(tractive_efficiency(terrain, 0.2))
    s_best, eta = max_tractive_efficiency(terrain)
    assert 0.05 < s_best < 0.3 and 0.0 < eta < 1.0


def test_rule_follows_soil_resistance_not_curve_type():
    """Rigid = no slip-producing resistance; over the catalogue that is exactly Burckhardt."""
    for name, terrain in TERRAINS.items():
        assert is_deformable(terrain) == (not isinstance(terrain.curve, BurckhardtCurve)), name


def test_peak_fraction_inverse_is_exact_and_agrees_with_the_tabulated_inverse():
    for name in ("ASPHALT", "ICE", "PACKED_SNOW", "SNOW", "UNPLOUGHED"):
        curve = get_terrain(name).curve
        s_peak, mu_peak = stable_side_end(curve)
        for frac in (0.5, 0.95, 0.99):
            s = slip_at_peak_fraction(curve, frac)
            assert 0.0 < s < s_peak
            assert float(traction_coefficient(curve, s)) == pytest.approx(frac * mu_peak,
                                                                          rel=1e-9)
            # the table's inverse (4001-point grid) lands on the same slip
            assert float(slip_from_traction(curve, frac * mu_peak).slip) == pytest.approx(
                s, abs=2e-3), (name, frac)
        assert slip_at_peak_fraction(curve, 1.0) == s_peak
    # a fraction above 1 has no slip on the stable side: the check must refuse it by name,
    # before root-finding fails with scipy's bare 'f(a) and f(b) must have different signs'
    for bad in (0.0, 1.2, float("nan")):
        with pytest.raises(ConfigError, match=r"fraction must be in \(0, 1\]"):
            slip_at_peak_fraction(get_terrain("ICE").curve, bad)


def test_soft_soil_efficiency_optimum_above_the_cap_comes_from_the_curves():
    """Wong's eta = (mu - rho)/(mu + h)(1 - s); with the catalogue's short contact patches
    (k = K / L = 0.31-0.37) mu rises slowly, so the optimum lies at 0.34-0.46 slip; without
    the torque-only hysteresis h it moves lower but stays above 0.25."""
    from dataclasses import replace
    expected = {"SANDY_LOAM": 0.341, "SNOW": 0.460, "GRASS": 0.363}
    for name, s_opt in expected.items():
        terrain = get_terrain(name)
        s_best, eta = max_tractive_efficiency(terrain)
        assert s_best == pytest.approx(s_opt, abs=2e-3), name
        mu, rho = (float(traction_coefficient(terrain.curve, s_best)),
                   float(soil_resistance_coefficient(terrain, s_best)))
        assert eta == pytest.approx((mu - rho) / (mu + terrain.hysteresis) * (1 - s_best))
        assert max_tractive_efficiency(replace(terrain, hysteresis=0.0))[0] > 0.25, name
    # a Brixius soil (strong tyre, stiff soil) peaks at low slip, as in Zoz & Grisso (2003)
    assert 0.1 < max_tractive_efficiency(get_terrain("UNPLOUGHED"))[0] < 0.13


def test_desired_slip_rows_refuse_targets_of_the_wrong_sign():
    """The table's rows carry the same sign rules as SlipTargets (traction > 0, braking < 0);
    a hand-made row with a positive braking target was accepted silently."""
    from terrain.control.desired_slip import DesiredSlip

    with pytest.raises(ConfigError, match=r"DesiredSlip\.braking .*got 0\.15"):
        DesiredSlip("X", 0.1, 0.15, 0.0, "hand-made", "none")
    # the docstring's steady in [0, traction] was not checked: a cruising wheel allowed
    # more slip than an accelerating one passed
    with pytest.raises(ConfigError, match=r"DesiredSlip\.steady must be in \[0, traction\] "
                                          r"\(0\.1\) for terrain 'X', got 0\.2"):
        DesiredSlip("X", 0.1, -0.15, 0.2, "hand-made", "none")
    assert DesiredSlip("X", 0.1, -0.15, 0.1, "hand-made", "none").steady == 0.1


def test_fallback_source_names_the_same_entries_in_any_order_of_the_classes():
    """Many steady targets tie at 0: fallback_entry's source named the first listed of them,
    so the same table's classes in another order printed another source (ctl20's
    left-alone); ties now go to the first terrain name, and the targets never depended on
    the order."""
    a = DesiredSlip("A", traction=0.1, braking=-0.2, steady=0.0, source="", method="")
    b = DesiredSlip("B", traction=0.1, braking=-0.2, steady=0.0, source="", method="")
    c = DesiredSlip("C", traction=0.3, braking=-0.1, steady=0.0, source="", method="")
    forward, backward = fallback_entry([a, b, c]), fallback_entry([c, b, a])
    assert forward == backward
    assert "traction from A, braking from C, steady from A" in forward.source
