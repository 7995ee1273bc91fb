"""Command-line options that several ``terrain`` subcommands share, defined once.

Each function adds one option to a sub-command's parser with one help text, so ``terrain
cv``, ``terrain train`` and ``terrain compare`` describe the same setting in the same words.
"""

from __future__ import annotations

import argparse


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
