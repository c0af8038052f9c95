"""Pure-NumPy reference implementation of the accelcore streaming kernels.

This package is the executable specification of :mod:`accelcore.core`, the test
oracle of the property tests and the baseline of the benchmarks. It is written
in the plainest vectorised NumPy and never imports the compiled extension, so
it can be read, run and trusted on its own. It imports nothing of accelcore
outside this package: not the Rust core, and not even :mod:`accelcore.errors`.

Every kernel has the same API as its Rust twin: a keyword-configured class with
``push`` (a chunk of samples), ``merge`` (another accumulator of the same
configuration) and ``finish`` (the result; it does not alter the state).
Chunks are validated in ``push``. :class:`TemperatureBinner` keeps the rows and
does all its arithmetic in ``finish`` (a two-pass variance); :class:`Decimator`
reduces each chunk to per-block sums and :class:`LeastSquares` each chunk to a
small triangular factor as they arrive, so that their memory does not grow
with the number of rows.

One module per kernel, named as its Rust twin in ``rust/accelcore-core/src``:

- :mod:`~accelcore.reference.decimate`: :class:`Decimator`, :class:`DecimatedBlocks`;
- :mod:`~accelcore.reference.binning`: :class:`TemperatureBinner`, :class:`BinnedStats`;
- :mod:`~accelcore.reference.regression`: :class:`LeastSquares`, :class:`LstsqSolution`;
- :mod:`~accelcore.reference.robust`: :func:`running_median`, :func:`sliding_median`;
- :mod:`~accelcore.reference.heldout`: :func:`cross_validate`, the held-out fits of
  ``BlockedLeastSquares`` by refitting the rows of every other fold;
- :mod:`~accelcore.reference.stats`: the statistics that accept or reject a term
  (:func:`chi2_sf`, :func:`t_sf`, :func:`f_sf`, :func:`paired_test`, :func:`sign_test`,
  :func:`bonferroni`,
  :func:`holm`, :class:`AcceptanceRule`), plain functions rather than kernels;
- :mod:`~accelcore.reference.search`: :class:`TimeConstantSearch`, a time constant by
  the held-out error of trials built and refitted plainly;
- :mod:`~accelcore.reference.errors`: the exceptions.

The reference raises its own exception classes, which carry the same names as
the ones in :mod:`accelcore` (``ParameterError``, ``ShapeError``, ...) and
likewise subclass :class:`ValueError`, so that tests can compare errors by
class name without this package depending on the extension.
"""

from __future__ import annotations

from accelcore.reference.binning import N_BINS_SLACK, BinnedStats, TemperatureBinner
from accelcore.reference.decimate import DecimatedBlocks, Decimator
from accelcore.reference.errors import (
    IncompatibleError,
    InsufficientDataError,
    NonFiniteError,
    ParameterError,
    ReferenceKernelError,
    ShapeError,
    SingularSystemError,
    TimeOrderError,
)
from accelcore.reference.heldout import HeldOut, cross_validate
from accelcore.reference.regression import RANK_RTOL, LeastSquares, LstsqSolution
from accelcore.reference.robust import running_median, sliding_median
from accelcore.reference.search import TimeConstantSearch
from accelcore.reference.stats import (
    Acceptance,
    AcceptanceRule,
    PairedTest,
    bonferroni,
    chi2_sf,
    f_sf,
    holm,
    paired_test,
    sign_test,
    t_sf,
)

__all__ = [
    "N_BINS_SLACK",
    "RANK_RTOL",
    "Acceptance",
    "AcceptanceRule",
    "BinnedStats",
    "DecimatedBlocks",
    "Decimator",
    "HeldOut",
    "IncompatibleError",
    "InsufficientDataError",
    "LeastSquares",
    "LstsqSolution",
    "NonFiniteError",
    "PairedTest",
    "ParameterError",
    "ReferenceKernelError",
    "ShapeError",
    "SingularSystemError",
    "TemperatureBinner",
    "TimeConstantSearch",
    "TimeOrderError",
    "bonferroni",
    "chi2_sf",
    "cross_validate",
    "f_sf",
    "holm",
    "paired_test",
    "running_median",
    "sign_test",
    "sliding_median",
    "t_sf",
]
