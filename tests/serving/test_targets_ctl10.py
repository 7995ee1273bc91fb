"""Review pass ctl10 of the target providers (terrain.serving.targets)."""

from __future__ import annotations

import pytest

from terrain.errors import ConfigError
from terrain.serving.targets import CataloguePeakTargets, TableTargets


def test_table_targets_fallback_attribute_is_what_it_answers_untrusted_decisions():
    """``TableTargets.fallback`` is the table's conservative row, steady target included:
    over SNOW and GRASS the smallest steady slip is GRASS's 0.125, not 0."""
    targets = TableTargets(["SNOW", "GRASS"])
    assert targets.fallback == targets.target_for(None, 1.0, False)
    assert targets.fallback == targets.target_for("SNOW", 0.1, False)
    assert targets.fallback.steady == pytest.approx(0.1253, abs=1e-4)


@pytest.mark.parametrize("provider", [CataloguePeakTargets, TableTargets])
@pytest.mark.parametrize("classes, message", [
    ("ICE", "needs a sequence of class names, got str 'ICE'"),
    (["ICE", 2], r"class names must be text, got \('ICE', 2\)"),
])
def test_providers_name_a_class_list_that_is_not_text_labels(provider, classes, message):
    with pytest.raises(ConfigError, match=f"{provider.__name__} {message}"):
        provider(classes)


class _Custom:
    """A robot's own provider with a threshold of its own."""

    classes = ("ASPHALT", "ICE")

    def __init__(self, floor):
        self.min_confidence = floor

    def target_for(self, terrain, confidence, stale):
        return (0.1, -0.1, 0.0) if confidence >= self.min_confidence else (0.01, -0.01, 0.0)


@pytest.mark.parametrize("floor", [float("nan"), "high", False, -0.1])
def test_check_provider_refuses_a_provider_threshold_that_is_not_a_number(floor):
    """A provider whose min_confidence is NaN answers every decision with its fallback
    (``c >= nan`` is false) and passed the check (``nan > 0.5`` is false too); text raised
    a bare ValueError from float(), a boolean passed as 1 or 0, a negative one as no floor."""
    from terrain.serving.targets import check_provider

    with pytest.raises(ConfigError, match=r"_Custom\.min_confidence"):
        check_provider(_Custom(floor), ("ASPHALT",), 0.5)
    check_provider(_Custom(0.5), ("ASPHALT",), 0.5)


@pytest.mark.parametrize("provider", [CataloguePeakTargets, TableTargets])
def test_stale_input_gets_the_fallback_however_confident_the_decision(provider):
    """A decision on stale input is not trusted: the fallback, as for no decision (the
    table's rule: an age beyond ``max_decision_age_s``); trusted and fresh, the class's own
    row, which differs from the fallback for one of the two classes."""
    targets = provider(["SNOW", "GRASS"])
    fresh = [targets.target_for(c, 0.99, False) for c in ("SNOW", "GRASS")]
    assert any(f != targets.fallback for f in fresh)
    for terrain in ("SNOW", "GRASS"):
        assert targets.target_for(terrain, 0.99, True) == targets.fallback


def test_check_provider_refuses_a_provider_threshold_just_above_the_services():
    # 0.505 > 0.5: decisions at confidence 0.5-0.505 would get the fallback unflagged
    from terrain.serving.targets import check_provider

    with pytest.raises(ConfigError, match=r"min_confidence 0\.505 is above the service's"):
        check_provider(_Custom(0.505), ("ASPHALT",), 0.5)


def test_a_model_with_lower_case_classes_takes_the_table_built_from_them():
    """The table answers a class in any case (``select_target`` upper-cases it, as the
    catalogue names are), but check_provider compared names as given: a model trained on
    'ice' and 'snow' was refused the TableTargets built from those very names ('holds no
    targets for the model's class(es) ['ice', 'snow'] (it has ['ICE', 'SNOW'])')."""
    from terrain.serving.targets import check_provider

    table = TableTargets(["ice", "snow"])
    check_provider(table, ["ice", "snow"], 0.5)
    assert table.target_for("ice", 0.9, False) == table.target_for("ICE", 0.9, False)
    with pytest.raises(ConfigError, match=r"class\(es\) \['grass'\]"):
        check_provider(table, ["ice", "grass"], 0.5)
