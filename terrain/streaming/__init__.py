"""Live terrain -> target-slip inference: the in-process streaming service.

Public API: :class:`StreamService`, :class:`StreamConfig`, :class:`Decision`,
:func:`decisions_frame`, :class:`StreamModel`, :func:`load_stream_model`,
:class:`SmoothingConfig`, :class:`TargetProvider`, :class:`TableTargets`,
:class:`CataloguePeakTargets`,
:func:`replay_run`.
"""

from terrain.streaming.model import StreamModel, load_stream_model
from terrain.streaming.replay import interleave, replay_run
from terrain.streaming.service import (Decision, StreamConfig, StreamService,
                                       decisions_frame)
from terrain.streaming.smoothing import SmoothingConfig
from terrain.streaming.targets import (CataloguePeakTargets, SlipTargets, TableTargets,
                                       TargetProvider)

__all__ = ["StreamModel", "load_stream_model", "interleave", "replay_run", "Decision",
           "StreamConfig", "StreamService", "decisions_frame", "SmoothingConfig",
           "CataloguePeakTargets", "SlipTargets", "TableTargets", "TargetProvider"]
