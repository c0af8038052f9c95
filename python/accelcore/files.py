"""Writing files safely: one ``atomic_write`` for every output accelcore writes.

:func:`atomic_write` writes a whole content at once; :func:`atomic_open` is the
same rule for an output written piece by piece (a log of any size compensated
in chunks).

Foundation: imports nothing of accelcore.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

__all__ = ["atomic_open", "atomic_write"]


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
