"""Output side of the streaming service: one decision, the decisions as a table, their flags.

:class:`Decision` is what :meth:`terrain.serving.service.StreamService.push` returns;
:func:`decisions_frame` writes decisions with the service's column names (``terrain
stream``, the served model); the flag helpers join the service's live flags with the
stuck-sensor flags a replay knows in hindsight (:func:`stuck_decision_flags`,
:func:`with_run_stuck_flags`, :func:`join_flags`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from terrain.errors import DataFormatError
from terrain.io.plausibility import stuck_window_flags


@dataclass(frozen=True)
class Decision:
    """One decision of the service.

    Parameters
    ----------
    t_s : float
        Decision time on the service clock, s.
    terrain : str or None
        Decided (smoothed) terrain; ``None`` before the first window taken as evidence.
    confidence : float
        Smoothed probability of ``terrain`` (0 when ``terrain`` is ``None``); a terrain
        decided below the service's ``min_confidence`` gets the provider's fallback
        targets (flag ``low_confidence``).
    proba : numpy.ndarray
        ``(n_classes,)`` smoothed class probabilities, in the model's class order.
    target_slip_traction, target_slip_braking, target_slip_steady : float
        Slip targets from the provider (dimensionless SAE slip).
    window_age_s : float
        ``t_s`` minus the end of the window the decision rests on (its last aligned sample
        plus one period), s; 0 when the window reaches ``t_s``, ``inf`` when no window
        could be aligned at all (flag ``short``).
    flags : str
        ``|``-separated flags (:mod:`terrain.serving.service`); empty when clean.
    """

    t_s: float
    terrain: str | None
    confidence: float
    proba: np.ndarray
    target_slip_traction: float
    target_slip_braking: float
    target_slip_steady: float
    window_age_s: float
    flags: str


def stuck_decision_flags(frame: pd.DataFrame, stuck: Mapping[str, list],
                         window_s: float) -> np.ndarray:
    """``stuck:<stream>.<channel>`` of each decision whose window holds a stuck stretch.

    The window of a decision is ``[t_s - window_age_s - window_s, t_s - window_age_s)``
    (a decision without a window has an infinite age and is never flagged), as
    ``terrain predict`` flags its windows (:func:`terrain.io.plausibility.stuck_window_flags`).

    Parameters
    ----------
    frame : pandas.DataFrame
        :func:`decisions_frame` (``t_s``, ``window_age_s``; s).
    stuck : Mapping[str, list]
        ``Run.meta["stuck"]`` of the replayed run.
    window_s : float
        Window length of the model, s.

    Returns
    -------
    numpy.ndarray
        ``(n_decisions,)`` strings, ``""`` where no stuck stretch is in the window.
    """
    end = frame["t_s"].to_numpy(dtype=float) - frame["window_age_s"].to_numpy(dtype=float)
    return stuck_window_flags(stuck, end - window_s, end)


def with_run_stuck_flags(frame: pd.DataFrame, stuck: Mapping[str, list], window_s: float,
                         *extra: Sequence[str]) -> tuple[list[str], int]:
    """The decisions' flags with the service's live ``stuck:`` flag replaced by the run's.

    A replay of a whole run knows a stuck stretch in hindsight from its first sample
    (:func:`stuck_decision_flags`), where the live rule knows it only once the stretch has
    lasted its limit; so the live flag is dropped and the run's is joined in
    (:func:`join_flags`), with any further flag columns.

    Parameters
    ----------
    frame : pandas.DataFrame
        :func:`decisions_frame` (``t_s``, ``window_age_s`` in s, ``flags``).
    stuck : Mapping[str, list]
        ``Run.meta["stuck"]`` of the replayed run.
    window_s : float
        Window length of the model, s.
    *extra : sequence of str
        More ``(n_decisions,)`` flag columns to join; ``""`` is no flag.

    Returns
    -------
    flags : list of str
        ``(n_decisions,)`` joined flags.
    n_stuck : int
        Decisions whose window holds a stuck stretch.
    """
    run_stuck = stuck_decision_flags(frame, stuck, window_s)
    live = ["|".join(f for f in _flag_list(cell) if not f.startswith("stuck:"))
            for cell in frame["flags"]]
    return join_flags(live, run_stuck, *extra), int((run_stuck != "").sum())


def join_flags(*columns: Sequence[str]) -> list[str]:
    """Per decision, the union of several ``|``-separated flag strings, sorted as the
    service writes its own flags.

    Parameters
    ----------
    *columns : sequence of str
        Equal-length flag columns (e.g. ``decisions_frame(...)["flags"]`` and
        :func:`stuck_decision_flags`); ``""`` is no flag, and so is a missing cell (None or
        NaN, as pandas reads an empty CSV cell), never a flag ``"nan"``.

    Returns
    -------
    list of str
        ``(n_decisions,)`` joined flags.

    Raises
    ------
    DataFormatError
        Columns of different lengths (named): ``zip`` would drop the last decisions.
    """
    lengths = [len(col) for col in columns]
    if len(set(lengths)) > 1:
        raise DataFormatError("join_flags needs one flag per decision in every column, got "
                              f"columns of lengths {', '.join(map(str, lengths))}")
    return ["|".join(sorted({f for cell in cells for f in _flag_list(cell)}))
            for cells in zip(*columns)]


def _flag_list(cell) -> list[str]:
    """The flags of one ``|``-separated cell; a missing cell (None, NaN) holds none."""
    if cell is None or (isinstance(cell, float) and cell != cell):
        return []
    return [f for f in str(cell).split("|") if f]


def decisions_frame(decisions: Sequence[Decision], classes: Sequence[str]) -> pd.DataFrame:
    """Decisions as a table with the service's column names.

    Parameters
    ----------
    decisions : sequence of Decision
    classes : sequence of str
        Class order of ``Decision.proba``.

    Returns
    -------
    pandas.DataFrame
        ``t_s, terrain, confidence, proba_<CLASS>..., target_slip_traction,
        target_slip_braking, target_slip_steady, window_age_s, flags``.

    Raises
    ------
    DataFormatError
        A decision whose ``proba`` does not hold one probability per class (named).
    """
    for i, d in enumerate(decisions):
        if np.size(d.proba) != len(classes):
            raise DataFormatError(f"decisions_frame: decision {i} (t_s {d.t_s}) holds "
                                  f"{np.size(d.proba)} probabilities for {len(classes)} "
                                  f"class(es) {list(classes)!r:.200}")
    cols = (["t_s", "terrain", "confidence"] + [f"proba_{c}" for c in classes]
            + ["target_slip_traction", "target_slip_braking", "target_slip_steady",
               "window_age_s", "flags"])
    rows = [[d.t_s, d.terrain, d.confidence, *d.proba, d.target_slip_traction,
             d.target_slip_braking, d.target_slip_steady, d.window_age_s, d.flags]
            for d in decisions]
    return pd.DataFrame(rows, columns=cols)
