"""Writing files safely: one ``atomic_write`` for every output accelcore writes.

Foundation: imports nothing of accelcore.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

__all__ = ["atomic_write"]


def atomic_write(path: str | os.PathLike[str], data: bytes | str, *, mode: int = 0o644) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the new, never a part.

    The data goes to a fresh temporary file in the target's folder, is flushed and
    ``fsync``-ed, then renamed over the target; the folder is ``fsync``-ed after the
    rename (where the OS allows) so the rename itself survives a power cut. On any
    error the temporary file is removed and the target is left as it was.

    Parameters
    ----------
    path : str or os.PathLike
        Target file. Its folder is created if missing.
    data : bytes or str
        Content; text is encoded as UTF-8.
    mode : int, optional
        Permission bits of the new file (default ``0o644``, before the umask).
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    payload = data.encode("utf-8") if isinstance(data, str) else data
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    tmp = Path(tmp_name)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(payload)
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
