"""The model a stream is classified with: fitted pipeline + channels + window + classes.

A model trained by ``terrain train`` is an MLflow model directory whose ``MLmodel`` file
carries the settings in its ``metadata`` (``channels``, ``classes``, ``window_s``,
``rate_hz``) and whose ``artifacts/pipeline.joblib`` is the fitted scikit-learn pipeline
(raw windows ``(n, n_channels, n_samples)`` in, ``predict_proba`` out). It is read here
directly, so the streaming service needs no MLflow server or pyfunc wrapper.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import yaml

from features.windows import DERIVED_WHEEL_CHANNELS, WindowConfig
from terrain.errors import ConfigError
from terrain.run import WHEEL_CHANNELS

PIPELINE_ARTIFACT = Path("artifacts") / "pipeline.joblib"


@dataclass(frozen=True)
class StreamModel:
    """A fitted window classifier and the settings it was trained with.

    Parameters
    ----------
    pipeline : object
        Fitted scikit-learn estimator with ``predict_proba`` and ``classes_`` taking windows
        ``(n_windows, n_channels, n_samples)``.
    channels : tuple of str
        Channel order of the windows (may include derived wheel channels).
    window : WindowConfig
        Window length and aligned clock rate of the training windows.
    classes : tuple of str
        Terrain classes, in the order of the decision's ``proba_<CLASS>`` columns.
    metadata : Mapping
        The model directory's whole ``metadata`` (``dataset``, ``vehicle``, ...), read-only;
        empty for a model built in memory. Not compared or hashed.
    """

    pipeline: Any
    channels: tuple[str, ...]
    window: WindowConfig
    classes: tuple[str, ...]
    metadata: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}),
                                        compare=False, hash=False)

    @property
    def raw_channels(self) -> tuple[str, ...]:
        """Measured channels the model needs (derived wheel channels need all four wheel
        channels, see :func:`features.windows.add_derived_channels`)."""
        raw = [c for c in self.channels if c not in DERIVED_WHEEL_CHANNELS]
        if any(c in DERIVED_WHEEL_CHANNELS for c in self.channels):
            raw += [c for c in WHEEL_CHANNELS if c not in raw]
        return tuple(raw)


def load_stream_model(path: str | Path) -> StreamModel:
    """Read a terrain model directory written by ``terrain train --model-out``.

    Parameters
    ----------
    path : str or Path
        MLflow model directory.

    Returns
    -------
    StreamModel
        With the directory's whole metadata in ``metadata``.

    Raises
    ------
    ConfigError
        Missing ``MLmodel`` or pipeline artifact, or metadata lacking the settings.
    """
    import joblib

    path = Path(path)
    mlmodel, pipe_file = path / "MLmodel", path / PIPELINE_ARTIFACT
    if not mlmodel.is_file() or not pipe_file.is_file():
        raise ConfigError(f"{path} is not a terrain model directory (needs MLmodel and "
                          f"{PIPELINE_ARTIFACT})")
    meta = (yaml.safe_load(mlmodel.read_text()) or {}).get("metadata") or {}
    missing = [k for k in ("channels", "classes", "window_s", "rate_hz") if k not in meta]
    if missing:
        raise ConfigError(f"{mlmodel}: metadata lacks {missing}")
    pipeline = joblib.load(pipe_file)
    return StreamModel(pipeline, tuple(meta["channels"]),
                       WindowConfig(window_s=float(meta["window_s"]),
                                    rate_hz=float(meta["rate_hz"])),
                       tuple(str(c) for c in meta["classes"]), MappingProxyType(dict(meta)))
