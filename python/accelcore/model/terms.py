"""Terms of the model: a basis in the offset or in a gain, and the design they make."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from accelcore.constants import AXES
from accelcore.errors import ParameterError

from .bases import Basis, Constant, Features, TemperaturePower

__all__ = ["Term", "base_terms", "design_columns", "evaluate_basis", "full_gain_terms"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Term:
    """One named term of an axis model.

    Parameters
    ----------
    kind : {"offset", "gain"}
        An offset term adds ``c·B``; a gain term adds ``c·B·g_source``.
    basis : Basis or str
        The basis (a name in the module's grammar is parsed once, here).
    source : str or None
        For gain terms, the axis whose gravity it multiplies (own axis:
        sensitivity; another axis: misalignment or cross-axis sensitivity).
    effect : str
        The effect that introduced the term (``base``, ``curvature``, ...).
    """

    kind: Literal["offset", "gain"]
    basis: Basis
    source: str | None = None
    effect: str = "base"

    def __init__(
        self,
        kind: Literal["offset", "gain"],
        basis: Basis | str,
        source: str | None = None,
        effect: str = "base",
    ) -> None:
        if kind != "offset" and kind != "gain":
            raise ParameterError(f"unknown term kind {kind!r}")
        if kind == "gain" and source not in AXES:
            raise ParameterError(f"a gain term needs a source axis x, y or z, got {source!r}")
        object.__setattr__(self, "kind", kind)
        object.__setattr__(self, "basis", Basis.parse(basis))
        object.__setattr__(self, "source", source if kind == "gain" else None)
        object.__setattr__(self, "effect", effect)
        # Terms key the diagnosis' caches (thousands of lookups per run): hashed once.
        object.__setattr__(self, "_hash", hash((self.kind, self.basis, self.source, effect)))

    def __hash__(self) -> int:
        return self._hash  # type: ignore[attr-defined,no-any-return]

    def __reduce__(self) -> tuple[type[Term], tuple[str, Basis, str | None, str]]:
        # The kept hash is of this process (str hashes are salted): rebuilt on unpickling.
        return (Term, (self.kind, self.basis, self.source, self.effect))

    @property
    def name(self) -> str:
        """Readable name, e.g. ``offset·dT^1`` or ``gain[y]·1``."""
        if self.kind == "offset":
            return f"offset·{self.basis}"
        return f"gain[{self.source}]·{self.basis}"

    def column(self, basis_values: FloatArray, gravity_g: FloatArray) -> FloatArray:
        """Return the design column: the basis values, times gravity in g (3,) or (n, 3) if gain."""
        if self.kind == "offset":
            return basis_values
        g = np.asarray(gravity_g)
        return basis_values * g[..., AXES.index(self.source or "x")]

    def to_dict(self) -> dict[str, str | None]:
        """Plain-data form for JSON."""
        return {
            "kind": self.kind,
            "basis": self.basis.name,
            "source": self.source,
            "effect": self.effect,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, object]) -> Term:
        """Inverse of :meth:`to_dict` (the basis name is checked against the grammar)."""
        kind = data["kind"]
        if kind != "offset" and kind != "gain":
            raise ParameterError(f"unknown term kind {kind!r}")
        source = data.get("source")
        return cls(
            kind=kind,
            basis=str(data["basis"]),
            source=None if source is None else str(source),
            effect=str(data.get("effect", "base")),
        )


def base_terms(axis: str) -> tuple[Term, ...]:
    """Return the seed paper's model of one axis: offset and sensitivity, linear in T."""
    return (
        Term("offset", Constant()),
        Term("offset", TemperaturePower(1)),
        Term("gain", Constant(), source=axis),
        Term("gain", TemperaturePower(1), source=axis),
    )


def full_gain_terms(axis: str) -> tuple[Term, ...]:
    """Return the default joint model of one axis: the seed paper's, plus cross-axis gain.

    The offset and own-axis sensitivity linear in T (:func:`base_terms`), then a
    constant gain on each other axis' gravity (misalignment and cross-axis
    sensitivity: the full 3x3 gain, as multi-position calibrators fit it). With
    fewer than six orientations the fit holds what the runs cannot identify at 0
    and lists it in ``Calibration.not_identified``.
    """
    cross = tuple(Term("gain", Constant(), source=b) for b in AXES if b != axis)
    return (*base_terms(axis), *cross)


def evaluate_basis(
    basis: Basis | str, features: Features, references: Mapping[str, float] | None = None
) -> FloatArray:
    """Evaluate one basis on a stretch of samples.

    Parameters
    ----------
    basis : Basis or str
        The basis, or its name (module docs).
    features : Features
        The samples' observables.
    references : mapping, optional
        Reference value of each ``extra:NAME`` basis (subtracted).

    Returns
    -------
    ndarray of float64
    """
    return Basis.parse(basis).evaluate(features, references)


def design_columns(
    terms: Sequence[Term],
    features: Features,
    gravity_g: FloatArray,
    references: Mapping[str, float] | None = None,
) -> FloatArray:
    """Design matrix of one axis over a stretch with constant gravity ``gravity_g`` (3,).

    Returns
    -------
    ndarray of float64, shape (n, len(terms))
    """
    n = len(features)
    out = np.empty((n, len(terms)))
    cache: dict[Basis, FloatArray] = {}
    for j, term in enumerate(terms):
        if term.basis not in cache:
            basis = term.basis
            if basis.needs_gravity:
                # The force of the stretch, not an estimate the features may carry.
                cache[basis] = basis.at_gravity(gravity_g, n)
            else:
                cache[basis] = basis.evaluate(features, references)
        out[:, j] = term.column(cache[term.basis], gravity_g)
    return out
