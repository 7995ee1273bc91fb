"""Review pass ctl10 of the desired-slip table's trust rules (terrain.control.desired_slip)."""

from __future__ import annotations

import pytest

from terrain.control.desired_slip import FALLBACK_LABEL, build_slip_table, select_target


@pytest.mark.parametrize("confidence, trusted", [
    (0.6 + 0.3 + 0.1, True),      # a soft vote of certain members: 1 + 1 ulp, rounding
    (1.0 + 1e-12, True),
    (1.0 + 1e-6, False),          # no rounding: not a probability, the fallback
    (1.001, False),
])
def test_only_rounding_above_one_is_a_trusted_confidence(confidence, trusted):
    """CONFIDENCE_ROUNDING (1e-9) is the slack above 1 taken as float rounding; a confidence
    1e-6 above 1 is no probability and gets the conservative fallback."""
    table = build_slip_table(["ASPHALT", "ICE"])
    got = select_target(table, "ASPHALT", confidence, 0.0)
    assert got.terrain == ("ASPHALT" if trusted else FALLBACK_LABEL)


def test_the_fallback_is_the_most_conservative_entry_of_the_table_only():
    """The fallback is taken over the table's classes, not the whole catalogue: a table of
    ASPHALT and SNOW falls back to ASPHALT's traction and braking targets, past the friction
    peak of PACKED_SNOW (0.060), a surface it does not hold."""
    from terrain.terramechanics import get_terrain, traction_peak

    table = build_slip_table(["ASPHALT", "SNOW"])
    assert (table.fallback.traction, table.fallback.braking) == (
        table.entries["ASPHALT"].traction, table.entries["ASPHALT"].braking)
    assert table.fallback.traction > traction_peak(get_terrain("PACKED_SNOW").curve).slip


def test_one_class_name_is_not_a_sequence_of_letters():
    """``classifier_classes("ICE")`` returned ('C', 'E', 'I', 'TILES', 'GRASS', 'GRAVEL')
    silently, and ``build_slip_table("ICE")`` complained of classes 'I', 'C', 'E'; both now
    refuse one name where a sequence of names is meant."""
    from terrain.control.desired_slip import classifier_classes
    from terrain.errors import ConfigError

    with pytest.raises(ConfigError, match="sequence of class names.*'ICE'"):
        classifier_classes("ICE")
    with pytest.raises(ConfigError, match="sequence of class names.*'ICE'"):
        build_slip_table("ICE")
    assert classifier_classes(["ice", "ASPHALT"]) == ("ASPHALT", "ICE", "TILES", "GRASS",
                                                      "GRAVEL")
    assert list(build_slip_table(("ice",)).entries) == ["ICE"]


def test_a_config_or_terrain_of_the_wrong_type_is_a_config_error():
    """``build_slip_table(classes, None)`` (TableTargets takes None for the defaults) raised
    AttributeError 'NoneType' object has no attribute 'braking_fraction', and
    ``desired_slip("ICE")`` 'str' object has no attribute 'curve'."""
    from terrain.control.desired_slip import desired_slip
    from terrain.errors import ConfigError
    from terrain.terramechanics import get_terrain

    with pytest.raises(ConfigError, match="DesiredSlipConfig.*NoneType"):
        build_slip_table(["ICE"], None)
    with pytest.raises(ConfigError, match="TerrainParams.*get_terrain.*'ICE'"):
        desired_slip("ICE")
    assert desired_slip(get_terrain("ICE")).terrain == "ICE"


def test_method_says_capped_only_where_the_cap_binds_and_reads_calibration_from_the_source():
    """``(capped)`` marks a deformable soil whose efficiency optimum lies above the cap
    (SNOW 0.460), not one below it (UNPLOUGHED 0.118); a catalogue source whose first part
    says CALIBRATED is 'calibrated' even when its curve's own source does not say so."""
    import dataclasses

    from terrain.control.desired_slip import desired_slip
    from terrain.terramechanics import get_terrain

    assert "at 0.460 (capped)" in desired_slip(get_terrain("SNOW")).method
    assert "(capped)" not in desired_slip(get_terrain("UNPLOUGHED")).method
    grass = get_terrain("GRASS")
    assert "CALIBRATED" in grass.source.split(";")[0]
    plain_curve = dataclasses.replace(grass, curve=dataclasses.replace(grass.curve,
                                                                       source="Janosi"))
    assert desired_slip(plain_curve).method.endswith("[calibrated]")


def test_gravel_is_the_fourth_janosi_soil_the_cap_binds_on():
    """docs/control_validation.md's soft-soil table: GRAVEL (Janosi, calibrated) has its
    efficiency optimum at 0.379 (eta 0.318), 0.364 without the hysteresis term, 0.143
    without the soil resistance; its traction target is the 0.30 cap."""
    from dataclasses import replace

    from terrain.control.desired_slip import desired_slip
    from terrain.terramechanics import get_terrain
    from terrain.terramechanics.efficiency import max_tractive_efficiency

    gravel = get_terrain("GRAVEL")
    s_best, eta = max_tractive_efficiency(gravel)
    assert (round(s_best, 3), round(eta, 3)) == (0.379, 0.318)
    assert round(max_tractive_efficiency(replace(gravel, hysteresis=0.0))[0], 3) == 0.364
    assert round(max_tractive_efficiency(replace(gravel, soil_resistance=0.0))[0], 3) == 0.143
    assert desired_slip(gravel).traction == 0.30
