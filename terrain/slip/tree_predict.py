"""Compiled prediction of the learned slip model's gradient-boosted trees.

Re-exports :func:`terrain.tree_predict.pack_trees` and
:func:`terrain.tree_predict.predict_packed` (the adaptors for fitted tree ensembles live in
one module, :mod:`terrain.tree_predict`, next to the classifier-forest one the streaming
service uses).
"""

from terrain.tree_predict import PACKED_KEYS, pack_trees, predict_packed

__all__ = ["PACKED_KEYS", "pack_trees", "predict_packed"]
