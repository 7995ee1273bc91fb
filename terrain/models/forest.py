"""Tree-forest classifier pipeline whose single-window ``predict_proba`` is compiled.

scikit-learn's ``ForestClassifier.predict_proba`` calls every tree from Python, so one
window through the wheel-only streaming model (300 extremely randomised trees) costs
~10-50 ms. :class:`ForestPipeline` is a :class:`sklearn.pipeline.Pipeline` that, when its
final step is a fitted single-output random-forest / extra-trees classifier, runs the
transform steps as usual and the forest through :func:`terrain.tree_predict.forest_proba`
over the fitted trees' own node arrays (packed once, :func:`terrain.tree_predict.pack_forest`),
which returns the same probabilities (tested to 1e-12, in practice bit-identical, in
``tests/models/test_forest_predict.py``). Like :class:`terrain.models.svm.SVMPipeline` (the
NumPy path of the calibrated SVM), it is a :class:`terrain.models.compiled.CompiledPipeline`.
"""

from __future__ import annotations

import numpy as np
from sklearn.ensemble._forest import ForestClassifier

from terrain.errors import ConfigError
from terrain.models.compiled import CompiledPipeline
from terrain.tree_predict import forest_proba, pack_forest


class ForestPipeline(CompiledPipeline):
    """``features -> forest classifier`` pipeline with a compiled ``predict_proba``.

    A :class:`sklearn.pipeline.Pipeline` in every respect (parameters, fitting, cloning,
    pickling). ``predict_proba`` and ``predict`` of a pipeline whose final step is a fitted
    single-output ``ForestClassifier`` (``ExtraTreesClassifier``,
    ``RandomForestClassifier``) walk the packed trees in one compiled loop; the packed arrays
    are rebuilt whenever the final step was replaced or refitted. Any other final step uses
    scikit-learn's path.

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

    def fit(self, X, y=None, **params):
        """Fit every step (``Pipeline.fit``) and pack the fitted forest's trees.

        Parameters
        ----------
        X : array-like
            ``(n_windows, ...)`` input of the first step.
        y : array-like or None
            ``(n_windows,)`` labels.
        **params : dict
            Fit parameters, routed as by ``Pipeline.fit``.

        Returns
        -------
        ForestPipeline
            ``self``.
        """
        super().fit(X, y, **params)
        self.__dict__.pop("_packed_forest", None)
        self._compiled()
        return self

    def _compiled(self) -> dict | None:
        """Packed trees of the final step, or ``None`` (scikit-learn's path): the final step
        is not a fitted single-output forest classifier. Repacked when its trees are not
        those packed (a replaced or refitted step, a warm-start refit that added trees)."""
        final = self.steps[-1][1]
        trees = getattr(final, "estimators_", None)
        if not isinstance(final, ForestClassifier) or not trees:
            return None
        cached = self.__dict__.get("_packed_forest")
        # a warm-start refit appends trees to the same list: its length is part of the key
        if cached is None or cached[0] is not trees or cached[1] != len(trees):
            try:
                cached = (trees, len(trees), pack_forest(final))
            except ConfigError:
                cached = (trees, len(trees), None)
            self._packed_forest = cached
        return cached[2]

    def _compiled_proba(self, compiled: dict, Xt) -> np.ndarray:
        """:func:`terrain.tree_predict.forest_proba` of the transformed features."""
        return forest_proba(compiled, Xt)
