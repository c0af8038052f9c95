"""A persistent cache of decimated runs, so that re-loading a session is nearly free.

:func:`accelcore.load_session` streams every log through the Rust reader and
hashes it (SHA-256, for provenance). Archived sessions are loaded again and
again (calibrate, diagnose, report), so the reader's result for each run file
is kept in one entry per file, under a key made of everything that changes
that result: the file's resolved absolute path, every reader parameter
(delimiter, column mapping, time scale, decimation factor, ``rate_hz``,
``min_count``, extra columns), the accelcore version, the identity of the
compiled extension and :data:`FORMAT`. An entry also holds the file's SHA-256
and its fingerprint ``(st_size, st_mtime_ns, st_ctime_ns, st_ino, st_dev)``.

Never stale
    An entry is used only when the file's fingerprint is the same now. Any
    write to a file changes its ctime, which no program can set back, so a
    rewrite that restores size and mtime is still seen. Entries are written
    only for files whose last change (mtime *and* ctime) is at least
    :data:`RACY_WINDOW_NS` (2 s) older than the moment the fingerprint was
    taken, before the read: a file still being written, or changed within one
    tick of a coarse file-system clock, is never cached (git's "racy clean"
    rule, applied to ctime as well). The fingerprint is taken again after the
    read and the entry is written only if it did not change.

Never in the way
    An unreadable, truncated, corrupt or other-version entry is a miss (and
    is replaced); a cache folder that cannot be written gives at most one
    :class:`CacheWarning` per load and the result is the same as without
    the cache. Entries are ``numpy.savez`` files (metadata as JSON inside,
    read with ``allow_pickle=False``), written to a temporary name in the
    same folder and renamed.

Bounded
    After writing, the least recently used entries (by the entry file's
    mtime, refreshed on every hit) are removed until the folder holds at
    most ``$ACCELCORE_CACHE_MAX_MB`` (default 1024) MB.

Where: ``$ACCELCORE_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/accelcore/runs``,
else ``~/.cache/accelcore/runs``; ``ACCELCORE_CACHE=0`` turns the default
off; ``load_session(..., cache=False)`` or ``cache=DIR`` per call. See
``docs/cache.md``.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import math
import os
import tempfile
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, TypeAlias

import numpy as np
from numpy.typing import NDArray

from accelcore import _accelcore
from accelcore._accelcore import RunData, __version__
from accelcore.errors import AccelcoreWarning

__all__ = [
    "FORMAT",
    "RACY_WINDOW_NS",
    "Blocks",
    "CacheSetting",
    "CacheWarning",
    "Probe",
    "RunCache",
    "RunRecord",
    "clear",
    "default_dir",
    "entry_key",
    "prune",
    "resolve_dir",
]

#: Version of the entry layout; part of every key, and checked on reading.
FORMAT: Final = 1
#: A file changed (mtime or ctime) less than this before it is read is not cached, ns.
RACY_WINDOW_NS: Final = 2_000_000_000
#: Default size bound of the cache folder, MB (``$ACCELCORE_CACHE_MAX_MB``).
DEFAULT_MAX_MB: Final = 1024.0

#: ``load_session(cache=...)``: True (default folder), False (off) or a folder.
CacheSetting: TypeAlias = bool | str | os.PathLike[str]
#: ``(st_size, st_mtime_ns, st_ctime_ns, st_ino, st_dev)``.
Fingerprint: TypeAlias = tuple[int, int, int, int, int]

_SUFFIX: Final = ".npz"
_TMP_PREFIX: Final = ".tmp-"
_STALE_TMP_NS: Final = 3600 * 1_000_000_000  # temporary files of a killed writer
_COUNTS: Final = ("n_rows", "n_skipped_nonfinite", "n_truncated_rows", "n_gaps")


class CacheWarning(AccelcoreWarning):
    """The run cache could not be written; results are correct, only not cached."""


@dataclass(frozen=True)
class Blocks:
    """Decimated blocks of one run, as :class:`accelcore.core.DecimatedBlocks` holds them.

    Attributes
    ----------
    block_index : ndarray of int64 or None
        Block number on the run's grid.
    count : ndarray of int64
        Raw samples averaged in each block.
    time_s, temperature_c : ndarray of float64
        Block mean time, s, and temperature, °C.
    channels : ndarray of float64, shape (n_blocks, n_channels)
        Block mean of each channel.
    """

    block_index: NDArray[np.int64] | None
    count: NDArray[np.int64]
    time_s: NDArray[np.float64]
    temperature_c: NDArray[np.float64]
    channels: NDArray[np.float64]


@dataclass(frozen=True)
class RunRecord:
    """Everything :func:`accelcore.load_session` uses of one :func:`read_run` result.

    The attributes have the names of :class:`accelcore._accelcore.RunData`'s.
    """

    channel_names: tuple[str, ...]
    blocks: Blocks
    n_rows: int
    n_skipped_nonfinite: int
    n_truncated_rows: int
    n_gaps: int
    max_interval_s: float
    first_time_s: float
    last_time_s: float
    channel_min: NDArray[np.float64]
    channel_max: NDArray[np.float64]
    n_at_min: NDArray[np.uint64]
    n_at_max: NDArray[np.uint64]

    @classmethod
    def from_run_data(cls, data: RunData) -> RunRecord:
        """Take what is needed from a reader result.

        Parameters
        ----------
        data : accelcore._accelcore.RunData

        Returns
        -------
        RunRecord
        """
        b = data.blocks
        block_index: NDArray[np.int64] | None = getattr(b, "block_index", None)
        return cls(
            channel_names=tuple(data.channel_names),
            blocks=Blocks(block_index, b.count, b.time_s, b.temperature_c, b.channels),
            n_rows=data.n_rows,
            n_skipped_nonfinite=data.n_skipped_nonfinite,
            n_truncated_rows=data.n_truncated_rows,
            n_gaps=data.n_gaps,
            max_interval_s=data.max_interval_s,
            first_time_s=data.first_time_s,
            last_time_s=data.last_time_s,
            channel_min=data.channel_min,
            channel_max=data.channel_max,
            n_at_min=data.n_at_min,
            n_at_max=data.n_at_max,
        )


class _BadEntry(Exception):
    """An entry that cannot be used: treated as a miss and replaced."""


def default_dir() -> Path | None:
    """Return the default cache folder, whether or not the cache is on.

    Returns
    -------
    pathlib.Path or None
        ``$ACCELCORE_CACHE_DIR``, else ``$XDG_CACHE_HOME/accelcore/runs`` (an
        absolute ``XDG_CACHE_HOME`` only, as the XDG specification says), else
        ``~/.cache/accelcore/runs``; None when there is no home folder.
    """
    explicit = os.environ.get("ACCELCORE_CACHE_DIR")
    if explicit:
        return Path(explicit).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "accelcore" / "runs"
    try:
        return Path.home() / ".cache" / "accelcore" / "runs"
    except RuntimeError:  # no home folder (e.g. an unknown uid without $HOME)
        return None


def resolve_dir(cache: CacheSetting) -> Path | None:
    """Return the folder a ``cache=`` argument means, or None for no cache.

    Parameters
    ----------
    cache : bool, str or os.PathLike
        True: :func:`default_dir`, unless the environment variable
        ``ACCELCORE_CACHE`` is ``0`` (or ``false``, ``no``, ``off``); False: no
        cache; a path: that folder.

    Returns
    -------
    pathlib.Path or None

    Raises
    ------
    TypeError
        ``cache`` is of another type.
    """
    if cache is True:
        if os.environ.get("ACCELCORE_CACHE", "").strip().lower() in ("0", "false", "no", "off"):
            return None
        return default_dir()
    if cache is False:
        return None
    if isinstance(cache, (str, os.PathLike)):
        return Path(cache).expanduser()
    raise TypeError(f"cache must be True, False or a folder, got {cache!r}")


def _max_bytes() -> float:
    try:
        mb = float(os.environ.get("ACCELCORE_CACHE_MAX_MB", DEFAULT_MAX_MB))
    except ValueError:
        mb = DEFAULT_MAX_MB
    if not math.isfinite(mb):
        mb = DEFAULT_MAX_MB
    return max(mb, 0.0) * 1e6


@functools.cache
def _extension_identity() -> list[int]:
    """Size and mtime of the compiled extension: a rebuild of the same version is a new key."""
    try:
        st = os.stat(str(_accelcore.__file__))
    except (OSError, TypeError, AttributeError):
        return []
    return [st.st_size, st.st_mtime_ns]


def entry_key(resolved_path: str, params: Mapping[str, Any]) -> str:
    """Return the key of one run file's entry.

    Parameters
    ----------
    resolved_path : str
        The run file's resolved absolute path.
    params : mapping
        Every reader parameter that changes the result (JSON-serialisable).

    Returns
    -------
    str
        64 hex digits (SHA-256 of the path, the parameters, the accelcore
        version, the extension's identity and :data:`FORMAT`).
    """
    material = {
        "format": FORMAT,
        "accelcore": __version__,
        "extension": _extension_identity(),
        "path": resolved_path,
        "params": dict(params),
    }
    text = json.dumps(material, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def _fingerprint(st: os.stat_result) -> Fingerprint:
    return (st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino, st.st_dev)


@dataclass(frozen=True)
class Probe:
    """A run file as :meth:`RunCache.lookup` saw it, just before it was read.

    Attributes
    ----------
    file : pathlib.Path
    key : str
        Its entry's key (:func:`entry_key`).
    resolved : str
        Its resolved absolute path.
    params : dict
        The reader parameters.
    seen_at_ns : int
        Wall clock just before the fingerprint was taken, ns since the epoch.
    fingerprint : tuple of int
        ``(st_size, st_mtime_ns, st_ctime_ns, st_ino, st_dev)``.
    """

    file: Path
    key: str
    resolved: str
    params: dict[str, Any]
    seen_at_ns: int  # wall clock just before the stat
    fingerprint: Fingerprint


def _member(npz: Any, name: str, dtype: type[np.generic], size: int | None = None) -> NDArray[Any]:
    a = npz[name]
    if not isinstance(a, np.ndarray) or a.dtype != np.dtype(dtype) or a.ndim != 1:
        raise _BadEntry(f"member {name!r}")
    if size is not None and a.shape[0] != size:
        raise _BadEntry(f"member {name!r} has {a.shape[0]} values, expected {size}")
    return a


def _pack(record: RunRecord) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Every array of a record in one float64 and one int64 vector (few zip members: fast)."""
    b = record.blocks
    floats = np.concatenate(
        [
            b.time_s,
            b.temperature_c,
            b.channels.ravel(),
            record.channel_min,
            record.channel_max,
            [record.max_interval_s, record.first_time_s, record.last_time_s],
        ]
    ).astype(np.float64, copy=False)
    ints = np.concatenate(
        [b.count]
        + ([] if b.block_index is None else [b.block_index])
        + [record.n_at_min.view(np.int64), record.n_at_max.view(np.int64)]
    ).astype(np.int64, copy=False)
    return floats, ints


def _read_entry(path: Path, probe: Probe) -> tuple[RunRecord, str, Fingerprint]:
    """Load and check one entry; :class:`_BadEntry` or any error means a miss.

    The arrays of the record are contiguous views of the entry's two vectors.
    """
    # Open the file here: np.load leaks its own handle when the zip is unreadable.
    with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as npz:
        meta = json.loads(bytes(_member(npz, "meta", np.uint8)).decode())
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise _BadEntry("format")
        if meta.get("key") != probe.key or meta.get("accelcore") != __version__:
            raise _BadEntry("key")
        fingerprint, sha256, names = meta["fingerprint"], meta["sha256"], meta["channel_names"]
        n, has_index = meta["n_blocks"], meta["block_index"]
        counts = [meta[k] for k in _COUNTS]
        if not (
            isinstance(fingerprint, list)
            and len(fingerprint) == 5
            and all(type(v) is int for v in fingerprint)
            and isinstance(sha256, str)
            and len(sha256) == 64
            and all(c in "0123456789abcdef" for c in sha256)
            and isinstance(names, list)
            and all(isinstance(c, str) for c in names)
            and all(type(v) is int and v >= 0 for v in [n, *counts])
            and type(has_index) is bool
        ):
            raise _BadEntry("metadata")
        k = len(names)
        floats = _member(npz, "floats", np.float64, n * (2 + k) + 2 * k + 3)
        ints = _member(npz, "ints", np.int64, n * (1 + has_index) + 2 * k)
    f = np.cumsum([0, n, n, n * k, k, k])
    i = np.cumsum([0, n, n * has_index, k])
    max_interval, first, last = (float(v) for v in floats[f[5] :])
    record = RunRecord(
        channel_names=tuple(names),
        blocks=Blocks(
            block_index=ints[i[1] : i[2]] if has_index else None,
            count=ints[i[0] : i[1]],
            time_s=floats[f[0] : f[1]],
            temperature_c=floats[f[1] : f[2]],
            channels=floats[f[2] : f[3]].reshape(n, k),
        ),
        n_rows=counts[0],
        n_skipped_nonfinite=counts[1],
        n_truncated_rows=counts[2],
        n_gaps=counts[3],
        max_interval_s=max_interval,
        first_time_s=first,
        last_time_s=last,
        channel_min=floats[f[3] : f[4]],
        channel_max=floats[f[4] : f[5]],
        n_at_min=ints[i[2] : i[3]].view(np.uint64),
        n_at_max=ints[i[3] :].view(np.uint64),
    )
    fp = (fingerprint[0], fingerprint[1], fingerprint[2], fingerprint[3], fingerprint[4])
    return record, sha256, fp


class RunCache:
    """The cache as one :func:`accelcore.load_session` call uses it.

    Parameters
    ----------
    directory : pathlib.Path
        The cache folder (created on the first write).

    Notes
    -----
    :meth:`lookup` each run file before reading it, :meth:`store` what was
    read, then :meth:`finish` (bounds the folder's size). No method raises
    because of the cache: every problem is a miss, and a folder that cannot
    be written gives one :class:`CacheWarning`.
    """

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.n_hits = 0
        self.n_written = 0
        self._warned = False

    @classmethod
    def open(cls, cache: CacheSetting) -> RunCache | None:
        """Open the cache a ``cache=`` argument asks for (see :func:`resolve_dir`), or None.

        Parameters
        ----------
        cache : bool, str or os.PathLike

        Returns
        -------
        RunCache or None
        """
        directory = resolve_dir(cache)
        return None if directory is None else cls(directory)

    def lookup(
        self, file: Path, params: Mapping[str, Any]
    ) -> tuple[tuple[RunRecord, str] | None, Probe | None]:
        """Look a run file up, just before it would be read.

        Parameters
        ----------
        file : pathlib.Path
            The run file.
        params : mapping
            The reader parameters (see :func:`entry_key`).

        Returns
        -------
        hit : (RunRecord, str) or None
            The reader's result and the file's SHA-256, when the entry is valid.
        probe : Probe or None
            Pass it to :meth:`store` after a miss (None: do not store).
        """
        try:
            resolved = str(file.resolve())
            key = entry_key(resolved, params)
            seen_at = time.time_ns()
            probe = Probe(file, key, resolved, dict(params), seen_at, _fingerprint(os.stat(file)))
        except (OSError, RuntimeError, ValueError, TypeError):
            return None, None  # the reader will report an unreadable file
        entry = self.directory / f"{key}{_SUFFIX}"
        try:
            record, sha256, fingerprint = _read_entry(entry, probe)
        except FileNotFoundError:
            return None, probe
        except Exception:  # a bad entry of any kind is a miss, never an error; replace it
            with contextlib.suppress(OSError):
                entry.unlink()
            return None, probe
        if fingerprint != probe.fingerprint:
            return None, probe
        with contextlib.suppress(OSError):
            os.utime(entry)  # least recently used goes first when pruning
        self.n_hits += 1
        return (record, sha256), probe

    def store(self, probe: Probe | None, record: RunRecord, sha256: str) -> bool:
        """Write the entry of a run file just read, if it is safe to.

        Skipped when the file changed less than :data:`RACY_WINDOW_NS` before
        it was probed, or when its fingerprint changed while it was read.

        Parameters
        ----------
        probe : Probe or None
            From :meth:`lookup`.
        record : RunRecord
            What the reader returned.
        sha256 : str
            The file's SHA-256, computed between the probe and now.

        Returns
        -------
        bool
            Whether an entry was written.
        """
        if probe is None:
            return False
        _, mtime_ns, ctime_ns, _, _ = probe.fingerprint
        if probe.seen_at_ns - max(mtime_ns, ctime_ns) < RACY_WINDOW_NS:
            return False  # may still be growing, or changed within a clock tick
        try:
            if _fingerprint(os.stat(probe.file)) != probe.fingerprint:
                return False  # changed while it was read
        except OSError:
            return False
        b = record.blocks
        n, k = b.count.shape[0], len(record.channel_names)
        layout = [
            (b.count, np.int64, (n,)),
            (b.time_s, np.float64, (n,)),
            (b.temperature_c, np.float64, (n,)),
            (b.channels, np.float64, (n, k)),
            (record.channel_min, np.float64, (k,)),
            (record.channel_max, np.float64, (k,)),
            (record.n_at_min, np.uint64, (k,)),
            (record.n_at_max, np.uint64, (k,)),
        ]
        if b.block_index is not None:
            layout.append((b.block_index, np.int64, (n,)))
        if any(a.dtype != np.dtype(t) or a.shape != shape for a, t, shape in layout):
            return False  # not what this entry format describes: never cache a guess
        meta = {
            "format": FORMAT,
            "key": probe.key,
            "accelcore": __version__,
            "path": probe.resolved,
            "params": probe.params,
            "fingerprint": list(probe.fingerprint),
            "sha256": sha256,
            "channel_names": list(record.channel_names),
            "n_blocks": n,
            "block_index": b.block_index is not None,
            "written_at_ns": time.time_ns(),
            **{name: int(getattr(record, name)) for name in _COUNTS},
        }
        floats, ints = _pack(record)
        arrays: dict[str, Any] = {  # Any: numpy types savez(**kwds) as allow_pickle too
            "meta": np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8),
            "floats": floats,
            "ints": ints,
        }
        tmp: str | None = None
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX, suffix=_SUFFIX, dir=self.directory)
            with os.fdopen(fd, "wb") as fh:
                np.savez(fh, **arrays)
            os.replace(tmp, self.directory / f"{probe.key}{_SUFFIX}")
            tmp = None
        except Exception as exc:  # disk full, read-only folder, ...: results stay correct
            if tmp is not None:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
            if not self._warned:
                self._warned = True
                warnings.warn(
                    CacheWarning(
                        f"cannot write the run cache in {self.directory} ({exc}); results are "
                        "correct but not cached (set ACCELCORE_CACHE_DIR, or cache=False / "
                        "--no-cache)"
                    ),
                    stacklevel=3,
                )
            return False
        self.n_written += 1
        return True

    def finish(self) -> None:
        """Bound the folder's size (after anything was written)."""
        if self.n_written:
            prune(self.directory)


def _entries(directory: Path) -> list[tuple[int, int, Path, bool]]:
    """(mtime_ns, size, path, is_temporary) of every cache file in ``directory``."""
    found = []
    with os.scandir(directory) as it:
        for e in it:
            name = e.name
            is_tmp = name.startswith(_TMP_PREFIX)
            if not name.endswith(_SUFFIX) or not (is_tmp or len(name) == 64 + len(_SUFFIX)):
                continue
            try:
                st = e.stat(follow_symlinks=False)
            except OSError:
                continue
            found.append((st.st_mtime_ns, st.st_size, Path(e.path), is_tmp))
    return found


def prune(directory: Path, max_bytes: float | None = None) -> int:
    """Remove least recently used entries until the folder is within its size bound.

    Parameters
    ----------
    directory : pathlib.Path
        The cache folder.
    max_bytes : float, optional
        The bound; default ``$ACCELCORE_CACHE_MAX_MB`` (1024) MB.

    Returns
    -------
    int
        Entries removed (temporary files of killed writers, more than an hour
        old, are removed too and not counted).
    """
    bound = _max_bytes() if max_bytes is None else max_bytes
    try:
        found = _entries(directory)
    except OSError:
        return 0
    now = time.time_ns()
    total, kept = 0, []
    for mtime, size, path, is_tmp in found:
        if is_tmp and now - mtime > _STALE_TMP_NS:
            with contextlib.suppress(OSError):
                path.unlink()
            continue
        total += size
        if not is_tmp:
            kept.append((mtime, size, path))
    removed = 0
    for _, size, path in sorted(kept, key=lambda e: e[0]):  # oldest use first
        if total <= bound:
            break
        try:
            path.unlink()
        except FileNotFoundError:
            pass  # another process pruned it
        except OSError:
            continue
        total -= size
        removed += 1
    return removed


def clear(cache_dir: str | os.PathLike[str] | None = None) -> int:
    """Remove every entry of the run cache.

    Parameters
    ----------
    cache_dir : str or os.PathLike, optional
        The cache folder; default :func:`default_dir`.

    Returns
    -------
    int
        Entries removed (0 when the folder does not exist).
    """
    directory = default_dir() if cache_dir is None else Path(cache_dir)
    if directory is None:
        return 0
    try:
        found = _entries(directory)
    except OSError:
        return 0
    removed = 0
    for _, _, path, is_tmp in found:
        try:
            path.unlink()
        except OSError:
            continue
        removed += not is_tmp
    return removed
