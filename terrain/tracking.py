"""MLflow conventions: the only module of the library that imports :mod:`mlflow`
(besides :mod:`terrain.serving`).

* Embedded default store: when ``MLFLOW_TRACKING_URI`` is unset, runs go to
  ``sqlite:///<cwd>/mlflow.db`` and artifacts to ``<cwd>/mlartifacts``. A remote server is
  one environment variable away (``MLFLOW_TRACKING_URI=http://host:5000``); any SQLite
  store keeps its artifacts beside its database (``<database folder>/mlartifacts``).
* One experiment per pipeline (``terrain-cv``, ``terrain-train``, ``terrain-benchmark``...).
* Every run is tagged and parametrised with the code version (git commit when the code is
  in a git checkout, else the package version).
* No process-wide side effects: :func:`tracked_run` passes the store and the artifact
  location to MLflow explicitly (an ``MlflowClient``) and never edits ``os.environ``; only
  an entry point may make the store MLflow's process-wide default (:func:`activate_store`,
  or for the length of a call, :func:`active_store`).
"""

from __future__ import annotations

import math
import os
import subprocess
import tempfile
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any, Iterator, Mapping

import pandas as pd

import terrain
from terrain.errors import ConfigError
from terrain.io.jsonfile import json_ready
from terrain.process_state import SharedSetting, restore_environment_variable

DB_FILE = "mlflow.db"
ARTIFACT_DIR = "mlartifacts"


def tracking_uri() -> str:
    """The tracking URI in force.

    Returns
    -------
    str
        ``MLFLOW_TRACKING_URI`` when set, else the embedded store
        ``sqlite:///<cwd>/mlflow.db``.
    """
    uri = os.environ.get("MLFLOW_TRACKING_URI")
    if uri:
        return uri
    return f"sqlite:///{Path.cwd() / DB_FILE}"


def store_errors() -> tuple[type[BaseException], ...]:
    """The exceptions a model or run store answers with when it cannot serve a request.

    MLflow's :class:`~mlflow.exceptions.MlflowException`, and the errors of the cloud SDK
    that reads a remote artifact store where that SDK is installed (botocore's
    ``BotoCoreError`` and ``ClientError`` for ``s3://`` artifacts, e.g. a ``models:/`` model
    read without AWS credentials). Commands report them as one line.

    Returns
    -------
    tuple of type
        Exception classes (empty where MLflow is not installed).
    """
    errors: list[type[BaseException]] = []
    try:
        from mlflow.exceptions import MlflowException
        errors.append(MlflowException)
    except ImportError:  # pragma: no cover - mlflow is a dependency
        pass
    try:
        from botocore.exceptions import BotoCoreError, ClientError
        errors += [BotoCoreError, ClientError]
    except ImportError:
        pass
    return tuple(errors)


#: Seconds a remote tracking server has to answer :func:`check_store`'s request.
STORE_CHECK_TIMEOUT_S = 5.0
#: Seconds :func:`store_lock` waits for another process that holds a SQLite store's lock
STORE_LOCK_TIMEOUT_S = 300.0


def sqlite_database(uri: str) -> Path | None:
    """The database file of a ``sqlite:///`` tracking URI, or None for any other store.

    Parameters
    ----------
    uri : str
        Tracking URI (:func:`tracking_uri`).

    Returns
    -------
    Path or None
        ``sqlite:///mlflow.db`` gives ``mlflow.db`` (relative), ``sqlite:////abs/mlflow.db``
        ``/abs/mlflow.db``; a query (``?timeout=30``, which SQLAlchemy passes to the driver)
        is not part of the file's name. None for another scheme or ``sqlite:///:memory:``.
    """
    if not uri.startswith("sqlite:///"):
        return None
    name = uri[len("sqlite:///"):].split("?", 1)[0]
    return None if name in ("", ":memory:") else Path(name)


def check_store(uri: str) -> None:
    """Refuse, in one line and at once, a tracking store MLflow could not use.

    MLflow itself retries a SQLite file it cannot open for about 100 s and then raises a
    database error, and retries an unreachable server for minutes. Checked here instead: a
    ``sqlite:///`` file must open and read as a SQLite database (its folder is created, as
    MLflow does), an ``http(s)://`` server must answer (any HTTP status) within
    :data:`STORE_CHECK_TIMEOUT_S`. Other schemes are left to MLflow.

    Parameters
    ----------
    uri : str
        Tracking URI (:func:`tracking_uri`).

    Raises
    ------
    ConfigError
        The SQLite file cannot be created or opened or is not a SQLite database, or the
        server does not answer; the message names the URI and says how to choose another
        store.
    """
    hint = ("set MLFLOW_TRACKING_URI to a store that can be used, or unset it for "
            "sqlite:///<current folder>/mlflow.db")
    scheme = uri.partition("://")[0]
    path = sqlite_database(uri)
    if path is not None:
        import sqlite3

        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            con = sqlite3.connect(path)
            try:
                # connect() opens lazily: a file that is not a database passes it; a read
                # of the header does not
                con.execute("PRAGMA schema_version").fetchone()
            finally:
                con.close()
        except (OSError, sqlite3.Error) as exc:
            raise ConfigError(f"MLflow tracking store {uri} cannot be opened: {exc}; "
                              f"{hint}") from None
    elif scheme in ("http", "https"):
        from urllib.error import HTTPError
        from urllib.request import urlopen

        try:
            urlopen(f"{uri.rstrip('/')}/health", timeout=STORE_CHECK_TIMEOUT_S).close()
        except HTTPError:
            pass                      # it answered: what it thinks of /health is MLflow's to say
        except (OSError, ValueError) as exc:
            reason = getattr(exc, "reason", None) or type(exc).__name__
            raise ConfigError(f"MLflow tracking server {uri} does not answer: {reason} "
                              f"(waited up to {STORE_CHECK_TIMEOUT_S:g} s); {hint}") from None


def activate_store() -> tuple[str, bool]:
    """For entry points only: make the store in force MLflow's process-wide default.

    MLflow's fluent API (``mlflow.pyfunc.load_model("models:/...")``, model logging) reads a
    process-wide tracking URI; setting it is a process-wide side effect, so only a program's
    entry point should call this. ``MLFLOW_TRACKING_URI`` is left as it was (MLflow would
    export the embedded store's URI, which names the current folder's database, to the rest
    of the process and its child processes). Nothing is changed when MLflow already resolves
    to the store in force, which is the case in a fresh process (MLflow's own default is the
    same ``sqlite:///<cwd>/mlflow.db`` and it reads the same environment variable), unless
    the folder holds an old ``./mlruns`` (MLflow's default is then that file store).
    :func:`tracked_run` does not need it.

    Returns
    -------
    uri : str
        The store in force (:func:`tracking_uri`).
    embedded : bool
        Whether it is the embedded store (``MLFLOW_TRACKING_URI`` unset).
    """
    import mlflow

    exported = os.environ.get("MLFLOW_TRACKING_URI")
    embedded = not exported
    uri = tracking_uri()
    if mlflow.get_tracking_uri() != uri:
        mlflow.set_tracking_uri(uri)
        # MLflow exports the URI; for the embedded store that named this folder's database
        # to whatever ran next in the process (a command run in-process in another folder
        # logged into this one's store, as if MLFLOW_TRACKING_URI named it)
        if exported is None:
            os.environ.pop("MLFLOW_TRACKING_URI", None)
        else:
            os.environ["MLFLOW_TRACKING_URI"] = exported
    return uri, embedded


def _mlflow_store_setting() -> tuple[str | None, str | None]:
    """MLflow's process-wide tracking URI as set (None: never set, MLflow resolves its
    default from the environment and the working folder at each use) and
    ``MLFLOW_TRACKING_URI`` as it is.

    MLflow 3.17 keeps the URI set by ``mlflow.set_tracking_uri`` in
    ``mlflow.tracking._tracking_service.utils._tracking_uri`` and offers no public getter
    that tells "set" from "resolved" (``mlflow.get_tracking_uri`` resolves); the version is
    pinned, and tests/pipelines/test_cli_state_cli25_review.py fails if this changes.
    """
    from mlflow.tracking._tracking_service import utils

    return getattr(utils, "_tracking_uri", None), os.environ.get("MLFLOW_TRACKING_URI")


def _restore_mlflow_store(saved: tuple[str | None, str | None]) -> None:
    import mlflow
    from mlflow.tracking._tracking_service import utils

    uri, variable = saved
    if getattr(utils, "_tracking_uri", None) != uri:
        mlflow.set_tracking_uri(uri)    # None: unset again (MLflow's own _use_tracking_uri)
    # set_tracking_uri exports (or unsets) MLFLOW_TRACKING_URI; the caller's value wins
    restore_environment_variable("MLFLOW_TRACKING_URI", variable)


_ACTIVE_STORE = SharedSetting(_mlflow_store_setting, lambda saved: activate_store(),
                              _restore_mlflow_store)


def active_store() -> SharedSetting:
    """For entry points only: the store in force as MLflow's process-wide default for the
    length of a call (a context manager), put back as the caller had it afterwards.

    :func:`activate_store` on entering; on leaving, MLflow's process-wide tracking URI and
    ``MLFLOW_TRACKING_URI`` are as the caller left them, so a command run in-process (from a
    folder MLflow's URI quotes, ``My Robots``) does not leave that folder's store as the
    default of what the caller runs next from another folder. Calls that overlap (commands
    run at once in threads) share the setting: the first to enter saves MLflow's, the last
    to leave puts it back (:class:`terrain.process_state.SharedSetting`).

    Returns
    -------
    terrain.process_state.SharedSetting
        The context manager (one per process).

    Raises
    ------
    ConfigError
        On entering, as :func:`activate_store` (nothing is changed then).
    """
    return _ACTIVE_STORE


def code_version() -> str:
    """The code version a run is tagged with.

    Returns
    -------
    str
        Git commit of the source tree (with ``-dirty`` when tracked files are modified),
        else ``terrain-<package version>`` outside a git checkout, or when this module is not
        tracked by the checkout around it (an install inside another project's checkout).
    """
    module = Path(__file__).resolve()
    here = module.parent
    try:
        # (a package installed in another project's checkout took that project's commit)
        subprocess.run(["git", "ls-files", "--error-unmatch", "--", module.name], cwd=here,
                       capture_output=True, timeout=5, check=True)
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True,
                             text=True, timeout=5, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=here, capture_output=True, text=True, timeout=5).stdout.strip()
        return sha + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return f"terrain-{terrain.__version__}"


def _experiment_id(client: Any, name: str, uri: str) -> str:
    """Id of experiment ``name`` in the client's store, created when missing.

    A SQLite store keeps its artifacts beside its database, in
    ``<database folder>/mlartifacts/<name>`` (passed explicitly; for the embedded store the
    database folder is the working directory). MLflow's own default for a ``sqlite:///``
    store named by ``MLFLOW_TRACKING_URI`` is ``./mlruns`` of whichever folder first creates
    the experiment: a stray ``mlruns/`` there, and one store's artifacts spread over
    folders. Other stores choose their own location. A deleted experiment (``mlflow
    experiments delete``) is a :class:`~terrain.errors.ConfigError` naming it and how to
    restore it: MLflow's own refusal of its runs named neither. An experiment another
    process creates between the look-up and the creation (two commands started together on
    a store :func:`store_lock` does not lock, a tracking server) is used: MLflow's
    ``RESOURCE_ALREADY_EXISTS`` failed the second command.
    """
    from mlflow.exceptions import MlflowException

    exp = client.get_experiment_by_name(name)
    if exp is None:
        database = sqlite_database(uri)
        location = (None if database is None
                    else (database.resolve().parent / ARTIFACT_DIR / name).as_uri())
        try:
            return client.create_experiment(name, artifact_location=location)
        except MlflowException as exc:
            if exc.error_code != "RESOURCE_ALREADY_EXISTS":
                raise
            exp = client.get_experiment_by_name(name)     # created meanwhile
            if exp is None:
                raise
    if getattr(exp, "lifecycle_stage", "active") == "deleted":
        raise ConfigError(f"MLflow experiment {name!r} (id {exp.experiment_id}) is deleted in "
                          f"the store {uri}: restore it (mlflow experiments restore "
                          f"--experiment-id {exp.experiment_id}, with MLFLOW_TRACKING_URI="
                          f"{uri}), delete it for good (mlflow gc), or use another store")
    return exp.experiment_id


def _is_number(value) -> bool:
    """Whether a metric value is a number ``float`` reads as such (Python or NumPy number,
    boolean, 0-d array, an integer beyond the float range included); text, None and
    anything ``float`` refuses are not."""
    if value is None or isinstance(value, (str, bytes)):
        return False
    try:
        _as_float(value)
    except (TypeError, ValueError):
        return False
    return True


def _as_float(value) -> float:
    """``float(value)``, or an infinity of its sign for an integer beyond the float range
    (``float(10**400)`` raises ``OverflowError``)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


#: Characters a parameter value holds in MLflow
#: (``mlflow.utils.validation.MAX_PARAM_VAL_LENGTH``); MLflow cuts a longer one.
PARAM_LIMIT = 6000
#: Characters a tag value holds in MLflow (``mlflow.utils.validation.MAX_TAG_VAL_LENGTH``);
#: MLflow cuts a longer one.
TAG_LIMIT = 8000
#: Artifact listing every non-finite metric name when the tag cannot hold them all.
NON_FINITE_FILE = "non_finite_metrics.txt"
_MORE_NON_FINITE = ",..."
#: Held while a run's ``non_finite_metrics`` tag is read, merged and written back: two
#: threads logging at once (through one handle or two) each wrote a list made before the
#: other's names were added, and the last erased the other's names.
_NON_FINITE_LOCK = threading.Lock()


@dataclass(frozen=True)
class TrackedRun:
    """Handle on an open MLflow run: thin typed wrappers over MLflow's client API.

    Every call goes through ``client`` to the run's own store (no process-wide MLflow state).

    Parameters
    ----------
    run_id : str
        MLflow run id.
    experiment : str
        Experiment name.
    uri : str
        Tracking URI of the store holding the run.
    client : mlflow.MlflowClient
        Client bound to ``uri``.
    """

    run_id: str
    experiment: str
    uri: str
    client: Any = field(repr=False, compare=False)
    _non_finite: set = field(default_factory=set, init=False, repr=False, compare=False)

    def log_params(self, params: Mapping[str, Any]) -> None:
        """Log parameters.

        A value longer than MLflow keeps (:data:`PARAM_LIMIT` characters; MLflow would cut
        it with only a log warning) is logged whole as the artifact ``params/<name>.txt``;
        the parameter holds its beginning and ``... (N characters in params/<name>.txt)``.

        Parameters
        ----------
        params : mapping of str to any
            Name -> value (stringified, as MLflow stores parameters).
        """
        from mlflow.entities import Param

        logged = []
        for k, v in params.items():
            name, text = str(k), str(v)
            if len(text) > PARAM_LIMIT:
                self.client.log_text(self.run_id, text, f"params/{name}.txt")
                note = f"... ({len(text)} characters in params/{name}.txt)"
                text = text[:PARAM_LIMIT - len(note)] + note
            logged.append(Param(name, text))
        self.client.log_batch(self.run_id, params=logged)

    def log_metrics(self, metrics: Mapping[str, float], step: int | None = None) -> None:
        """Log numeric metrics; non-finite values (and integers beyond the float range) are
        skipped and listed in a tag (``non_finite_metrics``: the names of every call so far,
        sorted). Where the list is longer than a tag holds (:data:`TAG_LIMIT` characters),
        the tag lists the first whole names and ends ``,... N more in
        non_finite_metrics.txt``, an artifact listing every name, one a line. Threads of
        one process may log at once (the tag is merged under a lock).

        Parameters
        ----------
        metrics : mapping of str to float
            Name -> value (a real number; a boolean is 0 or 1).
        step : int, optional
            Step of every value (default 0).

        Raises
        ------
        ConfigError
            A value that is not a number: text (``'0.5'`` was logged as 0.5 through
            ``float``), None (a bare TypeError from ``float``), named with the metric;
            nothing of the call is logged.
        """
        from mlflow.entities import Metric

        wrong = {k: v for k, v in metrics.items() if not _is_number(v)}
        if wrong:
            raise ConfigError("log_metrics takes real numbers, got "
                              + ", ".join(f"{k}={v!r:.40} ({type(v).__name__})"
                                          for k, v in list(wrong.items())[:5])
                              + (f" and {len(wrong) - 5} more" if len(wrong) > 5 else ""))
        values = {k: _as_float(v) for k, v in metrics.items()}
        good = {k: v for k, v in values.items() if math.isfinite(v)}
        bad = sorted(set(metrics) - set(good))
        now_ms = int(time.time() * 1000)
        self.client.log_batch(self.run_id, metrics=[Metric(k, v, now_ms, step or 0)
                                                    for k, v in good.items()])
        if bad:   # added to those of earlier calls, which the tag (or its file) keeps
            with _NON_FINITE_LOCK:
                self._list_non_finite(bad)

    def _list_non_finite(self, bad: list[str]) -> None:
        """Merge ``bad`` into the ``non_finite_metrics`` tag (:meth:`log_metrics`)."""
        before = self.client.get_run(self.run_id).data.tags.get("non_finite_metrics")
        listed = (before or "").partition(_MORE_NON_FINITE)[0]
        self._non_finite.update(listed.split(",") if listed else ())
        self._non_finite.update(bad)
        names = sorted(self._non_finite)
        text = ",".join(names)
        if len(text) > TAG_LIMIT:     # MLflow would cut the tag, mid-name
            self.client.log_text(self.run_id, "\n".join(names) + "\n", NON_FINITE_FILE)

            def more(n_kept: int) -> str:
                return f"{_MORE_NON_FINITE} {len(names) - n_kept} more in {NON_FINITE_FILE}"
            n = 0                     # the most whole names that fit beside the count
            while len(",".join(names[:n + 1]) + more(n + 1)) <= TAG_LIMIT:
                n += 1
            text = ",".join(names[:n]) + more(n)
        self.client.set_tag(self.run_id, "non_finite_metrics", text)

    def log_table(self, frame: pd.DataFrame, name: str) -> None:
        """Log a DataFrame as a CSV artifact.

        Parameters
        ----------
        frame : pandas.DataFrame
            The table (written without index).
        name : str
            Artifact path, e.g. ``predictions.csv`` or ``tables/x.csv``.

        Raises
        ------
        ConfigError
            ``name`` does not end in ``.csv`` (the content is CSV whatever the name).
        """
        if not name.endswith(".csv"):
            raise ConfigError(f"log_table writes CSV: name {name!r} must end in .csv")
        artifact = PurePosixPath(name)
        folder = str(artifact.parent) if str(artifact.parent) != "." else None
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / artifact.name
            frame.to_csv(path, index=False)
            self.client.log_artifact(self.run_id, str(path), folder)

    def log_figure(self, figure: Any, name: str) -> None:
        """Log a matplotlib figure as an image artifact.

        Parameters
        ----------
        figure : matplotlib.figure.Figure
            The figure.
        name : str
            Artifact path, e.g. ``confusion.png`` or ``figures/x.png``.
        """
        self.client.log_figure(self.run_id, figure, name)

    def log_dict(self, data: Mapping[str, Any], name: str) -> None:
        """Log a JSON-serialisable mapping as an artifact, in strict JSON.

        Non-finite floats become ``null`` (:func:`terrain.io.jsonfile.json_ready`, floats
        kept in full): MLflow writes them as the bare tokens ``NaN`` / ``Infinity``, which
        strict readers (``jq``, ``JSON.parse``) refuse.

        Parameters
        ----------
        data : mapping
            JSON-serialisable content (numpy scalars and tuples allowed).
        name : str
            Artifact path, e.g. ``report.json``.
        """
        self.client.log_dict(self.run_id, json_ready(data, None), name)

    def log_text(self, text: str, name: str) -> None:
        """Log text (e.g. a Markdown report) as an artifact.

        Parameters
        ----------
        text : str
            Content.
        name : str
            Artifact path, e.g. ``audit.md``.
        """
        self.client.log_text(self.run_id, text, name)

    def log_artifact(self, path: str | Path, folder: str | None = None) -> None:
        """Log a local file or directory as artifact(s).

        Parameters
        ----------
        path : str or pathlib.Path
            File or directory to copy into the run.
        folder : str, optional
            Artifact folder to put it in (default: the run's artifact root).
        """
        p = Path(path)
        if p.is_dir():
            self.client.log_artifacts(self.run_id, str(p), artifact_path=folder)
        else:
            self.client.log_artifact(self.run_id, str(p), artifact_path=folder)

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

        Raises
        ------
        ConfigError
            This run is not MLflow's active run (:func:`tracked_run` makes it so only when
            MLflow's process-wide URI is this run's store): MLflow's model logging goes to
            the active run, so the model would land in another run or store.
        """
        import mlflow
        import mlflow.sklearn
        from mlflow.models import infer_signature

        active = mlflow.active_run()
        if active is None or active.info.run_id != self.run_id:
            raise ConfigError(
                f"cannot log model {name!r} to run {self.run_id}: it is not MLflow's active "
                f"run (MLflow's process-wide store is {mlflow.get_tracking_uri()}, this run's "
                f"{self.uri}; call terrain.tracking.activate_store() first), and MLflow logs "
                "models to the active run")

        signature = infer_signature(input_example, model.predict(input_example))
        info = mlflow.sklearn.log_model(model, name=name, signature=signature,
                                        registered_model_name=registered_name,
                                        skops_trusted_types=list(trusted_types) or None)
        return info.model_uri

    def describe(self) -> str:
        """Where the run is.

        Returns
        -------
        str
            One line with the run id, experiment, store and the ``mlflow ui`` command that
            browses it.
        """
        return (f"MLflow run {self.run_id} in experiment '{self.experiment}' at {self.uri} "
                f"(browse: mlflow ui --backend-store-uri {self.uri})")


@contextmanager
def store_lock(uri: str) -> Iterator[None]:
    """Hold an inter-process lock while a SQLite store is first opened.

    MLflow creates and migrates a new SQLite store on its first use, and creates a missing
    experiment, without guarding either against another process doing the same: two
    ``terrain train`` started together in a fresh folder failed (measured: 3 of 3 tries,
    ``table _alembic_tmp_tags already exists`` and ``Online migration expected to match one
    row``). The lock (:mod:`filelock`) lives in the temporary folder, keyed by the database's
    path, so nothing is left beside the user's ``mlflow.db``. Other stores are not locked.

    Parameters
    ----------
    uri : str
        Tracking URI (:func:`tracking_uri`).

    Yields
    ------
    None

    Raises
    ------
    ConfigError
        Another process has held the lock for :data:`STORE_LOCK_TIMEOUT_S`.
    """
    database = sqlite_database(uri)
    if database is None:
        yield
        return
    import hashlib

    from filelock import FileLock, Timeout

    database = database.resolve()
    key = hashlib.sha1(str(database).encode()).hexdigest()[:16]
    # one lock file per user: a lock file left by another user could not be opened
    path = Path(tempfile.gettempdir()) / f"terrain-mlflow-{os.getuid()}-{key}.lock"
    lock = FileLock(str(path), timeout=STORE_LOCK_TIMEOUT_S)
    try:
        lock.acquire()
    except Timeout:
        raise ConfigError(f"the MLflow store {database} has been opened by another process "
                          f"for over {STORE_LOCK_TIMEOUT_S:g} s (lock {path}); wait for it "
                          "to finish, or run this one in another folder (or "
                          "MLFLOW_TRACKING_URI)") from None
    try:
        yield
    finally:
        lock.release()


def require_store() -> str:
    """Refuse at once the store in force when :func:`tracked_run` would refuse it.

    For a program that logs only at the end of long work (a benchmark): called before the
    work, a store it cannot use stops it then, not after minutes or hours of computing.

    Returns
    -------
    str
        The store in force (:func:`tracking_uri`).

    Raises
    ------
    ConfigError
        A store that cannot be used (:func:`check_store`), or a SQLite store that names no
        database file (``sqlite:///``, ``sqlite:///:memory:``: kept in memory and lost at
        exit).
    """
    uri = tracking_uri()
    if uri.partition("://")[0] == "sqlite" and sqlite_database(uri) is None:
        # (SQLAlchemy's in-memory or temporary database: the runs are gone at exit)
        raise ConfigError(f"MLflow tracking store {uri} names no database file: its runs would "
                          "be lost when the command ends; set MLFLOW_TRACKING_URI to "
                          "sqlite:///<file> or unset it for sqlite:///<current folder>/mlflow.db")
    check_store(uri)
    return uri


@contextmanager
def tracked_run(experiment: str, run_name: str | None = None,
                params: Mapping[str, Any] | None = None,
                tags: Mapping[str, str] | None = None,
                announce: bool = True) -> Iterator[TrackedRun]:
    """Open an MLflow run in ``experiment`` on the store in force (:func:`tracking_uri`).

    The store and, for a SQLite store, the artifact location (``mlartifacts`` beside the
    database) are passed to MLflow explicitly through a client: nothing process-wide is
    configured and the environment is left as it is. When MLflow's process-wide URI
    resolves to the same store (always so in a fresh ``terrain`` process, or after
    :func:`activate_store`), the run is also MLflow's active run for the duration of the
    block, so fluent calls inside it (model logging) land in it. If the caller already has
    an active run on that store, the run is its child (tag ``mlflow.parentRunId``, MLflow's
    nested run) and the caller's run is active again, still running, after the block. The
    run ends ``FINISHED``, or ``FAILED`` when the block raises.

    Parameters
    ----------
    experiment : str
        Experiment name, one per pipeline (``terrain-cv``...).
    run_name : str, optional
        Human-readable run name.
    params : mapping, optional
        Parameters logged at start (with ``code_version``, which is this function's to set).
    tags : mapping, optional
        Extra tags (``code_version`` is always set, by this function).
    announce : bool
        Print where the run is (stdout) when it starts.

    Yields
    ------
    TrackedRun

    Raises
    ------
    ConfigError
        A store that cannot be used (:func:`check_store`), a SQLite store that names no
        database file (``sqlite:///``, ``sqlite:///:memory:``: kept in memory and lost at
        exit), ``experiment`` deleted in it, or ``params`` or ``tags`` naming
        ``code_version`` (the run's tag and parameter would disagree), before any run is
        opened.
    """
    import mlflow

    for where, given in (("params", params), ("tags", tags)):
        if given and "code_version" in given:
            raise ConfigError(f"tracked_run sets code_version itself: {where} names it "
                              f"({given['code_version']!r:.60}), which would tag the run with "
                              "one code version and parametrise it with another")

    uri = require_store()
    with store_lock(uri):
        client = mlflow.MlflowClient(tracking_uri=uri)
        exp_id = _experiment_id(client, experiment, uri)
    version = code_version()
    fluent = mlflow.get_tracking_uri() == uri
    parent = mlflow.active_run() if fluent else None
    nesting = {} if parent is None else {"mlflow.parentRunId": parent.info.run_id}
    run = client.create_run(exp_id, run_name=run_name,
                            tags={"code_version": version, **nesting, **(tags or {})})
    handle = TrackedRun(run.info.run_id, experiment, uri, client)
    if fluent:
        try:
            mlflow.start_run(run_id=handle.run_id, nested=parent is not None)
        except BaseException:   # (e.g. the caller set another experiment): not left RUNNING
            client.set_terminated(handle.run_id, status="FAILED")
            raise
    status = "FAILED"
    try:
        handle.log_params({"code_version": version, **(params or {})})
        if announce:
            print(handle.describe(), flush=True)
        yield handle
        status = "FINISHED"
    finally:
        if fluent:
            mlflow.end_run(status=status)
        else:
            client.set_terminated(handle.run_id, status=status)
