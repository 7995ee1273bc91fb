"""The ``terrain`` command line.

Each subcommand lives in a module of :mod:`pipelines` that exposes

* a module docstring (first line = the subcommand's help),
* ``add_arguments(parser: argparse.ArgumentParser) -> None``,
* ``main(args: argparse.Namespace) -> int``.

This module only dispatches; it is the outermost layer (nothing imports it).
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import signal
import sys
import threading
import warnings
from types import MappingProxyType
from typing import Mapping, Sequence

# the pipelines, MLflow and scikit-learn load in main (seconds): a Ctrl-C meanwhile is
# main's one line, not a traceback of import frames
from terrain.errors import DataWarning, TerrainError
from terrain.process_state import SharedSetting

#: subcommand -> pipelines module implementing it
SUBCOMMANDS: Mapping[str, str] = MappingProxyType({
    "cv": "pipelines.cv",
    "train": "pipelines.train",
    "predict": "pipelines.predict",
    "convert": "pipelines.convert",
    "benchmark": "pipelines.benchmark",
    "simulate": "pipelines.simulate",
    "audit": "pipelines.audit",
    "estimate": "pipelines.estimate",
    "compare": "pipelines.compare",
    "validate": "pipelines.validate",
    "slip-table": "pipelines.slip_table",
    "slip-fit": "pipelines.slip_fit",
    "control-sim": "pipelines.control_sim",
    "control-grid": "pipelines.control_grid",
    "stream": "pipelines.stream",
    "stream-eval": "pipelines.stream_eval",
    "serve": "pipelines.serve",
})


#: placeholder help (zero-width space): argparse prints no line for an option without help
_NO_HELP = "\u200b"


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the descriptions' line breaks; shows each option's default and valid choices
    (unless its help already states them, or it is a flag or has no default)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = (action.help or "").replace(_NO_HELP, "")
        if (action.choices is not None and action.metavar is not None and "{" not in text
                and not isinstance(action, argparse._SubParsersAction)):
            text += f" (choices: {', '.join(map(str, action.choices))})"
        flag = isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction))
        if (action.option_strings and not flag and "default" not in text
                and action.default not in (None, argparse.SUPPRESS)):
            text += " (default: %(default)s)"
        return text.strip()


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with one subparser per available pipeline.

    A pipeline module of :data:`SUBCOMMANDS` that is not installed is left out; each
    subparser takes the module's ``add_arguments`` and its ``main`` as ``_main`` default.

    Returns
    -------
    argparse.ArgumentParser
        The ``terrain`` parser (global ``--debug``, a required ``COMMAND``).
    """
    # allow_abbrev=False: a prefix of an option is an error, not that option (``terrain cv
    # --seed 1`` ran a full cross-validation as ``--seeds 1``, unsaid)
    parser = argparse.ArgumentParser(
        prog="terrain", allow_abbrev=False,
        description="Terrain classification, slip estimation and simulation for field robots.")
    parser.add_argument("--debug", action="store_true",
                        help="show the full traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in SUBCOMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name == module_name:
                continue  # pipeline not part of this installation
            raise
        doc = (module.__doc__ or name).strip()
        sp = sub.add_parser(name, help=doc.splitlines()[0], description=doc,
                            formatter_class=_HelpFormatter, allow_abbrev=False)
        sp.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show the full traceback of an error")
        module.add_arguments(sp)
        sp.set_defaults(_main=module.main)
    for sp in sub.choices.values():
        for action in sp._actions:
            if action.help is None and (action.option_strings or action.choices):
                action.help = _NO_HELP  # argparse prints no help line without a help text
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """One line per warning on stderr (a :class:`~terrain.errors.DataWarning` is the
    reader telling what it assumed), instead of Python's two-line source display."""
    kind = "warning" if issubclass(category, DataWarning) else category.__name__
    print(f"terrain: {kind}: {message}", file=sys.stderr)


def _save_warnings() -> warnings.catch_warnings:
    """The warnings' state as it is (entered :class:`warnings.catch_warnings`)."""
    saved = warnings.catch_warnings()
    saved.__enter__()
    return saved


def _print_warnings_on_one_line(saved: warnings.catch_warnings) -> None:
    warnings.showwarning = _show_warning


_one_line_warnings = SharedSetting(_save_warnings, _print_warnings_on_one_line,
                                   lambda saved: saved.__exit__(None, None, None))
"""The warnings' state while any call of :func:`main` runs: :func:`_show_warning` prints
them; the first call to enter saves the state, the last to leave puts it back
(:class:`terrain.process_state.SharedSetting`; each call restoring what it had found left
the one-line printer installed for good when two calls ran at once in two threads)."""


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command stands so that it unwinds as after Ctrl-C (an open
    MLflow run ends ``FAILED``, temporary files go) instead of the process ending there."""


def _terminate(signum, frame) -> None:
    raise _Terminated()


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``terrain`` command; returns the process exit code.

    A project error (:class:`~terrain.errors.TerrainError`), a missing or unreadable file,
    or a model store error is printed as one line on stderr with exit status 2. Anything
    else (memory exhausted, a defect of terrain) is also one line, with exit status 1, and
    Ctrl-C prints ``interrupted`` with status 130 (also while the commands load); SIGTERM
    (``kill``, ``timeout``, a job scheduler) prints ``terminated`` with status 143 once the
    command has unwound (its MLflow run ended ``FAILED``). A reader
    that closes standard output early (``terrain slip-table | head``) ends the command
    quietly with status 141, as a shell reports a writer stopped by SIGPIPE. ``--debug``
    shows the traceback instead.

    Parameters
    ----------
    argv : sequence of str or None
        Command-line arguments without the program name; ``None`` reads ``sys.argv[1:]``.

    Returns
    -------
    int
        Exit status: the sub-command's (0 on success), 2 after a reported error (argparse
        itself exits with 2 on a usage error), 1 after an unexpected one, 130 after Ctrl-C,
        143 after SIGTERM, 141 when standard output was closed by its reader.
    """
    try:
        from pipelines.arguments import check_output_files
        from terrain.tracking import active_store, store_errors

        parser = build_parser()     # imports every pipeline
        args = parser.parse_args(argv)
        check_output_files(_command_parser(parser, args), args)
    except KeyboardInterrupt:
        print("terrain: interrupted", file=sys.stderr)
        return 130
    debug = getattr(args, "debug", False)
    # SIGTERM unwinds the command (signal handlers can be set from the main thread only: a
    # caller's thread keeps Python's default, which ends the process where it stands)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if main_thread else None
    try:
        with _one_line_warnings:
            try:
                # the entry point owns MLflow's process-wide store (model logging, the registry
                # and ``models:/`` URIs read it) while the command runs; the library never sets
                # it, and the caller of an in-process call finds it as it left it
                with active_store():
                    status = int(args._main(args) or 0)
                    sys.stdout.flush()  # a reader gone away fails here, not in Python's exit
                return status
            except BrokenPipeError:
                if debug:
                    raise
                _silence_stdout()
                return 141
            except (TerrainError, OSError) + store_errors() as exc:
                if debug:
                    raise
                print(f"terrain {args.command}: error: {_one_line(exc)}"
                      f"{_while_writing(exc, parser, args)}", file=sys.stderr)
                return 2
            except _Terminated:
                if debug:
                    raise
                print(f"terrain {args.command}: terminated (SIGTERM)", file=sys.stderr)
                return 143
            except KeyboardInterrupt:
                if debug:
                    raise
                print(f"terrain {args.command}: interrupted", file=sys.stderr)
                return 130
            except MemoryError as exc:
                if debug:
                    raise
                print(f"terrain {args.command}: error: not enough memory ({_one_line(exc)}); "
                      "ask for less (a shorter window, fewer resamples or a smaller grid)",
                      file=sys.stderr)
                return 1
            except Exception as exc:  # a defect of terrain itself: still one line, no traceback
                if debug:
                    raise
                print(f"terrain {args.command}: internal error: {type(exc).__name__}: "
                      f"{_one_line(exc)} (a defect of terrain, not of your input as far as it "
                      "could tell; rerun with --debug for the traceback and report it)",
                      file=sys.stderr)
                return 1
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def _silence_stdout() -> None:
    """Point standard output at the null device, so that the output still buffered is not
    flushed into the closed pipe again when Python exits (its "Exception ignored" lines)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, sys.stdout.fileno())
        finally:
            os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass    # not a file descriptor (captured output): nothing is flushed at exit


#: errors of a write that Python reports without the file's name
_WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def _while_writing(exc: BaseException, parser: argparse.ArgumentParser,
                   args: argparse.Namespace) -> str:
    """The output options of the command, for a write error that names no file (a full disk:
    ``[Errno 28] No space left on device`` alone), or ``""``."""
    from pipelines.arguments import OUTPUT_TYPES

    if not (isinstance(exc, OSError) and exc.filename is None and exc.errno in _WRITE_ERRNOS):
        return ""
    command = _command_parser(parser, args)
    outputs = [f"{action.option_strings[0]} {getattr(args, action.dest)}"
               for action in command._actions
               if action.type in OUTPUT_TYPES and action.option_strings
               and getattr(args, action.dest, None) is not None]
    if not outputs:
        return ""
    return (f" while writing {outputs[0]}" if len(outputs) == 1
            else f" while writing one of {', '.join(outputs)}")


def _command_parser(parser: argparse.ArgumentParser,
                    args: argparse.Namespace) -> argparse.ArgumentParser:
    """The sub-command parser of ``args.command``."""
    return parser._subparsers._group_actions[0].choices[args.command]


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename is not None:
        text = f"{exc.strerror or type(exc).__name__}: {exc.filename}"
    else:
        text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 500 else text[:497] + "..."


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
