"""The calibration model: per axis, a list of named terms, linear in their coefficients.

The output of axis ``a`` (in session units) is modelled as::

    v_a = Σ offset terms  c · B(features)  +  Σ gain terms  c · B(features) · g_b

where ``g_b`` is the gravity (in g) on axis ``b`` that the run's orientation
implies and ``B`` a *basis*: a named function of the sample's observables. The
basis names are a small grammar, so a model can be saved, loaded and extended
by later effects without new code paths:

``1``
    constant;
``dT^k``
    ``(T - t_ref_c)^k``, °C^k (curvature for k >= 2);
``lag(tau):dT^k``
    the same with the temperature passed through a first-order lag of
    ``tau`` seconds (the die trailing the logged probe);
``dTdt``
    rate of change of temperature, °C/min (causal, smoothed over 60 s);
``elapsed_h``
    time since the start of the run, hours (drift);
``extra:NAME``
    an extra logged column, minus its reference value stored in the model.

The base model of the seed paper is, on each axis, offset ``1``, ``dT^1`` and
gain (own axis) ``1``, ``dT^1``: zero-g offset and sensitivity, each a line in
temperature.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import first_order_lag
from accelcore.constants import AXES, DTDT_SMOOTHING_S
from accelcore.errors import ParameterError

__all__ = [
    "AXES",
    "DTDT_SMOOTHING_S",
    "Features",
    "Term",
    "base_terms",
    "evaluate_basis",
]


_POLY = re.compile(r"^dT\^([1-9])$")
_LAG = re.compile(r"^lag\(([0-9.eE+-]+)\):dT\^([1-9])$")


@dataclass(frozen=True)
class Term:
    """One named term of an axis model.

    Parameters
    ----------
    kind : {"offset", "gain"}
        An offset term adds ``c·B``; a gain term adds ``c·B·g_source``.
    basis : str
        The basis name (see the module docs).
    source : str or None
        For gain terms, the axis whose gravity it multiplies (own axis:
        sensitivity; another axis: misalignment or cross-axis sensitivity).
    effect : str
        The effect that introduced the term (``base``, ``curvature``, ...).
    """

    kind: Literal["offset", "gain"]
    basis: str
    source: str | None = None
    effect: str = "base"

    @property
    def name(self) -> str:
        """Readable name, e.g. ``offset·dT^1`` or ``gain[y]·1``."""
        if self.kind == "offset":
            return f"offset·{self.basis}"
        return f"gain[{self.source}]·{self.basis}"

    def to_dict(self) -> dict[str, str | None]:
        """Plain-data form for JSON."""
        return {
            "kind": self.kind,
            "basis": self.basis,
            "source": self.source,
            "effect": self.effect,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, object]) -> Term:
        """Inverse of :meth:`to_dict`."""
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
        Term("offset", "1"),
        Term("offset", "dT^1"),
        Term("gain", "1", source=axis),
        Term("gain", "dT^1", source=axis),
    )


@dataclass
class Features:
    """Observables of a stretch of contiguous samples, the inputs of every basis.

    Parameters
    ----------
    temperature_c : ndarray
        Logged temperature, °C.
    time_s : ndarray or None
        Time since the stretch's start, s (needed by time-dependent bases).
    extras : mapping of str to ndarray
        Extra logged columns.
    t_ref_c : float
        Reference temperature of ``dT``.
    """

    temperature_c: NDArray[np.float64]
    time_s: NDArray[np.float64] | None
    extras: Mapping[str, NDArray[np.float64]]
    t_ref_c: float
    _lag_cache: dict[float, NDArray[np.float64]] = field(default_factory=dict, repr=False)

    def __len__(self) -> int:
        return int(self.temperature_c.shape[0])

    def _need_time(self, basis: str) -> NDArray[np.float64]:
        if self.time_s is None:
            raise ParameterError(f"the model term basis {basis!r} needs time_s")
        return self.time_s

    def lagged_temperature_c(self, tau_s: float) -> NDArray[np.float64]:
        """Temperature through a first-order lag of ``tau_s`` seconds (cached)."""
        if tau_s not in self._lag_cache:
            time_s = self._need_time(f"lag({tau_s})")
            self._lag_cache[tau_s] = first_order_lag(time_s, self.temperature_c, tau_s)
        return self._lag_cache[tau_s]


def evaluate_basis(
    basis: str, features: Features, references: Mapping[str, float] | None = None
) -> NDArray[np.float64]:
    """Evaluate one basis on a stretch of samples.

    Parameters
    ----------
    basis : str
        Basis name (module docs).
    features : Features
        The samples' observables.
    references : mapping, optional
        Reference value of each ``extra:NAME`` basis (subtracted).

    Returns
    -------
    ndarray of float64
    """
    n = len(features)
    if basis == "1":
        return np.ones(n)
    m = _POLY.match(basis)
    if m:
        return (features.temperature_c - features.t_ref_c) ** int(m.group(1))
    m = _LAG.match(basis)
    if m:
        tau = float(m.group(1))
        return (features.lagged_temperature_c(tau) - features.t_ref_c) ** int(m.group(2))
    if basis == "dTdt":
        lagged = features.lagged_temperature_c(DTDT_SMOOTHING_S)
        return (features.temperature_c - lagged) / DTDT_SMOOTHING_S * 60.0
    if basis == "elapsed_h":
        return features._need_time(basis) / 3600.0
    if basis.startswith("extra:"):
        name = basis[len("extra:") :]
        if name not in features.extras:
            raise ParameterError(
                f"the model uses the extra column {name!r}, which the data does not have"
            )
        ref = (references or {}).get(basis, 0.0)
        return np.asarray(features.extras[name], dtype=np.float64) - ref
    raise ParameterError(f"unknown basis {basis!r}")


def design_columns(
    terms: Sequence[Term],
    features: Features,
    gravity_g: NDArray[np.float64],
    references: Mapping[str, float] | None = None,
) -> NDArray[np.float64]:
    """Design matrix of one axis over a stretch with constant gravity ``gravity_g`` (3,).

    Returns
    -------
    ndarray of float64, shape (n, len(terms))
    """
    n = len(features)
    out = np.empty((n, len(terms)))
    cache: dict[str, NDArray[np.float64]] = {}
    for j, term in enumerate(terms):
        if term.basis not in cache:
            cache[term.basis] = evaluate_basis(term.basis, features, references)
        column = cache[term.basis]
        if term.kind == "gain":
            column = column * gravity_g[AXES.index(term.source or "x")]
        out[:, j] = column
    return out
