"""Serve live terrain -> target-slip decisions over HTTP (MLflow scoring server, loopback).

--model is a model directory written by ``terrain train --model-out`` (it is wrapped into
the streaming pyfunc :mod:`terrain.serving.served`, kept in --served-out when given) or an
already wrapped one. The server is MLflow's own scoring server app (``/ping``,
``/invocations``), the same one ``mlflow models serve -m SERVED_DIR --env-manager local``
runs, plus a request-size guard: a body over --max-body-bytes is answered 413. Requests
carry the raw streams as logged (``dataframe_split`` JSON or CSV, long format with a
``stream`` column or wide format with ``<stream>_t_s`` columns); the answer is one decision
per window. Only loopback addresses are served.
"""

from __future__ import annotations

import argparse
import ipaddress
import tempfile
from pathlib import Path

import yaml

from terrain.errors import ConfigError
from terrain.serving.pyfunc import pip_requirements
from terrain.serving import load_stream_model
from terrain.serving.served import save_served_model, served_settings


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``terrain serve``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser.
    """
    parser.add_argument("--model", type=Path, required=True,
                        help="model directory (terrain train --model-out, or a served model)")
    parser.add_argument("--host", default="127.0.0.1", help="loopback address to bind")
    parser.add_argument("--port", type=int, default=5001, help="TCP port")
    parser.add_argument("--served-out", type=Path, default=None,
                        help="keep the wrapped streaming model here (servable with "
                             "`mlflow models serve -m DIR --env-manager local`)")
    parser.add_argument("--hop-s", type=float, default=0.5, help="time between decisions, s")
    parser.add_argument("--dwell-s", type=float, default=10.0,
                        help="expected time on one terrain of the forward filter, s "
                             "(0 disables smoothing)")
    parser.add_argument("--min-confidence", type=float, default=0.5,
                        help="smoothed probability below which the fallback target is used")
    parser.add_argument("--max-body-bytes", type=int, default=8_000_000,
                        help="largest request body, bytes (larger: HTTP 413)")


def is_served_model(path: Path) -> bool:
    """Whether ``path`` already holds the streaming pyfunc (its metadata kind).

    Parameters
    ----------
    path : Path
        Model directory.

    Returns
    -------
    bool
    """
    mlmodel = path / "MLmodel"
    meta = (yaml.safe_load(mlmodel.read_text()) or {}).get("metadata") or {} \
        if mlmodel.is_file() else {}
    return meta.get("kind") == "terrain-stream"


def wrap_model(model_dir: Path, out: Path, args: argparse.Namespace) -> Path:
    """Wrap a ``terrain train`` model into the streaming pyfunc at ``out``.

    Parameters
    ----------
    model_dir : Path
        Model directory of ``terrain train --model-out``.
    out : Path
        New directory of the served model.
    args : argparse.Namespace
        ``hop_s``, ``dwell_s``, ``min_confidence``.

    Returns
    -------
    Path
        ``out``.
    """
    model = load_stream_model(model_dir)
    settings = served_settings(model, args.hop_s, args.dwell_s or None, args.min_confidence)
    return save_served_model(out, model_dir, settings, pip_requirements(model.pipeline))


def build_app(served_dir: Path, max_body_bytes: int):
    """MLflow's scoring server app for ``served_dir`` with the request-size guard.

    Parameters
    ----------
    served_dir : Path
        Directory of the served streaming model.
    max_body_bytes : int
        Largest request body, bytes (larger: 413; no Content-Length: 411).

    Returns
    -------
    fastapi.FastAPI
        ``/ping``, ``/health``, ``/version``, ``/invocations``.
    """
    import mlflow.pyfunc
    from fastapi.responses import JSONResponse
    from mlflow.pyfunc import scoring_server

    app = scoring_server.init(mlflow.pyfunc.load_model(str(served_dir)))

    @app.middleware("http")
    async def limit_body(request, call_next):
        size = request.headers.get("content-length")
        if request.method == "POST" and (size is None or int(size) > max_body_bytes):
            message = (f"request body of {size} bytes exceeds the limit of {max_body_bytes}"
                       if size else "request without Content-Length")
            return JSONResponse({"error_code": "REQUEST_LIMIT_EXCEEDED",
                                 "message": f"DataFormatError: {message}; send the streams "
                                            "in shorter pieces"},
                                status_code=413 if size else 411)
        return await call_next(request)

    return app


def main(args: argparse.Namespace) -> int:
    """Wrap the model if needed and serve it until interrupted.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (see :func:`add_arguments`).

    Returns
    -------
    int
        Exit status 0.

    Raises
    ------
    ConfigError
        ``--host`` is not a loopback address, or ``--model`` does not exist or is not a
        terrain model.
    """
    import uvicorn

    try:
        loopback = args.host == "localhost" or ipaddress.ip_address(args.host).is_loopback
    except ValueError:
        loopback = False
    if not loopback:
        raise ConfigError(f"--host {args.host} is not a loopback address (use 127.0.0.1)")
    if not args.model.exists():
        raise ConfigError(f"model directory {args.model} does not exist")
    with tempfile.TemporaryDirectory() as tmp:
        served = args.model
        if not is_served_model(args.model):
            served = wrap_model(args.model, args.served_out or Path(tmp) / "served", args)
            print(f"wrapped {args.model} into the streaming model {served}")
        app = build_app(served, args.max_body_bytes)
        print(f"serving {served} on http://{args.host}:{args.port}/invocations "
              "(Ctrl-C stops)", flush=True)
        uvicorn.run(app, host=args.host, port=args.port, log_level="warning")
    return 0
