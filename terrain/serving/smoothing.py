"""Temporal smoothing of per-window class probabilities: HMM forward filter + hysteresis.

Forward filter (Rabiner, "A tutorial on hidden Markov models", Proc. IEEE 77(2) 1989,
eq. 20, the forward variable normalised at every step). The hidden state is the terrain
class; between two decisions (one hop apart) the robot stays on its terrain with
probability ``1 - p_switch`` and otherwise moves to any other class uniformly, with
``p_switch = min(hop_s / dwell_s, (K - 1) / K)`` (a mean dwell time ``dwell_s`` on one
terrain; a dwell shorter than ``K / (K - 1)`` hops means no memory, a uniform prior). The
classifier's posterior ``q`` stands for the emission likelihood up to the class prior
(the SVM is trained class-balanced, so the prior is uniform); it is tempered by
``evidence_power`` because overlapping windows are not independent observations::

    prior_k   = (1 - p_switch) p_{k-1} + p_switch (1 - p_{k-1}) / (K - 1)
    p_k      ∝ prior_k * q_k ** evidence_power

The decided class then changes only when another class's filtered probability exceeds the
current one's by ``hysteresis`` (0 disables it), and only on a window taken as evidence (a
prediction step keeps the order of the probabilities, so it never opens that margin).

Optional switch reset (``reset_confidence``, off by default): when ``reset_windows``
consecutive valid windows all name the same class, other than the decided one, each with
probability ``>= reset_confidence``, the filter restarts from the last window's
probabilities (floored as above) and decides that class. It lets the filter follow a
terrain switch as fast as the raw windows once the new terrain is unambiguous
(measured in docs/streaming.md, "One-second windows": chosen inside the training runs it
did not help on unseen streams, so it stays off).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrain.errors import (ConfigError, DataFormatError, config_integer, config_numbers,
                            config_positive)

#: floor on classifier probabilities so one window can never veto a class for good
PROBA_FLOOR = 1e-4


@dataclass(frozen=True)
class SmoothingConfig:
    """Settings of the forward filter.

    Parameters
    ----------
    dwell_s : float or None
        Expected time on one terrain, s (finite, > 0); ``None`` disables the filter (each window's
        probabilities pass through unchanged; a window not classified gives the uniform
        distribution, no memory, as a dwell under ``K / (K - 1)`` hops does).
    evidence_power : float
        Exponent on the classifier probabilities, in (0, 1].
    hysteresis : float
        Margin of filtered probability a new class needs over the current one, in [0, 1).
    reset_confidence : float or None
        Window probability, in (0, 1], at or above which a window naming another class than
        the decided one counts towards a reset of the filter (module docstring); None (the
        default) disables the reset.
    reset_windows : int
        Consecutive such windows, naming the same class, that reset the filter (>= 1).

    Raises
    ------
    ConfigError
        A field that is not a real number (text, a boolean, a list; ``dwell_s`` and
        ``reset_confidence`` may be ``None``), outside its range, or ``reset_confidence``
        without ``dwell_s``.
    """

    dwell_s: float | None = 10.0
    evidence_power: float = 0.5
    hysteresis: float = 0.0
    reset_confidence: float | None = None
    reset_windows: int = 2

    def __post_init__(self) -> None:
        config_numbers("SmoothingConfig", ("reset_confidence", "dwell_s"),
                       dwell_s=self.dwell_s, evidence_power=self.evidence_power,
                       hysteresis=self.hysteresis, reset_confidence=self.reset_confidence)
        if self.dwell_s is not None and not (math.isfinite(self.dwell_s) and self.dwell_s > 0):
            # an infinite dwell would never leave the first terrain (p_switch = 0)
            raise ConfigError(f"dwell_s must be a finite number > 0 (or None for no "
                              f"smoothing), got {self.dwell_s}")
        if not 0 < self.evidence_power <= 1:
            raise ConfigError(f"evidence_power must be in (0, 1], got {self.evidence_power}")
        if not 0 <= self.hysteresis < 1:
            raise ConfigError(f"hysteresis must be in [0, 1), got {self.hysteresis}")
        if self.reset_confidence is not None:
            if not 0 < self.reset_confidence <= 1:
                raise ConfigError("reset_confidence must be in (0, 1] or None, got "
                                  f"{self.reset_confidence}")
            if self.dwell_s is None:
                raise ConfigError("reset_confidence resets the forward filter; it needs "
                                  "dwell_s (the filter on)")
        config_integer("reset_windows", self.reset_windows, 1)


def forward_step(p_prev: np.ndarray, q: np.ndarray | None, p_switch: float,
                 evidence_power: float) -> np.ndarray:
    """One step of the normalised forward recursion.

    Parameters
    ----------
    p_prev : numpy.ndarray
        ``(K,)`` filtered class probabilities of the previous step (sum 1).
    q : numpy.ndarray or None
        ``(K,)`` classifier probabilities of the new window; ``None`` (no valid window):
        prediction only, as for a ``q`` holding a NaN or inf (no evidence: folded in, it
        would make the probabilities NaN for every later step).
    p_switch : float
        Probability of leaving the current class within one step, in [0, 1].
    evidence_power : float
        Tempering exponent of ``q``.

    Returns
    -------
    numpy.ndarray
        ``(K,)`` filtered probabilities.
    """
    k = len(p_prev)
    prior = (1.0 - p_switch) * p_prev + p_switch * (1.0 - p_prev) / max(k - 1, 1)
    if q is None:
        return prior
    post = prior * np.maximum(q, PROBA_FLOOR) ** evidence_power
    total = float(post.sum())   # (one scalar check: a NaN or inf in q makes it non-finite)
    return post / total if math.isfinite(total) else prior


def predict_steps(p_prev: np.ndarray, n_steps: int, p_switch: float) -> np.ndarray:
    """``n_steps`` prediction-only steps of :func:`forward_step` (no window) in closed form.

    The prediction is affine and keeps the uniform distribution ``u = 1/K`` fixed:
    ``prior - u = lambda (p - u)`` with ``lambda = 1 - p_switch K / (K - 1)``, so after
    ``n`` steps ``p_n = u + lambda**n (p_0 - u)`` (for ``K = 1``, ``p`` stays as is). It costs
    the same for a million steps as for one (a service skipping a long silent stretch).

    Parameters
    ----------
    p_prev : numpy.ndarray
        ``(K,)`` filtered class probabilities (sum 1).
    n_steps : int
        Steps without a window, >= 0.
    p_switch : float
        Probability of leaving the current class within one step, in [0, 1].

    Returns
    -------
    numpy.ndarray
        ``(K,)`` probabilities after the steps.
    """
    p = np.asarray(p_prev, dtype=float)
    k = len(p)
    if k < 2 or n_steps <= 0:
        return p.copy()
    lam = 1.0 - p_switch * k / (k - 1)
    u = 1.0 / k
    return u + lam ** int(n_steps) * (p - u)


class ForwardFilter:
    """Streaming forward filter with hysteresis on the decided class.

    Parameters
    ----------
    n_classes : int
        Number of terrain classes K.
    hop_s : float
        Time between decisions, s.
    config : SmoothingConfig

    Raises
    ------
    ConfigError
        ``n_classes`` not an integer >= 1, ``hop_s`` not a finite number > 0 (a hop of 0
        never leaves the first class, a negative one gives negative probabilities), or
        ``config`` not a :class:`SmoothingConfig`.

    Attributes
    ----------
    evidence : bool
        Whether the last :meth:`update` took its window as evidence (false for ``None``
        and for probabilities holding a NaN or inf; false before any update).
    """

    def __init__(self, n_classes: int, hop_s: float, config: SmoothingConfig) -> None:
        config_integer("n_classes", n_classes, 1)
        config_positive("ForwardFilter", hop_s=hop_s)
        if not isinstance(config, SmoothingConfig):
            raise ConfigError("ForwardFilter config must be a SmoothingConfig, got "
                              f"{type(config).__name__}")
        self.config = config
        # a dwell under K/(K-1) hops is no memory (a uniform prior), not a push away from
        # the last terrain (lam of predict_steps would turn negative)
        self.p_switch = 1.0 if config.dwell_s is None else min(
            (n_classes - 1) / n_classes, hop_s / config.dwell_s)
        self.p = np.full(n_classes, 1.0 / n_classes)
        self.current: int | None = None
        self._streak = 0
        self._last_top: int | None = None
        self.evidence = False

    def update(self, q: np.ndarray | None) -> tuple[int | None, np.ndarray]:
        """Fold in one window's probabilities.

        Parameters
        ----------
        q : numpy.ndarray or None
            ``(K,)`` classifier probabilities; ``None`` when the window was invalid. A ``q``
            with a NaN or infinite entry is no evidence either (taken as ``None``, with or
            without the filter; :attr:`evidence` says so): folded in, it would make ``p``
            NaN for every later step.

        Returns
        -------
        decided : int or None
            Index of the decided class (``None`` before the first window taken as
            evidence); a window that is no evidence keeps it.
        p : numpy.ndarray
            ``(K,)`` filtered probabilities (a copy); without the filter, ``q``, or the
            uniform distribution when ``q`` is ``None``.

        Raises
        ------
        DataFormatError
            ``q`` not of shape ``(K,)`` (a ``(1, K)`` row broadcast into a 2-D ``p``, a
            scalar into a decided class 0) or not real numbers (booleans: a mask read as
            certainty; text); nothing is folded in.
        """
        if q is not None:
            q = np.asarray(q)
            if q.shape != self.p.shape:
                raise DataFormatError(f"ForwardFilter.update: q must be the {self.p.shape} "
                                      f"probabilities of the filter's {len(self.p)} classes, "
                                      f"got shape {q.shape}")
            if q.dtype.kind not in "fiu":
                raise DataFormatError("ForwardFilter.update: q must be real numbers "
                                      f"(probabilities), got dtype {q.dtype}")
        # the one finiteness test of a window's probabilities (the service reads evidence)
        if q is not None and not np.isfinite(q).all():
            q = None
        self.evidence = q is not None
        if self.config.dwell_s is None:
            # no memory: an invalid window is no evidence (the last window's probabilities
            # kept would be reported as the current ones)
            self.p = np.full(len(self.p), 1.0 / len(self.p)) if q is None \
                else np.asarray(q, dtype=float).copy()
        else:
            self.p = forward_step(self.p, q, self.p_switch, self.config.evidence_power)
        if q is None:
            # no evidence keeps the decided class: the prediction step only shrinks the
            # differences of the probabilities (by lam >= 0, predict_steps), so it cannot
            # open a margin; on floats near the uniform distribution its rounding put another
            # class 1 ulp ahead, and n update(None) decided otherwise than skip(n)
            return self.current, self.p.copy()
        best = int(np.argmax(self.p))
        if self.current is None or \
                self.p[best] > self.p[self.current] + self.config.hysteresis:
            self.current = best
        if q is not None and self.config.reset_confidence is not None:
            self._reset_on_switch(np.asarray(q, dtype=float))
        return self.current, self.p.copy()

    def skip(self, n_steps: int) -> None:
        """Advance by ``n_steps`` hops without a window (:func:`predict_steps`), as that many
        ``update(None)`` calls would move ``p``; the decided class is then re-checked once
        against the hysteresis margin.

        Parameters
        ----------
        n_steps : int
            Hops skipped, >= 0.
        """
        if n_steps <= 0:
            return
        if self.config.dwell_s is None:   # no memory: the uniform distribution, as update(None)
            self.p = np.full(len(self.p), 1.0 / len(self.p))
            return
        self.p = predict_steps(self.p, n_steps, self.p_switch)
        if self.current is not None:
            best = int(np.argmax(self.p))
            if self.p[best] > self.p[self.current] + self.config.hysteresis:
                self.current = best

    def _reset_on_switch(self, q: np.ndarray) -> None:
        """Count confident windows naming another class; restart from ``q`` after enough."""
        top = int(np.argmax(q))
        confident = (q[top] >= self.config.reset_confidence and self.current is not None
                     and top != self.current)
        self._streak = (self._streak + 1 if top == self._last_top else 1) if confident else 0
        self._last_top = top
        if self._streak >= self.config.reset_windows:
            floored = np.maximum(q, PROBA_FLOOR)
            self.p = floored / floored.sum()
            self.current = top
            self._streak = 0
