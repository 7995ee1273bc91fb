"""Resolve the learned slip model for ``terrain estimate`` (MLflow model directory or the
registered ``slip-husky``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

#: Registered name of the learned slip model (``terrain slip-fit``).
REGISTERED_SLIP_MODEL = "slip-husky"


def resolve_slip_model(model_dir: Path | None) -> tuple[Any | None, str]:
    """Load the learned slip model.

    Parameters
    ----------
    model_dir : Path or None
        MLflow model directory (``.../artifacts`` of a ``terrain slip-fit`` run) or a model
        URI; None: the latest version of :data:`REGISTERED_SLIP_MODEL` in the tracking store
        in force (:func:`terrain.tracking.tracking_uri`).

    Returns
    -------
    model : SlipRegressor or None
        None when it cannot be resolved.
    where : str
        Where it came from, or why it could not be loaded.
    """
    import mlflow
    import mlflow.sklearn

    from terrain.tracking import tracking_uri

    if model_dir is not None:
        uri = str(model_dir)
    else:
        uri = f"models:/{REGISTERED_SLIP_MODEL}/latest"
        store = tracking_uri()
        if store.startswith("sqlite:///") and not Path(store[len("sqlite:///"):]).exists():
            return None, f"no tracking store at {store}"     # do not create an empty one
        mlflow.set_tracking_uri(tracking_uri())
        mlflow.set_registry_uri(tracking_uri())
    try:
        return mlflow.sklearn.load_model(uri), uri
    except Exception as exc:        # noqa: BLE001 - any failure means "no learned model"
        return None, f"{uri} not loadable ({type(exc).__name__})"


__all__ = ["REGISTERED_SLIP_MODEL", "resolve_slip_model"]
