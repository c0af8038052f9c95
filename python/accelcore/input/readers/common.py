"""What every reader shares: chunk size, argument checks and errors laid out as the Rust reader's.

May import: the foundation and :mod:`accelcore.input.format`.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from accelcore.constants import DEFAULT_COLUMNS, ORIENTATIONS, SAMPLE_TIME_UNIT, TIME_UNITS
from accelcore.errors import AccelcoreIOError, ParameterError, ParseError
from accelcore.input.format import check_distinct_columns

__all__ = ["CHUNK_ROWS", "MAX_LINE_BYTES", "GuardedLog"]

#: Rows read per chunk: bounds the memory of every reader, whatever the file size.
CHUNK_ROWS = 65_536

#: Longest line a text log may hold, bytes (the Rust reader's limit): a longer
#: one is binary data or a file without line ends (a sparse file's hole reads as
#: zeros with no line end), refused before it is buffered whole.
MAX_LINE_BYTES = 1 << 20

_ROLES = ("time", "temperature", "x", "y", "z")
_LABELS = tuple(ORIENTATIONS)  # index -> label; -1 means "no label"
_FloatArray = NDArray[np.float64]


def _parse_error(
    path: str, line: int, column: int, reason: str, where: str | None = ""
) -> ParseError:
    """Build a ParseError laid out as the Rust reader's (``path:line:column: reason``).

    ``where`` replaces ``line:column`` in the message; None leaves it out.
    """
    location = "" if where is None else f":{where or f'{line}:{column}'}"
    err = ParseError(f"{path}{location}: {reason}")
    err.path, err.line, err.column = path, line, column
    return err


def _io_error(path: str, reason: str) -> AccelcoreIOError:
    err = AccelcoreIOError(f"{path}: {reason}")
    err.path = path
    return err


def _check_file(path: str | os.PathLike[str]) -> str:
    p = Path(path)
    if not p.exists():
        raise _io_error(str(p), "no such file")
    if not p.is_file():
        raise _io_error(str(p), "not a file")
    return str(p)


def _column_names(columns: Mapping[str, str] | None) -> dict[str, str]:
    names = {**DEFAULT_COLUMNS, **(columns or {})}
    unknown = set(names) - set(DEFAULT_COLUMNS)
    if unknown:
        raise ParameterError(
            f"columns: unknown role(s) {', '.join(sorted(unknown))}; "
            f"expected some of {', '.join(_ROLES)}"
        )
    blank = [r for r in _ROLES if r != "temperature" and not str(names[r]).strip()]
    if blank:
        raise ParameterError(
            f'columns: {", ".join(blank)} must name a column (only temperature may be "": '
            "no temperature logged)"
        )
    check_distinct_columns({r: n for r, n in names.items() if n}, "columns")
    return names


def _check_rate(rate_hz: float, where: str = "rate_hz") -> float:
    if not isinstance(rate_hz, (int, float)) or not math.isfinite(rate_hz) or rate_hz <= 0:
        raise ParameterError(f"{where} must be a positive number, got {rate_hz!r}")
    return float(rate_hz)


def _check_settle(settle_s: float) -> float:
    if not isinstance(settle_s, (int, float)) or not math.isfinite(settle_s) or settle_s < 0:
        raise ParameterError(f"settle_s must be a finite number >= 0, got {settle_s!r}")
    return float(settle_s)


def _time_scale(time_unit: str, rate_hz: float | None) -> float:
    """Seconds per unit of the time column; a sample index (``"sample"``) is ``1 / rate_hz``."""
    if time_unit == SAMPLE_TIME_UNIT:
        if rate_hz is None:
            raise ParameterError("time_unit='sample' (a sample index) needs rate_hz")
        return 1.0 / rate_hz
    if time_unit not in TIME_UNITS:
        known = ", ".join((*TIME_UNITS, SAMPLE_TIME_UNIT))
        raise ParameterError(f"time_unit must be one of {known}, got {time_unit!r}")
    return TIME_UNITS[time_unit]


def _missing_columns(
    path: str, found: Sequence[str], wanted: Sequence[str], *, header_line: bool
) -> ParseError:
    """Missing columns, located on the header line of a text log (else just the file)."""
    missing = [w for w in wanted if w not in found]
    return _parse_error(
        path,
        1,
        1,
        f"missing column(s) {', '.join(repr(m) for m in missing)}; "
        f"found {', '.join(repr(str(f)) for f in found)}",
        where="" if header_line else None,
    )


def _timestamp_seconds(data: NDArray[Any], origin: list[Any]) -> _FloatArray:
    """Seconds of datetime64 values from the first one seen (kept in ``origin``); NaT: NaN."""
    stamps = data.astype("datetime64[ns]")
    valid = ~np.isnat(stamps)
    if not origin and valid.any():
        origin.append(stamps[int(np.argmax(valid))])
    seconds = np.full(stamps.shape, np.nan)
    if origin:
        seconds[valid] = (stamps[valid] - origin[0]).astype(np.int64).astype(np.float64) * 1e-9
    return seconds


class GuardedLog(io.RawIOBase):
    """A text log opened in binary for pandas, refusing a line over :data:`MAX_LINE_BYTES`.

    The check runs on the bytes as they are read, so a 2 GB sparse file or a
    64 MB line fails after about a megabyte instead of being buffered whole.

    Parameters
    ----------
    path : str
        The log (checked to be a regular file by the caller).

    Raises
    ------
    accelcore.ParseError
        From ``read``: a line longer than :data:`MAX_LINE_BYTES` (line and column 1).
    """

    _PIECE = 1 << 18  # bytes per read; below MAX_LINE_BYTES, so a line end is never missed

    def __init__(self, path: str) -> None:
        super().__init__()
        self._path = path
        self._fh = open(path, "rb")  # closed by close()
        self._line = 1  # number of the line being read
        self._since = 0  # bytes read since its start

    def readable(self) -> bool:
        """Return True: the log is read."""
        return True

    def readinto(self, buffer: Any) -> int:
        """Read up to 256 KiB into ``buffer``; refuse a line over the limit."""
        view = memoryview(buffer).cast("B")[: self._PIECE]
        n = self._fh.readinto(view) or 0
        piece = bytes(view[:n])
        first = piece.find(b"\n")
        if self._since + (n if first < 0 else first) > MAX_LINE_BYTES:
            raise _parse_error(
                self._path,
                self._line,
                1,
                f"line longer than {MAX_LINE_BYTES} bytes: not a delimited text log "
                "(binary data, or missing line ends?)",
            )
        if first < 0:
            self._since += n
        else:
            self._line += piece.count(b"\n")
            self._since = n - piece.rfind(b"\n") - 1
        return n

    def close(self) -> None:
        """Close the file."""
        self._fh.close()
        super().close()
