"""Typed errors raised by the library.

Every error that concerns input data names the file, the column and the **file line** (1-based,
as an editor shows it, header and blank lines included) where it is known, so a user can open
the file and find the problem. Messages stay short: the first offending lines and a count,
never a dump (:func:`first_items`).

Warnings about input that is only *likely* wrong (a plausibility rule that is not certain, a
stuck sensor) are :class:`DataWarning`: they say what the reader assumed and never rescale.
"""

from __future__ import annotations

import numbers

import numpy as np


class TerrainError(Exception):
    """Base class of every error raised on purpose by :mod:`terrain`."""


class DataFormatError(TerrainError, ValueError):
    """A data file does not follow the expected format.

    Parameters
    ----------
    message : str
        What is wrong.
    path : str or None
        File that holds the problem (None or ``""``: not named in the message).
    column : str or None
        Column that holds the problem, as named in the file.
    row : int or None
        0-based data row (header, blank and comment lines excluded) of the first offending
        value.
    line : int or None
        1-based line of the file holding the first offending value (what an editor shows).
    """

    def __init__(self, message: str, path: str | None = None, column: str | None = None,
                 row: int | None = None, line: int | None = None) -> None:
        self.message = message
        self.path = None if path is None else str(path)
        self.column = column
        self.row = row
        self.line = line
        where = []
        if path is not None and str(path):     # (an in-memory run's source is "")
            where.append(f"file {path}")
        if column is not None:
            where.append(f"column {column!r}")
        if line is not None:
            where.append(f"line {line}")
        elif row is not None:
            where.append(f"data row {row} (0-based)")
        super().__init__(f"{message} ({', '.join(where)})" if where else message)


class MissingColumnError(DataFormatError):
    """A required column is missing or renamed."""


class NonNumericError(DataFormatError):
    """A value that must be numeric is not."""


class NonFiniteError(DataFormatError):
    """A burst of NaN or infinite values that the reader may not repair."""


class TimestampError(DataFormatError):
    """Timestamps are not strictly increasing (duplicated or going back)."""


class EmptyFileError(DataFormatError):
    """A file has no data rows."""


class OrphanFileError(DataFormatError):
    """A stream file whose run has no wheel (``pro_``) file."""


class UnreadableFileError(DataFormatError):
    """A path where a data file is expected is a directory, a symlink loop, or unreadable."""


class EncodingError(DataFormatError):
    """A file holds bytes that are not UTF-8 text; the message gives the byte offset."""


class RaggedRowError(DataFormatError):
    """Data rows whose number of fields differs from the header's."""


class ImplausibleValueError(DataFormatError):
    """A value outside the physical plausibility range of its channel (sensor full scale,
    vehicle top speed, motor current), see :mod:`terrain.io.plausibility`."""


class UnitError(DataFormatError):
    """A plausibility rule is certain that a channel is in the wrong unit (deg/s for rad/s,
    km/h for m/s, ms, us or ns for s). The message names the rule, its evidence and the
    likely fix."""


class ClockError(DataFormatError):
    """The streams of one run do not share a clock (their time spans do not overlap)."""


class ServiceBusyError(TerrainError):
    """The served model answers as many requests as it may at once: retry shortly."""


class EndpointError(TerrainError):
    """A request the served model's HTTP front cannot route: see the subclasses."""


class UnknownEndpointError(EndpointError):
    """A request to a path the served model does not answer (HTTP 404)."""


class MethodNotAllowedError(EndpointError):
    """A request with a method its endpoint does not take (HTTP 405)."""


class DataWarning(UserWarning):
    """Input that is probably, not certainly, wrong: the message says what was assumed."""


def first_items(items, limit: int = 3, word: str = "line") -> str:
    """Short list of the first offending items and the count of the others.

    Parameters
    ----------
    items : sequence
        Offending items (e.g. file lines), in file order.
    limit : int
        How many to show.
    word : str
        Singular noun of the items (an ``s`` is appended for several).

    Returns
    -------
    str
        E.g. ``"lines 4, 9, 12 and 37 more"``.
    """
    items = list(items)
    shown = ", ".join(str(i) for i in items[:limit])
    more = f" and {len(items) - limit} more" if len(items) > limit else ""
    return f"{word}{'s' if len(items) > 1 else ''} {shown}{more}"


def listed(items, limit: int = 5, show=None) -> str:
    """The first items of a list as a message shows them (a list's repr) and a count of the
    others: ``['a', 'b', 'c', 'd', 'e'] and 4995 more``, so a message stays one short line
    however many columns, keys or runs are wrong.

    Parameters
    ----------
    items : sequence
        The items, in the order to show them.
    limit : int, optional
        How many to show.
    show : callable, optional
        Applied to each shown item (e.g. to cut long names); default: the item itself.

    Returns
    -------
    str
    """
    items = list(items)
    shown = [item if show is None else show(item) for item in items[:limit]]
    return f"{shown}" + (f" and {len(items) - limit} more" if len(items) > limit else "")


def duplicated(items) -> list:
    """The items that occur more than once, sorted (linear time: a request of 50 000 column
    names took 45 s with ``list.count`` per name).

    Parameters
    ----------
    items : iterable of hashable
        Names, e.g. a header's columns (unhashable or mixed types are the caller's to
        refuse first).

    Returns
    -------
    list
        Each repeated item once, sorted.
    """
    from collections import Counter

    return sorted(c for c, n in Counter(items).items() if n > 1)


def holds_booleans(x) -> bool:
    """Whether ``x`` is a boolean or holds booleans, where numbers are meant (``float(True)``
    is 1: a mask passed by mistake became commands of 1 m/s or a unit covariance).

    The one test behind the refusals of the traction step, the feed-forward, the EKF's inputs
    and the simulator's commands (each raises its own typed error). A Python float and a
    NumPy array of numbers pass on one type test (the per-step callers); a list is looked
    into entry by entry only when NumPy converted it to numbers or objects.

    Parameters
    ----------
    x : object
        A scalar, an array (anything with a ``dtype``: NumPy, pandas) or a list/tuple.

    Returns
    -------
    bool
        True for a Python or NumPy boolean, an array of boolean dtype (pandas' nullable
        ``boolean`` included), or a list/tuple that converts to booleans or holds one among
        numbers (``[0.5, True]``, which NumPy converted to ``[0.5, 1.0]``; nested lists and
        0-d boolean arrays included); False otherwise (a ragged list included: its
        conversion names it). An object array or column is judged by its dtype only: the
        readers' and the features' own rule (:func:`first_non_number_cell`) names the row
        of a boolean in it.
    """
    kind_x = type(x)
    if kind_x is float or kind_x is np.float64:
        return False
    if kind_x is np.ndarray:
        return x.dtype.kind == "b"
    dtype = getattr(x, "dtype", None)
    if dtype is not None:   # (pandas' nullable ``boolean`` is kind "b" but not == bool)
        kind = getattr(dtype, "kind", None)
        return kind == "b" or (kind is None and dtype == bool)
    if isinstance(x, (list, tuple)):
        return first_boolean(x) is not None
    return isinstance(x, bool)


def first_boolean(x) -> tuple[int, object] | None:
    """The first boolean among the entries of a list, tuple or object array, as
    ``(index, entry)``, or None (:func:`holds_booleans`' look into a list).

    Parameters
    ----------
    x : list, tuple or array_like
        Values, possibly nested (equal lengths).

    Returns
    -------
    tuple or None
        The 0-based index in the flattened (row-major) entries and the entry itself (a Python
        or NumPy boolean, or a 0-d boolean array); ``(0, x)`` where the whole of ``x``
        converts to a boolean array; None where no entry is a boolean, or where ``x`` does
        not convert to an array (a ragged list: its conversion names it).
    """
    try:
        array = x if isinstance(x, np.ndarray) else np.asarray(x)
        if array.dtype.kind == "b":
            return (0, x)
        if array.dtype.kind not in "iufcO":     # (text: the booleans became text)
            return None
        if array.dtype.kind == "O":
            cells = array.ravel()
        elif array.ndim == 1 and not isinstance(x, np.ndarray):
            cells = x                           # (a flat list: its entries as they are)
        else:
            cells = np.asarray(x, dtype=object).ravel()
    except (TypeError, ValueError):
        return None
    for k, cell in enumerate(cells):
        if type(cell) is not float and (isinstance(cell, (bool, np.bool_))
                                        or getattr(cell, "dtype", None) == bool):
            return (k, cell)
    return None


def refuse_unreal(owner: str, optional: tuple = (), **inputs) -> None:
    """Raise a :class:`DataFormatError` naming the first of ``inputs`` that does not convert
    to real numbers (text, a ragged list, a complex scalar, ``None`` where a number is
    needed): the slow path of the control steps, run only once NumPy's conversion failed,
    whose message named no input.

    Parameters
    ----------
    owner : str
        The refusing function, for the message.
    optional : tuple of str
        Inputs that may be ``None`` (not given).
    **inputs
        Input name -> scalar or array-like, in the order they are judged.

    Raises
    ------
    DataFormatError
        ``<owner>: <name> must hold real numbers (<NumPy's reason>)``, with ``column`` the
        input's name.
    """
    for name, x in inputs.items():
        if x is None and name in optional:
            continue
        try:
            if np.ndim(x) == 0:
                float(x)
            else:
                np.asarray(x, dtype=float)
        except (TypeError, ValueError) as exc:
            raise DataFormatError(f"{owner}: {name} must hold real numbers ({exc})",
                                  column=name) from None


def refuse_booleans(error: type[TerrainError], owner: str | None = None, **values) -> None:
    """Raise ``error`` naming the first of ``values`` that holds booleans where numbers are
    meant (:func:`holds_booleans`): the shared refusal of the slip, odometry, lag,
    consistency, observer and simulator inputs, each with its own typed error.

    Parameters
    ----------
    error : type
        The :class:`TerrainError` subclass to raise (its first argument is the message).
    owner : str or None
        The function or object refusing, put before the name in the message.
    **values
        Argument name -> value, checked in order.

    Raises
    ------
    TerrainError
        ``error``: "[<owner>: ]<name> must hold numbers, got booleans", followed, for a
        boolean among numbers (``[0.5, True]``), by "(<type> <entry> at index <k> is not a
        real number)", the flattened index (:func:`first_boolean`).
    """
    for name, value in values.items():
        if holds_booleans(value):
            where = f"{owner}: " if owner else ""
            found = (first_boolean(value) if isinstance(value, (list, tuple, np.ndarray))
                     else None)
            entry = ""
            if found is not None and found[1] is not value:     # (one among numbers)
                k, cell = found
                entry = f" ({type(cell).__name__} {cell!r:.30} at index {k} is not a real number)"
            raise error(f"{where}{name} must hold numbers, got booleans{entry}")


def real_arrays(owner: str, boolean_error: type[TerrainError] | None = None,
                **inputs) -> list[np.ndarray]:
    """The inputs of a feature calculator as float arrays, each refusal naming its input:
    booleans (:func:`refuse_booleans`: a mask was read as samples of 0 and 1), then what
    does not convert to real numbers (:func:`refuse_unreal`: text failed inside NumPy,
    naming no input). The one rule of the window statistics, the drive-physics, EKF-channel
    and slip features.

    Parameters
    ----------
    owner : str
        The refusing function, for the message.
    boolean_error : type or None
        The :class:`TerrainError` subclass raised for booleans (None: :class:`DataFormatError`).
    **inputs
        Input name -> array-like of numbers (any shape), in order.

    Returns
    -------
    list of numpy.ndarray
        ``np.asarray(value, dtype=float)`` of each input, in the order given.

    Raises
    ------
    TerrainError
        ``boolean_error`` for an input holding booleans; :class:`DataFormatError` for one
        that does not convert to real numbers (its name as ``column``).
    """
    refuse_booleans(boolean_error or DataFormatError, owner, **inputs)
    try:
        return [np.asarray(value, dtype=float) for value in inputs.values()]
    except (TypeError, ValueError):
        refuse_unreal(owner, **inputs)
        raise


def refuse_missing(owner: str, name: str, values, what: str, why: str = "") -> None:
    """Raise :class:`NonFiniteInputError` where ``values`` hold a missing entry (NaN or
    None, as :func:`pandas.isna` reads them): the shared refusal of missing labels and runs
    in the models (pandas' ``groupby`` leaves such a window out, NumPy's ``unique`` counts
    every NaN once or apart, ``astype(str)`` makes it the class ``'nan'``).

    Parameters
    ----------
    owner : str
        The function or object refusing, put first in the message.
    name : str
        The argument's name.
    values : array_like
        ``(n,)`` labels or run ids.
    what : str
        What an entry is, plural form, e.g. ``"label(s)"``, ``"run(s)"``.
    why : str
        Appended after a colon where not empty.

    Raises
    ------
    NonFiniteInputError
        "<owner>: <name> holds <count> missing <what> (NaN or None), the first at index
        <i>[: <why>]".
    """
    import pandas as pd

    missing = np.flatnonzero(pd.isna(np.asarray(values, dtype=object)))
    if missing.size:
        raise NonFiniteInputError(f"{owner}: {name} holds {missing.size} missing {what} (NaN "
                                  f"or None), the first at index {missing[0]}"
                                  + (f": {why}" if why else ""))


def refuse_infinite(owner: str, X, names=None, why: str = "", name: str = "X",
                    flat: bool = False) -> None:
    """Raise :class:`NonFiniteInputError` where ``X`` holds an infinite value, naming the
    count and the first one (NaN passes: a missing value, which the tree models send down
    a learned branch and the physical relations return as a NaN); the shared refusal of the
    tree models (scikit-learn's trees took inf as the largest value, without a word) and of
    the relations whose argument may be missing but not infinite
    (:func:`terrain.terramechanics.resistance.grade_resistance_n`).

    Parameters
    ----------
    owner : str
        The function or object refusing, put first in the message.
    X : array_like
        Real values of any shape: a ``(n_rows, n_features)`` feature matrix is named by
        column and row, any other shape (a vector, a scalar) by flat index.
    names : sequence of str, optional
        ``(n_features,)`` the columns' names of a 2-D ``X``; None: a column is named by its
        0-based position.
    why : str
        Appended after a colon where not empty.
    name : str
        The argument's name (``"X"``, a feature matrix, unless told).
    flat : bool
        Name the first infinite value by its flat index whatever the shape (an argument that
        is no feature matrix, e.g. a 2-D array of pitch angles).

    Raises
    ------
    NonFiniteInputError
        "<owner>: <name> holds <count> infinite value(s), the first in column <column>, row
        <i> (0-based)[: <why>]" for a 2-D ``X`` (unless ``flat``); "... the first at flat
        index <i>[: <why>]" for any other shape (a 1-D or 0-D ``X`` was NumPy's bare
        ValueError).
    """
    bad = np.isinf(X)
    if bad.any():
        if bad.ndim == 2 and not flat:
            rows, cols = np.nonzero(bad)        # (row-major: the first row first)
            column = repr(str(names[cols[0]])) if names is not None else str(cols[0])
            where = f"in column {column}, row {rows[0]} (0-based)"
        else:
            where = f"at flat index {int(np.flatnonzero(bad)[0])}"
        raise NonFiniteInputError(f"{owner}: {name} holds {int(bad.sum())} infinite value(s), "
                                  f"the first {where}" + (f": {why}" if why else ""))


def _type_family(kind: type) -> object:
    """The family of a label's type: booleans (Python's and NumPy's), numbers (Python's and
    NumPy's integers and floats), text (``str``, ``numpy.str_``), bytes, or the type
    itself."""
    if issubclass(kind, (bool, np.bool_)):
        return bool
    if issubclass(kind, numbers.Real):
        return numbers.Real
    for family in (str, bytes):
        if issubclass(kind, family):
            return family
    return kind


def refuse_mixed_types(owner: str, name: str, values) -> None:
    """Raise :class:`MixedTypesError` where ``values`` mix types that do not sort together
    (text beside numbers, bytes beside text, e.g. ``np.array([1, "r2"], dtype=object)``) or
    booleans beside numbers: the shared refusal of labels and runs before the models sort
    them (NumPy's ``unique`` and ``sorted`` failed with the bare "'<' not supported between
    instances of 'str' and 'int'", naming no argument; ``True`` equals ``1``, so a mask
    beside numbers merged two labels without a word).

    Python's and NumPy's numbers (integers, floats) are one family and pass, as are
    booleans alone, and anything NumPy reads as one dtype (a list of ``1`` and ``"r2"``
    reads as text); only an object array is judged. Missing entries are
    :func:`refuse_missing`'s, judged first.

    Parameters
    ----------
    owner : str
        The function or object refusing, put first in the message.
    name : str
        The argument's name.
    values : array_like
        ``(n,)`` labels or run ids.

    Raises
    ------
    MixedTypesError
        "<owner>: <name> mixes values of type <first> and <second> (the first <second> at
        index <i>): NumPy cannot sort them; give every one the same type (e.g. all text)"
        (booleans beside numbers: "True equals 1 and False 0, so two labels would be
        one").
    """
    flat = np.asarray(values)
    if flat.dtype != object:
        return
    flat = flat.ravel()
    kinds = set(map(type, flat.tolist()))
    if len({_type_family(kind) for kind in kinds}) < 2:
        return
    family = _type_family(type(flat[0]))
    index = next(i for i, v in enumerate(flat) if _type_family(type(v)) is not family)
    first, second = type(flat[0]).__name__, type(flat[index]).__name__
    why = ("True equals 1 and False 0, so two labels would be one"
           if {family, _type_family(type(flat[index]))} == {bool, numbers.Real}
           else "NumPy cannot sort them")
    raise MixedTypesError(f"{owner}: {name} mixes values of type {first} and {second} (the "
                          f"first {second} at index {index}): {why}; give every one the "
                          "same type (e.g. all text)")


class ConfigError(TerrainError, ValueError):
    """An unknown name or an out-of-range parameter in a configuration.

    The message lists the valid choices.
    """


#: Types Python or NumPy count as numbers that no setting takes as one: a boolean (``True``
#: is 1), a NumPy duration (``np.timedelta64`` is a ``np.signedinteger``, whatever its unit)
_NOT_NUMBERS = (bool, np.timedelta64)


def real_number(cell) -> bool:
    """Whether one value is a real number: a Python or NumPy integer or float (NaN and inf
    included), not a boolean, nor a NumPy duration (``np.timedelta64``, a NumPy integer).

    The test of :func:`first_non_number_cell` and of :func:`config_numbers`. Text (even
    ``"1e3"`` or ``"nan"``, which NumPy and ``float()`` parse), bytes, complex numbers,
    dates, ``decimal.Decimal`` (not a :class:`numbers.Real`: it does not mix with floats),
    arrays and ``None`` are not.

    Parameters
    ----------
    cell : object
        One value.

    Returns
    -------
    bool
    """
    return isinstance(cell, numbers.Real) and not isinstance(cell, _NOT_NUMBERS)


def missing_cell(cell) -> bool:
    """Whether one value of an object column is a missing cell: ``None``, pandas' ``NA``
    or ``NaT`` (a NaN is a number: :func:`real_number`).

    Parameters
    ----------
    cell : object
        One value.

    Returns
    -------
    bool
    """
    if cell is None:
        return True
    import pandas as pd

    return cell is pd.NA or cell is pd.NaT


def first_non_number_cell(cells, allow_missing: bool) -> int | None:
    """Index of the first value that is not a real number (:func:`real_number`), or None:
    the one rule of values that must be numbers, shared by the data columns (the readers'
    clock, the alignment, the writer, the slip features' probabilities:
    :func:`terrain.io.align.first_non_number`) and the kinematics' array arguments
    (:func:`terrain.vehicles.common.float_arrays`).

    The callers differ only on a missing cell (:func:`missing_cell`), which
    ``allow_missing`` makes explicit: in a data column it is a missing sample, left to
    the caller's missing-value rule, which counts or refuses it (the writer refuses it by
    name, the readers interpolate and count an isolated empty cell); in an argument of a
    physical relation it stands for no value, and NumPy would read ``None`` as NaN.

    Parameters
    ----------
    cells : iterable
        The values, in order (a column, or an array's flattened entries).
    allow_missing : bool
        Whether a missing cell passes (True: a data column) or is itself the first non
        number (False: an argument).

    Returns
    -------
    int or None
        The 0-based index of the first offending value, None when every one passes.
    """
    for k, cell in enumerate(cells):
        if not (real_number(cell) or (allow_missing and missing_cell(cell))):
            return k
    return None


def config_numbers(owner: str, optional: tuple = (), **values) -> None:
    """Refuse configuration values that are not real numbers, before any range check.

    A range check such as ``0 < x <= 1`` raises Python's own ``TypeError`` on text, ``None``
    or a list, and an array of two numbers raises NumPy's "truth value is ambiguous";
    ``True`` passes it as 1. This names the field instead.

    Parameters
    ----------
    owner : str
        The configuration's name, for the message (e.g. ``"StreamConfig"``).
    optional : tuple of str
        Fields that may be ``None`` (an optional setting left out).
    **values
        Field name -> value.

    Raises
    ------
    ConfigError
        A value that is ``None`` (unless ``optional``), a boolean, text, bytes, complex, a
        NumPy duration (``np.timedelta64``), or not one real number (a list, an array of
        several numbers, an object).
    """
    for name, value in values.items():
        if value is None and name in optional:
            continue
        ok = real_number(value)
        if not ok and type(value).__module__ == "numpy" and getattr(value, "shape", None) == ():
            ok = value.dtype.kind in "iuf"  # a NumPy scalar or 0-d array of a real number
        if not ok:
            raise ConfigError(f"{owner}.{name} must be a real number, got "
                              f"{type(value).__name__} {value!r:.60}")


def indexed(name: str, values) -> dict[str, object]:
    """The entries of a sequence setting as fields ``name[0]``, ``name[1]``, ... for the
    ``config_*`` checks, so that a refusal names the entry (``q_diag[3]``).

    Parameters
    ----------
    name : str
        The setting's name.
    values : iterable
        Its entries.

    Returns
    -------
    dict
        ``"name[i]" -> entry``, in order.
    """
    return {f"{name}[{i}]": value for i, value in enumerate(values)}


def config_flags(owner: str, **values) -> None:
    """Refuse on/off settings that are not booleans.

    A switch read by truthiness takes the text ``"no"`` of a config file, or ``1``, as on.

    Parameters
    ----------
    owner : str
        The configuration's name, for the message (e.g. ``"ModelConfig"``).
    **values
        Field name -> value.

    Raises
    ------
    ConfigError
        A value that is neither ``True`` nor ``False`` (a NumPy boolean is one), named.
    """
    import numpy as np

    for name, value in values.items():
        if not isinstance(value, (bool, np.bool_)):
            raise ConfigError(f"{owner}.{name} must be True or False, got "
                              f"{type(value).__name__} {value!r:.60}")


def config_seed(name: str, value) -> None:
    """Refuse a random seed that is not a whole number >= 0.

    A whole float such as ``3.0`` is a seed (the simulator's configurations take seeds from
    JSON and CSV files, where 3 may be written 3.0); ``2.7`` is not (it was simulated as
    seed 2 and labelled so), nor a boolean, NaN or infinity.

    Parameters
    ----------
    name : str
        The setting's name, for the message.
    value : object
        The value given.

    Raises
    ------
    ConfigError
        ``value`` not a real number, a boolean or a NumPy duration, not finite, not whole,
        or negative.
    """
    import math

    if not (real_number(value) and math.isfinite(value) and int(value) == value and value >= 0):
        raise ConfigError(f"{name} must be an integer >= 0, got {value!r}")


def is_integer(value) -> bool:
    """Whether ``value`` is an integer, Python's or NumPy's, as a count or an index is given:
    not a boolean (``True`` is Python's 1, and was column 1), not a float (``2.0``, ``0.5``)
    and not a NumPy duration (``np.timedelta64`` is a ``np.signedinteger``).

    Parameters
    ----------
    value : object
        The value given.

    Returns
    -------
    bool
        True for an integer.
    """
    import numbers

    # (NumPy's bool is not Integral)
    return isinstance(value, numbers.Integral) and not isinstance(value, _NOT_NUMBERS)


def config_integer(name: str, value, lo: int, hi: int | None = None) -> None:
    """Refuse a configuration value that is not an integer in ``[lo, hi]``.

    ``True`` is refused although Python counts it as the integer 1, and a float such as
    ``2.0`` is refused too (a count is given as one).

    Parameters
    ----------
    name : str
        The setting's name, for the message.
    value : object
        The value given.
    lo : int
        Smallest accepted value.
    hi : int, optional
        Largest accepted value (no bound when omitted).

    Raises
    ------
    ConfigError
        ``value`` a boolean or a NumPy duration, not an integer (Python or NumPy), or
        outside ``[lo, hi]``.
    """
    ok = is_integer(value) and lo <= value and (hi is None or value <= hi)
    if not ok:
        bound = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise ConfigError(f"{name} must be an integer {bound}, got {value!r}")


def config_positive(owner: str, allow_zero: bool = False, **values) -> None:
    """Refuse configuration values that are not finite real numbers > 0 (>= 0 with
    ``allow_zero``): a mass, a length, a modulus, a time constant.

    Parameters
    ----------
    owner : str
        The configuration's or function's name, for the message (``"HuskyParams"``,
        ``"bekker_sinkage_m"``).
    allow_zero : bool, optional
        Accept 0 (a quantity that may be off or absent).
    **values
        Field name -> value.

    Raises
    ------
    ConfigError
        The first value that is not a real number (:func:`config_numbers`), or not finite
        and > 0 (>= 0), named ``owner.field`` with the value given.
    """
    config_numbers(owner, **values)
    for name, value in values.items():
        if not (value >= 0.0 if allow_zero else value > 0.0) or value == float("inf"):
            rule = ">= 0" if allow_zero else "> 0"     # (NaN fails both comparisons)
            raise ConfigError(f"{owner}.{name} must be a finite value {rule}, got {value!r}")


def config_fraction(owner: str, **values) -> None:
    """Refuse configuration values that are not real numbers in (0, 1]: a fraction of a
    peak, a saturation, a slip (a percentage such as 95 is refused).

    Parameters
    ----------
    owner : str
        The function's name, for the message (``"traction_peak"``).
    **values
        Field name -> value.

    Raises
    ------
    ConfigError
        The first value that is not a real number (:func:`config_numbers`), or not in
        (0, 1] (NaN included), named with the value given.
    """
    config_numbers(owner, **values)
    for name, value in values.items():
        if not 0.0 < value <= 1.0:
            raise ConfigError(f"{owner}: {name} must be in (0, 1], got {value}")


def config_probability(owner: str, **values) -> None:
    """Refuse configuration values that are not real numbers in the closed range [0, 1]: a
    probability threshold (a minimum confidence), a fraction that may be 0 or 1.

    :func:`config_fraction` is the half-open (0, 1] of a fraction that must be positive.

    Parameters
    ----------
    owner : str
        The configuration's name, for the message (``"StreamConfig"``).
    **values
        Field name -> value.

    Raises
    ------
    ConfigError
        The first value that is not a real number (:func:`config_numbers`), or not in
        [0, 1] (NaN included: a NaN threshold is never crossed), named as
        ``owner.name`` with the value given.
    """
    config_numbers(owner, **values)
    for name, value in values.items():
        if not 0.0 <= value <= 1.0:
            raise ConfigError(f"{owner}.{name} must be in [0, 1], got {value}")


class EstimationError(TerrainError, ValueError):
    """Bad input to a state estimator (:mod:`terrain.estimation`, :mod:`terrain.slip`).

    Subclasses say what is wrong; the message names the argument and the offending shape,
    value or index.
    """


class ShapeError(EstimationError):
    """An array argument has the wrong shape (e.g. a state of shape (n, 1) for (n,))."""


class NonFiniteInputError(EstimationError):
    """A state, covariance, measurement or parameter holds NaN or inf."""


class CovarianceError(EstimationError):
    """A covariance matrix is not symmetric positive (semi-)definite."""


class TimeStepError(EstimationError):
    """A time step is not strictly positive and finite, or timestamps do not increase."""


class MixedTypesError(EstimationError, TypeError):
    """Labels or runs of types that do not sort together (text or booleans beside numbers): a
    :class:`TypeError` too, as NumPy's own refusal was (:func:`refuse_mixed_types`)."""
