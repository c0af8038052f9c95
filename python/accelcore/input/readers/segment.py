"""From chunks of rows to runs, each decimated and tallied as it streams by.

Every change of orientation label starts a run.

May import: the foundation, :mod:`accelcore.input.format`, :mod:`accelcore.input.session`
and :mod:`accelcore.input.readers.common`.
"""

from __future__ import annotations

import itertools
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from accelcore import core
from accelcore._accelcore import RunTally
from accelcore.constants import ORIENTATIONS
from accelcore.errors import (
    DataQualityWarning,
    InsufficientDataError,
    SessionFormatError,
    TimeOrderError,
)
from accelcore.input.format import gravity_of
from accelcore.input.readers.common import _LABELS, _FloatArray, _parse_error
from accelcore.input.session import Run, RunStats, _make_run
from accelcore.input.temperature_units import impossible_temperature, not_a_temperature


class _RunBuilder:
    """Decimates one run pushed in chunks, with the statistics the Rust reader keeps.

    ``where`` turns a row's position into the text of an error location. Without
    ``temperature`` (none logged), the caller pushes the time in its place (always
    finite, so no row is skipped for it) and the run gets NaN temperatures, as
    :func:`accelcore.load_session` does.
    """

    def __init__(
        self,
        label: str,
        *,
        source: str,
        path: str,
        time_column: int,
        n_channels: int,
        extra_names: Sequence[str],
        factor: int,
        rate_hz: float,
        min_count: int,
        settle_s: float,
        row_word: str,
        temperature: bool = True,
        temperature_column: int = 0,
    ) -> None:
        self.label = label
        self.temperature = temperature
        self.temperature_column = temperature_column
        self.source = source
        self.path = path
        self.time_column = time_column
        self.extra_names = list(extra_names)
        self.settle_s = settle_s
        self.row_word = row_word
        self.decimator = core.Decimator(
            factor=factor, rate_hz=rate_hz, n_channels=n_channels, min_count=min_count
        )
        self.tally = RunTally(n_channels=n_channels, rate_hz=rate_hz)
        self.start_s: float | None = None  # first finite time of the run (settling origin)
        self.settled = False
        self.first_pos: int | None = None
        self.last_pos: int | None = None
        self.n_settling = 0
        self.n_truncated = 0

    def push(
        self,
        time_s: _FloatArray,
        temperature_c: _FloatArray,
        channels: _FloatArray,
        positions: NDArray[np.int64],
    ) -> None:
        if time_s.size == 0:
            return
        if self.first_pos is None:
            self.first_pos = int(positions[0])
        self.last_pos = int(positions[-1])
        if self.settle_s > 0 and not self.settled:
            finite = np.isfinite(time_s)
            if self.start_s is None and finite.any():
                self.start_s = float(time_s[int(np.argmax(finite))])
            settled = (
                time_s >= self.start_s + self.settle_s
                if self.start_s is not None
                else np.zeros(time_s.shape, dtype=bool)
            )
            if not settled.any():
                self.n_settling += time_s.size
                return
            i = int(np.argmax(settled))
            self.settled = True
            self.n_settling += i
            time_s, temperature_c = time_s[i:], temperature_c[i:]
            channels, positions = channels[i:], positions[i:]
        if self.temperature:
            k = impossible_temperature(temperature_c)
            if k is not None:
                pos = int(positions[k])
                raise _parse_error(
                    self.path,
                    pos,
                    self.temperature_column,
                    not_a_temperature(float(temperature_c[k])),
                    where=self._where(pos, self.temperature_column),
                ) from None
        try:
            self.decimator.push(time_s, temperature_c, channels)
        except TimeOrderError as exc:
            pos = int(positions[exc.index])
            raise _parse_error(
                self.path,
                pos,
                self.time_column,
                f"time is not strictly increasing: {exc.previous_s!r} s then {exc.time_s!r} s",
                where=self._where(pos),
            ) from None
        self.tally.push(time_s, temperature_c, channels)

    def _where(self, pos: int, column: int | None = None) -> str:
        column = self.time_column if column is None else column
        return f"{self.row_word} {pos}" if self.row_word != "line" else f"{pos}:{column}"

    def span(self) -> str:
        """Describe the run's rows, e.g. ``lines 2-7201``."""
        return f"{self.row_word}s {self.first_pos}-{self.last_pos}"

    def finish(self) -> Run | None:
        """Return the decimated run, or None (with a warning) when no block has valid data."""
        try:
            blocks = self.decimator.finish()
        except InsufficientDataError:
            why = (
                f"all within settle_s={self.settle_s:g} s of its start"
                if self.tally.n_rows == 0 and self.n_settling
                else "no row with finite values in every column"
            )
            warnings.warn(
                f"{self.path}: run {self.label} ({self.span()}) dropped: {why}",
                DataQualityWarning,
                stacklevel=4,
            )
            return None
        stats = RunStats.from_raw(self.tally.finish(), n_truncated_rows=self.n_truncated)
        return _make_run(
            self.label,
            gravity_of(self.label),
            blocks,
            self.extra_names,
            self.source,
            stats,
            temperature=self.temperature,
        )


@dataclass
class _Chunk:
    """Rows of a log, ready for the segmenter.

    ``labels`` holds an index into ``_LABELS`` per row (-1: no label), or None when
    one orientation covers the whole file; ``positions`` the 1-based line or row
    number of each row, for error messages and run spans; ``truncated`` says that
    a last line cut off mid-write was dropped after these rows.
    """

    time_s: _FloatArray
    temperature_c: _FloatArray
    channels: _FloatArray
    positions: NDArray[np.int64]
    labels: NDArray[np.int64] | None
    truncated: bool = False


@dataclass
class _Layout:
    path: str
    time_column: int
    extra_names: list[str]
    n_channels: int
    row_word: str
    fragment: str  # how a run's span is written into Run.source ("L" or "rows=")
    temperature: bool = True  # False: no temperature logged (time pushed in its place)
    temperature_column: int = 0  # 1-based column of the temperature (0: not a column)


def _label_ids(
    raw: NDArray[Any],
    positions: NDArray[np.int64],
    *,
    path: str,
    column_index: int,
    column_name: str,
    row_word: str,
) -> NDArray[np.int64]:
    """Orientation index of each raw label (``-1`` for a missing one); unknown labels raise."""
    codes, uniques = pd.factorize(pd.Series(raw, dtype=object), use_na_sentinel=True)
    table = np.full(len(uniques) + 1, -1, dtype=np.int64)  # last slot: the NA sentinel
    for k, value in enumerate(uniques):
        key = str(value).strip().upper()
        if key in ORIENTATIONS:
            table[k] = _LABELS.index(key)
        elif key:
            pos = int(positions[int(np.argmax(codes == k))])
            where = f"{pos}:{column_index}" if row_word == "line" else f"{row_word} {pos}"
            raise SessionFormatError(
                f"{path}:{where}: unknown orientation {str(value)!r} in column "
                f"{column_name!r} (column {column_index}); expected one of "
                f"{', '.join(ORIENTATIONS)}"
            )
    return table[np.asarray(codes, dtype=np.int64)]


def _drop_unlabelled(chunk: _Chunk, *, path: str, column_index: int, row_word: str) -> _Chunk:
    """Drop blank rows (no label, no value); a row with values but no label raises."""
    assert chunk.labels is not None
    missing = chunk.labels < 0
    if not missing.any():
        return chunk
    values = np.column_stack([chunk.time_s, chunk.temperature_c, chunk.channels])
    has_data = missing & np.isfinite(values).any(axis=1)
    if has_data.any():
        pos = int(chunk.positions[int(np.argmax(has_data))])
        where = f"{pos}:{column_index}" if row_word == "line" else f"{row_word} {pos}"
        raise SessionFormatError(
            f"{path}:{where}: no orientation label (column {column_index}) on a row with data"
        )
    keep = ~missing
    return _Chunk(
        chunk.time_s[keep],
        chunk.temperature_c[keep],
        chunk.channels[keep],
        chunk.positions[keep],
        chunk.labels[keep],
    )


def _segment(
    chunks: Iterator[_Chunk],
    layout: _Layout,
    *,
    orientation: str | None,
    factor: int,
    rate_hz: float,
    min_count: int,
    settle_s: float,
) -> list[Run]:
    """Split a stream of chunks into runs at every change of label and decimate each."""
    runs: list[Run] = []
    current: _RunBuilder | None = None

    def start(label: str) -> _RunBuilder:
        return _RunBuilder(
            label,
            source=layout.path,
            path=layout.path,
            time_column=layout.time_column,
            n_channels=layout.n_channels,
            extra_names=layout.extra_names,
            factor=factor,
            rate_hz=rate_hz,
            min_count=min_count,
            settle_s=settle_s,
            row_word=layout.row_word,
            temperature=layout.temperature,
            temperature_column=layout.temperature_column,
        )

    def close(builder: _RunBuilder | None) -> None:
        if builder is None or builder.first_pos is None:
            return
        builder.source = f"{layout.path}#{layout.fragment}{builder.first_pos}-{builder.last_pos}"
        run = builder.finish()
        if run is not None:
            runs.append(run)

    for chunk in chunks:
        n = chunk.time_s.shape[0]
        if chunk.truncated and current is not None and n == 0:
            current.n_truncated = 1
        if n == 0:
            continue
        if chunk.labels is None:
            assert orientation is not None
            if current is None:
                current = start(orientation)
            current.push(chunk.time_s, chunk.temperature_c, chunk.channels, chunk.positions)
            continue
        ids = chunk.labels
        cuts = np.flatnonzero(ids[1:] != ids[:-1]) + 1
        bounds = [0, *cuts.tolist(), n]
        for a, b in itertools.pairwise(bounds):
            label = _LABELS[int(ids[a])]
            if current is None or current.label != label or a > 0:
                close(current)
                current = start(label)
            current.push(
                chunk.time_s[a:b],
                chunk.temperature_c[a:b],
                chunk.channels[a:b],
                chunk.positions[a:b],
            )
        if chunk.truncated and current is not None:
            current.n_truncated = 1
    close(current)
    if not runs:
        raise SessionFormatError(f"{layout.path}: no run with valid data")
    return runs
