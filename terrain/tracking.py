"""MLflow conventions: the only module of the library that imports :mod:`mlflow`
(besides :mod:`terrain.serving`).

* Embedded default store: when ``MLFLOW_TRACKING_URI`` is unset, runs go to
  ``sqlite:///<cwd>/mlflow.db`` and artifacts to ``<cwd>/mlartifacts``. A remote server is
  one environment variable away (``MLFLOW_TRACKING_URI=http://host:5000``).
* One experiment per pipeline (``terrain-cv``, ``terrain-train``, ``terrain-benchmark``...).
* Every run is tagged and parametrised with the code version (git commit when the code is
  in a git checkout, else the package version).
"""

from __future__ import annotations

import os
import subprocess
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Mapping

import pandas as pd

import terrain

DB_FILE = "mlflow.db"
ARTIFACT_DIR = "mlartifacts"


def tracking_uri() -> str:
    """The tracking URI in force: ``MLFLOW_TRACKING_URI`` or the embedded sqlite store."""
    uri = os.environ.get("MLFLOW_TRACKING_URI")
    if uri:
        return uri
    return f"sqlite:///{Path.cwd() / DB_FILE}"


def activate_store() -> tuple[str, bool]:
    """Point MLflow at the store in force; returns ``(uri, embedded)``.

    MLflow's ``set_tracking_uri`` also exports ``MLFLOW_TRACKING_URI``; for the embedded
    store the variable is removed again, so a later call (another working directory, e.g. in
    tests) still resolves the embedded store afresh and the user's environment is unchanged.
    """
    import mlflow

    embedded = not os.environ.get("MLFLOW_TRACKING_URI")
    uri = tracking_uri()
    mlflow.set_tracking_uri(uri)
    if embedded:
        os.environ.pop("MLFLOW_TRACKING_URI", None)
    return uri, embedded


def code_version() -> str:
    """Git commit of the source tree (with ``-dirty`` when modified), else the version."""
    here = Path(__file__).resolve().parent
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True,
                             text=True, timeout=5, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=here, capture_output=True, text=True, timeout=5).stdout.strip()
        return sha + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return f"terrain-{terrain.__version__}"


def _experiment_id(mlflow: Any, name: str, embedded: bool) -> str:
    exp = mlflow.get_experiment_by_name(name)
    if exp is not None:
        return exp.experiment_id
    kwargs = {}
    if embedded:
        kwargs["artifact_location"] = (Path.cwd() / ARTIFACT_DIR / name).as_uri()
    return mlflow.create_experiment(name, **kwargs)


@dataclass
class TrackedRun:
    """Handle on an active MLflow run; thin typed wrappers over the MLflow logging API."""

    run_id: str
    experiment: str
    uri: str

    def log_params(self, params: Mapping[str, Any]) -> None:
        """Log parameters (values are stringified by MLflow)."""
        import mlflow
        mlflow.log_params({k: v for k, v in params.items()})

    def log_metrics(self, metrics: Mapping[str, float], step: int | None = None) -> None:
        """Log numeric metrics; non-finite values are skipped and listed in a tag."""
        import math

        import mlflow
        good = {k: float(v) for k, v in metrics.items() if math.isfinite(float(v))}
        bad = sorted(set(metrics) - set(good))
        mlflow.log_metrics(good, step=step)
        if bad:
            mlflow.set_tag("non_finite_metrics", ",".join(bad))

    def log_table(self, frame: pd.DataFrame, name: str) -> None:
        """Log a DataFrame as a CSV artifact ``name`` (e.g. ``predictions.csv``)."""
        import mlflow
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / name
            frame.to_csv(path, index=False)
            mlflow.log_artifact(str(path))

    def log_figure(self, figure: Any, name: str) -> None:
        """Log a matplotlib figure as an image artifact ``name`` (e.g. ``confusion.png``)."""
        import mlflow
        mlflow.log_figure(figure, name)

    def log_dict(self, data: Mapping[str, Any], name: str) -> None:
        """Log a JSON-serialisable mapping as artifact ``name``."""
        import mlflow
        mlflow.log_dict(dict(data), name)

    def log_text(self, text: str, name: str) -> None:
        """Log text (e.g. a Markdown report) as artifact ``name``."""
        import mlflow
        mlflow.log_text(text, name)

    def log_artifact(self, path: str | Path, folder: str | None = None) -> None:
        """Log a local file or directory as artifact(s)."""
        import mlflow
        p = Path(path)
        if p.is_dir():
            mlflow.log_artifacts(str(p), artifact_path=folder)
        else:
            mlflow.log_artifact(str(p), artifact_path=folder)

    def log_sklearn_model(self, model: Any, name: str, input_example: pd.DataFrame,
                          registered_name: str | None = None,
                          trusted_types: tuple[str, ...] = ()) -> str:
        """Log (and register) a fitted scikit-learn estimator; returns its model URI.

        Parameters
        ----------
        model : sklearn estimator
            Fitted estimator (``predict`` on a feature table).
        name : str
            Artifact name of the model in the run.
        input_example : pandas.DataFrame
            A few feature rows (sets the model signature).
        registered_name : str, optional
            Model registry name (None: log without registering).
        trusted_types : tuple of str
            Classes the skops serialiser must accept (the project's own estimator and
            scikit-learn internals it contains; reviewed by the caller).

        Returns
        -------
        str
            ``models:/...`` URI.
        """
        import mlflow.sklearn
        from mlflow.models import infer_signature

        signature = infer_signature(input_example, model.predict(input_example))
        info = mlflow.sklearn.log_model(model, name=name, signature=signature,
                                        registered_model_name=registered_name,
                                        skops_trusted_types=list(trusted_types) or None)
        return info.model_uri

    def describe(self) -> str:
        """One line telling where the run is."""
        return (f"MLflow run {self.run_id} in experiment '{self.experiment}' at {self.uri} "
                f"(browse: mlflow ui --backend-store-uri {self.uri})")


@contextmanager
def tracked_run(experiment: str, run_name: str | None = None,
                params: Mapping[str, Any] | None = None,
                tags: Mapping[str, str] | None = None,
                announce: bool = True) -> Iterator[TrackedRun]:
    """Open an MLflow run in ``experiment`` on the store in force.

    Parameters
    ----------
    experiment : str
        Experiment name, one per pipeline (``terrain-cv``...).
    run_name : str, optional
        Human-readable run name.
    params : Mapping, optional
        Parameters logged at start.
    tags : Mapping, optional
        Extra tags.
    announce : bool
        Print where the run is (stdout) when it starts.

    Yields
    ------
    TrackedRun
    """
    import mlflow

    uri, embedded = activate_store()
    exp_id = _experiment_id(mlflow, experiment, embedded)
    version = code_version()
    with mlflow.start_run(experiment_id=exp_id, run_name=run_name) as active:
        mlflow.set_tags({"code_version": version, **(tags or {})})
        handle = TrackedRun(active.info.run_id, experiment, uri)
        handle.log_params({"code_version": version, **(params or {})})
        if announce:
            print(handle.describe(), flush=True)
        yield handle
