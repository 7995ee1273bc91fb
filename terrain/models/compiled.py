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
runs. A fitted ``StandardScaler`` among the transform steps is applied with its own arithmetic
but without scikit-learn's per-call input checks (:func:`scale_unchecked`).
"""

from __future__ import annotations

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler


def scale_unchecked(scaler: StandardScaler, X) -> np.ndarray | None:
    """``scaler.transform(X)`` without scikit-learn's input checks, or ``None``.

    The same arithmetic as ``StandardScaler.transform`` in scikit-learn 1.9 (a copy of ``X``,
    then in place ``X -= mean_`` and ``X /= scale_`` with both cast to the dtype of ``X``, so
    a float32 input stays float32 and rounds as it does there), for a fitted centring and
    scaling ``scaler`` and a finite dense float matrix of the fitted width. The checks cost
    more than the arithmetic on one window.

    Parameters
    ----------
    scaler : sklearn.preprocessing.StandardScaler
        The step (anything else gives ``None``).
    X : array-like
        ``(n_windows, n_features)`` features.

    Returns
    -------
    numpy.ndarray or None
        ``(n_windows, n_features)`` standardised features, same dtype as ``X``; ``None``
        when this shortcut does not apply (call ``scaler.transform``).
    """
    if not (isinstance(scaler, StandardScaler) and scaler.with_mean and scaler.with_std
            and getattr(scaler, "scale_", None) is not None and isinstance(X, np.ndarray)
            and X.ndim == 2 and X.dtype in (np.float32, np.float64)
            and X.shape[1] == scaler.n_features_in_
            and not hasattr(scaler, "feature_names_in_") and np.isfinite(X).all()):
        return None
    Xt = np.array(X, copy=True)
    Xt -= scaler.mean_.astype(Xt.dtype, copy=False)
    Xt /= scaler.scale_.astype(Xt.dtype, copy=False)
    return Xt


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
        """Run every step but the last (``Pipeline``'s transform chain; a standard scaler
        through :func:`scale_unchecked` where it applies)."""
        Xt = X
        for _, step in self.steps[:-1]:
            if step is None or step == "passthrough":
                continue
            scaled = scale_unchecked(step, Xt) if isinstance(step, StandardScaler) else None
            Xt = step.transform(Xt) if scaled is None else scaled
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
