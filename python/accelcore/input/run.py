"""A run: one temperature sweep in one orientation, decimated, with what the reader saw.

The data every other module of the input room hands on (:class:`Run`, :class:`RunStats`);
it imports only the foundation, so the session, the readers and the consistency
checks can all build on it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import RawStats, nanmedian_columns

__all__ = ["Run", "RunStats"]


@dataclass(frozen=True)
class RunStats:
    """What the reader saw in one run's raw log (before decimation).

    Attributes
    ----------
    n_rows : int
        Data rows read.
    n_skipped_nonfinite : int
        Rows skipped because a value was NaN, infinite or empty.
    n_truncated_rows : int
        A last line cut off mid-write, dropped (0 or 1).
    n_gaps : int
        Intervals between rows longer than 1.5 nominal periods.
    max_interval_s : float
        Longest interval between rows, s.
    duration_s : float
        Time from the first to the last row, s.
    channel_min, channel_max : ndarray
        Raw range of each channel (x, y, z, then extras).
    n_at_min, n_at_max : ndarray
        Rows exactly at that minimum / maximum (many at one value: clipping).
    """

    n_rows: int
    n_skipped_nonfinite: int = 0
    n_truncated_rows: int = 0
    n_gaps: int = 0
    max_interval_s: float = 0.0
    duration_s: float = 0.0
    channel_min: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    channel_max: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    n_at_min: NDArray[np.uint64] = field(default_factory=lambda: np.zeros(0, dtype=np.uint64))
    n_at_max: NDArray[np.uint64] = field(default_factory=lambda: np.zeros(0, dtype=np.uint64))

    @classmethod
    def from_raw(cls, raw: RawStats, *, n_truncated_rows: int = 0) -> RunStats:
        """Build the statistics of a run from a :class:`~accelcore._accelcore.RunTally`'s result.

        Parameters
        ----------
        raw : accelcore._accelcore.RawStats
            What the tally counted.
        n_truncated_rows : int, default 0
            A last line cut off mid-write and dropped (0 or 1).

        Returns
        -------
        RunStats
        """
        first, last = raw.first_time_s, raw.last_time_s
        return cls(
            n_rows=raw.n_rows,
            n_skipped_nonfinite=raw.n_skipped_nonfinite,
            n_truncated_rows=n_truncated_rows,
            n_gaps=raw.n_gaps,
            max_interval_s=raw.max_interval_s,
            duration_s=last - first if math.isfinite(first) else 0.0,
            channel_min=raw.channel_min,
            channel_max=raw.channel_max,
            n_at_min=raw.n_at_min,
            n_at_max=raw.n_at_max,
        )

    @property
    def mean_rate_hz(self) -> float:
        """Average sample rate over the run, Hz (NaN for a single row)."""
        if self.n_rows < 2 or self.duration_s <= 0:
            return math.nan
        return (self.n_rows - 1) / self.duration_s


@dataclass(frozen=True)
class Run:
    """One temperature sweep in one orientation, decimated.

    Attributes
    ----------
    orientation : str
        ``OX+`` ... ``OZ-``.
    gravity_g : ndarray, shape (3,)
        Gravity on x, y, z in g implied by the orientation.
    time_s : ndarray
        Block mean time, s, from the run's own origin.
    temperature_c : ndarray
        Block mean logged temperature, °C.
    output : ndarray, shape (n, 3)
        Block mean raw output of x, y, z in session units.
    count : ndarray
        Raw samples averaged in each block.
    extras : dict of str to ndarray
        Block means of every extra logged column (e.g. ``supply_v``).
    source : str or None
        The log file, when read from disk.
    stats : RunStats
        What the reader saw in the raw log.
    continues : bool or None
        What ``session.toml`` says of this run's log (its ``continues`` key): True,
        it continues the run listed before it (one record, one power-on, whatever its
        clock); False, it starts a record of its own; None, told from the clock
        (:func:`accelcore.input.records.records`).
    """

    orientation: str
    gravity_g: NDArray[np.float64]
    time_s: NDArray[np.float64]
    temperature_c: NDArray[np.float64]
    output: NDArray[np.float64]
    count: NDArray[np.int64]
    extras: dict[str, NDArray[np.float64]]
    source: str | None
    stats: RunStats
    continues: bool | None = None

    def __len__(self) -> int:
        return int(self.time_s.shape[0])

    @functools.cached_property
    def levels(self) -> NDArray[np.float64]:
        """Median output of each axis over the run, session units (NaN where none is finite).

        Kept: the label check and the calibration's sensitivity check both read it.
        """
        return nanmedian_columns(self.output)

    @property
    def label(self) -> str:
        """Short name: the file name, or the orientation for in-memory runs."""
        return Path(self.source).name if self.source else self.orientation
