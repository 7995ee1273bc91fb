"""Input side of the streaming service: one pushed chunk as checked float arrays.

What a robot pushes (:meth:`terrain.serving.service.StreamService.push`) arrives as floats,
NumPy arrays, lists, masked arrays or pandas objects. These functions turn a chunk into
``(n,)`` timestamps and ``(n, n_channels)`` values in the stream's channel order, or raise a
:class:`~terrain.errors.DataFormatError` / :class:`~terrain.errors.MissingColumnError` that
names the stream and the column; nothing is reshaped or reordered on a guess.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from terrain.errors import DataFormatError, MissingColumnError, duplicated


def chunk_values(values, t_s: np.ndarray, channels: Sequence[str],
                 stream: str) -> np.ndarray:
    """The values of one pushed chunk as an ``(n, n_channels)`` float array.

    Parameters
    ----------
    values : Mapping[str, array], pandas.DataFrame, pandas.Series or array-like
        Channel -> ``(n,)`` values (a DataFrame is read by its column names, a Series as
        one sample), or ``(n, n_channels)`` in ``channels`` order (one sample may be a 1-D
        row, one channel a 1-D column); masked values are missing (NaN).
    t_s : numpy.ndarray
        ``(n,)`` timestamps of the chunk, s (:func:`real_array`).
    channels : sequence of str
        Channel names of the stream, in order.
    stream : str
        Stream name (for the messages).

    Returns
    -------
    numpy.ndarray
        ``(n, n_channels)`` values, SI units as sent.

    Raises
    ------
    MissingColumnError
        A channel of the stream is missing from a mapping or DataFrame.
    DataFormatError
        A channel given as several columns of a DataFrame, a channel's values and the
        timestamps of different lengths, values of any shape
        other than the above (a transposed chunk included), or values that are not real
        numbers (:func:`real_array`).
    """
    if isinstance(values, pd.DataFrame):  # by its column names, not their order
        twice = duplicated([c for c in values.columns if c in channels])
        if twice:   # (values[c] is then a frame: a "shape (n, 2)" message)
            raise DataFormatError(f"stream {stream!r}: channel(s) {twice} given as several "
                                  "columns of the DataFrame; give each channel once",
                                  f"stream {stream}", twice[0])
        values = {c: values[c].to_numpy() for c in values.columns if c in channels}
    elif isinstance(values, pd.Series):   # one sample, channel -> value
        values = values.to_dict()
    if not _is_mapping(values):
        return values_matrix(real_array(values, stream, "values"), len(t_s), channels,
                             stream)
    absent = [c for c in channels if c not in values]
    if absent:
        raise MissingColumnError(f"stream {stream!r} sample lacks channel(s) {absent}",
                                 f"stream {stream}", absent[0])
    columns = [real_array(values[c], stream, c) for c in channels]
    uneven = [c for c, col in zip(channels, columns) if col.shape != t_s.shape]
    if uneven:
        raise DataFormatError(f"stream {stream!r}: channel {uneven[0]!r} holds "
                              f"{columns[channels.index(uneven[0])].size} values for "
                              f"{t_s.size} timestamps", f"stream {stream}", uneven[0])
    return np.column_stack(columns) if len(t_s) else np.empty((0, len(channels)))


def check_same_index(t_s, values, stream: str) -> None:
    """Refuse pandas inputs of one chunk whose indexes differ: they are read by position.

    A channel filtered or sorted apart from the others (a Series with its own index) was
    paired with the other channels' samples row by row, silently; pandas itself would have
    aligned them by index.

    Parameters
    ----------
    t_s : float, array-like or pandas.Series
        Timestamps of the chunk as pushed, s.
    values : Mapping[str, array], pandas.DataFrame, pandas.Series or array-like
        Values of the chunk as pushed (:func:`chunk_values`); a Series is one sample, whose
        index holds the channel names.
    stream : str
        Stream name (for the message).

    Raises
    ------
    DataFormatError
        ``t_s``, a DataFrame of values or a mapping's Series carry indexes that are not all
        equal; the message names the first channel (or ``t_s``) that differs.
    """
    indexed = [("t_s", t_s.index)] if isinstance(t_s, pd.Series) else []
    if isinstance(values, pd.DataFrame):
        indexed.append(("values", values.index))
    elif _is_mapping(values):
        indexed += [(c, x.index) for c, x in values.items() if isinstance(x, pd.Series)]
    if len(indexed) < 2:
        return
    # the index most of them share is the reference: the message names the odd one out
    shared = max((sum(index.equals(other) for _, other in indexed), -k)
                 for k, (_, index) in enumerate(indexed))
    ref_name, ref_index = indexed[-shared[1]]
    for name, index in indexed:
        if not index.equals(ref_index):
            raise DataFormatError(
                f"stream {stream!r}: {name!r} carries another pandas index than "
                f"{ref_name!r}; values are read by position, so its samples would be "
                "paired with other samples' stamps: align them (e.g. DataFrame.join or "
                "reindex) or pass arrays", f"stream {stream}", name)


def values_matrix(v: np.ndarray, n: int, channels: Sequence[str],
                  stream: str) -> np.ndarray:
    """``(n, n_channels)`` values of a chunk of ``n`` samples, never reshaped on a guess.

    Parameters
    ----------
    v : numpy.ndarray
        Values as sent: ``(n, n_channels)``, one sample as a 1-D ``(n_channels,)`` row, or
        one channel as a 1-D ``(n,)`` column.
    n : int
        Samples in the chunk.
    channels : sequence of str
        Channel names of the stream.
    stream : str
        Stream name (for the message).

    Returns
    -------
    numpy.ndarray
        ``(n, n_channels)``.

    Raises
    ------
    DataFormatError
        Any other shape, a transposed ``(n_channels, n)`` chunk included (it was reshaped
        row by row: speeds became currents).
    """
    want = (n, len(channels))
    if v.shape == want:
        return v
    if n == 0 and v.size == 0:  # an empty chunk, e.g. [] or np.empty(0)
        return np.empty(want)
    one_row = v.ndim == 1 and n == 1 and v.size == len(channels)
    one_column = v.ndim == 1 and len(channels) == 1 and v.size == n
    if one_row or one_column or (v.ndim == 0 and want == (1, 1)):
        return v.reshape(want)
    raise DataFormatError(f"stream {stream!r}: expected values of shape {want} (samples x "
                          f"channels {list(channels)}), got {v.shape}"
                          + (" (transposed?)" if v.shape == want[::-1] else ""),
                          f"stream {stream}", "values")


def real_array(x, stream: str, column: str) -> np.ndarray:
    """``x`` as a float array, or a typed error naming the stream and column.

    Parameters
    ----------
    x : float, array-like or numpy.ma.MaskedArray
        Timestamps (s) or values (SI units) as sent; masked entries become NaN.
    stream : str
        Stream name (for the message).
    column : str
        ``"t_s"``, a channel name (both 1-D), or ``"values"`` (the shape is kept).

    Returns
    -------
    numpy.ndarray
        float64; 1-D (at least one element) unless ``column == "values"``.

    Raises
    ------
    DataFormatError
        Text, complex numbers, booleans (``True`` would be 1 s), NumPy datetimes or
        timedeltas (their count of ms or us would be read as s), an integer beyond the float
        range, ragged lists, or more than one dimension for ``t_s`` or one channel.
    """
    # the usual push (a float64 array or one float): the same result without the checks
    if type(x) is np.ndarray and x.dtype == np.float64 and (x.ndim == 1 or column == "values"):
        return x
    if type(x) is float:
        return np.array(x) if column == "values" else np.array((x,))
    if isinstance(x, np.ma.MaskedArray):  # a masked sample is a missing one, not its data
        x = np.ma.filled(x.astype(float), np.nan) if x.dtype.kind in "biuf" else x.filled()
    try:
        raw = x if isinstance(x, np.ndarray) else np.asarray(x)
        kind = raw.dtype.kind
        if kind in "bmM":
            # True would be 1.0; a timedelta64 or datetime64 its count of ms or us as s
            raise DataFormatError(f"stream {stream!r}: {column} must hold real numbers (s and "
                                  f"SI units), got {'booleans' if kind == 'b' else 'NumPy times'}"
                                  f" ({raw.dtype})", f"stream {stream}", column)
        # NumPy reads text that spells a number ("10.5") and an object array's booleans
        # as floats without a word
        text = kind in "USa" or (kind == "O" and any(
            isinstance(v, (str, bytes, bool, np.bool_)) for v in raw.flat))
        if text:
            raise DataFormatError(f"stream {stream!r}: {column} must hold real numbers (s and "
                                  "SI units), got text or booleans", f"stream {stream}",
                                  column)
        a = None if kind == "c" else np.asarray(raw, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, DataFormatError):
            raise
        raise DataFormatError(f"stream {stream!r}: {column} must hold real numbers "
                              f"({exc})", f"stream {stream}", column) from None
    if a is None:
        raise DataFormatError(f"stream {stream!r}: {column} must hold real numbers, not "
                              "complex ones", f"stream {stream}", column)
    if column == "values":
        return a
    if a.ndim > 1:
        raise DataFormatError(f"stream {stream!r}: {column} must be one number or a 1-D "
                              f"array, got shape {a.shape}", f"stream {stream}", column)
    return np.atleast_1d(a)


def same_values(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two samples' values are equal to float32 precision (NaN equal to NaN).

    Parameters
    ----------
    a, b : numpy.ndarray
        ``(n_channels,)`` values of two samples.

    Returns
    -------
    bool
        ``allclose`` with a relative tolerance of 1e-6 and no absolute one.
    """
    return bool(np.allclose(a, b, rtol=1e-6, atol=0.0, equal_nan=True))


def _is_mapping(x) -> bool:
    """Whether ``x`` is a mapping; a dict (the usual push) without the ``Mapping`` ABC
    check, which costs microseconds per pushed sample."""
    return isinstance(x, dict) or isinstance(x, Mapping)
