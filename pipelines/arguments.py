"""Command-line options that several ``terrain`` subcommands share, defined once.

Each ``add_*`` function adds an option (``add_smoothing``: the forward filter's three) to a
sub-command's parser with one help text, so ``terrain cv``, ``train`` and ``compare``, and
``terrain stream`` and ``serve``, describe the same setting in the same words;
:func:`smoothing_from_args` reads the filter's options back as one :class:`SmoothingConfig`.
"""

from __future__ import annotations

import argparse

from terrain.errors import ConfigError
from terrain.serving.smoothing import SmoothingConfig


def add_cnn_seeds(parser: argparse.ArgumentParser, default: int = 1) -> None:
    """Add ``--cnn-seeds`` (seed bagging of every CNN; :attr:`ModelConfig.cnn_seeds`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser (modified in place).
    default : int
        Networks per CNN when the option is not given (>= 1).
    """
    parser.add_argument("--cnn-seeds", type=int, default=default,
                        help="CNNs (alone or in an ensemble) average the probabilities of this "
                             "many independently seeded networks (seed bagging; default "
                             f"{default})")


def add_window_ekf(parser: argparse.ArgumentParser) -> None:
    """Add ``--window-ekf`` (the EKF's channels computed from each window's own samples).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser (modified in place).
    """
    parser.add_argument("--window-ekf", action="store_true",
                        help="the model also sees the skid-steer EKF's channels computed from "
                             "each window's own samples (needs vel_l, vel_r, wz; nothing "
                             "older than the window, so it streams: docs/streaming.md)")


def add_run_balanced(parser: argparse.ArgumentParser) -> None:
    """Add ``--run-balanced`` (every run of a class weighs the same in training;
    :attr:`terrain.models.registry.ModelConfig.run_balanced`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser (modified in place).
    """
    parser.add_argument("--run-balanced", action="store_true",
                        help="weigh the training windows so that every run of a class counts "
                             "the same, instead of every window (a long run then does not "
                             "stand for its terrain; docs/streaming.md)")


def add_train_hop(parser: argparse.ArgumentParser) -> None:
    """Add ``--train-hop-s`` of the cross-validating commands (training windows' hop).

    ``terrain train`` has its own, since its default depends on the dataset.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser (modified in place).
    """
    parser.add_argument("--train-hop-s", type=float, default=None,
                        help="hop of the training windows, s: each fold trains on windows cut "
                             "this often from its training runs; the test windows are "
                             "unchanged (default: train on the test windows' cut)")


def add_smoothing(parser: argparse.ArgumentParser) -> None:
    """Add the forward filter's options of ``terrain stream`` and ``terrain serve``.

    ``--dwell-s`` (0 disables smoothing), ``--reset-confidence`` and ``--reset-windows``
    (the filter's switch reset, off by default; :class:`SmoothingConfig`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser (modified in place).
    """
    parser.add_argument("--dwell-s", type=float, default=10.0,
                        help="expected time on one terrain of the forward filter, s "
                             "(0 disables smoothing)")
    parser.add_argument("--reset-confidence", type=float, default=None,
                        help="reset the filter to the window's probabilities when "
                             "--reset-windows consecutive windows name the same other class "
                             "with at least this probability (default: no reset; "
                             "docs/streaming.md)")
    parser.add_argument("--reset-windows", type=int, default=2,
                        help="consecutive confident windows that reset the filter (default 2)")


def smoothing_from_args(args: argparse.Namespace) -> SmoothingConfig:
    """The :class:`SmoothingConfig` of :func:`add_smoothing`'s options.

    Parameters
    ----------
    args : argparse.Namespace
        ``dwell_s``, ``reset_confidence``, ``reset_windows``.

    Returns
    -------
    SmoothingConfig

    Raises
    ------
    ConfigError
        A value out of its range (a negative dwell, a reset without the filter...).
    """
    if not args.dwell_s >= 0:
        raise ConfigError(f"--dwell-s must be >= 0 (0 disables smoothing), got {args.dwell_s:g}")
    return SmoothingConfig(dwell_s=args.dwell_s or None,
                           reset_confidence=args.reset_confidence,
                           reset_windows=args.reset_windows)
