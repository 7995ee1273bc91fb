"""Resolve the learned slip model for ``terrain estimate`` (MLflow model directory or the
registered ``slip-husky``).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from terrain.errors import ConfigError

#: Registered name of the learned slip model (``terrain slip-fit``).
REGISTERED_SLIP_MODEL = "slip-husky"

#: a model URI (``models:/name/1``, ``runs:/id/model``, ``file:///...``), not a folder
_URI = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]+:/")   # 2+ letters: not a drive (C:/)


def load_slip_model_dir(model_dir: str | Path) -> Any:
    """Load the learned slip model the user named with ``--slip-model-dir``.

    A folder is checked first (it exists, is a folder, holds the ``MLmodel`` file that
    ``terrain slip-fit`` writes) so the message says what is missing; a model URI is handed
    to MLflow as it is.

    Parameters
    ----------
    model_dir : str or Path
        MLflow model folder or model URI (a URI as text: a ``Path`` drops a slash of its
        ``//``, ``s3:/bucket/...``).

    Returns
    -------
    SlipRegressor
        The loaded model.

    Raises
    ------
    ConfigError
        The folder does not exist, is not a folder, lacks ``MLmodel``, its ``MLmodel`` is
        not a YAML mapping (:func:`terrain.serving.model.read_mlmodel`), or the model cannot
        be loaded (the message names the folder and the reason).
    """
    where = f"--slip-model-dir {model_dir}"
    if not _URI.match(str(model_dir)):
        model_dir = Path(model_dir)
        if not model_dir.exists():
            raise ConfigError(f"{where}: no such folder")
        if not model_dir.is_dir():
            raise ConfigError(f"{where}: not a folder (an MLflow model folder holds an "
                              "MLmodel file)")
        if not (model_dir / "MLmodel").is_file():
            found = sorted(p.name for p in model_dir.iterdir())[:8]
            raise ConfigError(f"{where}: no MLmodel file, not an MLflow model folder (found: "
                              f"{', '.join(found) or 'nothing'}); give the artifacts folder "
                              "of a `terrain slip-fit` run")
        from terrain.serving.model import read_mlmodel

        read_mlmodel(model_dir / "MLmodel")   # not YAML / not a mapping: named, typed
    import mlflow.sklearn

    try:
        return mlflow.sklearn.load_model(str(model_dir))
    except Exception as exc:        # noqa: BLE001 - any failure: the model is unusable
        text = " ".join(str(exc).split())
        text = text if len(text) <= 200 else text[:197] + "..."
        raise ConfigError(f"{where}: the model cannot be loaded ({type(exc).__name__}"
                          f"{': ' + text if text else ''})") from None


def resolve_slip_model(model_dir: str | Path | None) -> tuple[Any | None, str]:
    """Load the learned slip model.

    Parameters
    ----------
    model_dir : str, Path or None
        MLflow model directory (``.../artifacts`` of a ``terrain slip-fit`` run) or a model
        URI the user named: it must load (:func:`load_slip_model_dir`). None: the latest
        version of :data:`REGISTERED_SLIP_MODEL` in the tracking store in force
        (:func:`terrain.tracking.tracking_uri`), if there is one.

    Returns
    -------
    model : SlipRegressor or None
        None when the registered model cannot be resolved.
    where : str
        Where it came from, or why the registered model could not be loaded.

    Raises
    ------
    ConfigError
        ``model_dir`` given but not loadable (:func:`load_slip_model_dir`).
    """
    import mlflow
    import mlflow.sklearn

    from terrain.tracking import check_store, sqlite_database, tracking_uri

    if model_dir is not None:
        return load_slip_model_dir(model_dir), str(model_dir)
    uri = f"models:/{REGISTERED_SLIP_MODEL}/latest"
    store = tracking_uri()
    database = sqlite_database(store)
    if database is not None and not database.exists():
        return None, f"no tracking store at {store}"     # do not create an empty one
    try:        # an unreachable server: at once, not after MLflow's minutes of retries
        check_store(store)
    except ConfigError as exc:
        return None, f"tracking store not usable: {str(exc).split('; ')[0]}"
    # an explicit client on this store: setting MLflow's process-wide tracking and registry
    # URIs here (set_registry_uri also writes MLFLOW_REGISTRY_URI into the environment)
    # pinned every later registry lookup of the process to this store
    from mlflow import MlflowClient
    from mlflow.artifacts import download_artifacts
    try:
        client = MlflowClient(tracking_uri=store, registry_uri=store)
        versions = client.search_model_versions(f"name='{REGISTERED_SLIP_MODEL}'")
        if not versions:
            return None, f"{uri} not registered in {store}"
        latest = max(versions, key=lambda v: int(v.version))
        source = client.get_model_version_download_uri(REGISTERED_SLIP_MODEL, latest.version)
        local = download_artifacts(artifact_uri=source, tracking_uri=store)
        return mlflow.sklearn.load_model(local), uri
    except Exception as exc:        # noqa: BLE001 - any failure means "no learned model"
        return None, f"{uri} not loadable ({type(exc).__name__})"


__all__ = ["REGISTERED_SLIP_MODEL", "load_slip_model_dir", "resolve_slip_model"]
