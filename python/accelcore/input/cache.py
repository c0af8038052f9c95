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
    the cache. Entries are written to a temporary name in the same folder
    and renamed.

Entry layout (``<key>.acrun``, :data:`FORMAT` 2)
    Everything little-endian::

        offset        size        content
        0             8           magic: "ACRUN", then the bytes 00 01 00 (hex)
        8             8           meta_len, uint64 (a multiple of 8)
        16            8           n_floats, uint64
        24            8           n_ints, uint64
        32            8           checksum, uint64: the sum, modulo 2**64, of
                                  all that follows, read as '<u8' words
        40            meta_len    metadata: UTF-8 JSON, padded with spaces
        40+meta_len   8*n_floats  float64 ('<f8'): time_s, temperature_c,
                                  channels (row-major, n_blocks x n_channels),
                                  channel_min, channel_max, then
                                  max_interval_s, first_time_s, last_time_s
        ...           8*n_ints    int64 ('<i8'): count, block_index (if any),
                                  n_at_min, n_at_max (uint64 bits as int64)

    The file is read with one ``readinto`` and the record's arrays are views
    of that buffer (:func:`numpy.frombuffer`, no copy; writeable, as a cold
    read's are; the entries of one load share one buffer). An entry is used
    only if the magic matches, the file's size is exactly what the header
    declares (a truncated entry is a miss), the checksum matches, the
    metadata is valid and of this :data:`FORMAT`, and the two vectors have
    the lengths the metadata implies. The checksum (a plain word sum, much
    cheaper than a CRC) catches any change confined to one 8-byte word, such
    as a flipped bit or byte, and zeroed or overwritten blocks; it is no
    defence against deliberate edits. Entries of the earlier ``numpy.savez``
    format (``<key>.npz``, :data:`FORMAT` 1) are never read; :func:`prune`
    and :func:`clear` remove them.

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
import struct
import tempfile
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from io import FileIO
from pathlib import Path
from typing import Any, BinaryIO, Final, TypeAlias

import numpy as np
from numpy.typing import NDArray

from accelcore import _accelcore
from accelcore._accelcore import RunData, __version__
from accelcore.errors import AccelcoreWarning

__all__ = [
    "FORMAT",
    "RACY_WINDOW_NS",
    "SUFFIX",
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
FORMAT: Final = 2
#: File name suffix of an entry (``<key>.acrun``).
SUFFIX: Final = ".acrun"
#: A file changed (mtime or ctime) less than this before it is read is not cached, ns.
RACY_WINDOW_NS: Final = 2_000_000_000
#: Default size bound of the cache folder, MB (``$ACCELCORE_CACHE_MAX_MB``).
DEFAULT_MAX_MB: Final = 1024.0

#: ``load_session(cache=...)``: True (default folder), False (off) or a folder.
CacheSetting: TypeAlias = bool | str | os.PathLike[str]
#: ``(st_size, st_mtime_ns, st_ctime_ns, st_ino, st_dev)``.
Fingerprint: TypeAlias = tuple[int, int, int, int, int]

#: Suffixes of the entries of earlier formats: never read, removed by prune and clear.
_OLD_SUFFIXES: Final = (".npz",)
#: First 8 bytes of an entry.
_MAGIC: Final = b"ACRUN\x00\x01\x00"
#: magic, meta_len, n_floats, n_ints, checksum.
_HEADER: Final = struct.Struct("<8sQQQQ")
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
    """A run file as :meth:`RunCache.lookup_all` saw it, just before it was read.

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


def _read_files(paths: Sequence[Path]) -> list[NDArray[np.uint8] | Exception | None]:
    """Read each file whole into its own slice of one new, writeable buffer.

    One allocation for all entries of a load (not one per entry): fewer page
    faults, and the allocator recycles it from one load to the next. Each file
    is read with one ``readinto``. Returns, for each path, its bytes; None
    when there is no such file; or the exception that reading it raised.
    """
    out: list[NDArray[np.uint8] | Exception | None] = [None] * len(paths)
    with contextlib.ExitStack() as stack:
        opened: list[tuple[int, FileIO, int]] = []
        for j, path in enumerate(paths):
            try:
                fh = stack.enter_context(open(path, "rb", buffering=0))
                opened.append((j, fh, os.fstat(fh.fileno()).st_size))
            except FileNotFoundError:
                pass
            except Exception as exc:
                out[j] = exc
        starts = [0]
        for _, _, size in opened:
            starts.append(starts[-1] + -(-size // 64) * 64)  # each entry 64-byte aligned
        buf = np.empty(starts[-1], dtype=np.uint8)  # not zeroed, unlike bytearray(size)
        view = buf.data
        for (j, fh, size), start in zip(opened, starts, strict=False):
            got = 0
            try:
                while got < size:  # one read(2) in practice; a loop in case it is cut short
                    n = fh.readinto(view[start + got : start + size])
                    if not n:
                        raise _BadEntry("shorter than its size")
                    got += n
            except Exception as exc:
                out[j] = exc
            else:
                out[j] = buf[start : start + size]
    return out


def _vector(buf: NDArray[np.uint8], dtype: str, count: int, offset: int) -> NDArray[Any]:
    a = np.frombuffer(buf, dtype=dtype, count=count, offset=offset)
    return a if a.dtype.isnative else a.astype(a.dtype.newbyteorder("="))


def _pack(record: RunRecord) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Every array of a record in one float64 and one int64 vector (the entry's layout)."""
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


def _checksum(*parts: NDArray[Any]) -> int:
    """Sum, mod 2**64, of the little-endian uint64 words of ``parts`` (whole words each)."""
    total = 0
    for part in parts:
        words = np.frombuffer(part.data, dtype="<u8")
        total += int(np.add.reduce(words, dtype=np.uint64))
    return total % (1 << 64)


def _write_entry(
    fh: BinaryIO, meta: Mapping[str, Any], floats: NDArray[np.float64], ints: NDArray[np.int64]
) -> None:
    """Write an entry in the layout of the module docstring."""
    text = json.dumps(meta).encode()
    text += b" " * (-len(text) % 8)
    body = [
        np.frombuffer(text, dtype=np.uint8),
        np.ascontiguousarray(floats, dtype="<f8"),
        np.ascontiguousarray(ints, dtype="<i8"),
    ]
    n_floats, n_ints = floats.shape[0], ints.shape[0]
    fh.write(_HEADER.pack(_MAGIC, len(text), n_floats, n_ints, _checksum(*body)))
    for part in body:
        fh.write(part.data)


def _parse_entry(buf: NDArray[np.uint8], probe: Probe) -> tuple[RunRecord, str, Fingerprint]:
    """Check one entry's bytes; :class:`_BadEntry` or any error means a miss.

    The arrays of the record are contiguous, writeable views of the entry's
    two vectors, which are views of ``buf`` (no copy).
    """
    if buf.shape[0] < _HEADER.size:
        raise _BadEntry("shorter than a header")
    magic, meta_len, n_floats, n_ints, checksum = _HEADER.unpack_from(buf.data)
    if magic != _MAGIC:
        raise _BadEntry("magic")
    if meta_len % 8 or buf.shape[0] != _HEADER.size + meta_len + 8 * (n_floats + n_ints):
        raise _BadEntry("size")  # truncated, or a header that does not describe the file
    if _checksum(buf[_HEADER.size :]) != checksum:
        raise _BadEntry("checksum")
    data_start = _HEADER.size + meta_len
    meta = json.loads(buf[_HEADER.size : data_start].tobytes().decode())
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
    if n_floats != n * (2 + k) + 2 * k + 3:
        raise _BadEntry(f"{n_floats} floats, expected {n * (2 + k) + 2 * k + 3}")
    if n_ints != n * (1 + has_index) + 2 * k:
        raise _BadEntry(f"{n_ints} ints, expected {n * (1 + has_index) + 2 * k}")
    floats = _vector(buf, "<f8", n_floats, data_start)
    ints = _vector(buf, "<i8", n_ints, data_start + 8 * n_floats)
    f = [0, n, 2 * n, (2 + k) * n, (2 + k) * n + k, (2 + k) * n + 2 * k]  # vector offsets
    i = [0, n, (1 + has_index) * n, (1 + has_index) * n + k]
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
    :meth:`lookup_all` the run files before reading them, :meth:`store` what
    was read, then :meth:`finish` (bounds the folder's size). No method raises
    because of the cache: every problem is a miss, and a folder that cannot be
    written gives one :class:`CacheWarning`.
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

    def lookup_all(
        self, files: Sequence[Path], params: Mapping[str, Any]
    ) -> list[tuple[tuple[RunRecord, str] | None, Probe | None]]:
        """Look run files up, just before they would be read.

        The entries found are read into one buffer, of which the arrays of
        every hit are views: they stay in memory as long as any of them does.

        Parameters
        ----------
        files : sequence of pathlib.Path
            The run files.
        params : mapping
            The reader parameters (see :func:`entry_key`), the same for all.

        Returns
        -------
        list of (hit, probe)
            For each file: ``hit``, the reader's result and the file's SHA-256
            when the entry is valid (else None), and ``probe``, to pass to
            :meth:`store` after a miss (None: do not store).
        """
        probes: list[Probe | None] = []
        for file in files:
            try:
                resolved = str(file.resolve())
                key = entry_key(resolved, params)
                seen_at = time.time_ns()
                fingerprint = _fingerprint(os.stat(file))
                probes.append(Probe(file, key, resolved, dict(params), seen_at, fingerprint))
            except (OSError, RuntimeError, ValueError, TypeError):
                probes.append(None)  # the reader will report an unreadable file
        results: list[tuple[tuple[RunRecord, str] | None, Probe | None]] = [
            (None, probe) for probe in probes
        ]
        looked_up = [(j, probe) for j, probe in enumerate(probes) if probe is not None]
        entries = [self.directory / f"{probe.key}{SUFFIX}" for _, probe in looked_up]
        try:
            contents = _read_files(entries)
        except Exception:  # e.g. no memory for an absurd entry size: all misses, no error
            return results
        for (j, probe), entry, content in zip(looked_up, entries, contents, strict=True):
            if content is None:
                continue  # no entry
            try:
                if isinstance(content, Exception):
                    raise content
                record, sha256, fingerprint = _parse_entry(content, probe)
            except Exception:  # a bad entry of any kind is a miss, never an error; replace it
                with contextlib.suppress(OSError):
                    entry.unlink()
                continue
            if fingerprint != probe.fingerprint:
                continue
            with contextlib.suppress(OSError):
                os.utime(entry)  # least recently used goes first when pruning
            self.n_hits += 1
            results[j] = ((record, sha256), probe)
        return results

    def store(self, probe: Probe | None, record: RunRecord, sha256: str) -> bool:
        """Write the entry of a run file just read, if it is safe to.

        Skipped when the file changed less than :data:`RACY_WINDOW_NS` before
        it was probed, or when its fingerprint changed while it was read.

        Parameters
        ----------
        probe : Probe or None
            From :meth:`lookup_all`.
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
        tmp: str | None = None
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX, suffix=SUFFIX, dir=self.directory)
            with os.fdopen(fd, "wb") as fh:
                _write_entry(fh, meta, floats, ints)
            os.replace(tmp, self.directory / f"{probe.key}{SUFFIX}")
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


def _entries(directory: Path) -> list[tuple[int, int, Path, str]]:
    """(mtime_ns, size, path, kind) of every cache file in ``directory``.

    ``kind`` is ``"entry"``, ``"temporary"`` (being written, or left by a killed
    writer) or ``"old"`` (an entry of an earlier format, never read again).
    """
    found = []
    with os.scandir(directory) as it:
        for e in it:
            name = e.name
            suffix = next((s for s in (SUFFIX, *_OLD_SUFFIXES) if name.endswith(s)), None)
            if suffix is None:
                continue
            if name.startswith(_TMP_PREFIX):
                kind = "temporary"
            elif len(name) == 64 + len(suffix):
                kind = "entry" if suffix == SUFFIX else "old"
            else:
                continue
            try:
                st = e.stat(follow_symlinks=False)
            except OSError:
                continue
            found.append((st.st_mtime_ns, st.st_size, Path(e.path), kind))
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
        Entries removed, counting the entries of earlier formats (``.npz``),
        which are always removed (temporary files of killed writers, more
        than an hour old, are removed too and not counted).
    """
    bound = _max_bytes() if max_bytes is None else max_bytes
    try:
        found = _entries(directory)
    except OSError:
        return 0
    now = time.time_ns()
    total, kept, removed = 0, [], 0
    for mtime, size, path, kind in found:
        if kind == "old" or (kind == "temporary" and now - mtime > _STALE_TMP_NS):
            try:
                path.unlink()
            except OSError:
                pass
            else:
                removed += kind == "old"
            continue
        total += size
        if kind == "entry":
            kept.append((mtime, size, path))
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
        Entries removed, entries of earlier formats included (0 when the folder
        does not exist).
    """
    directory = default_dir() if cache_dir is None else Path(cache_dir)
    if directory is None:
        return 0
    try:
        found = _entries(directory)
    except OSError:
        return 0
    removed = 0
    for _, _, path, kind in found:
        try:
            path.unlink()
        except OSError:
            continue
        removed += kind != "temporary"
    return removed
