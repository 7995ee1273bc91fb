"""JSON files that strict readers accept: a figure that could not be computed is ``null``.

Python's :func:`json.dumps` writes a NaN or infinite float as the bare tokens ``NaN`` and
``Infinity``, which JSON does not allow (RFC 8259, section 6): ``jq``, JavaScript's
``JSON.parse`` and other strict readers refuse the whole file. The audit report and the
``summary.json`` of ``terrain slip-fit`` and ``terrain control-grid`` go through
:func:`json_ready` first.

Output files are written whole or not at all: :func:`whole_file` (one file through a
temporary name and :func:`os.replace`; the commands' CSV and JSON outputs),
:func:`replace_text` (the same for a text) and :func:`staged_outputs` (a command's set of
files, moved in together); :func:`folder_lock` lets two commands writing one folder take
turns.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import stat
import tempfile
import uuid
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import numpy as np


def json_ready(v: Any, nd: int | None = 5) -> Any:
    """A value made JSON-ready.

    Parameters
    ----------
    v : any
        Value; mappings, lists and tuples are converted recursively.
    nd : int or None, optional
        Decimals kept of every float (None: all).

    Returns
    -------
    any
        ``v`` with numpy scalars turned into Python ones, floats rounded to ``nd`` decimals,
        non-finite floats to ``None``, mappings to dicts with string keys, tuples to lists.
    """
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        if not np.isfinite(v):
            return None
        return float(v) if nd is None else round(float(v), nd)
    if isinstance(v, Mapping):
        return {str(k): json_ready(x, nd) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [json_ready(x, nd) for x in v]
    return v


def strict_json(obj: Any, indent: int = 1) -> str:
    """Indented standard JSON of ``obj``, every float kept in full and a non-finite one
    written as ``null``.

    Parameters
    ----------
    obj : any
        Mappings, lists, tuples, numbers (numpy scalars included), strings, booleans, None.
    indent : int, optional
        Indentation, spaces.

    Returns
    -------
    str
        The JSON text, ending with a newline.

    Raises
    ------
    TypeError
        A value JSON cannot hold (an array, an object).
    """
    return json.dumps(json_ready(obj, None), indent=indent, allow_nan=False) + "\n"


@contextlib.contextmanager
def whole_file(path: Path) -> Iterator[Path]:
    """Write an output file whole or not at all.

    Yields a fresh temporary name in ``path``'s folder (created if missing; the same file
    system) to write the file to; on a clean exit it replaces ``path`` in one step
    (:func:`os.replace`), and on any error (an interrupt included) it is removed: a failure
    half-way through (a full disk) neither leaves half a file that a later step reads as
    the whole output nor destroys the file of an earlier run.

    An output that is a stream, not a file (a named pipe, a terminal, ``/dev/stdout`` or
    another device, directly or through a link), cannot be replaced whole: it is yielded
    as it is and written as it goes (renaming a file over it would take the pipe's or the
    device's place and its reader would get nothing).

    Parameters
    ----------
    path : pathlib.Path
        The output file (a symbolic link: the file it links to).

    Yields
    ------
    pathlib.Path
        The temporary file to write (it exists, empty), with ``path``'s permission bits,
        or those of a new file where there is no ``path`` yet; ``path`` itself for a pipe
        or a device.
    """
    path = Path(path)
    try:
        mode = path.stat().st_mode      # through a link, as open() writes
    except OSError:                     # none yet, or a link to nothing: a new file
        mode = None
    if mode is not None and not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        yield path
        return
    if path.is_symlink():   # the file linked to is the output, as open() writes through
        path = path.resolve()
    path.parent.mkdir(parents=True, exist_ok=True)
    # a name of this write's own (short: a name the system takes stays one), created as
    # open() creates a new file (the umask's mode: mkstemp's 0600 hid the output from others)
    tmp = path.with_name(f".{path.name[:64]}.{os.getpid()}-{uuid.uuid4().hex[:8]}.partial")
    try:
        tmp.open("x").close()
        if path.exists():
            shutil.copymode(path, tmp)
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def replace_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` whole or not at all.

    The text goes to a temporary file beside ``path`` (same folder, so the same file
    system) that is renamed onto ``path`` in one step; on any error (an interrupt, a full
    disk) the temporary file is removed and an earlier ``path`` is left as it was, never
    cut short.

    Parameters
    ----------
    path : str or pathlib.Path
        File to write (its folder is created).
    text : str
        Its whole content.

    Raises
    ------
    OSError
        The folder cannot be created or written (``path`` unchanged).
    """
    with whole_file(Path(path)) as tmp:
        tmp.write_text(text)


@contextlib.contextmanager
def staged_outputs(folder: str | Path, owned: Sequence[str],
                   last: Sequence[str] = ("summary.json",)) -> Iterator[Path]:
    """Write a command's output files into ``folder`` all together or not at all.

    Yields a fresh hidden staging folder inside ``folder`` (the same file system) to write
    the outputs to. On a clean exit, the files of an earlier run that match one of the
    ``owned`` patterns and that this run did not write are removed from ``folder`` (no table
    or figure of an earlier run is left beside the new ones), then every staged file is
    renamed into ``folder``, those named in ``last`` after the others (a summary appears
    only once what it describes is in place). On any error (an interrupt included) the
    staging folder is removed and ``folder`` is left as the earlier run left it.

    Parameters
    ----------
    folder : str or pathlib.Path
        The output folder (created).
    owned : sequence of str
        Glob patterns of the files the command writes to ``folder`` (``"tuning_*.csv"``).
    last : sequence of str, optional
        File names moved in after every other.

    Yields
    ------
    pathlib.Path
        The staging folder.

    Raises
    ------
    OSError
        ``folder`` cannot be created or written.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".partial-", dir=folder))
    try:
        yield stage
        written = sorted((p.name for p in stage.iterdir() if p.is_file()),
                         key=lambda name: (name in last, name))
        # one command at a time moves its files in (two writing one folder at once left a
        # mix: the summary of one beside tables of both); the last to do so wins, whole
        with folder_lock(folder):
            for pattern in owned:
                for old in folder.glob(pattern):
                    if old.is_file() and old.name not in written:
                        old.unlink(missing_ok=True)
            for name in written:
                os.replace(stage / name, folder / name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


@contextlib.contextmanager
def folder_lock(folder: str | Path) -> Iterator[None]:
    """Hold an exclusive advisory lock on ``folder`` while the block runs.

    Two commands that each take this lock before writing into one folder write one after
    the other (the other waits). The lock is ``flock`` on the folder itself, so no lock file
    is left in it, and the system releases it when the process ends; a no-op where the
    system, or the folder's file system, has no ``flock``.

    Parameters
    ----------
    folder : str or pathlib.Path
        An existing folder.

    Yields
    ------
    None

    Raises
    ------
    OSError
        ``folder`` cannot be opened (missing, no permission).
    """
    try:
        import fcntl
    except ImportError:     # pragma: no cover - not a POSIX system
        yield
        return
    fd = os.open(folder, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
        except OSError as exc:
            if exc.errno not in _NO_LOCKS:
                raise
            # a file system without locks (some network and FUSE ones): written as before
        yield
    finally:
        os.close(fd)    # releases the lock


#: errors of ``flock`` on a file system that has no locks
_NO_LOCKS = (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EINVAL)
