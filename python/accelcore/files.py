"""Writing files safely: one ``atomic_write`` for every output accelcore writes.

:func:`atomic_write` writes a whole content at once; :func:`atomic_open` is the
same rule for an output written piece by piece (a log of any size compensated
in chunks). :func:`check_outputs` refuses, before anything is read, an output
that is, or links to, one of a command's inputs; :func:`check_input_file`
refuses an input that is not a regular file (a FIFO would block the read) or is
far larger than its kind can be.

Foundation: imports only :mod:`accelcore.errors`.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import BinaryIO

from accelcore.errors import AccelcoreIOError, OutputConflictError

__all__ = ["atomic_open", "atomic_write", "check_input_file", "check_outputs", "file_kind"]

_PathLike = str | os.PathLike[str]


def _identity(path: Path) -> tuple[int, int] | None:
    """(device, inode) of what ``path`` names after following links, None if nothing."""
    try:
        st = path.stat()
    except (OSError, ValueError):
        return None
    return (st.st_dev, st.st_ino)


def _protected(inputs: Iterable[_PathLike]) -> list[tuple[Path, Path, tuple[int, int] | None]]:
    """(path as given, resolved path, identity) of every input; nothing is opened."""
    return [(Path(p), Path(p).resolve(), _identity(Path(p))) for p in inputs]


def check_outputs(
    inputs: Iterable[_PathLike],
    outputs: Iterable[_PathLike | None],
) -> None:
    """Refuse any output that is, or links to, an input, or whose folder cannot be written.

    Call it before reading anything: then an output can never destroy an input,
    whatever the command finds later. An output aliases an input when it names
    the same file after following symbolic links (same device and inode, which
    also catches hard links), or resolves to the same path (a link not yet
    pointing anywhere). A session folder is passed as its ``session.toml`` and
    log files (:meth:`accelcore.input.format.SessionFormat.input_files`), so a
    new file written next to them is allowed.

    Parameters
    ----------
    inputs : iterable of path
        Files and folders the command reads.
    outputs : iterable of path or None
        Files the command would write; None and ``"-"`` (standard output) are
        skipped.

    Raises
    ------
    accelcore.errors.OutputConflictError
        An output aliases an input; ``.output`` and ``.input`` name both.
    accelcore.AccelcoreIOError
        An output's folder exists but is not a folder or cannot be written
        (``.path`` is the output).
    """
    protected = _protected(inputs)
    for given in outputs:
        if given is None or str(given) == "-":
            continue
        out = Path(given)
        ident = _identity(out)
        resolved = out.resolve()
        for shown, res, in_ident in protected:
            same = (ident is not None and ident == in_ident) or resolved == res
            if same:
                kind = "input folder" if shown.is_dir() else "input"
                err = OutputConflictError(
                    f"output {out} would overwrite the {kind} {shown}; choose another output path"
                )
                err.output, err.input = str(out), str(shown)
                raise err
        _check_writable(out)


def _check_writable(out: Path) -> None:
    """Refuse an output whose nearest existing folder is not a folder we may write into."""
    parent = out.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    reason = None
    if out.is_dir():
        reason = "is a folder"
    elif not parent.is_dir():
        reason = f"{parent} is not a folder"
    elif not os.access(parent, os.W_OK | os.X_OK):
        reason = f"folder {parent} is not writable"
    if reason is not None:
        err = AccelcoreIOError(f"{out}: cannot write the output: {reason}")
        err.path = str(out)
        raise err


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], *, mode: int = 0o644) -> Iterator[BinaryIO]:
    """Open a binary stream whose content replaces ``path`` only when the block ends cleanly.

    The stream writes to a fresh temporary file in the target's folder. When the
    ``with`` block ends without an exception, the file is flushed and
    ``fsync``-ed, renamed over the target, and the folder is ``fsync``-ed (where
    the OS allows) so the rename itself survives a power cut. On any error the
    temporary file is removed and the target is left as it was.

    Parameters
    ----------
    path : str or os.PathLike
        Target file. Its folder is created if missing.
    mode : int, optional
        Permission bits of the new file (default ``0o644``, before the umask).

    Yields
    ------
    BinaryIO
        The temporary file, open for writing bytes.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    tmp = Path(tmp_name)
    try:
        with os.fdopen(fd, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, mode & ~umask)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    with contextlib.suppress(OSError):
        dir_fd = os.open(target.parent, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)


def atomic_write(path: str | os.PathLike[str], data: bytes | str, *, mode: int = 0o644) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the new, never a part.

    The data goes to a fresh temporary file in the target's folder, is flushed and
    ``fsync``-ed, then renamed over the target; the folder is ``fsync``-ed after the
    rename (where the OS allows) so the rename itself survives a power cut. On any
    error the temporary file is removed and the target is left as it was
    (:func:`atomic_open`).

    Parameters
    ----------
    path : str or os.PathLike
        Target file. Its folder is created if missing.
    data : bytes or str
        Content; text is encoded as UTF-8.
    mode : int, optional
        Permission bits of the new file (default ``0o644``, before the umask).
    """
    payload = data.encode("utf-8") if isinstance(data, str) else data
    with atomic_open(path, mode=mode) as fh:
        fh.write(payload)


def file_kind(mode: int) -> str:
    """Name what a path that is not a regular file is, from its ``st_mode``.

    ``"a folder"``, ``"a FIFO (named pipe)"``, ``"a device"`` or ``"not a regular file"``.
    """
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "not a regular file"


def check_input_file(path: _PathLike, what: str, *, max_bytes: int | None = None) -> None:
    """Refuse an input that is not a regular file, or larger than ``max_bytes``, before opening it.

    Opening a FIFO blocks until someone writes to it, a device such as
    ``/dev/zero`` never ends, and a 2 GB sparse file reads as 2 GB of zeros:
    each is named for what it is instead.

    Parameters
    ----------
    path : str or os.PathLike
        The input.
    what : str
        What the input should be, for the message (``"calibration file"``).
    max_bytes : int, optional
        Largest size accepted.

    Raises
    ------
    accelcore.AccelcoreIOError
        Missing, unreadable, not a regular file (the message says "a folder",
        "a FIFO (named pipe)" or "a device"), or too large; ``.path`` is set.
    """
    try:
        st = os.stat(path)
    except FileNotFoundError:
        reason = f"cannot read {what}: no such file"
    except OSError as exc:
        reason = f"cannot read {what}: {exc.strerror}"
    else:
        mode = st.st_mode
        if not stat.S_ISREG(mode):
            reason = f"cannot read {what}: it is {file_kind(mode)}, not a file"
        elif max_bytes is not None and st.st_size > max_bytes:
            reason = (
                f"not read: {st.st_size} bytes, far more than a {what} holds (at most {max_bytes})"
            )
        else:
            return
    err = AccelcoreIOError(f"{path}: {reason}")
    err.path = str(path)
    raise err
