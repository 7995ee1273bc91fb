"""Desired-slip table: terrain class -> target slip for traction, braking and steady cruising.

Seed ``001_59da564c4b2d6a48.txt`` ch. 8.2 maps the classifier's terrain label to a "desired
slip" that the traction PID of ch. 8.3.2 regulates to, one value per dynamic condition
(eqs. 8.7-8.9). Every target here is **computed** from the terrain's traction-slip curve in the
catalogue (:mod:`terrain.terramechanics.catalogue`), never typed in:

Rigid surfaces (no slip-producing soil resistance, :func:`is_deformable`; the catalogue's
Burckhardt friction curves: paved, tiled, icy, snow-covered road)
    *traction*: the slip where ``mu`` first reaches ``traction_fraction`` (95 %) of its peak,
    i.e. on the stable side of the friction peak
    (:func:`terrain.terramechanics.inverse.slip_at_peak_fraction`); the peak of a Burckhardt
    curve lies at ``ln(c1 c2 / c3) / c2`` (:func:`~terrain.terramechanics.traction_peak`), a
    curve without interior peak (ice, ``c3 = 0``) uses its maximum on [0, 1];
    *braking*: ch. 8.3.2 puts it at the peak of the braking curve; we take the stable-side slip
    at ``braking_fraction`` (99 %) of the peak, negative (the catalogue's curves are odd, so
    this is larger in magnitude than the traction target, as the thesis expects).
Deformable soils (slip-producing soil resistance > 0; the catalogue's Janosi-Hanamoto and
Brixius curves: snow, sandy loam, grass, gravel, dirt, ploughed and unploughed fields)
    *traction*: the slip of maximum tractive efficiency
    (:func:`terrain.terramechanics.efficiency.max_tractive_efficiency`), capped at
    ``deformable_cap``: their net-pull maximum lies at 54-73 % slip (Brixius soils) or at full
    spin (the Janosi-Hanamoto curves rise up to ``s = 1``) and is no usable set point;
    *braking*: the stable-side slip at ``braking_fraction`` of the braking peak, capped at
    ``-deformable_cap``.
Every terrain, *steady*: the slip at which traction balances the slip-producing soil resistance
    (:func:`terrain.terramechanics.steady_slip`; ch. 8.3.2: "exactly what we need to balance
    external resistances"), never above the traction target.

The physics of the entry decides the rule, not its name or curve type: the catalogue models
BorealTC's deep forest ``SNOW`` as a deformable soil (Janosi-Hanamoto), so it gets the
tractive-efficiency rule; a snow-covered *road* (``PACKED_SNOW``, Burckhardt) would get the
friction-peak rule.

Fallback (:func:`select_target`): an unknown class, a decision below ``min_confidence``,
older than ``max_decision_age_s`` or of a negative age gets the most conservative entry of
the table: the smallest traction and steady targets and the braking target closest to zero
over the table's classes, so the wheel never runs past the friction peak of any surface in the
table (on a deformable soil it then gives away pull, never stability). Only of those: a
catalogue surface the table does not hold may peak lower (a table of ASPHALT and SNOW falls
back to 0.100 traction slip, past PACKED_SNOW's peak at 0.060); the classifier's table holds
ICE, whose targets are the fallback.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping, Sequence

import pandas as pd

from terrain.control.traction import age_is_fresh, check_slip_targets
from terrain.errors import ConfigError, config_numbers, config_probability
from terrain.terramechanics import (TerrainParams, get_terrain, is_deformable,
                                    steady_slip, traction_peak)
from terrain.terramechanics.catalogue import TERRAIN_NAMES
from terrain.terramechanics.efficiency import max_tractive_efficiency
from terrain.terramechanics.inverse import slip_at_peak_fraction

#: Terrain classes of the thesis's own AgriMaRo tests (seed 001 ch. 7.2.3), emitted by a
#: classifier trained on them besides the nine measured BorealTC / Vulpi classes.
THESIS_CLASSES: tuple[str, ...] = ("TILES", "GRASS", "GRAVEL")

#: Columns of ``terrain slip-table`` (issue 11), in this order.
TABLE_COLUMNS: tuple[str, ...] = ("terrain", "target_slip_traction", "target_slip_braking",
                                  "target_slip_steady", "source", "method")

#: Label of the fallback row.
FALLBACK_LABEL = "UNKNOWN"
#: How far above 1 a confidence may lie and still be a probability: a weighted soft vote of
#: members that are all certain sums its float weights to one ulp above 1 (weights 0.6, 0.3,
#: 0.1 give 1.0000000000000002), which is rounding, not a percentage.
CONFIDENCE_ROUNDING = 1e-9


def confidence_is_trusted(confidence: float | None, min_confidence: float) -> bool:
    """Whether a decision's confidence may be trusted: a probability at or above the
    threshold.

    The one rule for the confidence of a terrain decision (:func:`select_target`,
    :class:`terrain.serving.targets.CataloguePeakTargets`).

    Parameters
    ----------
    confidence : float or None
        Probability of the decided class, dimensionless (None: a decision without one).
    min_confidence : float
        Lowest trusted probability, in [0, 1] (a confidence equal to it is trusted).

    Returns
    -------
    bool
        False for a confidence below ``min_confidence``, above 1 (a percentage: 45 would
        pass a 0.5 threshold; up to ``CONFIDENCE_ROUNDING`` above 1 is rounding and
        trusted), not finite (NaN, +-inf) or None.

    Raises
    ------
    ConfigError
        ``confidence`` not a real number or None (a boolean: ``True`` passed as a
        probability of 1; text: Python's bare TypeError); ``min_confidence`` not a real
        number in [0, 1] (text, None, a boolean, NaN), named.
    """
    if type(min_confidence) is not float or not 0.0 <= min_confidence <= 1.0:
        config_probability("confidence_is_trusted", min_confidence=min_confidence)
    config_numbers("confidence_is_trusted", optional=("confidence",), confidence=confidence)
    return (confidence is not None and math.isfinite(confidence)
            and min_confidence <= confidence <= 1.0 + CONFIDENCE_ROUNDING)


@dataclass(frozen=True)
class DesiredSlipConfig:
    """How targets are derived from the curves, and when the fallback applies.

    Parameters
    ----------
    traction_fraction : float
        Fraction of the friction peak at which rigid-surface traction targets sit, on the
        stable side (0.95: issue 11's example; the slope of ``mu`` there is still positive).
    braking_fraction : float
        Fraction of the braking friction peak for braking targets (0.99: "at the peak of the
        braking curve", seed 001 ch. 8.3.2 eq. 8.8, kept 1 % on the stable side).
    deformable_cap : float
        Largest traction / braking slip magnitude on deformable soils (0.30: the upper end of
        the "often exceeding 20-30 %" slip that seed 001 ch. 8.2 gives for plastic terrain,
        below the net-pull peak: 54-73 % slip on the catalogue's Brixius soils, full spin on
        its Janosi-Hanamoto soils).
    min_confidence : float
        Decisions with a top-class probability below this use the fallback (0.5: ASSUMED, the
        decision must hold the majority of the probability mass).
    max_decision_age_s : float
        Decisions older than this (s) use the fallback (4.0: ASSUMED, two 2 s classification
        windows of the default feature set); finite, > 0.

    Raises
    ------
    ConfigError
        A field that is not a real number (text, a boolean, ``None``, a list) or outside
        its range.
    """

    traction_fraction: float = 0.95
    braking_fraction: float = 0.99
    deformable_cap: float = 0.30
    min_confidence: float = 0.5
    max_decision_age_s: float = 4.0

    def __post_init__(self) -> None:
        config_numbers("DesiredSlipConfig", traction_fraction=self.traction_fraction,
                       braking_fraction=self.braking_fraction,
                       deformable_cap=self.deformable_cap, min_confidence=self.min_confidence,
                       max_decision_age_s=self.max_decision_age_s)
        if not (0.0 < self.traction_fraction <= self.braking_fraction < 1.0):
            raise ConfigError("need 0 < traction_fraction <= braking_fraction < 1, got "
                              f"{self.traction_fraction}, {self.braking_fraction}")
        if not 0.0 < self.deformable_cap < 1.0:
            raise ConfigError(f"deformable_cap must be in (0, 1), got {self.deformable_cap}")
        config_probability("DesiredSlipConfig", min_confidence=self.min_confidence)
        # inf: no decision would ever turn stale, the last class would hold for good
        if not 0.0 < self.max_decision_age_s < float("inf"):
            raise ConfigError("DesiredSlipConfig: need max_decision_age_s > 0 s and finite, "
                              f"got {self.max_decision_age_s}")


@dataclass(frozen=True)
class DesiredSlip:
    """Target slips of one terrain class (magnitudes for forward driving, SAE slip).

    Parameters
    ----------
    terrain : str
        Class label, or :data:`FALLBACK_LABEL`.
    traction : float
        Target slip while accelerating, > 0 (dimensionless).
    braking : float
        Target slip while braking, < 0 (dimensionless).
    steady : float
        Target slip while cruising, in [0, traction] (dimensionless).
    source : str
        Where the curve comes from (catalogue entry) and the relation used.
    method : str
        The rule of each target, and whether the curve is direct, by analogy or calibrated.

    Raises
    ------
    ConfigError
        A target of the wrong sign, beyond [-1, 1] or not a real number
        (:func:`terrain.control.traction.check_slip_targets`), or a steady target above
        the traction target.
    """

    terrain: str
    traction: float
    braking: float
    steady: float
    source: str
    method: str

    def __post_init__(self) -> None:
        check_slip_targets("DesiredSlip", self.traction, self.braking, self.steady)
        if self.steady > self.traction:   # a cruising wheel allowed more slip than a driving one
            raise ConfigError(f"DesiredSlip.steady must be in [0, traction] "
                              f"({self.traction}) for terrain {self.terrain!r}, got "
                              f"{self.steady}")


def classifier_classes(measured: Sequence[str]) -> tuple[str, ...]:
    """Classes the terrain classifier can emit: the measured ones plus :data:`THESIS_CLASSES`.

    Parameters
    ----------
    measured : sequence of str
        Classes of the measured datasets (``data/manifest.json``: BorealTC and Vulpi, nine).

    Returns
    -------
    tuple of str
        Sorted measured classes, then the thesis classes not already among them.

    Raises
    ------
    ConfigError
        ``measured`` one class name (text) instead of a sequence of them, or not a
        collection (None, a number).
    """
    measured = _class_list(measured, "classifier_classes")
    upper = sorted({str(c).upper() for c in measured})
    return tuple(upper) + tuple(c for c in THESIS_CLASSES if c not in upper)


def _class_list(classes, owner: str) -> list:
    """``classes`` as a list (an iterator is read once: ``build_slip_table`` read a generator
    twice and found no class the second time); a :class:`ConfigError` for one class name
    (text, bytes: iterated, it would be read as one class per letter) or for a value that is
    not a collection (None, a number: Python's bare TypeError)."""
    if isinstance(classes, (str, bytes)):
        raise ConfigError(f"{owner} needs a sequence of class names, got one name "
                          f"{classes!r:.60}")
    try:
        return list(classes)
    except TypeError:
        raise ConfigError(f"{owner} needs a sequence of class names, got "
                          f"{type(classes).__name__} {classes!r:.60}") from None


def _basis(terrain: TerrainParams) -> str:
    """Direct, by analogy or calibrated, read from the catalogue's curve description."""
    head = terrain.source.split(";")[0]
    if "ANALOGY" in head:
        return "analogy"
    if "CALIBRATED" in head or terrain.curve.source.startswith("calibrated"):
        return "calibrated"
    if re.search(r"(K = [\d.]+ m|cone index [\d.]+ MPa) ASSUMED", terrain.source):
        return "direct, one parameter assumed"
    return "direct"


def desired_slip(terrain: TerrainParams, config: DesiredSlipConfig = DesiredSlipConfig()
                 ) -> DesiredSlip:
    """Target slips of one catalogue terrain (rules in the module docstring).

    Parameters
    ----------
    terrain : TerrainParams
        Catalogue entry.
    config : DesiredSlipConfig

    Returns
    -------
    DesiredSlip

    Raises
    ------
    ConfigError
        ``terrain`` not a :class:`TerrainParams` (a name: pass ``get_terrain(name)``) or
        ``config`` not a :class:`DesiredSlipConfig`.
    """
    if not isinstance(terrain, TerrainParams):
        raise ConfigError(f"desired_slip needs a catalogue entry (TerrainParams, "
                          f"get_terrain(name)), got {type(terrain).__name__} {terrain!r:.60}")
    if not isinstance(config, DesiredSlipConfig):
        raise ConfigError(f"desired_slip config must be a DesiredSlipConfig, got "
                          f"{type(config).__name__}")
    curve = terrain.curve
    braking_peak = slip_at_peak_fraction(curve, config.braking_fraction)
    head = terrain.source.split(";")[0]
    if not is_deformable(terrain):
        traction = slip_at_peak_fraction(curve, config.traction_fraction)
        braking = -braking_peak
        rule = (f"traction: {config.traction_fraction:.0%} of the friction peak (stable side); "
                f"braking: {config.braking_fraction:.0%} of the peak")
        relation = ("interior friction peak (Burckhardt: ln(c1 c2/c3)/c2)"
                    if not traction_peak(curve).monotonic else
                    "curve without interior peak: peak = max on [0, 1]")
    else:
        s_eff, _ = max_tractive_efficiency(terrain)
        traction = min(s_eff, config.deformable_cap)
        braking = -min(braking_peak, config.deformable_cap)
        capped = " (capped)" if s_eff > config.deformable_cap else ""
        rule = (f"traction: max tractive efficiency at {s_eff:.3f}{capped}, cap "
                f"{config.deformable_cap:g}; braking: {config.braking_fraction:.0%} of the "
                f"peak, cap {config.deformable_cap:g}")
        relation = "tractive efficiency (Wong 2008 ch. 4.2; Zoz & Grisso 2003)"
    steady = min(steady_slip(terrain), traction)
    return DesiredSlip(
        terrain=terrain.name, traction=float(traction), braking=float(braking),
        steady=float(steady),
        source="; ".join(part for part in (f"catalogue {terrain.name}: {head}",
                                           curve.source and f"curve: {curve.source}",
                                           relation) if part),
        method=f"{rule}; steady: mu = soil resistance [{_basis(terrain)}]")


def fallback_entry(entries: Sequence[DesiredSlip]) -> DesiredSlip:
    """The conservative target: the smallest magnitude of each target over ``entries``.

    Parameters
    ----------
    entries : sequence of DesiredSlip
        The table's entries (at least one).

    Returns
    -------
    DesiredSlip
        Labelled :data:`FALLBACK_LABEL`; its ``source`` names the entry each target was
        taken from (among entries with the same magnitude, the first terrain name, whatever
        the order of ``entries``).

    Raises
    ------
    ConfigError
        Empty ``entries``; ``entries`` one row's text, a mapping (its keys are names: pass
        ``table.entries.values()``) or holding anything but :class:`DesiredSlip` rows.
    """
    if isinstance(entries, (str, bytes, Mapping)):
        raise ConfigError(f"fallback_entry needs a sequence of DesiredSlip rows "
                          f"(table.entries.values()), got {type(entries).__name__} "
                          f"{entries!r:.60}")
    try:   # an iterator is read once (min below reads the entries three times)
        entries = [] if entries is None else list(entries)
    except TypeError:
        raise ConfigError(f"fallback_entry needs a sequence of DesiredSlip rows, got "
                          f"{type(entries).__name__} {entries!r:.60}") from None
    if not entries:
        raise ConfigError("the desired-slip table has no entries")
    bad = [f"entries[{i}] {type(e).__name__} {e!r:.40}" for i, e in enumerate(entries)
           if not isinstance(e, DesiredSlip)]
    if bad:
        raise ConfigError(f"fallback_entry needs DesiredSlip rows, got {', '.join(bad[:3])}")
    # ties (many steady targets are 0) go to the first terrain name, so the source text does
    # not follow the order the classes were listed in
    lowest = (lambda key: min(entries, key=lambda e: (abs(getattr(e, key)),  # noqa: E731
                                                      e.terrain)))
    trac, brake, steady = lowest("traction"), lowest("braking"), lowest("steady")
    return DesiredSlip(
        terrain=FALLBACK_LABEL, traction=trac.traction, braking=brake.braking,
        steady=min(steady.steady, trac.traction),
        source=(f"most conservative entry of the table: traction from {trac.terrain}, braking "
                f"from {brake.terrain}, steady from {steady.terrain}"),
        method="fallback for unknown, low-confidence or stale terrain decisions")


@dataclass(frozen=True)
class SlipTable:
    """Desired-slip table over the classifier's classes, with its fallback.

    Parameters
    ----------
    entries : Mapping[str, DesiredSlip]
        Class label -> targets (kept as a read-only copy of the mapping given).
    fallback : DesiredSlip
        Conservative targets (:func:`fallback_entry`).
    config : DesiredSlipConfig
        The rules' settings and the fallback thresholds.

    Raises
    ------
    ConfigError
        ``entries`` not a mapping of :class:`DesiredSlip` rows, ``fallback`` not a
        :class:`DesiredSlip` or ``config`` not a :class:`DesiredSlipConfig` (named; None
        was taken, and :func:`select_target` stopped on a bare TypeError).
    """

    entries: Mapping[str, DesiredSlip]
    fallback: DesiredSlip
    config: DesiredSlipConfig

    def __post_init__(self) -> None:
        # a read-only copy: the caller's dict stayed the entries, so changing it afterwards
        # changed the table (a class deleted there was served the fallback)
        if not isinstance(self.entries, Mapping) or not all(
                isinstance(e, DesiredSlip) for e in self.entries.values()):
            raise ConfigError(f"SlipTable.entries must map class labels to DesiredSlip rows, "
                              f"got {type(self.entries).__name__} {self.entries!r:.60}")
        for name, kind in (("fallback", DesiredSlip), ("config", DesiredSlipConfig)):
            if not isinstance(getattr(self, name), kind):
                raise ConfigError(f"SlipTable.{name} must be a {kind.__name__}, got "
                                  f"{type(getattr(self, name)).__name__} "
                                  f"{getattr(self, name)!r:.60}")
        object.__setattr__(self, "entries", MappingProxyType(dict(self.entries)))

    def __reduce__(self):
        """Copy and pickle through a plain dict of the entries (a mappingproxy does
        neither: copy.deepcopy and pickle failed with a TypeError)."""
        return type(self), (dict(self.entries), self.fallback, self.config)

    def frame(self) -> pd.DataFrame:
        """The table as a frame with :data:`TABLE_COLUMNS` (fallback last).

        Returns
        -------
        pandas.DataFrame
        """
        rows = [*self.entries.values(), self.fallback]
        return pd.DataFrame([(e.terrain, e.traction, e.braking, e.steady, e.source, e.method)
                             for e in rows], columns=list(TABLE_COLUMNS))


def build_slip_table(classes: Sequence[str],
                     config: DesiredSlipConfig = DesiredSlipConfig()) -> SlipTable:
    """Compute the desired-slip table for the given classes from the terrain catalogue.

    Parameters
    ----------
    classes : sequence of str
        Class labels (see :func:`classifier_classes`), each in the catalogue.
    config : DesiredSlipConfig

    Returns
    -------
    SlipTable

    Raises
    ------
    ConfigError
        A class missing from the catalogue (the message lists the valid ones),
        ``classes`` one class name (text) instead of a sequence of them or not a collection
        (None, a number), or ``config`` not a
        :class:`DesiredSlipConfig` (:func:`desired_slip`).
    """
    classes = _class_list(classes, "build_slip_table")
    missing = [c for c in classes if str(c).upper() not in TERRAIN_NAMES]
    if missing:
        raise ConfigError(f"no desired slip for class(es) {missing}: a target comes from the "
                          "class's traction-slip curve in the terrain catalogue, which has "
                          f"{', '.join(TERRAIN_NAMES)} (a model must be trained on catalogue "
                          "classes to give slip targets)")
    entries = {c.upper(): desired_slip(get_terrain(c), config) for c in classes}
    return SlipTable(MappingProxyType(entries), fallback_entry(list(entries.values())), config)


def check_table(table, owner: str) -> None:
    """Refuse a desired-slip table that is not a :class:`SlipTable`.

    Parameters
    ----------
    table : object
        The table given.
    owner : str
        Who reads it, for the message (``"select_target"``, ``"TractionLoop"``).

    Raises
    ------
    ConfigError
        ``table`` not a :class:`SlipTable`: its printed frame (:meth:`SlipTable.frame`), its
        ``entries`` mapping or None stopped on a bare AttributeError.
    """
    if not isinstance(table, SlipTable):
        raise ConfigError(f"{owner} needs the desired-slip table as a SlipTable "
                          f"(build_slip_table(classes)), got {type(table).__name__} "
                          f"{table!r:.60}")


def select_target(table: SlipTable, terrain: str | None, confidence: float = 1.0,
                  decision_age_s: float = 0.0) -> DesiredSlip:
    """Targets for a classifier decision, or the fallback when it cannot be trusted.

    Parameters
    ----------
    table : SlipTable
    terrain : str or None
        Decided class (case-insensitive); None or a class not in the table -> fallback.
    confidence : float or None
        Probability of the decided class, in [0, 1]; below ``table.config.min_confidence``,
        above 1 (a percentage: 45 would have passed a 0.5 threshold; up to
        ``CONFIDENCE_ROUNDING`` above 1 is rounding and trusted), non-finite or None (a
        decision without one) -> fallback.
    decision_age_s : float or None
        Time since the decision, s; above ``table.config.max_decision_age_s``, negative (a
        decision stamped after the time it is used at: clocks that disagree), non-finite or
        None -> fallback (:func:`terrain.control.traction.age_is_fresh`, the rule of the traction
        step's input age too).

    Returns
    -------
    DesiredSlip

    Raises
    ------
    ConfigError
        ``table`` not a :class:`SlipTable` (:func:`check_table`); ``confidence`` or
        ``decision_age_s`` not a real number or None (text, a bool); ``terrain`` neither
        text nor None (bytes ``b"ICE"``, an array, a number: read as ``"B'ICE'"`` and
        given the fallback unsaid).
    """
    check_table(table, "select_target")
    # True passed as a confidence of 1, text failed inside numpy's isfinite
    config_numbers("select_target", optional=("confidence", "decision_age_s"),
                   confidence=confidence, decision_age_s=decision_age_s)
    if terrain is not None and not isinstance(terrain, str):
        raise ConfigError(f"select_target: terrain must be a class label (text) or None, got "
                          f"{type(terrain).__name__} {terrain!r:.60}")
    cfg = table.config
    key = None if terrain is None else str(terrain).upper()
    trusted = (key in table.entries and confidence_is_trusted(confidence, cfg.min_confidence)
               and age_is_fresh(decision_age_s, cfg.max_decision_age_s))
    return table.entries[key] if trusted else table.fallback
