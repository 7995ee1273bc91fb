"""Serve live terrain -> target-slip decisions over HTTP (MLflow scoring server, loopback).

--model is a model directory written by ``terrain train --model-out`` (it is wrapped into
the streaming pyfunc :mod:`terrain.serving.served`, kept in --served-out when given) or an
already wrapped one, which carries its own settings (the options that set them, --hop-s,
--dwell-s, --min-confidence, --reset-*, --max-decisions, and --served-out, are refused for
it). The server is
MLflow's own scoring server app (``/ping``, ``/invocations``), the same one ``mlflow
models serve -m SERVED_DIR --env-manager local`` runs, behind a request guard
(:class:`terrain.serving.http.RequestGuard`): a body over --max-body-bytes is answered 413,
a request without Content-Type 415, and every error answer carries one line with the
project's typed message (``<ErrorClass>: ...``), never a stack
trace or a dump of the request. Requests carry the raw streams as logged (``dataframe_split`` JSON
or CSV, long format with a ``stream`` column or wide format with ``<stream>_t_s`` columns); the
answer is one decision per window. Only loopback addresses are served.

The port is bound before anything is announced (a port in use is a one-line error, exit
2; ``--port 0`` takes a free port and announces it). SIGTERM and SIGINT stop the server
gracefully and remove the temporary wrapped model (exit 0); one that comes before the server
serves (while the model is wrapped or loaded) exits 130 (SIGINT) or 143 (SIGTERM), saying
whether ``--served-out`` was written.
"""

from __future__ import annotations

import argparse
import errno
import ipaddress
import math
import signal
import socket
import tempfile
from pathlib import Path
from typing import Any

from pipelines.arguments import (add_smoothing, model_dir, model_folder, positive_number,
                                 probability, smoothing_from_args)
from terrain.control import DesiredSlipConfig
from terrain.errors import ConfigError
from terrain.serving import load_stream_model
from terrain.serving.http import (HEADER_TIMEOUT_S, MAX_CONNECTIONS, MAX_IN_FLIGHT, MIN_IDLE_S,
                                  RESERVED_FILES, RequestGuard, bounded_connections_protocol,
                                  run_server)
from terrain.serving.model import read_mlmodel
from terrain.serving.pyfunc import pip_requirements
from terrain.serving.served import MAX_DECISIONS, save_served_model, served_settings


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain serve``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser.
    """
    parser.add_argument("--model", type=model_folder, required=True,
                        help="model directory (terrain train --model-out, or a served model)")
    parser.add_argument("--host", default="127.0.0.1", help="loopback address to bind")
    parser.add_argument("--port", type=int, default=5001,
                        help="TCP port, 1-65535 (0: a free port, announced at start)")
    parser.add_argument("--served-out", type=model_dir, default=None,
                        help="keep the wrapped streaming model here (servable with "
                             "`mlflow models serve -m DIR --env-manager local`)")
    parser.add_argument("--hop-s", type=positive_number, default=0.5,
                        help="time between decisions, s (at least one period of the "
                             "model's clock)")
    add_smoothing(parser)
    parser.add_argument("--min-confidence", type=probability,
                        default=DesiredSlipConfig().min_confidence,
                        help="smoothed probability below which the fallback target is used "
                             "(default: the desired-slip table's, %(default)s)")
    parser.add_argument("--max-body-bytes", type=int, default=8_000_000,
                        help="largest request body, bytes (larger: HTTP 413)")
    parser.add_argument("--max-decisions", type=int, default=MAX_DECISIONS,
                        help="most decisions one request may make, i.e. its time span over "
                             "--hop-s (more: HTTP 400)")
    parser.add_argument("--max-in-flight", type=int, default=MAX_IN_FLIGHT,
                        help="requests answered at once (more: HTTP 503 at once, instead of "
                             "queueing behind slow ones)")
    parser.add_argument("--header-timeout-s", type=float, default=HEADER_TIMEOUT_S,
                        help="seconds a connection may go without starting a request while "
                             "none is in progress (a client stalled in its headers) before "
                             "it is answered 408 and closed")
    parser.add_argument("--max-connections", type=int, default=MAX_CONNECTIONS,
                        help="connections kept open (more: the oldest one idle for "
                             f"{MIN_IDLE_S:g} s is closed, else the new one is answered 503); "
                             "twice this (as many refused ones are held up to "
                             f"{MIN_IDLE_S:g} s) at most the open-file limit (ulimit -n) minus "
                             f"{RESERVED_FILES}")


def is_served_model(path: Path) -> bool:
    """Whether ``path`` already holds the streaming pyfunc (its metadata kind).

    Parameters
    ----------
    path : Path
        Model directory.

    Returns
    -------
    bool

    Raises
    ------
    ConfigError
        An ``MLmodel`` that is not a YAML mapping (:func:`terrain.serving.model.read_mlmodel`).
    """
    mlmodel = path / "MLmodel"
    meta = read_mlmodel(mlmodel).get("metadata") if mlmodel.is_file() else None
    return isinstance(meta, dict) and meta.get("kind") == "terrain-stream"


#: options that set the wrapped model (:func:`wrap_model`); an already wrapped one carries
#: its own
WRAP_OPTIONS = ("hop_s", "dwell_s", "min_confidence", "reset_confidence", "reset_windows",
                "max_decisions")


def check_no_wrap_options(served_dir: Path, args: argparse.Namespace) -> None:
    """Refuse the wrapping options given to an already wrapped model (they would be ignored).

    Parameters
    ----------
    served_dir : Path
        Directory of a served streaming model (:func:`is_served_model`).
    args : argparse.Namespace
        Parsed arguments; an option of :data:`WRAP_OPTIONS` at its default is not refused;
        ``--served-out`` (where a wrapped copy would be kept) is refused whenever given.

    Raises
    ------
    ConfigError
        Naming the options given, the model's own settings and how to wrap it again.
    """
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    given = {name: getattr(args, name) for name in WRAP_OPTIONS
             if getattr(args, name, parser.get_default(name)) != parser.get_default(name)}
    served_out = getattr(args, "served_out", None)
    if not given and served_out is None:
        return
    meta = read_mlmodel(served_dir / "MLmodel").get("metadata") or {}
    options = ", ".join([f"--{name.replace('_', '-')} {value:g}"
                         for name, value in given.items()]
                        + ([f"--served-out {served_out}"] if served_out is not None else []))
    own = ", ".join(f"{name} {meta.get(name, 'unset')}" for name in (given or WRAP_OPTIONS))
    source = meta.get("source_model") or "TRAIN_MODEL_DIR"
    raise ConfigError(f"{options}: {served_dir} is an already wrapped model, which carries its "
                      f"own settings ({own}) and is served as it is; to change them or keep "
                      f"a wrapped copy, wrap the `terrain train --model-out` directory again: "
                      f"terrain serve --model {source} with these options")


def wrap_model(model_dir: Path, out: Path, args: argparse.Namespace) -> Path:
    """Wrap a ``terrain train`` model into the streaming pyfunc at ``out``.

    Parameters
    ----------
    model_dir : Path
        Model directory of ``terrain train --model-out``.
    out : Path
        New directory of the served model.
    args : argparse.Namespace
        ``hop_s``, ``dwell_s``, ``reset_confidence``, ``reset_windows``,
        ``min_confidence``, ``max_decisions``.

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    ConfigError
        The directory's pipeline is not a fitted classifier, or a setting is out of range.
    """
    model = load_stream_model(model_dir)
    smoothing = smoothing_from_args(args)
    settings = served_settings(model, args.hop_s, smoothing.dwell_s, args.min_confidence,
                               max_decisions=getattr(args, "max_decisions", MAX_DECISIONS),
                               reset_confidence=smoothing.reset_confidence,
                               reset_windows=smoothing.reset_windows)
    return save_served_model(out, model_dir, settings, pip_requirements(model.pipeline))


def build_app(served_dir: Path, max_body_bytes: int, max_in_flight: int = MAX_IN_FLIGHT):
    """MLflow's scoring server app for ``served_dir`` behind :class:`RequestGuard`.

    Parameters
    ----------
    served_dir : Path
        Directory of the served streaming model.
    max_body_bytes : int
        Largest request body, bytes (larger: 413; no Content-Length: 411).
    max_in_flight : int
        Requests to ``/invocations`` answered at once (more: 503).

    Returns
    -------
    fastapi.FastAPI
        ``/ping``, ``/health``, ``/version``, ``/invocations``.

    Raises
    ------
    ConfigError
        The served model cannot be loaded (e.g. its pipeline is not a classifier).
    """
    import mlflow.pyfunc
    from mlflow.pyfunc import scoring_server

    model = mlflow.pyfunc.load_model(str(served_dir))
    app = scoring_server.init(model)
    settings = getattr(model.unwrap_python_model(), "settings", {})
    # outermost of the app's middleware (inside only Starlette's 500 handler), so that it
    # sees the exceptions MLflow's handler lets escape
    app.add_middleware(RequestGuard, max_body_bytes=max_body_bytes,
                       max_rows=settings.get("max_rows"), max_in_flight=max_in_flight)
    return app


def bind_port(host: str, port: int) -> socket.socket:
    """Bind the server's socket now, so a port in use is reported before any announcement.

    Parameters
    ----------
    host : str
        Address to bind.
    port : int
        TCP port, 0-65535 (0: the system picks a free one).

    Returns
    -------
    socket.socket
        Bound (not yet listening); uvicorn listens on it.

    Raises
    ------
    ConfigError
        Port out of range, in use, or not bindable.
    """
    if not 0 <= port <= 65535:
        raise ConfigError(f"--port {port} is outside 1-65535 (0 picks a free port)")
    # the socket uvicorn itself would bind (IPv6 for an address with a colon)
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        hint = " (another server listens there; choose another --port)" \
            if exc.errno == errno.EADDRINUSE else ""
        raise ConfigError(f"cannot serve on {host}:{port}: "
                          f"{exc.strerror or type(exc).__name__}{hint}") from None
    return sock


class _Stopped(BaseException):
    """SIGTERM or SIGINT: unwinds ``main`` so the temporary wrapped model is removed."""


def _stop(signum: int, frame: Any) -> None:
    raise _Stopped(signal.Signals(signum).name)


def _check_args(args: argparse.Namespace) -> None:
    """Refuse out-of-range numbers before anything is started (ConfigError); the port's
    range is :func:`bind_port`'s, the first thing started."""
    units = {"max_body_bytes": "bytes", "max_decisions": "decisions",
             "max_in_flight": "requests", "max_connections": "connections"}
    for name, unit in units.items():
        value = getattr(args, name, 1)
        if not value > 0:
            raise ConfigError(f"--{name.replace('_', '-')} must be a positive number of "
                              f"{unit}, got {value}")
    limit = _open_file_limit()
    connections = getattr(args, "max_connections", MAX_CONNECTIONS)
    # kept ones, and as many answered 503 and held until their client has read it
    if limit is not None and 2 * connections > limit - RESERVED_FILES:
        raise ConfigError(f"--max-connections {connections} does not fit the open-file limit "
                          f"{limit} (ulimit -n) less {RESERVED_FILES} for the server's own "
                          f"files (twice the bound: as many connections refused beyond it "
                          f"are held up to {MIN_IDLE_S:g} s): pass at most "
                          f"{max((limit - RESERVED_FILES) // 2, 1)} or raise the limit")
    header_timeout = getattr(args, "header_timeout_s", HEADER_TIMEOUT_S)
    if not (math.isfinite(header_timeout) and header_timeout > 0):
        raise ConfigError(f"--header-timeout-s must be a finite number of seconds > 0, got "
                          f"{header_timeout:g}")
    if not args.hop_s > 0:
        raise ConfigError(f"--hop-s must be > 0, got {args.hop_s:g}")
    smoothing_from_args(args)


#: listen backlog of ``terrain serve`` where the open-file limit leaves room for it
MAX_BACKLOG = 2048


def accept_backlog(max_connections: int) -> int:
    """Listen backlog of ``terrain serve``: :data:`MAX_BACKLOG`, or less under a tight
    open-file limit.

    asyncio accepts up to ``backlog`` connections in one pass of its loop before any of
    them can be closed, so the connections kept open (and as many refused ones, held until
    their client has read the 503) plus about two passes must fit the
    open-file limit (measured: with 2,048 under a limit of 1,024, a burst of 1,100 idle
    connections still made ``accept`` fail with EMFILE while the oldest were being
    closed).

    Parameters
    ----------
    max_connections : int
        ``--max-connections``.

    Returns
    -------
    int
        Between 16 and :data:`MAX_BACKLOG`.
    """
    limit = _open_file_limit()
    if limit is None:
        return MAX_BACKLOG
    return int(min(MAX_BACKLOG, max(16, (limit - RESERVED_FILES - 2 * max_connections) // 3)))


def _open_file_limit() -> int | None:
    """The process's soft open-file limit (``ulimit -n``), or None where unknown or
    unlimited."""
    try:
        import resource
        soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
    except (ImportError, OSError, ValueError):
        return None
    return None if soft < 0 or soft == getattr(resource, "RLIM_INFINITY", -1) else int(soft)


def main(args: argparse.Namespace) -> int:
    """Wrap the model if needed and serve it until SIGTERM or SIGINT.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (see :func:`add_arguments`).

    Returns
    -------
    int
        Exit status 0 (also after SIGTERM / SIGINT: the server stopped gracefully and the
        temporary wrapped model was removed); 130 (SIGINT) or 143 (SIGTERM) when the signal
        came before the server served (the message says whether ``--served-out`` was
        written: a wrapping cut short leaves nothing there).

    Raises
    ------
    ConfigError
        ``--host`` is empty or not a loopback address, ``--port`` is out of range or in use, a
        number is out of range, ``--model`` does not exist or is not a terrain model
        (its pipeline must be a fitted classifier), or it is an already wrapped model and
        an option setting the wrapped model (:data:`WRAP_OPTIONS`) is given.
    """
    import uvicorn

    if not args.host.strip():     # an unset shell variable: "--host  is not..." hid it
        raise ConfigError(f"--host is {'blank' if args.host else 'empty'} ({args.host!r}): "
                          "give a loopback address (127.0.0.1, ::1 or localhost)")
    try:
        loopback = args.host == "localhost" or ipaddress.ip_address(args.host).is_loopback
    except ValueError:
        loopback = False
    if not loopback:
        raise ConfigError(f"--host {args.host} is not a loopback address (use 127.0.0.1)")
    _check_args(args)
    if not args.model.exists():
        raise ConfigError(f"model directory {args.model} does not exist")
    wrapped = is_served_model(args.model)
    if wrapped:
        check_no_wrap_options(args.model, args)
    previous = {sig: signal.signal(sig, _stop) for sig in (signal.SIGTERM, signal.SIGINT)}
    sock, serving, written = None, False, False
    try:
        sock = bind_port(args.host, args.port)
        port = sock.getsockname()[1]
        with tempfile.TemporaryDirectory(prefix="terrain-serve-") as tmp:
            served = args.model
            if not wrapped:
                served = wrap_model(args.model, args.served_out or Path(tmp) / "served", args)
                written = True
                print(f"wrapped {args.model} into the streaming model {served}")
            app = build_app(served, args.max_body_bytes,
                            getattr(args, "max_in_flight", MAX_IN_FLIGHT))
            backlog = accept_backlog(getattr(args, "max_connections", MAX_CONNECTIONS))
            sock.listen(backlog)  # connections wait in the backlog until uvicorn accepts
            host = f"[{args.host}]" if ":" in args.host else args.host
            print(f"serving {served} on http://{host}:{port}/invocations "
                  "(Ctrl-C stops)", flush=True)
            protocol = bounded_connections_protocol(
                getattr(args, "max_connections", MAX_CONNECTIONS),
                getattr(args, "header_timeout_s", HEADER_TIMEOUT_S))
            config = uvicorn.Config(app, host=args.host, port=port, log_level="warning",
                                    timeout_graceful_shutdown=5, http=protocol,
                                    backlog=backlog)
            serving = True
            try:
                # twice the requests admitted: a request MLflow answered 504 (its timeout)
                # frees its slot while its prediction still runs in its thread
                run_server(uvicorn.Server(config), [sock],
                           2 * getattr(args, "max_in_flight", MAX_IN_FLIGHT))
            finally:
                if protocol.timed_out:
                    print(f"terrain serve: closed {protocol.timed_out} connection(s) that "
                          f"started no request within --header-timeout-s "
                          f"{protocol.header_timeout_s:g}", flush=True)
                if protocol.closed:
                    print(f"terrain serve: closed {protocol.closed} idle connection(s) "
                          f"beyond --max-connections {protocol.limit}", flush=True)
                if protocol.refused:
                    print(f"terrain serve: answered {protocol.refused} new connection(s) 503 "
                          f"beyond --max-connections {protocol.limit} (none idle for "
                          f"{protocol.min_idle_s:g} s)", flush=True)
    except _Stopped as stop:
        if serving:
            print(f"terrain serve: stopped ({stop})", flush=True)
        else:   # nothing served: not a success, nor --served-out if cut short
            out = getattr(args, "served_out", None)
            kept = "" if out is None or wrapped else \
                f"; --served-out {out} {'written' if written else 'not written'}"
            print(f"terrain serve: stopped ({stop}) before serving{kept}", flush=True)
            return 128 + signal.Signals[str(stop)].value
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if sock is not None:
            sock.close()
    return 0
