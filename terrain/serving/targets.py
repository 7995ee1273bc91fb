"""Target slip per decision: the injected desired-slip lookup and a catalogue-based one.

The service asks a :class:`TargetProvider` for the slip targets of each decision.
:class:`TableTargets` is the production provider: the project's desired-slip table
(:mod:`terrain.control.desired_slip`). :class:`CataloguePeakTargets` derives simpler targets
straight from the peaks of the catalogue's traction-slip curves
(:mod:`terrain.terramechanics`); the tests use it as an independent provider.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping, Protocol, Sequence

from terrain.control import DesiredSlipConfig, build_slip_table, select_target
from terrain.control.desired_slip import confidence_is_trusted
# the controller's record (signs and range checked), re-exported: one class for the targets
from terrain.control.traction import SlipTargets
from terrain.errors import ConfigError, config_probability
from terrain.terramechanics import get_terrain, steady_slip, traction_peak


class TargetProvider(Protocol):
    """Desired-slip lookup injected into the service.

    A provider may also expose ``classes`` (the terrain classes it holds targets for) and
    ``min_confidence`` (the confidence below which it returns its fallback);
    :class:`~terrain.serving.service.StreamService` then checks them against its model and
    its own threshold (:func:`check_provider`), since a decision the provider answers with
    its fallback for either reason would carry no flag saying so. Both providers here
    expose them.
    """

    def target_for(self, terrain: str | None, confidence: float, stale: bool) -> SlipTargets:
        """Targets for a decided terrain.

        Parameters
        ----------
        terrain : str or None
            Decided terrain class; ``None`` when the service has no trustworthy decision
            (low confidence or no valid window yet): the provider returns its conservative
            fallback.
        confidence : float
            Smoothed probability of ``terrain`` in [0, 1].
        stale : bool
            Whether the decision rests on stale or missing input.

        Returns
        -------
        SlipTargets or tuple of float
            Traction, braking and steady slip targets (SAE slip, dimensionless):
            :class:`terrain.control.traction.SlipTargets` (checked signs), or any triple the
            service can unpack as ``traction, braking, steady``.
        """
        ...  # pragma: no cover


class CataloguePeakTargets:
    """Targets from the catalogue's traction-slip curves.

    ``traction`` is the slip at the peak of the terrain's curve
    (:func:`terrain.terramechanics.traction_peak`), ``braking`` its mirror image (the curves
    are taken as symmetric in braking), ``steady`` the level-ground steady slip
    (:func:`terrain.terramechanics.steady_slip`). The conservative fallback, used for
    ``terrain=None``, for a stale decision and below ``min_confidence``, is the smallest
    traction target over ``classes`` with its steady slip: the slip that is safe on the
    slipperiest terrain the model knows.

    Parameters
    ----------
    classes : sequence of str
        Terrain classes of the model (each must be in the catalogue; any case, kept in
        upper case as the desired-slip table keeps them).
    min_confidence : float
        Confidence below which the fallback is returned.

    Raises
    ------
    ConfigError
        A class unknown to the catalogue, ``classes`` not a sequence of text labels, or
        ``min_confidence`` not a number in [0, 1].
    """

    def __init__(self, classes: Sequence[str], min_confidence: float = 0.5) -> None:
        classes = _class_names(classes, "CataloguePeakTargets")
        # NaN is refused: it would never take the fallback
        config_probability("CataloguePeakTargets", min_confidence=min_confidence)
        table = {}
        for name in classes:
            params = get_terrain(name)
            peak = traction_peak(params.curve).slip
            # keyed in upper case, as check_provider and the desired-slip table read a
            # class: one built from 'snow' answered the model's 'SNOW' with the fallback
            table[name.upper()] = SlipTargets(peak, -peak, steady_slip(params))
        if not table:
            raise ConfigError("CataloguePeakTargets needs at least one class")
        self.table: Mapping[str, SlipTargets] = MappingProxyType(table)
        self.classes = tuple(table)
        self.fallback = min(table.values(), key=lambda s: s.traction)
        self.min_confidence = float(min_confidence)

    def __reduce__(self):
        """Copies and pickles rebuild the provider from its classes and threshold (its
        read-only ``table``, a mapping proxy, cannot be pickled: ``copy.deepcopy`` of a
        service using it raised TypeError)."""
        return type(self), (self.classes, self.min_confidence)

    def target_for(self, terrain: str | None, confidence: float, stale: bool) -> SlipTargets:
        """Targets of ``terrain``, or the fallback (see class docstring).

        Parameters
        ----------
        terrain : str or None
            Decided class (in any case).
        confidence : float
            Its smoothed probability; not trusted (the fallback) below ``min_confidence``,
            above 1 or not finite, as the table's rule
            (:func:`terrain.control.desired_slip.confidence_is_trusted`).
        stale : bool
            Stale input.

        Returns
        -------
        SlipTargets
        """
        key = None if terrain is None else str(terrain).upper()
        if key is None or stale or key not in self.table \
                or not confidence_is_trusted(confidence, self.min_confidence):
            return self.fallback
        return self.table[key]


class TableTargets:
    """Targets from the project's desired-slip table (:mod:`terrain.control.desired_slip`).

    The table's own fallback rule (:func:`terrain.control.select_target`) decides when its
    conservative entry is used: unknown class, confidence below the table's
    ``min_confidence``; a stale decision is passed as older than the table's
    ``max_decision_age_s``.

    Parameters
    ----------
    classes : sequence of str
        Terrain classes of the model.
    config : terrain.control.DesiredSlipConfig, optional
        Rules and fallback thresholds of the table (its defaults when omitted).

    Raises
    ------
    ConfigError
        A class missing from the terrain catalogue, ``classes`` not a sequence of text
        labels, or ``config`` not a DesiredSlipConfig.
    """

    def __init__(self, classes: Sequence[str], config=None) -> None:
        classes = _class_names(classes, "TableTargets")
        if config is not None and not isinstance(config, DesiredSlipConfig):
            raise ConfigError("TableTargets config must be a DesiredSlipConfig, got "
                              f"{type(config).__name__}")

        self.table = build_slip_table(classes, config or DesiredSlipConfig())
        self.classes = tuple(self.table.entries)
        self.min_confidence = float(self.table.config.min_confidence)
        fb = self.table.fallback
        self.fallback = SlipTargets(fb.traction, fb.braking, fb.steady)

    def __reduce__(self):
        """Copies and pickles rebuild the provider from its classes and the table's settings
        (the table's entries, a read-only mapping proxy, cannot be pickled:
        ``copy.deepcopy`` of a service using it raised TypeError)."""
        return type(self), (self.classes, self.table.config)

    def target_for(self, terrain: str | None, confidence: float, stale: bool) -> SlipTargets:
        """Targets of the table for a decision.

        Parameters
        ----------
        terrain : str or None
            Decided class (``None``: fallback).
        confidence : float
            Its smoothed probability.
        stale : bool
            Stale input (fallback).

        Returns
        -------
        SlipTargets
        """
        age = 2.0 * self.table.config.max_decision_age_s if stale else 0.0
        e = select_target(self.table, terrain, confidence, age)
        return SlipTargets(e.traction, e.braking, e.steady)


def check_provider(targets, classes: Sequence[str], min_confidence: float) -> None:
    """Refuse a provider that would answer a trusted decision with its fallback, unflagged.

    The service flags ``low_confidence`` below its own ``min_confidence`` and asks for the
    fallback there; a provider with a higher threshold of its own, or without targets for a
    class of the model, would return the fallback for decisions the service trusts, and
    nothing in the decision would say so. A provider without ``classes`` or
    ``min_confidence`` attributes is not checked on that point.

    Parameters
    ----------
    targets : TargetProvider
        The provider.
    classes : sequence of str
        Classes of the service's model.
    min_confidence : float
        The service's threshold, in [0, 1].

    Raises
    ------
    ConfigError
        The provider's ``min_confidence`` not a number in [0, 1] (NaN: every decision gets
        the fallback) or above the service's, or a model class missing from the provider's
        ``classes`` (each named; names compared in upper case, as the tables look them up).
    """
    floor = getattr(targets, "min_confidence", None)
    if floor is not None:
        owner = type(targets).__name__
        config_probability(owner, min_confidence=floor)
    if floor is not None and float(floor) > float(min_confidence):
        raise ConfigError(f"{type(targets).__name__}.min_confidence {float(floor):g} is above "
                          f"the service's min_confidence {float(min_confidence):g}: decisions "
                          "between the two would get the fallback targets without the "
                          "low_confidence flag; give both the same threshold")
    held = getattr(targets, "classes", None)
    if held is not None:
        # a table answers a class in any case (select_target upper-cases it, as the
        # catalogue names are): 'ice' was refused the table built from 'ice'
        known = {str(h).upper() for h in held}
        missing = [str(c) for c in classes if str(c).upper() not in known]
        if missing:
            raise ConfigError(f"{type(targets).__name__} holds no targets for the model's "
                              f"class(es) {missing} (it has {[str(c) for c in held]}): their "
                              "decisions would get the fallback targets without a flag")


def _class_names(classes, owner: str) -> tuple[str, ...]:
    """``classes`` as a tuple of text labels, or a :class:`ConfigError` naming ``owner``."""
    if isinstance(classes, (str, bytes)) or not hasattr(classes, "__iter__"):
        raise ConfigError(f"{owner} needs a sequence of class names, got "
                          f"{type(classes).__name__} {classes!r:.60}")
    classes = tuple(classes)
    if not all(isinstance(c, str) for c in classes):
        raise ConfigError(f"{owner} class names must be text, got {classes!r:.80}")
    return classes
