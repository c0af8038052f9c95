"""Type stubs of the compiled extension ``accelcore._accelcore``.

Users import these classes from :mod:`accelcore.core`. Docstrings follow the
NumPy convention and state units, NaN policy and empty-input behaviour.
"""

from collections.abc import Sequence
from typing import final

import numpy as np
from numpy.typing import ArrayLike, NDArray

__version__: str
#: Lines the CSV reader reads looking for the header below a logger's preamble.
MAX_PREAMBLE_LINES: int
#: The temperatures a log may hold, °C: beyond them a value is corrupt (or in another unit).
MIN_TEMPERATURE_C: float
MAX_TEMPERATURE_C: float

@final
class DecimatedBlocks:
    """Output of :class:`Decimator`: one row per kept block, in increasing block order.

    Attributes
    ----------
    block_index : ndarray of int64
        Block ``k`` covers ``[t0 + k*factor/rate_hz, t0 + (k+1)*factor/rate_hz)``.
    count : ndarray of int64
        Valid samples averaged in each block.
    time_s : ndarray of float64
        Mean time of the block's valid samples, s.
    temperature_c : ndarray of float64
        Mean temperature of the block's valid samples, °C.
    channels : ndarray of float64, shape (n_blocks, n_channels)
        Mean of each channel.
    """

    @property
    def block_index(self) -> NDArray[np.int64]: ...
    @property
    def count(self) -> NDArray[np.int64]: ...
    @property
    def time_s(self) -> NDArray[np.float64]: ...
    @property
    def temperature_c(self) -> NDArray[np.float64]: ...
    @property
    def channels(self) -> NDArray[np.float64]: ...
    def __len__(self) -> int: ...

@final
class Decimator:
    """Time-aligned block-mean decimator (default 20 Hz to 2 Hz).

    Parameters
    ----------
    factor : int, default 10
        Nominal samples per block (>= 1).
    rate_hz : float, default 20.0
        Nominal input sample rate, Hz.
    n_channels : int, default 3
        Data channels besides time and temperature.
    min_count : int, default 1
        Blocks with fewer valid samples are dropped.
    t0_s : float, optional
        Origin of the block grid, s. Default: time of the first sample. Pass the
        same value to every piece of a log that is split for :meth:`merge`.

    Notes
    -----
    Block index of a sample: ``floor((t - t0) * rate_hz / factor)``, so a gap in
    the log does not shift later blocks. A row with any NaN or infinite value is
    skipped and counted in :attr:`n_skipped_nonfinite`. Time must strictly
    increase, else :class:`accelcore.TimeOrderError`.
    """

    def __new__(
        cls,
        *,
        factor: int = 10,
        rate_hz: float = 20.0,
        n_channels: int = 3,
        min_count: int = 1,
        t0_s: float | None = None,
    ) -> Decimator: ...
    def push(self, time_s: ArrayLike, temperature_c: ArrayLike, channels: ArrayLike) -> None:
        """Push a chunk of ``n`` samples: time (s), temperature (°C), channels ``(n, n_channels)``.

        Raises
        ------
        accelcore.ShapeError
            If the lengths differ or ``channels`` has the wrong number of columns.
        accelcore.TimeOrderError
            If time does not strictly increase; the decimator is left unchanged.
        """

    def merge(self, other: Decimator) -> None:
        """Merge the state of another piece of the same stream into this one.

        Raises
        ------
        accelcore.IncompatibleError
            If configurations or ``t0_s`` differ, or the pieces overlap in time.
        """

    def finish(self) -> DecimatedBlocks:
        """Return every block with at least ``min_count`` valid samples; state is kept.

        Raises
        ------
        accelcore.InsufficientDataError
            If no block is kept.
        """

    def drain_completed(self) -> DecimatedBlocks:
        """Remove and return the blocks that can no longer receive samples.

        A drained decimator must not be merged with a piece that precedes it.
        """

    @property
    def n_samples(self) -> int:
        """Rows pushed so far, valid or not."""

    @property
    def n_skipped_nonfinite(self) -> int:
        """Rows skipped because a value was NaN or infinite."""

    @property
    def factor(self) -> int: ...
    @property
    def rate_hz(self) -> float: ...
    @property
    def n_channels(self) -> int: ...
    @property
    def min_count(self) -> int: ...
    @property
    def t0_s(self) -> float | None: ...

@final
class BinnedStats:
    """Output of :class:`TemperatureBinner`; per-bin arrays of length ``n_bins``.

    Attributes
    ----------
    edges_c : ndarray of float64
        ``n_bins + 1`` edges, °C; bins are closed below and open above, ``[lo, hi)``.
    count : ndarray of int64
        Samples per bin.
    temperature_c, time_s : ndarray of float64
        Mean temperature (°C) and mean time (s) per bin; NaN for empty bins.
    mean, variance : ndarray of float64, shape (n_bins, n_channels)
        Mean and sample variance (ddof=1) per bin and channel; NaN where undefined.
    n_below, n_above, n_nonfinite : int
        Samples below ``lo_c``, at or above ``hi_c``, and skipped as non-finite.
    """

    @property
    def edges_c(self) -> NDArray[np.float64]: ...
    @property
    def count(self) -> NDArray[np.int64]: ...
    @property
    def temperature_c(self) -> NDArray[np.float64]: ...
    @property
    def time_s(self) -> NDArray[np.float64]: ...
    @property
    def mean(self) -> NDArray[np.float64]: ...
    @property
    def variance(self) -> NDArray[np.float64]: ...
    @property
    def n_below(self) -> int: ...
    @property
    def n_above(self) -> int: ...
    @property
    def n_nonfinite(self) -> int: ...

@final
class TemperatureBinner:
    """Fixed-width temperature bins with numerically stable (Welford) statistics.

    Parameters
    ----------
    lo_c, hi_c : float, default 0.0 and 60.0
        Analysis window, °C: ``lo_c <= T < hi_c`` (the paper's 0–60 °C).
    width_c : float, default 0.5
        Bin width, °C. The last bin is narrower when the window is not a multiple.
    n_channels : int, default 3
        Data channels.
    """

    def __new__(
        cls, *, lo_c: float = 0.0, hi_c: float = 60.0, width_c: float = 0.5, n_channels: int = 3
    ) -> TemperatureBinner: ...
    def push(self, time_s: ArrayLike, temperature_c: ArrayLike, channels: ArrayLike) -> None:
        """Push a chunk of ``n`` samples; rows with a non-finite value are skipped and counted."""

    def merge(self, other: TemperatureBinner) -> None:
        """Merge another binner of identical configuration (Chan's parallel formula)."""

    def finish(self) -> BinnedStats:
        """Return per-bin statistics; raises InsufficientDataError if no sample was in the window."""

    @property
    def n_bins(self) -> int: ...
    @property
    def lo_c(self) -> float: ...
    @property
    def hi_c(self) -> float: ...
    @property
    def width_c(self) -> float: ...
    @property
    def n_channels(self) -> int: ...

@final
class LstsqSolution:
    """Solution of a weighted least-squares problem.

    Attributes
    ----------
    column_names : list of str
    coefficients : ndarray of float64, shape (p,)
    covariance : ndarray of float64, shape (p, p)
        ``sigma² (XᵀWX)⁻¹`` with ``sigma² = residual_sum_squares / dof``; NaN when dof == 0.
    residual_sum_squares : float
        Weighted residual sum of squares.
    dof : int
        ``n_rows - p``.
    n_rows : int
        Rows with non-zero weight.
    condition_number : float
        2-norm condition number of ``sqrt(W) X``.
    condition_number_scaled : float
        The same after scaling every column to unit norm; it bounds the relative
        error of the coefficients (about ``condition_number_scaled * eps``).
    """

    @property
    def column_names(self) -> list[str]: ...
    @property
    def coefficients(self) -> NDArray[np.float64]: ...
    @property
    def covariance(self) -> NDArray[np.float64]: ...
    @property
    def residual_sum_squares(self) -> float: ...
    @property
    def dof(self) -> int: ...
    @property
    def n_rows(self) -> int: ...
    @property
    def condition_number(self) -> float: ...
    @property
    def condition_number_scaled(self) -> float: ...

@final
class LeastSquares:
    """Incremental weighted least squares by orthogonal (QR) updates.

    Parameters
    ----------
    n_columns : int
        Number of unknowns, 1 to 64.
    column_names : list of str, optional
        Names used in results and errors; default ``x0, x1, ...``.
    n_responses : int, default 1
        Right-hand sides sharing the design, 1 to 64 (one factor ``R`` serves all).

    Notes
    -----
    The state is the triangular factor ``R`` of the weighted design, ``Qᵀy`` and the
    residual sum of squares, so memory does not grow with the number of rows and
    :meth:`merge` is exact algebra. Rows are brought in by Givens rotations up to 4
    columns, and from 5 columns on by Householder reflections of blocks of 64 rows
    (a partial block is carried to the next push, so how rows are cut into pushes
    changes no bit of the result). Never normal equations. Non-finite input raises
    NonFiniteError.
    """

    def __new__(
        cls, n_columns: int, *, column_names: list[str] | None = None, n_responses: int = 1
    ) -> LeastSquares: ...
    def push(
        self, design: ArrayLike, response: ArrayLike, weights: ArrayLike | None = None
    ) -> None:
        """Push rows: ``design`` (n, p), ``response`` (n, or (n, m) with m responses).

        ``weights`` (n, >= 0), or None for 1.
        """

    def push_mapped(
        self,
        source: LeastSquares,
        map: ArrayLike,
        responses: list[int] | None = None,
        shift: ArrayLike | None = None,
    ) -> None:
        """Push the rows of ``source`` seen through a linear map of its columns.

        As if each row ``sqrt(w) [x | y]`` pushed into ``source`` were pushed here as
        ``sqrt(w) [x @ map | y[r] - x @ shift[:, k]]`` with ``r = responses[k]`` for
        this problem's response ``k``: equal up to rounding, at the cost of the
        source's triangle (``q`` rows) instead of its rows. A design whose columns are
        a few functions of the samples times per-stretch constants is the QR of those
        functions once per stretch, then ``q`` rows per stretch.

        Parameters
        ----------
        source : LeastSquares
            With ``q`` columns.
        map : array_like, shape (q, n_columns)
        responses : list of int, optional
            The source's response for each of this problem's; default ``0, 1, ...``.
        shift : array_like, shape (q, n_responses), optional
            Subtracted from each response through the source's columns.
        """

    def merge(self, other: LeastSquares) -> None:
        """Merge another problem with the same columns."""

    def finish(self, response: int = 0) -> LstsqSolution:
        """Solve for ``response`` (0 to ``n_responses - 1``).

        Raises
        ------
        accelcore.InsufficientDataError
            With no rows, or fewer rows than columns.
        accelcore.SingularSystemError
            If some columns cannot be identified; ``.columns`` names them.
        """

    @property
    def n_columns(self) -> int: ...
    @property
    def n_rows(self) -> int: ...
    @property
    def n_responses(self) -> int: ...

@final
class HeldOutFit:
    """In-sample and held-out fits of a :class:`BlockedLeastSquares` for one fold assignment.

    Attributes
    ----------
    coefficients : ndarray of float64, shape (p,)
        Fit on every block; columns that cannot be identified are held at 0.
    not_identified : list of int
        Columns held at 0 in that fit.
    in_sample_rss : float
        Weighted residual sum of squares of that fit.
    heldout_rss : float
        Sum of :attr:`heldout_rss_per_block`.
    fold_coefficients : ndarray of float64, shape (n_folds, p)
        Row ``k``: the fit without fold ``k`` (NaN for a fold that holds no rows).
    heldout_rss_per_block : ndarray of float64, shape (n_blocks,)
        Weighted squared error of each block under the fit without its fold.
    rows_per_block : ndarray of uint64, shape (n_blocks,)
        Rows with non-zero weight in each block.
    """

    @property
    def coefficients(self) -> NDArray[np.float64]: ...
    @property
    def not_identified(self) -> list[int]: ...
    @property
    def in_sample_rss(self) -> float: ...
    @property
    def heldout_rss(self) -> float: ...
    @property
    def fold_coefficients(self) -> NDArray[np.float64]: ...
    @property
    def heldout_rss_per_block(self) -> NDArray[np.float64]: ...
    @property
    def rows_per_block(self) -> NDArray[np.uint64]: ...

@final
class FoldedLeastSquares:
    """The factors of a :class:`BlockedLeastSquares` for one fold assignment.

    Made by :meth:`BlockedLeastSquares.folds`: each block's factor, each fold's
    training factor (every other fold, merged) and the factor of all data, over
    every column and response. :meth:`cross_validate` then fits any subset of the
    columns for one response without visiting a row: each training factor is
    reduced to the subset (exact algebra) and each block scored from its full
    factor with the coefficients zero-padded. A query costs
    ``O(n_folds * P * q**2 + n_blocks * P**2)`` for ``P`` columns and ``q`` selected.
    """

    def cross_validate(self, columns: ArrayLike | None = None, *, response: int = 0) -> HeldOutFit:
        """Cross-validate the model of some columns for one response.

        Parameters
        ----------
        columns : array_like of int, optional
            Distinct column indices, in the order of the coefficients returned
            (of two dependent columns the later is held at 0); default all.
        response : int, default 0
            Which response.

        Raises
        ------
        accelcore.ParameterError
            Columns empty, repeated or out of range; response out of range.
        accelcore.InsufficientDataError
            No block holds a row.
        """

    @property
    def n_columns(self) -> int: ...
    @property
    def n_folds(self) -> int: ...

@final
class BlockedLeastSquares:
    """Per-block least-squares factors; the held-out error of any folds by merging them.

    Rows are pushed once with their block; :meth:`cross_validate` then fits the model
    without each fold by merging the other blocks' factors (QR, exact algebra,
    never normal equations) and scores each block from its own factor
    (``||R β - z||² + rss``), without visiting a row again. Push the wide design of
    many candidate models (several responses when they share it) once, fix the folds
    once with :meth:`folds`, and cross-validate any subset of columns from there.

    Parameters
    ----------
    n_columns : int
        Number of unknowns, 1 to 64.
    n_blocks : int
        Number of blocks.
    n_responses : int, default 1
        Right-hand sides sharing the design, 1 to 64.
    """

    def __new__(
        cls, n_columns: int, n_blocks: int, *, n_responses: int = 1
    ) -> BlockedLeastSquares: ...
    def push(
        self,
        design: ArrayLike,
        response: ArrayLike,
        block: ArrayLike,
        weights: ArrayLike | None = None,
    ) -> None:
        """Push rows: ``design`` (n, p), ``response`` (n) or (n, n_responses), blocks, weights.

        Raises
        ------
        accelcore.NonFiniteError
            A non-finite value (the chunk is refused whole).
        accelcore.ParameterError
            A block index out of range or a negative weight.
        accelcore.ShapeError
            Lengths that disagree, or a 1-D response with several responses.
        """

    def merge(self, other: BlockedLeastSquares) -> None:
        """Merge another accumulator of the same shape, block by block."""

    def folds(self, block_fold: ArrayLike) -> FoldedLeastSquares:
        """Fix a fold assignment: merge each fold's training factor once.

        Parameters
        ----------
        block_fold : array_like of int, shape (n_blocks,)
            Fold of each block (0, 1, ...; a fold may be empty).
        """

    def cross_validate(
        self, block_fold: ArrayLike, *, columns: ArrayLike | None = None, response: int = 0
    ) -> HeldOutFit:
        """Fit on every block and, for each fold, without it; score each block held out.

        Parameters
        ----------
        block_fold : array_like of int, shape (n_blocks,)
            Fold of each block (0, 1, ...; a fold may be empty).
        columns : array_like of int, optional
            Columns of the model, as in :meth:`FoldedLeastSquares.cross_validate`.
        response : int, default 0
            Which response.
        """

    @property
    def n_columns(self) -> int: ...
    @property
    def n_blocks(self) -> int: ...
    @property
    def n_responses(self) -> int: ...

@final
class TimeConstantSearch:
    """Searches of a time constant over one data set, by the held-out error of trials.

    A trial is a linear model at one value of ``tau``: columns that do not depend on
    it (*fixed*) and columns built from it, ``(lag(T, tau) - t_ref_c)^k`` (the
    temperature through :func:`first_order_lag`, one pass per record) or
    ``exp(-elapsed_s / tau)``, each averaged over the windows (weighted by
    ``sample_weight``; a window of zero weight gets the weighted sum) in NumPy's
    summation order and times a per-window multiplier (a gain column's gravity). The
    trial's score is the held-out weighted squared error of every block on every
    ``stride``-th window, summed (:class:`BlockedLeastSquares` with the windows as
    rows, a column the training data cannot identify held at 0: the later of two
    dependent columns; the blocks of one fold are fitted as one block, whose held-out
    error is the sum of theirs). The window means of each ``tau`` are kept (64 values
    per kind), so models that try the same values build each column once.

    Parameters
    ----------
    records : sequence of (array_like, array_like)
        Time (s) and temperature (°C) of every record, whole.
    gather : array_like of int, shape (n,)
        Each sample's index in the records laid end to end.
    elapsed_s : array_like, shape (n,)
        Each sample's time since its run's start, s.
    sample_weight : array_like, shape (n,)
        Each sample's weight.
    window_start : array_like of int, shape (n_windows,)
        First sample of each window (contiguous, non-empty, from sample 0).
    window_weight : array_like, shape (n_windows,)
        Each window's weight (the sum of its samples' weights).
    window_block : array_like of int, shape (n_windows,)
        Each window's block.
    block_fold : array_like of int, shape (n_blocks,)
        Each block's fold.
    t_ref_c : float
        Reference temperature, °C.
    stride : int
        Trials fit windows ``0, stride, 2 stride, ...`` (>= 1).

    Raises
    ------
    accelcore.ParameterError
        A zero stride, a block or gather index out of range, windows that are not
        contiguous stretches.
    accelcore.ShapeError
        Lengths that disagree.
    """

    def __new__(
        cls,
        records: Sequence[tuple[ArrayLike, ArrayLike]],
        gather: ArrayLike,
        elapsed_s: ArrayLike,
        sample_weight: ArrayLike,
        window_start: ArrayLike,
        window_weight: ArrayLike,
        window_block: ArrayLike,
        block_fold: ArrayLike,
        /,
        *,
        t_ref_c: float,
        stride: int,
    ) -> TimeConstantSearch: ...
    def search(
        self,
        fixed: ArrayLike,
        response: ArrayLike,
        columns: Sequence[tuple[str, int, ArrayLike | None]],
        /,
        *,
        range_s: tuple[float, float],
        grid_points: int = 10,
        steps: int = 8,
        tol: float = 5e-3,
    ) -> tuple[float, NDArray[np.float64]]:
        """Search ``tau`` for one model; return the best and every trial.

        ``tau`` is rounded to three significant digits as ``float(f"{tau:.3g}")``
        (a value is scored once); a log grid of ``grid_points`` over ``range_s``,
        then at most ``steps`` parabolic steps in ``log tau`` (golden section where
        a parabola leaves the bracket) until a step moves less than ``tol`` or the
        bracket is narrower than ``2 tol``. The steps of
        ``accelcore.diagnosis.search.search_1d``.

        Parameters
        ----------
        fixed : array_like, shape (n_windows, p0)
            The model's fixed columns as window means.
        response : array_like, shape (n_windows,)
            The response as window means.
        columns : sequence of (str, int, array_like or None)
            The design's columns in order: ``("fixed", j, None)`` (column ``j`` of
            ``fixed``), ``("lag", k, multiplier)``, ``("decay", 0, multiplier)``;
            ``multiplier`` one value per window, or None.
        range_s : (float, float)
            Smallest and largest ``tau`` of the grid, s (``0 < lo <= hi``).

        Returns
        -------
        best_tau_s : float
            The trial of least score (the first tried among equals).
        trials : ndarray of float64, shape (n_trials, 2)
            ``(tau, score)`` of every distinct ``tau`` tried, in order.

        Raises
        ------
        accelcore.ParameterError
            A bad column, range, grid or tolerance.
        accelcore.ShapeError
            A fixed design, response or multiplier not one value per window.
        accelcore.NonFiniteError
            A non-finite value in the trial design, or in a record's time or
            temperature for a model with a lag column (as :func:`first_order_lag`).
        accelcore.TimeOrderError
            A record's time going back, for a model with a lag column.
        """

    def search_many(
        self,
        models: Sequence[tuple[ArrayLike, ArrayLike, Sequence[tuple[str, int, ArrayLike | None]]]],
        /,
        *,
        range_s: tuple[float, float],
        grid_points: int = 10,
        steps: int = 8,
        tol: float = 5e-3,
        threads: int = 1,
    ) -> list[tuple[float, NDArray[np.float64]]]:
        """Search ``tau`` for several models at once; one ``(best, trials)`` per model.

        Each model ``(fixed, response, columns)`` is searched as :meth:`search` does
        alone (the same trials, in the same order, the same scores bit for bit), on
        up to ``threads`` threads with the GIL released: the grid's window means
        first (every model tries the same grid), one value of ``tau`` per thread at
        a time, then the models, one per thread at a time. ``threads=1``: one search
        after the other.

        Raises
        ------
        accelcore.ParameterError, accelcore.ShapeError, accelcore.NonFiniteError, accelcore.TimeOrderError
            As :meth:`search`: the error of the first model (in order) that has one;
            a ``ParameterError`` for ``threads`` below 1.
        accelcore.AccelcoreError
            A search thread panicked (an internal error; the process goes on).
        """

    def score(
        self,
        fixed: ArrayLike,
        response: ArrayLike,
        columns: Sequence[tuple[str, int, ArrayLike | None]],
        tau_s: float,
        /,
    ) -> float:
        """Score of one model at ``tau_s`` (not rounded); arguments as :meth:`search`."""

    @property
    def n_rows(self) -> int:
        """Windows a trial fits."""

@final
class RunData:
    """One log file read and decimated by :func:`read_run`."""

    @property
    def header(self) -> list[str]: ...
    @property
    def channel_names(self) -> list[str]: ...
    @property
    def blocks(self) -> DecimatedBlocks: ...
    @property
    def n_rows(self) -> int: ...
    @property
    def n_skipped_nonfinite(self) -> int: ...
    @property
    def n_truncated_rows(self) -> int: ...
    @property
    def first_time_s(self) -> float: ...
    @property
    def last_time_s(self) -> float: ...
    @property
    def n_gaps(self) -> int: ...
    @property
    def max_interval_s(self) -> float: ...
    @property
    def channel_min(self) -> NDArray[np.float64]: ...
    @property
    def channel_max(self) -> NDArray[np.float64]: ...
    @property
    def n_at_min(self) -> NDArray[np.uint64]: ...
    @property
    def n_at_max(self) -> NDArray[np.uint64]: ...
    @property
    def digest(self) -> str | None:
        """Hex digest of the bytes read, with ``read_run(..., digest=...)``; else None."""
    @property
    def digest_algorithm(self) -> str | None:
        """``"blake3"`` or ``"sha256"``: the algorithm of :attr:`digest`; else None."""
    @property
    def sha256(self) -> str | None:
        """Hex SHA-256 of the bytes read, when the digest asked for was SHA-256; else None.

        ``read_run(..., sha256=True)`` is ``read_run(..., digest="sha256")``.
        """

@final
class RawStats:
    """What a run's raw rows looked like: the result of :class:`RunTally`.

    Times are over the rows with a finite time only; channel ranges over the
    finite values only (a channel without one: ``min = inf``, ``max = -inf``, counts 0).
    """

    @property
    def n_rows(self) -> int:
        """Rows counted."""

    @property
    def n_skipped_nonfinite(self) -> int:
        """Rows with a NaN or infinite time, temperature or channel value (as the decimator skips)."""

    @property
    def first_time_s(self) -> float:
        """First finite time, s (NaN when there is none)."""

    @property
    def last_time_s(self) -> float:
        """Last finite time, s (NaN when there is none)."""

    @property
    def n_gaps(self) -> int:
        """Intervals between consecutive finite times longer than ``1.5 * (1 / rate_hz)``."""

    @property
    def max_interval_s(self) -> float:
        """Longest interval between consecutive finite times, s (0 for fewer than two)."""

    @property
    def channel_min(self) -> NDArray[np.float64]:
        """Smallest finite value of each channel."""

    @property
    def channel_max(self) -> NDArray[np.float64]:
        """Largest finite value of each channel."""

    @property
    def n_at_min(self) -> NDArray[np.uint64]:
        """Values exactly at each channel's minimum (many: clipping)."""

    @property
    def n_at_max(self) -> NDArray[np.uint64]:
        """Values exactly at each channel's maximum (many: clipping)."""

@final
class RunTally:
    """Statistics of a run's raw rows, before decimation (the readers' one accumulator).

    Parameters
    ----------
    n_channels : int, default 3
        Data channels besides time and temperature.
    rate_hz : float, default 20.0
        Nominal sample rate, Hz (an interval over 1.5 periods is a gap).

    Notes
    -----
    NaN policy: a row with any NaN or infinite value is counted in
    ``n_skipped_nonfinite`` and its finite values still count. Time order is not
    checked (the decimator does). The result does not depend on how the rows
    are chunked, and ``a.merge(b)`` (``b``'s rows after ``a``'s) equals one pass.
    """

    def __new__(cls, *, n_channels: int = 3, rate_hz: float = 20.0) -> RunTally: ...
    def push(self, time_s: ArrayLike, temperature_c: ArrayLike, channels: ArrayLike) -> None:
        """Count a chunk of ``n`` rows: time (s), temperature (°C), channels ``(n, n_channels)``.

        Raises
        ------
        accelcore.ShapeError
            If the lengths differ or ``channels`` has the wrong number of columns;
            nothing is counted.
        """

    def merge(self, other: RunTally) -> None:
        """Add a tally whose rows follow this one's; the interval across the cut counts.

        Raises
        ------
        accelcore.IncompatibleError
            If the channel counts or rates differ.
        """

    def finish(self) -> RawStats:
        """Return the statistics of every row counted so far; state is kept."""

    @property
    def n_channels(self) -> int: ...
    @property
    def rate_hz(self) -> float: ...
    @property
    def n_rows(self) -> int:
        """Rows counted so far."""

def read_run(
    path: str,
    /,
    *,
    delimiter: str = ",",
    time_column: str = "time_s",
    temperature_column: str = "temp_c",
    channel_columns: list[str] = ...,
    keep_extra_columns: bool = True,
    time_scale_to_s: float = 1.0,
    factor: int = 10,
    rate_hz: float = 20.0,
    min_count: int = 1,
    sha256: bool = False,
    digest: str | None = None,
) -> RunData:
    """Read one delimited log and decimate it on the fly; the file is never held whole.

    Channels are the required ``channel_columns`` then, with ``keep_extra_columns``,
    every other column. Errors name the file, the 1-based line and column. With
    ``digest`` (``"blake3"`` or ``"sha256"``), the file's bytes are hashed as they
    are parsed (``RunData.digest``, ``RunData.digest_algorithm``): the digest is
    that of exactly the bytes the result was read from. ``sha256=True`` is the
    older spelling of ``digest="sha256"`` (``RunData.sha256``).

    Raises
    ------
    accelcore.ParameterError
        An unknown ``digest``, or ``sha256=True`` with another ``digest``.
    accelcore.ParseError
        Missing columns, a non-numeric cell, a wrong field count, time going backwards.
    accelcore.AccelcoreIOError
        The file cannot be opened or read.
    """

def digest_bytes(data: bytes, /, algorithm: str = "blake3") -> str:
    """Return the hex digest of ``data`` in one shot, as :func:`read_run` takes it of a file.

    Parameters
    ----------
    data : bytes
    algorithm : {"blake3", "sha256"}, default "blake3"

    Returns
    -------
    str
        64 hex digits.

    Raises
    ------
    accelcore.ParameterError
        An unknown ``algorithm``.
    """

def compensate(
    raw: ArrayLike, basis: ArrayLike, offset_coefficients: ArrayLike, gain_coefficients: ArrayLike
) -> NDArray[np.float64]:
    """Turn raw ``(n, 3)`` readings into acceleration in g.

    The model of axis ``a`` is ``v_a = O[a] · B + Σ_b (G[3a+b] · B) g_b`` with basis
    values ``B`` (n, K) per sample, offset coefficients ``O`` (3, K) and gain
    coefficients ``G`` (9, K); the 3x3 system is solved per sample. A sample with a
    non-finite input gives NaN; a singular gain matrix raises NonFiniteError.
    """

def first_order_lag(
    time_s: ArrayLike,
    temperature_c: ArrayLike,
    tau_s: float,
    /,
    initial: float | None = None,
    tau_cool_s: float | None = None,
) -> NDArray[np.float64]:
    """First-order lag of a temperature series with time constant ``tau_s`` (s).

    ``y[i] = y[i-1] + (1 - exp(-(t[i]-t[i-1])/tau)) (x[i] - y[i-1])``, ``y[0] = initial``
    or ``x[0]``: what a die trailing the logged probe sees. ``tau_s = 0`` returns the input.
    With ``tau_cool_s``, ``tau`` is ``tau_s`` at a step whose input is above the output
    (the die heating) and ``tau_cool_s`` at any other (cooling); equal, the plain lag.
    """

def fingerprint(values: ArrayLike, counts: ArrayLike, /) -> int:
    """128-bit fingerprint of a float series and an integer series, for caches.

    XXH3 of the length and little-endian bytes of ``values``, then of ``counts``:
    equal arrays give equal fingerprints; arrays that differ in any bit or length give
    different ones, but for chance (odds about 2^-64 among 2^32 arrays). Not a
    provenance digest (those are BLAKE3 or SHA-256).

    Parameters
    ----------
    values : array_like, shape (n,)
        Converted to float64.
    counts : array_like of int64, shape (m,)

    Returns
    -------
    int
        In ``0 ... 2**128 - 1``.

    Raises
    ------
    ShapeError
        An input is not 1-D.
    """

def median(a: ArrayLike, /) -> float:
    """Median of ``a`` as ``float(np.median(a))`` gives it, bit for bit.

    The middle value, or the mean of the two middle values ``a <= b`` as NumPy
    computes it, ``(0.0 + a + b) / 2`` (a zero median is ``+0.0``). NaN for an empty
    ``a`` or one holding a NaN (without NumPy's warning).

    Parameters
    ----------
    a : array_like, shape (n,)
        The values (converted to float64).

    Returns
    -------
    float

    Raises
    ------
    ShapeError
        ``a`` is not 1-D.
    """

def nanmedian_columns(a: ArrayLike, /) -> NDArray[np.float64]:
    """``np.nanmedian(a, axis=0)`` of a 2-D array, bit for bit.

    Each column's median of its values that are not NaN (see :func:`median`); NaN
    for a column with none (without NumPy's warning).

    Parameters
    ----------
    a : array_like, shape (n, k)
        The values (converted to float64; any memory layout).

    Returns
    -------
    ndarray of float64, shape (k,)

    Raises
    ------
    ShapeError
        ``a`` is not 2-D.
    """

def sorted_values(values: ArrayLike, /) -> NDArray[np.float64]:
    """``np.sort(values)``: ascending, NaN last (a radix sort in the core).

    Values that compare equal come out equal, but ``-0.0`` sorts before ``0.0``
    (NumPy leaves their order to its algorithm); the NaNs keep their bits and their
    order, after everything else.

    Parameters
    ----------
    values : array_like, shape (n,)
        Converted to float64.

    Returns
    -------
    ndarray of float64, shape (n,)

    Raises
    ------
    ShapeError
        ``values`` is not 1-D.
    """

def robust_sigma(r: ArrayLike, /) -> float:
    """Robust standard deviation of the finite values of ``r``.

    ``1.4826`` times the median absolute deviation from the median; where that is 0
    (most values equal), ``sqrt(pi / 2)`` times the mean absolute deviation (NumPy's
    summation order); 0 when no value is finite. The figures of
    ``accelcore.input.quality``'s NumPy, bit for bit.

    Parameters
    ----------
    r : array_like, shape (n,)
        Converted to float64.

    Returns
    -------
    float

    Raises
    ------
    ShapeError
        ``r`` is not 1-D.
    """

def block_noise(
    y: ArrayLike, count: ArrayLike, /, *, window: int
) -> tuple[NDArray[np.float64], float]:
    """Return a run's block residuals about a running median, scaled, and their noise.

    Each block's ``y - running_median(y, window)`` times ``sqrt(count / typical)``
    (``typical``: the most common count, the smallest of those tied), and the
    residuals' :func:`robust_sigma`.

    Parameters
    ----------
    y : array_like, shape (n,)
        Block means of one channel (converted to float64).
    count : array_like of int64, shape (n,)
        Raw samples in each block.
    window : int
        Running median's window, >= 1 (see :func:`running_median`).

    Returns
    -------
    resid : ndarray of float64, shape (n,)
    sigma : float

    Raises
    ------
    ParameterError
        ``window < 1``, or ``count`` and ``y`` differ in length.
    ShapeError
        An input is not 1-D.
    """

def typical_count(count: ArrayLike, /) -> int:
    """Return the samples most blocks of a run hold: the most common of ``count``.

    The smallest of the counts tied for most common (``np.bincount(count).argmax()``);
    1 when ``count`` is empty.

    Parameters
    ----------
    count : array_like of int64, shape (n,)
        Raw samples in each block.

    Returns
    -------
    int

    Raises
    ------
    ShapeError
        ``count`` is not 1-D.
    """

def running_median(y: ArrayLike, /, *, window: int) -> NDArray[np.float64]:
    """Centred running median of ``y`` over ``2 * (window // 2) + 1`` values.

    ``y`` is extended by ``half = window // 2`` values at each end as
    ``np.pad(y, half, mode="reflect")`` would (the end values are not repeated), or
    with ``mode="edge"`` when ``len(y) <= half``; output ``i`` is the median of padded
    values ``i`` to ``i + 2 * half``. An even ``window`` is thus rounded up to the next
    odd size. The median of an odd number of values is one of them, so the result is
    exact and equals ``accelcore.reference.running_median`` bit for bit.

    Parameters
    ----------
    y : array_like, shape (n,)
        The series (converted to float64).
    window : int
        Window length, >= 1.

    Returns
    -------
    ndarray of float64, shape (n,)
        The running median; NaN where the window holds a NaN. Empty for empty ``y``.

    Raises
    ------
    ParameterError
        ``window < 1``.
    ShapeError
        ``y`` is not 1-D.
    """

def sliding_median(y: ArrayLike, /, *, window: int) -> NDArray[np.float64]:
    """Median of every window ``y[j : j + window]``, ``j = 0, ..., len(y) - window``.

    Equals ``np.median(sliding_window_view(y, window), axis=1)`` bit for bit (and
    ``accelcore.reference.sliding_median``): an odd window gives its middle value, an
    even one the mean of its two middle values ``a <= b`` as NumPy computes it,
    ``(0.0 + a + b) / 2`` (a zero median is ``+0.0``).

    Parameters
    ----------
    y : array_like, shape (n,)
        The series (converted to float64).
    window : int
        Window length, ``1 <= window <= n``.

    Returns
    -------
    ndarray of float64, shape (n - window + 1,)
        The window medians; NaN where the window holds a NaN.

    Raises
    ------
    ParameterError
        ``window < 1`` or ``window > len(y)``.
    ShapeError
        ``y`` is not 1-D.
    """

def plan_split(
    path: str,
    pieces: int,
    /,
    *,
    delimiter: str = ",",
    time_column: str = "time_s",
    temperature_column: str = "temp_c",
    channel_columns: list[str] = ...,
    time_scale_to_s: float = 1.0,
) -> tuple[list[tuple[int, int]], float | None]:
    """Plan the reading of one log in up to ``pieces`` parallel pieces.

    Returns line-aligned ``[start, end)`` byte ranges covering every data line once,
    and the time of the first data row: the block origin every piece must use.
    """

def read_run_range(
    path: str,
    start: int,
    end: int,
    /,
    *,
    t0_s: float,
    delimiter: str = ",",
    time_column: str = "time_s",
    temperature_column: str = "temp_c",
    channel_columns: list[str] = ...,
    keep_extra_columns: bool = True,
    time_scale_to_s: float = 1.0,
    factor: int = 10,
    rate_hz: float = 20.0,
) -> RunData:
    """Read the data lines in a byte range of a log (one piece of :func:`plan_split`).

    Blocks are kept whatever their count (``min_count`` is applied by
    :func:`merge_runs`); errors name the line in the whole file.
    """

def merge_runs(pieces: list[RunData], /, *, min_count: int = 1, rate_hz: float = 20.0) -> RunData:
    """Combine the pieces of one log, in file order, into the one-pass result.

    Blocks cut by a piece boundary are joined (count-weighted means), then blocks
    with fewer than ``min_count`` samples are dropped; counters add.
    """

# ----------------------------------------------------------------- statistics

def chi2_sf(x: float, /, *, dof: float) -> float:
    """Survival function of the chi-square distribution, ``P(X > x)``.

    Parameters
    ----------
    x : float
        The statistic.
    dof : float
        Degrees of freedom (need not be an integer).

    Returns
    -------
    float
        ``Q(dof / 2, x / 2)``, about 1e-13 relative in either tail; 1 for ``x <= 0``
        and for ``dof <= 0`` (nothing tested), 0 for ``x = inf``, NaN for a NaN
        argument or an infinite ``dof``.
    """

def t_sf(t: float, /, *, dof: float) -> float:
    """One-sided upper tail of Student's t, ``P(T > t)``.

    Parameters
    ----------
    t : float
        The statistic.
    dof : float
        Degrees of freedom, > 0 and finite (need not be an integer).

    Returns
    -------
    float
        The tail, about 1e-13 relative; 0.5 at ``t = 0``, ``t_sf(-t) = 1 - t_sf(t)``.
        NaN for a NaN argument or a ``dof`` that is not > 0 and finite.
    """

def f_sf(f: float, /, *, dfn: float, dfd: float) -> float:
    """Survival function of Fisher's F, ``P(F > f)``: the p-value of a nested-model F test.

    Parameters
    ----------
    f : float
        The statistic.
    dfn, dfd : float
        Numerator and denominator degrees of freedom, > 0 and finite.

    Returns
    -------
    float
        The tail, about 1e-13 relative; 1 for ``f <= 0``, 0 for ``f = inf``, NaN for a
        NaN argument or degrees of freedom that are not > 0 and finite.
    """

@final
class PairedTest:
    """Result of :func:`paired_test`.

    Attributes
    ----------
    t : float
        Student's t of the mean difference, ``mean / (sd / sqrt(n))``.
    p : float
        One-sided p-value that the mean is positive, ``t_sf(t, dof=n - 1)``.
    n : int
        Number of differences.
    """

    @property
    def t(self) -> float: ...
    @property
    def p(self) -> float: ...
    @property
    def n(self) -> int: ...

def paired_test(diff: ArrayLike, /) -> PairedTest:
    """One-sided paired t-test that the mean of ``diff`` is positive.

    Parameters
    ----------
    diff : array_like, shape (n,)
        The differences (converted to float64).

    Returns
    -------
    PairedTest
        ``t = mean / (sd / sqrt(n))`` with the sample sd, ``p = t_sf(t, dof=n - 1)``.
        Fewer than two differences: ``t = nan``, ``p = 1``. A NaN or infinite
        difference: ``t = p = nan``. Every difference equal: ``t = inf``, ``p = 0`` when
        they are positive, else ``t = 0``, ``p = 1``.

    Raises
    ------
    ShapeError
        ``diff`` is not 1-D.
    """

def bonferroni(p: ArrayLike, /, *, n_tests: int | None = None) -> NDArray[np.float64]:
    """Bonferroni-adjusted p-values, ``min(1, m p)``.

    Parameters
    ----------
    p : array_like, shape (k,)
        P-values in [0, 1]; a NaN stays NaN.
    n_tests : int, optional
        Number of tests ``m >= k``, when only the smallest p-values were computed;
        default ``k``.

    Returns
    -------
    ndarray of float64, shape (k,)
        The adjusted p-values.

    Raises
    ------
    ParameterError
        A p-value outside [0, 1], or ``n_tests < k``.
    ShapeError
        ``p`` is not 1-D.
    """

def holm(p: ArrayLike, /, *, n_tests: int | None = None) -> NDArray[np.float64]:
    """Holm's step-down adjusted p-values, in the order given.

    Parameters
    ----------
    p : array_like, shape (k,)
        P-values in [0, 1]; a NaN stays NaN and ranks after every other.
    n_tests : int, optional
        Number of tests ``m >= k`` (the untested ones rank last); default ``k``.

    Returns
    -------
    ndarray of float64, shape (k,)
        With the p-values sorted increasing, the ``j``-th (from 0) becomes the running
        maximum of ``min(1, (m - j) p_(j))``: never above :func:`bonferroni`, equal for
        ties.

    Raises
    ------
    ParameterError
        A p-value outside [0, 1], or ``n_tests < k``.
    ShapeError
        ``p`` is not 1-D.
    """

@final
class Acceptance:
    """The verdict of an :class:`AcceptanceRule` and its figures.

    Attributes
    ----------
    accepted : bool
        The term is added.
    cut : float
        Fraction of the held-out RMS error cut, ``1 - sqrt(sum(candidate) / sum(current))``
        (0 when the current sum is not positive, negative when the candidate is worse).
    t : float
        Student's t of the paired test of ``current - candidate`` per block.
    p : float
        The rule's one-sided p-value, ``min(1, 3 min(p_sum, p_log, p_sign))`` (NaN
        when ``p_sum`` is).
    p_sum : float
        One-sided p-value of the paired test of ``current - candidate`` (the total).
    p_log : float
        One-sided p-value of the paired test of ``log(current / candidate)`` over the
        blocks where both are positive (every block alike).
    p_sign : float
        One-sided p-value of the exact sign test of ``current - candidate`` (how many
        blocks it cuts, whatever by).
    n : int
        Blocks compared.
    """

    @property
    def accepted(self) -> bool: ...
    @property
    def cut(self) -> float: ...
    @property
    def t(self) -> float: ...
    @property
    def p(self) -> float: ...
    @property
    def p_sum(self) -> float: ...
    @property
    def p_log(self) -> float: ...
    @property
    def p_sign(self) -> float: ...
    @property
    def n(self) -> int: ...

@final
class AcceptanceRule:
    """When the diagnosis adds a term to an axis.

    The held-out RMS error falls by at least ``min_improvement`` *and* the paired
    one-sided test over blocks gives ``p < alpha``: two paired t-tests, on the per-block
    change of held-out squared error (the total) and on its log ratio (every block
    alike), and the exact sign test of that change (how many blocks it cuts),
    Bonferroni-combined.
    Not adjusted for the number of candidates compared: ``min_improvement`` guards
    against a lucky one.

    Parameters
    ----------
    min_improvement : float
        Least fraction of the held-out RMS error cut, in [0, 1).
    alpha : float
        Level of the paired test, in (0, 1).

    Raises
    ------
    ParameterError
        A value out of range.
    """

    def __new__(cls, *, min_improvement: float, alpha: float) -> AcceptanceRule: ...
    @property
    def min_improvement(self) -> float: ...
    @property
    def alpha(self) -> float: ...
    def judge(self, current_sse: ArrayLike, candidate_sse: ArrayLike, /) -> Acceptance:
        """Judge a candidate from the held-out squared error per block, before and after.

        Parameters
        ----------
        current_sse, candidate_sse : array_like, shape (n_blocks,)
            Held-out squared error of each block under the current model and under the
            candidate, same blocks in the same order.

        Returns
        -------
        Acceptance
            ``accepted`` when ``cut >= min_improvement``, ``p < alpha`` and ``cut`` is
            finite; a NaN gives a NaN figure and a rejection; fewer than two blocks give
            ``p = 1``.

        Raises
        ------
        ShapeError
            The two differ in length, or one is not 1-D.
        """

def _blocks_from_arrays(
    block_index: ArrayLike,
    count: ArrayLike,
    time_s: ArrayLike,
    temperature_c: ArrayLike,
    channels: NDArray[np.float64],
) -> DecimatedBlocks: ...
def _run_from_state(state: tuple[object, ...]) -> RunData: ...
