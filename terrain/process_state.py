"""Process-wide settings changed for the length of a call and put back after it.

Some settings belong to the whole process, not to one call: an environment variable that a
library reads at every use (``MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR``), Python's warnings
printer, MLflow's default tracking store. A call that changes one of them must put it back,
on success or failure, and calls may overlap (two commands run in-process from two threads,
models loaded concurrently). When each call restores what *it* found, overlapping calls put
back each other's setting: the later one to enter found the earlier one's change and
restores that, for good. :class:`SharedSetting` is the one rule the entry point, the served
model and the tracking store use instead: the first call to enter saves the setting, the last
to leave puts it back, and the calls in between share the changed setting.
"""

from __future__ import annotations

import os
import threading
from typing import Any, Callable

__all__ = ["SharedSetting", "environment_variable", "restore_environment_variable"]


class SharedSetting:
    """Context manager: a process-wide setting saved by the first of overlapping calls to
    enter and put back by the last to leave.

    Parameters
    ----------
    save : callable () -> object
        Reads the setting as it is; called by the first call to enter (no other is inside).
    apply : callable (object) -> None
        Changes the setting for the calls inside; called at every entry, after ``save`` on
        the first, with the value ``save`` returned then (so it may depend on it).
    restore : callable (object) -> None
        Puts back what ``save`` returned; called by the last call to leave, also when the
        call inside raised, and by the first call to enter when its ``apply`` raised (that
        call is then not inside, and the error propagates).

    Notes
    -----
    The three callables run under one lock, so an entry and a leave never interleave; they
    must not enter this same context themselves. Reentrant: a call nested in another counts
    as one more call inside.

    Examples
    --------
    >>> import os
    >>> quiet = environment_variable("TERRAIN_EXAMPLE_VARIABLE", "false")
    >>> with quiet:
    ...     os.environ["TERRAIN_EXAMPLE_VARIABLE"]
    'false'
    >>> "TERRAIN_EXAMPLE_VARIABLE" in os.environ
    False
    """

    def __init__(self, save: Callable[[], Any], apply: Callable[[Any], None],
                 restore: Callable[[Any], None]) -> None:
        self._save, self._apply, self._restore = save, apply, restore
        self._lock = threading.Lock()
        self._inside = 0
        self._saved: Any = None

    def __enter__(self) -> None:
        with self._lock:
            if self._inside == 0:
                self._saved = self._save()
            try:
                self._apply(self._saved)
            except BaseException:
                if self._inside == 0:
                    saved, self._saved = self._saved, None
                    self._restore(saved)
                raise
            self._inside += 1

    def __exit__(self, *exc) -> None:
        with self._lock:
            self._inside -= 1
            if self._inside == 0:
                saved, self._saved = self._saved, None
                self._restore(saved)


def environment_variable(name: str, value: str) -> SharedSetting:
    """A :class:`SharedSetting` that sets one environment variable while any call is inside.

    Parameters
    ----------
    name : str
        The variable.
    value : str
        Its value while a call is inside; after the last call leaves, the variable is as the
        first found it (unset again if it was unset).

    Returns
    -------
    SharedSetting
    """
    def apply(saved: str | None) -> None:
        os.environ[name] = value

    return SharedSetting(lambda: os.environ.get(name), apply,
                         lambda saved: restore_environment_variable(name, saved))


def restore_environment_variable(name: str, saved: str | None) -> None:
    """Put an environment variable back as it was read (``os.environ.get``).

    Parameters
    ----------
    name : str
        The variable.
    saved : str or None
        Its value as read before; None unsets it.
    """
    if saved is None:
        os.environ.pop(name, None)
    else:
        os.environ[name] = saved
