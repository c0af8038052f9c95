"""A temperature probe at its rail: the logged temperature stops at one value, the part does not.

A probe (or its ADC) that saturates logs exactly one value, the run's highest or
lowest, while the chamber goes on beyond it and back; the output goes on following
the part's real temperature. Fitted against the logged value, those blocks bend any
temperature term to the plateau (blind round 4: a probe pinned at 55 °C for 12 % of
the samples, a 5th-order curvature carried past it, 2.41 → 4.94 mg on another session).

A stretch of at least :data:`MIN_PINNED_S` seconds whose block means of temperature
are all exactly the run's extreme is *pinned* when, over it, some axis' output (its
running median) goes out and comes back: it strays from the straight line between
its ends by more than :data:`HUMP_SIGMA` of its block noise and by more than half its
own range. A soak at a setpoint logs a steady temperature too (a rounded probe, one
value), but there the output settles one way, as a lag catches up, or stays.

Imports: NumPy and the core's running median and block noise.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import block_noise, fingerprint, running_median
from accelcore.constants import AXES
from accelcore.input.run import Run

__all__ = [
    "HUMP_SIGMA",
    "MIN_PINNED_S",
    "PinnedStretch",
    "pinned_mask",
    "pinned_stretches",
    "pinned_text",
]

#: Shortest stretch at one temperature value that is checked, s.
MIN_PINNED_S = 60.0

#: How far (in block-noise sigmas) the output must stray from the line between its
#: values at the stretch's ends.
HUMP_SIGMA = 10.0

#: Blocks of the output's running median over a stretch.
_SMOOTH = 9

#: (first block, end block, pinned value °C, axis index, largest stray in output units)
PinnedStretch = tuple[int, int, float, int, float]


def pinned_stretches(run: Run) -> list[PinnedStretch]:
    """Return the stretches of ``run`` where its logged temperature is pinned at a rail."""
    t = np.asarray(run.temperature_c, dtype=np.float64)
    n = t.shape[0]
    if n < 2 * _SMOOTH or not np.all(np.isfinite(t)):
        return []
    out: list[PinnedStretch] = []
    sigmas: list[float] | None = None
    for extreme in sorted({float(t.max()), float(t.min())}):
        on = np.concatenate([[False], t == extreme, [False]])
        edges = np.flatnonzero(np.diff(on.astype(np.int8)))
        for s, e in zip(edges[::2], edges[1::2], strict=True):
            if e - s < _SMOOTH or run.time_s[e - 1] - run.time_s[s] < MIN_PINNED_S:
                continue
            if sigmas is None:
                sigmas = [_noise(run, c) for c in range(3)]
            found = _hump(run, int(s), int(e), sigmas)
            if found is not None:
                out.append((int(s), int(e), extreme, *found))
    return out


#: Block noise per channel content (its fingerprint): every fit of a run screens it.
_NOISE: dict[int, float] = {}
_NOISE_KEPT = 256


def _noise(run: Run, c: int) -> float:
    """Return channel ``c``'s block noise (:func:`block_noise`'s sigma), kept per content."""
    key = fingerprint(run.output[:, c], run.count)
    found = _NOISE.get(key)
    if found is None:
        found = block_noise(run.output[:, c], run.count, window=_SMOOTH)[1]
        if len(_NOISE) >= _NOISE_KEPT:
            _NOISE.clear()
        _NOISE[key] = found
    return found


def _hump(run: Run, s: int, e: int, sigmas: list[float]) -> tuple[int, float] | None:
    """Return the axis whose output goes out and back over blocks ``s:e`` and how far, or None."""
    best: tuple[int, float] | None = None
    for c, sigma in enumerate(sigmas):
        y = running_median(np.ascontiguousarray(run.output[s:e, c]), window=_SMOOTH)
        if not (sigma > 0 and np.all(np.isfinite(y))):
            continue
        chord = np.linspace(y[0], y[-1], y.shape[0])
        stray = float(np.max(np.abs(y - chord)))
        spread = float(y.max() - y.min())
        humps = stray > HUMP_SIGMA * sigma and stray > 0.5 * spread
        if humps and (best is None or stray > best[1]):
            best = (c, stray)
    return best


def pinned_mask(run: Run) -> NDArray[np.bool_]:
    """Blocks of ``run`` in a pinned stretch (:func:`pinned_stretches`)."""
    mask = np.zeros(len(run), dtype=bool)
    for s, e, *_ in pinned_stretches(run):
        mask[s:e] = True
    return mask


def pinned_text(run: Run, stretch: PinnedStretch) -> str:
    """Describe one pinned stretch (the message of its quality finding)."""
    s, e, value, c, stray = stretch
    which = "highest" if value >= float(np.max(run.temperature_c)) else "lowest"
    seconds = float(run.time_s[e - 1] - run.time_s[s])
    return (
        f"the logged temperature stays at exactly {value:.6g} °C, the run's {which}, for "
        f"{seconds:.0f} s (from {float(run.time_s[s]):.0f} s) while the {AXES[c]} output "
        f"goes {stray:.3g} out and back: the probe at its rail? those {e - s} blocks are "
        "left out of the fits"
    )
