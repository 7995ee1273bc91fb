"""Command-line options that several ``terrain`` subcommands share, defined once.

Each ``add_*`` function adds an option (``add_smoothing``: the forward filter's three) to a
sub-command's parser with one help text, so ``terrain cv``, ``train`` and ``compare``, and
``terrain stream`` and ``serve``, describe the same setting in the same words;
:func:`smoothing_from_args` reads the filter's options back as one :class:`SmoothingConfig`.
:func:`output_file` and :func:`output_dir` are the argparse types of every output option:
a path that cannot be written is refused before any work, not after it; :func:`seed_value`
is the type of every seed option.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import re
import tempfile
from pathlib import Path

from terrain.errors import ConfigError, duplicated
from terrain.io.measured import is_run_file_name
from terrain.models.experiment import MAX_SEED
from terrain.models.registry import MAX_CNN_SEEDS
from terrain.serving.smoothing import SmoothingConfig
from terrain.sim.simulate import MAX_DURATION_S
from terrain.terramechanics.catalogue import get_terrain


def _blocking_ancestor(path: Path) -> Path | None:
    """The first existing ancestor of ``path`` that is not a folder, or ``None``."""
    for parent in reversed(path.parents):
        if parent.exists() and not parent.is_dir():
            return parent
    return None


def _why(exc: OSError) -> str:
    """An error's reason without the path (``File name too long``)."""
    return exc.strerror or type(exc).__name__


def _refuse_loop(path: Path) -> None:
    """Raise the ``OSError`` of a path whose lookup runs through a symbolic link loop (ELOOP:
    ``exists`` says False, and ``Path.resolve`` raises ``RuntimeError``)."""
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise


def _exists(path: Path) -> bool:
    """``path.exists()``, False for a name the system refuses to look up (too long: the
    command's own reading then reports it, naming it)."""
    try:
        return path.exists()
    except OSError:
        return False


def _nearest_existing(path: Path) -> Path:
    """``path`` itself or its nearest existing ancestor (``.`` for a relative path)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path(".")


def _cannot_create_in(folder: Path) -> str | None:
    """Why no file can be created in the existing ``folder``, or ``None`` if one can.

    A permission test alone (``os.access``) says yes to root everywhere, also in a
    read-only or virtual file system (``/proc``) where nothing can be created; so a
    scratch file is created and removed.
    """
    if not os.access(folder, os.W_OK):
        return "no write permission"
    try:
        handle, name = tempfile.mkstemp(prefix=".terrain-write-test-", dir=folder)
    except OSError as exc:
        return exc.strerror or type(exc).__name__
    os.close(handle)
    os.unlink(name)
    return None


#: The one refusal of an empty or blank path, whatever the option (``--model ""``,
#: ``--data-dir ""``, ``--out ""``): an unset shell variable, not the option left out.
EMPTY_PATH = "an empty path (give a path, or leave the option out where it has a default)"


def _refuse_empty(value: str) -> None:
    """Refuse an empty or blank option value with :data:`EMPTY_PATH`."""
    if not value.strip():
        raise argparse.ArgumentTypeError(EMPTY_PATH)


def output_file(value: str) -> Path:
    """argparse ``type`` of an output file option: refuse, while the options are read and
    before any work, a path that could not be written.

    Parameters
    ----------
    value : str
        The option's value (a file path; missing parent folders are created later).

    Returns
    -------
    pathlib.Path
        ``value`` as a path.

    Raises
    ------
    argparse.ArgumentTypeError
        The value is empty, a name the system refuses (too long, or a symbolic link loop),
        an ancestor of the path is a file, the path ends with a slash or is an existing
        folder or a file without write permission, or no file can be created in the nearest
        existing folder (tried with a scratch file, removed at once; argparse prints the
        error as a one-line usage error).
    """
    _refuse_empty(value)
    if value.endswith(("/", os.sep)):     # Path drops the slash: 'out/' became a file 'out'
        raise argparse.ArgumentTypeError(
            f"cannot write {value!r}: it names a folder (give a file name)")
    path = Path(value)
    try:
        _refuse_loop(path)
        blocker = _blocking_ancestor(path)
        if blocker is not None:
            raise argparse.ArgumentTypeError(
                f"cannot write {value!r}: {str(blocker)!r} is a file, not a folder")
        if path.is_dir():
            raise argparse.ArgumentTypeError(
                f"cannot write {value!r}: it is a folder (give a file name)")
        if path.exists():
            if not os.access(path, os.W_OK):
                raise argparse.ArgumentTypeError(
                    f"cannot write {value!r}: no write permission on {value!r}")
            return path
        base = _nearest_existing(path.parent)
    except OSError as exc:      # a name the system refuses to look up (too long, a loop)
        raise argparse.ArgumentTypeError(f"cannot write {value!r}: {_why(exc)}") from None
    why = _cannot_create_in(base)
    if why is not None:
        raise argparse.ArgumentTypeError(
            f"cannot write {value!r}: cannot create a file in {str(base)!r} ({why})")
    return path


def output_dir(value: str) -> Path:
    """argparse ``type`` of an output folder option: refuse, while the options are read and
    before any work, a folder that could not be created or written.

    Parameters
    ----------
    value : str
        The option's value (a folder; created later if missing).

    Returns
    -------
    pathlib.Path
        ``value`` as a path.

    Raises
    ------
    argparse.ArgumentTypeError
        The value is empty, a name the system refuses (too long, or a symbolic link loop),
        the path or one of its ancestors is a file, or no file can be created in the nearest
        existing folder (tried with a scratch file, removed at once; argparse prints the
        error as a one-line usage error).
    """
    _refuse_empty(value)
    path = Path(value)
    try:
        _refuse_loop(path)
        blocker = path if path.exists() and not path.is_dir() else _blocking_ancestor(path)
        base = _nearest_existing(path)
    except OSError as exc:      # a name the system refuses to look up (too long, a loop)
        raise argparse.ArgumentTypeError(
            f"cannot use {value!r} as output folder: {_why(exc)}") from None
    if blocker is not None:
        raise argparse.ArgumentTypeError(
            f"cannot use {value!r} as output folder: {str(blocker)!r} is a file")
    why = _cannot_create_in(base)
    if why is not None:
        raise argparse.ArgumentTypeError(
            f"cannot use {value!r} as output folder: cannot create a file in {str(base)!r} "
            f"({why})")
    return path


def input_path(value: str) -> str:
    """argparse ``type`` of an option naming a file, folder or URI the command reads, whose
    absence means a default: an empty value is refused, not taken as the option left out.

    Parameters
    ----------
    value : str
        The option's value.

    Returns
    -------
    str
        ``value`` unchanged (a path or an MLflow URI; read later, where a missing one is a
        typed error naming it).

    Raises
    ------
    argparse.ArgumentTypeError
        The value is empty or blank (``--model ""`` fell back to the default source).
    """
    _refuse_empty(value)
    return value


def input_folder(value: str) -> Path:
    """argparse ``type`` of an argument naming a folder the command reads: as
    :func:`input_path`, so an empty value is refused rather than taken as ``Path("")``, the
    working folder.

    Parameters
    ----------
    value : str
        The argument's value.

    Returns
    -------
    pathlib.Path
        ``value`` as a path (read later, where a missing one is a typed error naming it).

    Raises
    ------
    argparse.ArgumentTypeError
        The value is empty or blank (``terrain predict --model M ""`` read the runs of the
        working folder).
    """
    return Path(input_path(value))


def model_folder(value: str) -> Path:
    """argparse ``type`` of ``--model`` of a command that reads a model directory only
    (``terrain stream``, ``terrain serve``): as :func:`input_folder`, and a model URI is
    refused by name (``models:/terrain-borealtc/latest`` was reported as "model directory
    models:/terrain-borealtc/latest does not exist", ``http://x/y`` as ``http:/x/y``).

    Parameters
    ----------
    value : str
        The option's value.

    Returns
    -------
    pathlib.Path
        ``value`` as a path.

    Raises
    ------
    argparse.ArgumentTypeError
        The value is empty or blank, or a URI (a scheme of two or more characters and a
        colon: ``models:``, ``runs:``, ``http:``; a drive letter such as ``C:`` is a path).
    """
    _refuse_empty(value)
    if re.match(r"[A-Za-z][A-Za-z0-9+.-]+:", value):
        raise argparse.ArgumentTypeError(
            f"{value!r} is a URI: this command reads a model directory (terrain train "
            "--model-out DIR); terrain predict reads models:/ and runs:/ URIs")
    return Path(value)


def model_dir(value: str) -> Path:
    """argparse ``type`` of an option naming a model directory to create: as
    :func:`output_dir`, and the folder must be absent or empty (MLflow writes a model only
    there), checked before the model is trained rather than after.

    Parameters
    ----------
    value : str
        The option's value.

    Returns
    -------
    pathlib.Path
        ``value`` as a path.

    Raises
    ------
    argparse.ArgumentTypeError
        As :func:`output_dir`, or the folder exists and is not empty or cannot be listed.
    """
    path = output_dir(value)
    try:
        full = path.is_dir() and any(path.iterdir())
    except OSError as exc:      # a folder one may write into but not list (mode -wx)
        raise argparse.ArgumentTypeError(
            f"cannot use {value!r} as model directory: {_why(exc)}") from None
    if full:
        raise argparse.ArgumentTypeError(
            f"model directory {value!r} exists and is not empty (give a new or empty one)")
    return path


#: argparse ``type`` of every option naming a file or folder the command writes: an error
#: while writing that names no file (a full disk) is reported naming these options
OUTPUT_TYPES = (output_file, output_dir, model_dir)


def check_output_files(command: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse, once every option is read and before any work, an output file that another
    output option names too, or that would overwrite what the command reads.

    An output file is refused where it is a file or folder given as an input, lies in an
    input model directory (one holding ``MLmodel``), or is named like a run file
    (:func:`terrain.io.measured.is_run_file_name`) in an input runs folder or one of its
    terrain folders. Other files beside the inputs (``runs/predictions.csv``) are taken.

    Parameters
    ----------
    command : argparse.ArgumentParser
        The sub-command's parser (its actions with an :data:`OUTPUT_TYPES` type are the
        outputs, those naming an existing path the inputs).
    args : argparse.Namespace
        Its parsed arguments.

    Raises
    ------
    SystemExit
        Through ``command.error``: argparse's usage lines and a one-line error naming the
        option, exit status 2.
    """
    outputs, inputs = [], []
    for action in command._actions:
        value = getattr(args, action.dest, None)
        if not isinstance(value, (str, Path)) or not str(value).strip():
            continue
        name = action.option_strings[0] if action.option_strings else action.dest
        if action.type is output_file:
            outputs.append((name, Path(value)))
        elif action.type not in OUTPUT_TYPES and action.choices is None \
                and _exists(Path(value)):
            inputs.append((str(value), Path(value).resolve()))
    seen: dict[Path, str] = {}
    for name, path in outputs:
        target = path.resolve()
        if target in seen:
            command.error(f"argument {name}: {str(path)!r} is the file of {seen[target]} too "
                          "(give each output its own file)")
        seen[target] = name
        why = _overwritten_input(target, inputs)
        if why:
            command.error(f"argument {name}: cannot write {str(path)!r}: {why}")


def check_derived_output(option: str, path: Path, inputs: list[Path | None]) -> None:
    """Refuse a file whose name a command derives from an output option's value (``terrain
    estimate --out`` writes one file per run beside it) as :func:`output_file` and
    :func:`check_output_files` refuse the option's own file, before the command writes any.

    Parameters
    ----------
    option : str
        The output option the name derives from (``--out``), named in the error.
    path : pathlib.Path
        The derived file.
    inputs : list of pathlib.Path or None
        The command's inputs (``None`` for an input option left out).

    Raises
    ------
    ConfigError
        ``path`` could not be written (:func:`output_file`), or writing it would overwrite
        an input (a run file of an input runs folder, a file in an input model directory).
    """
    try:
        output_file(str(path))
    except argparse.ArgumentTypeError as exc:
        raise ConfigError(f"{option}: {exc}") from None
    given = [(str(p), Path(p).resolve()) for p in inputs if p is not None and _exists(Path(p))]
    why = _overwritten_input(path.resolve(), given)
    if why:
        raise ConfigError(f"{option}: cannot write {str(path)!r}: {why}")


def _overwritten_input(target: Path, inputs: list[tuple[str, Path]]) -> str | None:
    """Why writing the resolved ``target`` would overwrite one of the ``inputs`` (each as
    given and resolved), or ``None``."""
    for shown, source in inputs:
        if target == source:
            return "it is an input of this command"
        if source.is_dir() and source in target.parents:
            if (source / "MLmodel").is_file():
                return f"it lies in the input model directory {shown!r}"
            if source in (target.parent, target.parent.parent) \
                    and is_run_file_name(target.name):
                return (f"it is named like a run file of the input runs folder "
                        f"{shown!r} (write the output elsewhere)")
    return None


def positive_number(value: str) -> float:
    """argparse ``type`` of an option that takes a finite number > 0 (a window length, hop or
    cut-off), so a bad value is refused with the option's name rather than the name of the
    configuration field it fills.

    Parameters
    ----------
    value : str
        The option's text.

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        Not a number, or not finite and > 0.
    """
    return parse_number(value, lambda x: 0 < x < math.inf, "a finite number > 0")


def sim_duration_s(value: str) -> float:
    """argparse ``type`` of a simulated run's ``--duration-s``: a finite number in
    ``(0, MAX_DURATION_S]`` s (:class:`terrain.sim.SimConfig`'s range), refused with the
    option's name rather than the configuration field's (``terrain simulate``,
    ``control-sim``, ``control-grid``; the vehicle's minimum needs the vehicle and stays
    with :class:`~terrain.sim.SimConfig`).

    Parameters
    ----------
    value : str
        The option's text, s.

    Returns
    -------
    float
        Simulated time, s.

    Raises
    ------
    argparse.ArgumentTypeError
        Not a number, or not in ``(0, MAX_DURATION_S]`` (NaN and inf included).
    """
    return parse_number(value, lambda x: 0 < x <= MAX_DURATION_S,
                        f"a finite number in (0, {MAX_DURATION_S:g}] s")


def terrain_name(value: str) -> str:
    """argparse ``type`` of a catalogue terrain name (any case), so an unknown name is
    refused with the option's name before any run is simulated (benchmarks' ``--terrains``).

    Parameters
    ----------
    value : str
        The option's text.

    Returns
    -------
    str
        The catalogue's name (``"ice"`` -> ``"ICE"``).

    Raises
    ------
    argparse.ArgumentTypeError
        Not a name of :data:`terrain.terramechanics.catalogue.TERRAIN_NAMES` (the message
        lists them).
    """
    try:
        return get_terrain(value).name
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def non_negative_number(value: str) -> float:
    """argparse ``type`` of an option that takes a finite number >= 0 (a controller gain),
    refused with the option's name rather than the configuration field's.

    Parameters
    ----------
    value : str
        The option's text.

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        Not a number, or not finite and >= 0.
    """
    return parse_number(value, lambda x: 0 <= x < math.inf, "a finite number >= 0")


def parse_number(value: str, accept, wording: str) -> float:
    """An option's text as a float that ``accept`` takes: the one parse of every number
    argparse ``type``.

    Parameters
    ----------
    value : str
        The option's text.
    accept : callable
        ``float -> bool``: True for an accepted value (NaN must fail it).
    wording : str
        What the option takes, for the message (``"a finite number > 0"``).

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        Not a number (``not a number: 'x'``), or a number ``accept`` refuses (``must be
        <wording>, got <value>``).
    """
    try:
        number = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {value!r}") from None
    if not accept(number):
        raise argparse.ArgumentTypeError(f"must be {wording}, got {value}")
    return number


def parse_integer(value: str, refusal: str) -> int:
    """An option's text as an integer: the one parse of every integer argparse ``type``.

    Parameters
    ----------
    value : str
        The option's text.
    refusal : str
        Start of the message for text that is not an integer (the text's ``repr`` follows).

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        ``value`` is not an integer.
    """
    try:
        return int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{refusal}{value!r}") from None


def positive_integer(value: str) -> int:
    """argparse ``type`` of an option that takes an integer >= 1 (threads, epochs, a count).

    Parameters
    ----------
    value : str
        The option's text.

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        Not an integer, or below 1.
    """
    number = parse_integer(value, "not an integer: ")
    if number < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {value}")
    return number


def integer_up_to(high: int):
    """argparse ``type`` of an option that takes an integer in ``1..high``, so the upper limit
    (kept with its configuration field, e.g. :data:`terrain.models.registry.MAX_CNN_SEEDS`) is
    refused with the option's name rather than the field's.

    Parameters
    ----------
    high : int
        Largest value accepted (>= 1).

    Returns
    -------
    callable
        ``str -> int``; raises ``argparse.ArgumentTypeError`` for text that is not an integer
        or an integer outside ``1..high``.
    """
    def parse(value: str) -> int:
        number = positive_integer(value)
        if number > high:
            raise argparse.ArgumentTypeError(f"must be an integer in 1-{high}, got {value}")
        return number

    parse.__name__ = f"integer_up_to_{high}"
    return parse


def integer_in(low: int, high: int):
    """argparse ``type`` of an option that takes an integer in ``low..high`` (a setting's
    range, kept with its configuration, e.g. :data:`terrain.audit.selection.MAX_BOOTSTRAP`),
    refused with the option's name rather than the setting's.

    Parameters
    ----------
    low, high : int
        Smallest and largest value accepted.

    Returns
    -------
    callable
        ``str -> int``; raises ``argparse.ArgumentTypeError`` for text that is not an integer
        (``not an integer: 'x'``) or one outside ``low..high`` (``must be an integer in
        10-100,000, got 0``).
    """
    def parse(value: str) -> int:
        number = parse_integer(value, "not an integer: ")
        if not low <= number <= high:
            raise argparse.ArgumentTypeError(
                f"must be an integer in {low}-{high:,}, got {value}")
        return number

    parse.__name__ = f"integer_in_{low}_{high}"
    return parse


def probability(value: str) -> float:
    """argparse ``type`` of an option that takes a probability in [0, 1] (a confidence).

    Parameters
    ----------
    value : str
        The option's text.

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        Not a number, or outside [0, 1] (NaN included).
    """
    return parse_number(value, lambda x: 0 <= x <= 1, "a probability in [0, 1]")


def seed_value(value: str) -> int:
    """argparse ``type`` of a seed option: an integer in ``0..MAX_SEED``
    (:data:`terrain.models.experiment.MAX_SEED`).

    Parameters
    ----------
    value : str
        The option's text.

    Returns
    -------
    int
        The seed.

    Raises
    ------
    argparse.ArgumentTypeError
        Not an integer, negative or above ``MAX_SEED`` (scikit-learn's splitters seed
        ``numpy.random.RandomState``, which takes no other value).
    """
    number = parse_integer(value, "a seed is an integer, got ")
    if not 0 <= number <= MAX_SEED:
        raise argparse.ArgumentTypeError(
            f"a seed is an integer in 0-{MAX_SEED} (NumPy's seed range), got {value}")
    return number


class DistinctValues(argparse.Action):
    """argparse action of a list option (``nargs="+"``): each value at most once.

    A repeated value (``--models svm svm``, ``--terrains ICE ICE``) would run the same cell
    twice and count it as two, or log one name's figures twice under one key. argparse
    reports the error as a usage error naming the option.
    """

    what = "value(s)"
    why = "each once: a repeated value runs and counts one cell twice"

    def __call__(self, parser, namespace, values, option_string=None):
        repeated = duplicated(values)
        if repeated:
            parser.error(f"argument {option_string or self.dest}: {self.what} "
                         f"{', '.join(map(str, repeated))} given twice ({self.why})")
        setattr(namespace, self.dest, list(values))


class DistinctSeeds(DistinctValues):
    """argparse action of a seed-list option (``nargs="+"``, ``type=seed_value``): each seed
    at most once.

    A repeated seed would run the same split or simulation twice and count it as two: the
    spread over seeds would shrink and the pooled counts double one split. argparse reports
    the error as a usage error naming the option.
    """

    what = "seed(s)"
    why = "each seed once: a repeated seed counts one run of it twice"


def add_cnn_seeds(parser: argparse.ArgumentParser, default: int = 1) -> None:
    """Add ``--cnn-seeds`` (seed bagging of every CNN; :attr:`ModelConfig.cnn_seeds`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser (modified in place).
    default : int
        Networks per CNN when the option is not given (>= 1).
    """
    parser.add_argument("--cnn-seeds", type=integer_up_to(MAX_CNN_SEEDS), default=default,
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
                             "stand for its terrain; docs/streaming.md; not with "
                             "--window-ekf)")


def add_train_hop(parser: argparse.ArgumentParser) -> None:
    """Add ``--train-hop-s`` of the cross-validating commands (training windows' hop).

    ``terrain train`` has its own, since its default depends on the dataset.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        Sub-command parser (modified in place).
    """
    parser.add_argument("--train-hop-s", type=positive_number, default=None,
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
    parser.add_argument("--reset-confidence", type=probability, default=None,
                        help="reset the filter to the window's probabilities when "
                             "--reset-windows consecutive windows name the same other class "
                             "with at least this probability (default: no reset; "
                             "docs/streaming.md)")
    parser.add_argument("--reset-windows", type=positive_integer, default=None,
                        help="consecutive confident windows that reset the filter (default 2; "
                             "needs --reset-confidence)")


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
        A value out of its range (a negative dwell, a reset without the filter...), or
        ``--reset-windows`` without ``--reset-confidence``.
    """
    if not 0 <= args.dwell_s < math.inf:   # inf reached SmoothingConfig's own message
        raise ConfigError(f"--dwell-s must be a finite number >= 0 (0 disables smoothing), "
                          f"got {args.dwell_s:g}")
    if args.reset_windows is not None and args.reset_confidence is None:
        # the reset is off without a confidence: the count alone would change nothing
        raise ConfigError(f"--reset-windows {args.reset_windows} needs --reset-confidence (the "
                          "filter's switch reset is off without it)")
    if args.reset_confidence is not None:
        if args.reset_confidence == 0:
            # every window would reset the filter: no smoothing, said the wrong way
            raise ConfigError("--reset-confidence must be > 0 (at 0 every window resets the "
                              "filter; --dwell-s 0 turns smoothing off)")
        if args.dwell_s == 0:
            raise ConfigError("--reset-confidence resets the forward filter, which --dwell-s 0 "
                              "turns off")
    windows = {} if args.reset_windows is None else {"reset_windows": args.reset_windows}
    return SmoothingConfig(dwell_s=args.dwell_s or None,
                           reset_confidence=args.reset_confidence, **windows)


def option_params(args: argparse.Namespace, leave_out: tuple[str, ...] = ()) -> dict:
    """A command's options as MLflow run parameters.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options; names starting with ``_`` are the CLI's own (``_main``, the
        sub-command's function, which MLflow logged as ``<function main at 0x...>``, a
        value that changes from run to run) and are left out.
    leave_out : tuple of str
        Further option names not to log (e.g. machine-specific paths).

    Returns
    -------
    dict
        Option name -> value, as given.
    """
    return {k: v for k, v in vars(args).items() if not k.startswith("_") and k not in leave_out}
