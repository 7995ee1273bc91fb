"""Serving: live terrain -> target-slip inference and the served MLflow models.

One responsibility per module:

* the in-process streaming service for the robot: :mod:`~terrain.serving.service`
  (:class:`StreamService`: windows, decisions), :mod:`~terrain.serving.config` (its settings,
  :class:`StreamConfig`), :mod:`~terrain.serving.intake` (what it keeps of each stream:
  buffers, rejection events, the clocks, applying the clock rules of
  :mod:`~terrain.serving.clocks`), :mod:`~terrain.serving.inputs`
  (a pushed chunk as checked arrays), :mod:`~terrain.serving.decisions` (a decision, the
  decisions table and its flags), :mod:`~terrain.serving.buffers` (bounded ring buffers),
  :mod:`~terrain.serving.rules` (per-sample plausibility rules),
  :mod:`~terrain.serving.smoothing` (forward filter and hysteresis),
  :mod:`~terrain.serving.targets` (slip-target providers), :mod:`~terrain.serving.model`
  (reading a trained model directory), :mod:`~terrain.serving.replay` (recorded runs as a
  live stream), :mod:`~terrain.serving.recipes` (how each streaming model is trained),
  :mod:`~terrain.serving.evaluation` (held-out streams, switching delay);
* MLflow pyfuncs: :mod:`~terrain.serving.pyfunc` (the inference pipeline of ``terrain
  train`` / ``terrain predict`` on aligned samples, entry
  :mod:`~terrain.serving.pyfunc_entry`) and :mod:`~terrain.serving.served` (the raw-stream
  service of ``terrain serve``, entry :mod:`~terrain.serving.served_entry`; its requests
  validated by :mod:`~terrain.serving.request`). They import MLflow, so they are not
  imported here: the robot's service loads without it.

Public API of the package: :class:`StreamService`, :class:`StreamConfig`, :class:`Decision`,
:func:`decisions_frame`, :class:`StreamModel`, :func:`load_stream_model`,
:class:`SmoothingConfig`, :class:`TargetProvider`, :class:`TableTargets`,
:class:`CataloguePeakTargets`,
:func:`replay_run`.
"""

from terrain.serving.model import StreamModel, load_stream_model
from terrain.serving.replay import interleave, replay_run
from terrain.serving.decisions import Decision, decisions_frame
from terrain.serving.service import StreamConfig, StreamService
from terrain.serving.smoothing import SmoothingConfig
from terrain.serving.targets import (CataloguePeakTargets, SlipTargets, TableTargets,
                                     TargetProvider)

__all__ = ["StreamModel", "load_stream_model", "interleave", "replay_run", "Decision",
           "StreamConfig", "StreamService", "decisions_frame", "SmoothingConfig",
           "CataloguePeakTargets", "SlipTargets", "TableTargets", "TargetProvider"]
