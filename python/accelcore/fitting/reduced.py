"""Each stretch of the joint fit reduced to the QR of its few functions of the samples.

Every column of an axis' design is one basis function of the samples times a
constant of the stretch: an offset term's basis times 1, a gain term's times the
stretch's gravity on its source axis (a record holds one orientation), a basis of
the force (``g_b^2``) a constant. So a stretch's design is ``X = B · M`` with ``B``
the few distinct functions (two for the seed paper's model: ``1`` and ``dT``) and
``M`` a small map, and its weighted least squares is ``B``'s: its triangle ``R``,
``Qᵀy`` of the three outputs and their residuals
(:meth:`accelcore.core.LeastSquares.push_mapped`). One QR of ``B`` per stretch
serves the three axes and every model over the same functions; each fit then
costs a few rows per stretch instead of its samples. Orthogonal all the way: never
normal equations.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from accelcore import core
from accelcore.fitting.stacking import Stacked
from accelcore.model import AXES, Constant, Term
from accelcore.model.bases import Basis

__all__ = ["MAX_FUNCTIONS", "Reduced", "functions_of", "shared"]

#: Largest number of distinct functions reduced together (the core's column limit).
MAX_FUNCTIONS = 64


def functions_of(terms: Sequence[Term]) -> tuple[Basis, ...]:
    """Return the distinct functions of the samples the terms' columns are multiples of.

    A basis of the force is a constant within a stretch: a multiple of ``1``.
    """
    out: dict[Basis, None] = {}
    for t in terms:
        out[Constant() if t.basis.needs_gravity else t.basis] = None
    return tuple(out)


@dataclass(frozen=True)
class Reduced:
    """The stretches of a :class:`~accelcore.fitting.stacking.Stacked` reduced to ``functions``.

    Attributes
    ----------
    functions : tuple of Basis
        The columns of each stretch's ``B``.
    factors : list of accelcore.core.LeastSquares
        Per stretch, the weighted QR of ``B`` with the three outputs as responses.
    sum_squares : list of ndarray
        Per stretch, ``sum w b²`` of each function (a column that is 0 on every
        weighted sample is told from these exactly).
    """

    functions: tuple[Basis, ...]
    factors: list[core.LeastSquares]
    sum_squares: list[NDArray[np.float64]]

    @classmethod
    def of(
        cls, data: Stacked, functions: Sequence[Basis], references: Mapping[str, float]
    ) -> Reduced:
        """Reduce every stretch of ``data`` to ``functions`` (distinct, at most 64)."""
        functions = tuple(functions)
        factors, sums = [], []
        for feats, out, w in zip(data.features, data.output, data.weight, strict=True):
            b = np.empty((len(feats), len(functions)))
            for k, f in enumerate(functions):
                b[:, k] = f.evaluate(feats, references)
            acc = core.LeastSquares(len(functions), n_responses=len(AXES))
            acc.push(b, out, w)
            factors.append(acc)
            sums.append(np.einsum("i,ij,ij->j", w, b, b))
        return cls(functions, factors, sums)

    @functools.cached_property
    def _index(self) -> dict[Basis, int]:
        """Row of each function in a map."""
        return {f: k for k, f in enumerate(self.functions)}

    def covers(self, terms: Sequence[Term]) -> bool:
        """Whether every function of ``terms`` is among :attr:`functions`."""
        return all(f in self._index for f in functions_of(terms))

    def map(self, terms: Sequence[Term], gravity_g: NDArray[np.float64]) -> NDArray[np.float64]:
        """``M`` of one stretch: its design is ``B · M`` (``len(functions)`` × ``len(terms)``).

        ``gravity_g`` is the stretch's (3,) gravity in g.
        """
        index = self._index
        m = np.zeros((len(self.functions), len(terms)))
        for j, t in enumerate(terms):
            if t.basis.needs_gravity:
                row, value = index[Constant()], float(t.basis.at_gravity(gravity_g, 1)[0])
            else:
                row, value = index[t.basis], 1.0
            m[row, j] = float(t.column(np.array([value]), gravity_g)[0])
        return m


def shared(data: Stacked, terms: Sequence[Term], references: Mapping[str, float]) -> Reduced | None:
    """Reduce ``data`` once for several axes' ``terms``, or None if the functions are too many.

    With more than :data:`MAX_FUNCTIONS` functions, each axis' fit reduces its own.
    """
    functions = functions_of(terms)
    return Reduced.of(data, functions, references) if len(functions) <= MAX_FUNCTIONS else None
