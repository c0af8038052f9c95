"""Input checks and array helpers shared by the reference kernels."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from accelcore.reference.errors import ParameterError, ShapeError

__all__ = [
    "FloatArray",
    "IntArray",
    "check_finite_positive",
    "check_int",
    "concat",
    "matrix",
    "safe_divide",
    "vector",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def vector(values: ArrayLike, what: str, n: int | None = None) -> FloatArray:
    """Return ``values`` as a 1-D float64 array, checking its length."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        raise ShapeError(f"{what} must be 1-D, got {array.ndim} dimensions")
    if n is not None and array.shape[0] != n:
        raise ShapeError(f"{what} has {array.shape[0]} rows, expected {n}")
    return array


def matrix(values: ArrayLike, what: str, n: int, n_columns: int) -> FloatArray:
    """Return ``values`` as an ``(n, n_columns)`` float64 array, checking its shape."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 2:
        raise ShapeError(f"{what} must be 2-D, got {array.ndim} dimensions")
    if array.shape != (n, n_columns):
        raise ShapeError(f"{what} has shape {array.shape}, expected {(n, n_columns)}")
    return array


def concat(chunks: Sequence[FloatArray], width: int | None = None) -> FloatArray:
    """Concatenate chunks along axis 0; an empty list gives an empty array."""
    if chunks:
        return np.concatenate(chunks, axis=0)
    shape = (0,) if width is None else (0, width)
    return np.empty(shape, dtype=np.float64)


def safe_divide(numerator: FloatArray, denominator: FloatArray) -> FloatArray:
    """Divide elementwise, giving NaN where ``denominator`` is zero (no warning)."""
    out = np.full(np.broadcast_shapes(numerator.shape, denominator.shape), np.nan)
    np.divide(numerator, denominator, out=out, where=denominator != 0)
    return out


def check_finite_positive(name: str, value: float) -> None:
    """Raise :class:`ParameterError` unless ``value`` is finite and positive."""
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(f"{name} must be finite and > 0, got {value}")


def check_int(name: str, value: int, minimum: int) -> None:
    """Raise :class:`ParameterError` unless ``value`` is an integer ``>= minimum``."""
    if int(value) != value or value < minimum:
        raise ParameterError(f"{name} must be an integer >= {minimum}, got {value}")
