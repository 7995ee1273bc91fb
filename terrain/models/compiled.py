"""A scikit-learn ``Pipeline`` whose final classifier is scored by a fast path.

One window through scikit-learn costs milliseconds of per-call checks and per-tree Python
loops while the arithmetic takes microseconds. :class:`CompiledPipeline` is a
:class:`sklearn.pipeline.Pipeline` in every respect (parameters, fitting, cloning, pickling)
whose ``predict_proba`` and ``predict`` run the transform steps and then hand the fitted final
step's arrays to a NumPy or compiled function that returns the *same* probabilities.
Subclasses say which arrays (``_compiled``) and which function (``_compiled_proba``):
:class:`terrain.models.svm.SVMPipeline` (calibrated RBF SVC in NumPy) and
:class:`terrain.models.forest.ForestPipeline` (tree forests walked in one compiled loop).
Where no fast path applies (another final step, routed ``**params``) scikit-learn's own path
runs.
"""

from __future__ import annotations

import numpy as np
from sklearn.pipeline import Pipeline


class CompiledPipeline(Pipeline):
    """``Pipeline`` with a fast ``predict_proba`` for its fitted final step (base class).

    Parameters
    ----------
    steps : list of (str, estimator)
        As for ``Pipeline``.
    memory : None
        As for ``Pipeline``.
    transform_input : None
        As for ``Pipeline``.
    verbose : bool
        As for ``Pipeline``.
    """

    def _compiled(self):
        """Arrays of the fast path for the current final step, or ``None`` (scikit-learn's
        path). Subclasses implement it."""
        return None

    def _compiled_proba(self, compiled, Xt) -> np.ndarray:
        """Probabilities of the final step from its arrays and the transformed input."""
        raise NotImplementedError

    def _transform_head(self, X):
        """Run every step but the last (``Pipeline``'s transform chain)."""
        Xt = X
        for _, step in self.steps[:-1]:
            if step is not None and step != "passthrough":
                Xt = step.transform(Xt)
        return Xt

    def predict_proba(self, X, **params) -> np.ndarray:
        """Class probabilities (fast path when it applies, see the class docstring).

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` input of the first step (raw windows).
        **params : dict
            Routed as by ``Pipeline.predict_proba`` (forces scikit-learn's path).

        Returns
        -------
        numpy.ndarray
            ``(n_windows, n_classes)``, columns in the order of ``classes_``.
        """
        compiled = self._compiled() if not params else None
        if compiled is None:
            return super().predict_proba(X, **params)
        return self._compiled_proba(compiled, self._transform_head(X))

    def predict(self, X, **params) -> np.ndarray:
        """Most probable class of each window (``classes_[argmax(predict_proba)]``).

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` input of the first step (raw windows).
        **params : dict
            Routed as by ``Pipeline.predict`` (forces scikit-learn's path).

        Returns
        -------
        numpy.ndarray
            ``(n_windows,)`` labels.
        """
        if params or self._compiled() is None:
            return super().predict(X, **params)
        return self.classes_[self.predict_proba(X).argmax(axis=1)]
