"""State of the commands (aud24): a command's ``main`` leaves the caller's parsed arguments
as they were, so that the same ``argparse.Namespace`` run twice runs the same command."""

from __future__ import annotations

import argparse
import copy

import pytest

from pipelines import stream_eval


class _Stop(Exception):
    """Raised where a command would start its long work (the runs read)."""


def _stop(*args, **kwargs):
    raise _Stop()


def _parsed(module, argv):
    parser = argparse.ArgumentParser()
    module.add_arguments(parser)
    return parser.parse_args(argv)


@pytest.mark.parametrize("argv", [["--part", "wheel-cv"], ["--part", "streams"], []])
def test_stream_eval_main_leaves_the_parsed_arguments_as_they_were(monkeypatch, argv):
    # main filled the defaults into the caller's Namespace (--folds 5, --window-s...): the
    # same arguments run again were refused ("--folds shapes the held-out streams; --part
    # wheel-cv does not run them"), as if the user had given the defaults
    monkeypatch.setattr(stream_eval, "load_dataset", _stop)
    args = _parsed(stream_eval, argv)
    before = copy.deepcopy(vars(args))
    for _ in range(2):
        with pytest.raises(_Stop):
            stream_eval.main(args)
        assert vars(args) == before
