"""The run cache's entry: what one entry file holds, how it is written and checked.

:mod:`accelcore.input.cache` decides when an entry is used, written and
removed; this module only knows the bytes.

Entry layout (``<key>.acrun``, :data:`FORMAT` 3)
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
    and :func:`clear` remove them. :data:`FORMAT` 2 held a SHA-256 under
    ``"sha256"``; 3 holds ``"digest"`` and ``"digest_algorithm"`` (BLAKE3 by
    default); a format 2 entry is a miss, replaced.

May import: the foundation only.
"""

from __future__ import annotations

import contextlib
import json
import os
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from io import FileIO
from pathlib import Path
from typing import Any, Final, TypeAlias

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import RunData, __version__

__all__ = [
    "FORMAT",
    "BadEntry",
    "Blocks",
    "Fingerprint",
    "RunRecord",
    "entry_bytes",
    "pack",
    "parse_entry",
    "read_files",
]

#: Version of the entry layout; part of every key, and checked on reading.
FORMAT: Final = 3
#: The digests an entry may hold (``load_session(..., digest=...)``).
DIGEST_ALGORITHMS: Final = ("blake3", "sha256")
#: ``(st_size, st_mtime_ns, st_ctime_ns, st_ino, st_dev)``.
Fingerprint: TypeAlias = tuple[int, int, int, int, int]
#: First 8 bytes of an entry.
_MAGIC: Final = b"ACRUN\x00\x01\x00"
#: magic, meta_len, n_floats, n_ints, checksum.
_HEADER: Final = struct.Struct("<8sQQQQ")
#: The counters of a record, kept in the metadata.
COUNTS: Final = ("n_rows", "n_skipped_nonfinite", "n_truncated_rows", "n_gaps")


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


class BadEntry(Exception):
    """An entry that cannot be used: treated as a miss and replaced."""


def read_files(paths: Sequence[Path]) -> list[NDArray[np.uint8] | Exception | None]:
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
                        raise BadEntry("shorter than its size")
                    got += n
            except Exception as exc:
                out[j] = exc
            else:
                out[j] = buf[start : start + size]
    return out


def _vector(buf: NDArray[np.uint8], dtype: str, count: int, offset: int) -> NDArray[Any]:
    a = np.frombuffer(buf, dtype=dtype, count=count, offset=offset)
    return a if a.dtype.isnative else a.astype(a.dtype.newbyteorder("="))


def pack(record: RunRecord) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
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


def entry_bytes(
    meta: Mapping[str, Any], floats: NDArray[np.float64], ints: NDArray[np.int64]
) -> bytes:
    """Return an entry's bytes, in the layout of the module docstring.

    Parameters
    ----------
    meta : mapping
        The metadata (JSON-serialisable).
    floats, ints : ndarray
        The two vectors (see :func:`pack`).

    Returns
    -------
    bytes
    """
    text = json.dumps(meta).encode()
    text += b" " * (-len(text) % 8)
    body = [
        np.frombuffer(text, dtype=np.uint8),
        np.ascontiguousarray(floats, dtype="<f8"),
        np.ascontiguousarray(ints, dtype="<i8"),
    ]
    n_floats, n_ints = floats.shape[0], ints.shape[0]
    header = _HEADER.pack(_MAGIC, len(text), n_floats, n_ints, _checksum(*body))
    return b"".join([header, *(part.tobytes() for part in body)])


def parse_entry(buf: NDArray[np.uint8], key: str) -> tuple[RunRecord, str, Fingerprint]:
    """Check one entry's bytes; :class:`BadEntry` or any error means a miss.

    The arrays of the record are contiguous, writeable views of the entry's
    two vectors, which are views of ``buf`` (no copy).
    """
    if buf.shape[0] < _HEADER.size:
        raise BadEntry("shorter than a header")
    magic, meta_len, n_floats, n_ints, checksum = _HEADER.unpack_from(buf.data)
    if magic != _MAGIC:
        raise BadEntry("magic")
    if meta_len % 8 or buf.shape[0] != _HEADER.size + meta_len + 8 * (n_floats + n_ints):
        raise BadEntry("size")  # truncated, or a header that does not describe the file
    if _checksum(buf[_HEADER.size :]) != checksum:
        raise BadEntry("checksum")
    data_start = _HEADER.size + meta_len
    meta = json.loads(buf[_HEADER.size : data_start].tobytes().decode())
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise BadEntry("format")
    if meta.get("key") != key or meta.get("accelcore") != __version__:
        raise BadEntry("key")
    fingerprint, digest, names = meta["fingerprint"], meta["digest"], meta["channel_names"]
    n, has_index = meta["n_blocks"], meta["block_index"]
    counts = [meta[k] for k in COUNTS]
    if not (
        isinstance(fingerprint, list)
        and len(fingerprint) == 5
        and all(type(v) is int for v in fingerprint)
        and meta["digest_algorithm"] in DIGEST_ALGORITHMS
        and isinstance(digest, str)
        and len(digest) == 64
        and all(c in "0123456789abcdef" for c in digest)
        and isinstance(names, list)
        and all(isinstance(c, str) for c in names)
        and all(type(v) is int and v >= 0 for v in [n, *counts])
        and type(has_index) is bool
    ):
        raise BadEntry("metadata")
    k = len(names)
    if n_floats != n * (2 + k) + 2 * k + 3:
        raise BadEntry(f"{n_floats} floats, expected {n * (2 + k) + 2 * k + 3}")
    if n_ints != n * (1 + has_index) + 2 * k:
        raise BadEntry(f"{n_ints} ints, expected {n * (1 + has_index) + 2 * k}")
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
    return record, digest, fp
