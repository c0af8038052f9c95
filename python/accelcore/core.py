"""The streaming kernels of the Rust core.

Each kernel is a small object with ``push`` (a chunk of samples), ``merge``
(another accumulator of the same configuration) and ``finish`` (the result).
Results never depend on how the input was chunked, and ``a.merge(b)`` gives the
result of one pass over ``a``'s input followed by ``b``'s.

- :class:`Decimator`: time-aligned block means (20 Hz to 2 Hz by default).
- :class:`TemperatureBinner`: per-temperature-bin count, mean and variance.
- :class:`LeastSquares`: incremental weighted least squares (QR: Givens rotations,
  blocked Householder reflections from 5 columns on).
- :class:`BlockedLeastSquares`: one such factor per block of samples; the held-out
  error of any fold assignment by merging factors (the diagnosis' engine);
  :class:`FoldedLeastSquares`, its folds fixed, cross-validates any subset of columns.
- :func:`running_median`: a centred running median (the data-quality checks' smoother);
  :func:`sliding_median`, the median of every window (the step check's).
- The statistics that accept or reject a term of the diagnosis: :func:`chi2_sf`,
  :func:`t_sf`, :func:`f_sf` (survival functions), :func:`paired_test`,
  :func:`bonferroni`, :func:`holm` and :class:`AcceptanceRule` (its verdict an
  :class:`Acceptance`).
- :class:`TimeConstantSearch`: a lag's or warm-up's time constant by held-out error.

All computation runs in Rust with the GIL released. ``accelcore.reference``
holds an independent NumPy implementation of the same specification.
"""

from __future__ import annotations

from accelcore._accelcore import (
    Acceptance,
    AcceptanceRule,
    BinnedStats,
    BlockedLeastSquares,
    DecimatedBlocks,
    Decimator,
    FoldedLeastSquares,
    HeldOutFit,
    LeastSquares,
    LstsqSolution,
    PairedTest,
    TemperatureBinner,
    TimeConstantSearch,
    bonferroni,
    chi2_sf,
    f_sf,
    holm,
    paired_test,
    running_median,
    sliding_median,
    t_sf,
)

__all__ = [
    "Acceptance",
    "AcceptanceRule",
    "BinnedStats",
    "BlockedLeastSquares",
    "DecimatedBlocks",
    "Decimator",
    "FoldedLeastSquares",
    "HeldOutFit",
    "LeastSquares",
    "LstsqSolution",
    "PairedTest",
    "TemperatureBinner",
    "TimeConstantSearch",
    "bonferroni",
    "chi2_sf",
    "f_sf",
    "holm",
    "paired_test",
    "running_median",
    "sliding_median",
    "t_sf",
]
