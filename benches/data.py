"""Synthetic data shared by the cases: 20 Hz logs of time, temperature and 3 channels."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
RATE_HZ = 20.0


def log(n: int, seed: int = 0) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``n`` samples: time (s, 20 Hz with jitter), a -20..80 °C ramp, 3 noisy channels."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=np.float64) / RATE_HZ
    t += rng.uniform(0.0, 0.01, n)
    temp = -20.0 + 100.0 * np.arange(n) / n + rng.normal(0.0, 0.05, n)
    ch = rng.normal(0.0, 0.01, (n, 3))
    ch += (temp[:, None] - 25.0) * np.array([1e-3, -2e-3, 5e-4]) + np.array([1.5, 1.48, 1.54])
    return t, temp, ch


def stream(
    n: int, chunk: int = 1 << 20, seed: int = 0
) -> Iterator[tuple[FloatArray, FloatArray, FloatArray]]:
    """The same kind of log generated chunk by chunk, never whole (a ramp over ``n``)."""
    rng = np.random.default_rng(seed)
    for start in range(0, n, chunk):
        m = min(chunk, n - start)
        i = np.arange(start, start + m, dtype=np.float64)
        t = i / RATE_HZ + rng.uniform(0.0, 0.01, m)
        temp = -20.0 + 100.0 * i / n + rng.normal(0.0, 0.05, m)
        ch = rng.normal(0.0, 0.01, (m, 3))
        ch += (temp[:, None] - 25.0) * np.array([1e-3, -2e-3, 5e-4]) + 1.5
        yield t, temp, ch
