"""Running the ``terrain`` command line in a test."""

from __future__ import annotations

import json
from pathlib import Path

from terrain.cli import main


def exit_code(argv: list[str]) -> int:
    """Exit status of ``terrain ARGV``: what ``main`` returns, or argparse's usage error.

    Parameters
    ----------
    argv : list of str
        The command line after ``terrain``.

    Returns
    -------
    int
        0 on success, 2 for a usage or input error, 1 for an internal error.
    """
    try:
        return main(argv)
    except SystemExit as exc:  # argparse's own usage error
        return exc.code


def control_sim_json(tmp_path: Path, *options: str) -> dict:
    """``terrain control-sim`` of a Husky on ICE, ``straight_accel``, with ``options``;
    the JSON it writes (the command must succeed).

    Parameters
    ----------
    tmp_path : pathlib.Path
        Folder of the JSON file (``c.json``).
    *options : str
        Further options (controller, terrain source, gains, duration...).

    Returns
    -------
    dict
        The run's JSON summary.
    """
    out = tmp_path / "c.json"
    assert main(["control-sim", "--vehicle", "husky", "--terrain", "ice", "--scenario",
                 "straight_accel", "--json", str(out), *options]) == 0
    return json.loads(out.read_text())


class RecordingRun:
    """Stand-in of :func:`terrain.tracking.tracked_run` for a command under test: called
    as it is, it opens no MLflow run; it keeps the parameters each start was given
    (``starts``), and what was logged with ``log_params``, ``log_metrics`` and
    ``log_table``; any other call on the run does nothing."""

    def __init__(self):
        self.starts: list = []
        self.params: dict = {}
        self.metrics: dict = {}
        self.tables: dict = {}

    def __call__(self, *args, params=None, **kwargs):
        self.starts.append(params)
        return self

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def __getattr__(self, name):
        return lambda *args, **kwargs: None

    def log_params(self, params):
        self.params.update(params)

    def log_metrics(self, metrics, step=None):
        self.metrics.update(metrics)

    def log_table(self, table, name):
        self.tables[name] = table
