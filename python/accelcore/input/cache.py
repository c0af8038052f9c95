"""A persistent cache of decimated runs, so that re-loading a session is nearly free.

:func:`accelcore.load_session` streams every log through the Rust reader and
hashes it (BLAKE3 by default, or SHA-256 on request, for provenance).
Archived sessions are loaded again and again (calibrate, diagnose, report), so
the reader's result for each run file is kept in one entry per file, under a
key made of everything that changes that result: the file's resolved absolute
path, every reader parameter (delimiter, column mapping, time scale,
decimation factor, ``rate_hz``, ``min_count``, extra columns) and the digest's
algorithm, the accelcore version, the identity of the compiled extension and
:data:`FORMAT`. An entry also holds the file's digest, its algorithm and the
file's fingerprint ``(st_size, st_mtime_ns, st_ctime_ns, st_ino, st_dev)``.

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
    the cache. Entries are written with :func:`accelcore.files.atomic_write`
    (a temporary name in the same folder, fsync, rename; readable by the
    owner only, as the runs they hold may be private).

Entry layout
    One file per run, ``<key>.acrun``, checked on reading (magic, size,
    checksum, metadata): see :mod:`accelcore.input.cache_entry`.

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
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, TypeAlias

import numpy as np
from numpy.typing import NDArray

import accelcore._accelcore as _accelcore
from accelcore._accelcore import __version__
from accelcore.errors import AccelcoreWarning
from accelcore.files import atomic_write
from accelcore.input.cache_entry import (
    COUNTS,
    FORMAT,
    Blocks,
    Fingerprint,
    RunRecord,
    entry_bytes,
    pack,
    parse_entry,
    read_files,
)

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

#: File name suffix of an entry (``<key>.acrun``).
SUFFIX: Final = ".acrun"
#: A file changed (mtime or ctime) less than this before it is read is not cached, ns.
RACY_WINDOW_NS: Final = 2_000_000_000
#: Default size bound of the cache folder, MB (``$ACCELCORE_CACHE_MAX_MB``).
DEFAULT_MAX_MB: Final = 1024.0

#: ``load_session(cache=...)``: True (default folder), False (off) or a folder.
CacheSetting: TypeAlias = bool | str | os.PathLike[str]

#: Suffixes of the entries of earlier formats: never read, removed by prune and clear.
_OLD_SUFFIXES: Final = (".npz",)
#: Temporary files of the writers of earlier versions (``.tmp-*.acrun``).
_TMP_PREFIX: Final = ".tmp-"
#: Suffix of :func:`accelcore.files.atomic_write`'s temporary files (``.<entry name>.*.tmp``).
_ATOMIC_TMP_SUFFIX: Final = ".tmp"
_STALE_TMP_NS: Final = 3600 * 1_000_000_000  # temporary files of a killed writer


class CacheWarning(AccelcoreWarning):
    """The run cache could not be written; results are correct, only not cached."""


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
        The reader parameters and ``"digest"``, the digest's algorithm.
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


def _write_entry(
    path: Path, meta: Mapping[str, Any], floats: NDArray[np.float64], ints: NDArray[np.int64]
) -> None:
    """Write an entry atomically (readable by the owner only)."""
    atomic_write(path, entry_bytes(meta, floats, ints), mode=0o600)


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
        self, files: Sequence[Path], params: Mapping[str, Any], digest: str = "blake3"
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
        digest : {"blake3", "sha256"}, default "blake3"
            The algorithm of the digest wanted: part of the key (an entry holds
            one digest).

        Returns
        -------
        list of (hit, probe)
            For each file: ``hit``, the reader's result and the file's hex digest
            when the entry is valid (else None), and ``probe``, to pass to
            :meth:`store` after a miss (None: do not store).
        """
        params = {**params, "digest": digest}
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
            contents = read_files(entries)
        except Exception:  # e.g. no memory for an absurd entry size: all misses, no error
            return results
        for (j, probe), entry, content in zip(looked_up, entries, contents, strict=True):
            if content is None:
                continue  # no entry
            try:
                if isinstance(content, Exception):
                    raise content
                record, hexdigest, fingerprint = parse_entry(content, probe.key)
            except Exception:  # a bad entry of any kind is a miss, never an error; replace it
                with contextlib.suppress(OSError):
                    entry.unlink()
                continue
            if fingerprint != probe.fingerprint:
                continue
            with contextlib.suppress(OSError):
                os.utime(entry)  # least recently used goes first when pruning
            self.n_hits += 1
            results[j] = ((record, hexdigest), probe)
        return results

    def store(self, probe: Probe | None, record: RunRecord, hexdigest: str) -> bool:
        """Write the entry of a run file just read, if it is safe to.

        Skipped when the file changed less than :data:`RACY_WINDOW_NS` before
        it was probed, or when its fingerprint changed while it was read.

        Parameters
        ----------
        probe : Probe or None
            From :meth:`lookup_all`.
        record : RunRecord
            What the reader returned.
        hexdigest : str
            The file's digest (of the algorithm ``probe.params["digest"]``),
            computed between the probe and now.

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
            "digest": hexdigest,
            "digest_algorithm": probe.params["digest"],
            "channel_names": list(record.channel_names),
            "n_blocks": n,
            "block_index": b.block_index is not None,
            "written_at_ns": time.time_ns(),
            **{name: int(getattr(record, name)) for name in COUNTS},
        }
        floats, ints = pack(record)
        try:  # atomic_write leaves no temporary file behind when it fails
            _write_entry(self.directory / f"{probe.key}{SUFFIX}", meta, floats, ints)
        except Exception as exc:  # disk full, read-only folder, ...: results stay correct
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


def _is_atomic_tmp(name: str) -> bool:
    """Whether ``name`` is an entry's temporary file (``.<key>.acrun.<random>.tmp``)."""
    head = 1 + 64 + len(SUFFIX) + 1
    return (
        name.startswith(".")
        and name.endswith(_ATOMIC_TMP_SUFFIX)
        and len(name) > head + len(_ATOMIC_TMP_SUFFIX)
        and all(c in "0123456789abcdef" for c in name[1:65])
        and name[65:head] == f"{SUFFIX}."
    )


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
                if _is_atomic_tmp(name):
                    kind = "temporary"
                    with contextlib.suppress(OSError):
                        st = e.stat(follow_symlinks=False)
                        found.append((st.st_mtime_ns, st.st_size, Path(e.path), kind))
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
