"""Typed errors raised by the library.

Every error that concerns input data names the file, the column and the row (0-based data
row, header excluded) where it is known, so a user can open the file and find the problem.
"""

from __future__ import annotations


class TerrainError(Exception):
    """Base class of every error raised on purpose by :mod:`terrain`."""


class DataFormatError(TerrainError, ValueError):
    """A data file does not follow the expected format.

    Parameters
    ----------
    message : str
        What is wrong.
    path : str or None
        File that holds the problem.
    column : str or None
        Column that holds the problem, as named in the file.
    row : int or None
        0-based data row (header excluded) of the first offending value.
    """

    def __init__(self, message: str, path: str | None = None, column: str | None = None,
                 row: int | None = None) -> None:
        self.path = None if path is None else str(path)
        self.column = column
        self.row = row
        where = []
        if path is not None:
            where.append(f"file {path}")
        if column is not None:
            where.append(f"column {column!r}")
        if row is not None:
            where.append(f"row {row}")
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


class ConfigError(TerrainError, ValueError):
    """An unknown name or an out-of-range parameter in a configuration.

    The message lists the valid choices.
    """


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
