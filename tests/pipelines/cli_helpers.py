"""Running the ``terrain`` command line in a test."""

from __future__ import annotations

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
