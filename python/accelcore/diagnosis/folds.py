"""Held-out folds of the diagnosis: whole runs, legs of the temperature cycle, or blocks.

A fold is a set of blocks held out together. :func:`choose_folds` picks whole
records (three or more, each fold's training data keeping every axis' gravity at
two values wherever the session has them), else legs (three or more), else every
third block of each record in time. Records, not files: the same samples cut into
files differently get the same folds.

Two legs (heat, then cool back) are not folds: each would be fitted on the other
direction alone, along which time and temperature move together; a drift fitted on
one ramp was extrapolated to the other, never passed, and a warm-up and a lag took its
place (two to five orientations, one run each).

Every scheme holds out data inside the session's temperature range: a run, or a leg,
spans it. Within a record that runs one way only (a board heated from a soak, as PX4's
and ArduPilot's thermal calibrations log it), contiguous thirds in time would be
thirds in temperature, and each held-out fold a 20 °C extrapolation: the curvature of
the offset (the model of those projects' own scripts) lost to terms of time that
extrapolate gently (a drift, a lag at the end of its range), which another session
does not repeat. Blocks taken in turn are spread over the range.

Imports: NumPy and the error types only.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from accelcore.errors import ParameterError

__all__ = ["MIN_BLOCKS_PER_PART", "SCHEMES", "choose_folds", "cut_blocks"]

IntArray = NDArray[np.int64]

#: The fold schemes ``folds=`` may name.
SCHEMES = ("auto", "runs", "legs", "blocks")

#: Whole runs are folds only when, with any one held out, each gravity value of an axis
#: that sees two is left over at least this share of the session's temperature span.
MIN_SPAN_SHARE = 0.5

#: Fewest held-out blocks a part (run x leg) is cut into when it holds the samples.
MIN_BLOCKS_PER_PART = 3


def cut_blocks(
    times_s: Sequence[NDArray[np.float64]], part_start: IntArray, block_s: float
) -> tuple[list[int], list[int]]:
    """Cut parts into blocks: first sample and part of each block.

    A block is a contiguous stretch of at most ``block_s`` inside one part (its
    samples' times ``times_s[p]``, starting at sample ``part_start[p]``), and a part
    holding the samples gets at least :data:`MIN_BLOCKS_PER_PART` of them (a static
    hold of a few seconds still gets blocks, so folds, inside it).
    """
    starts: list[int] = []
    block_part: list[int] = []
    for p, t in enumerate(times_s):
        length = block_s
        if t.size >= 2 * MIN_BLOCKS_PER_PART and t[-1] > t[0]:
            # Sample times are block centres: the part spans one interval more.
            span = (t[-1] - t[0]) * t.size / (t.size - 1)
            length = min(block_s, span / MIN_BLOCKS_PER_PART)
        chunk = np.floor((t - t[0]) / length * (1 - 1e-9)).astype(np.int64)
        edges = np.flatnonzero(np.diff(chunk)) + 1
        b0 = [0, *edges.tolist()]
        # Merge a short last chunk into the one before it.
        if len(b0) > 1 and (t[-1] - t[b0[-1]]) < 0.5 * length:
            b0 = b0[:-1]
        starts += [int(part_start[p]) + s for s in b0]
        block_part += [p] * len(b0)
    return starts, block_part


def choose_folds(
    folds: str,
    part_run: Sequence[int],
    part_leg: Sequence[int],
    part_gravity: Sequence[NDArray[np.float64]],
    run_labels: Sequence[str],
    leg_kinds: Mapping[tuple[int, int], str],
    block_part: IntArray,
    block_elapsed_s: NDArray[np.float64],
    part_span_c: Sequence[tuple[float, float]] = (),
) -> tuple[str, list[str], IntArray]:
    """Return the scheme, the fold names and the fold of every block.

    Parameters
    ----------
    folds : {"auto", "runs", "legs", "blocks"}
    part_run, part_leg : sequence of int
        Record and leg of each part.
    part_gravity : sequence of ndarray, shape (3,)
        Gravity (g) of each part.
    run_labels : sequence of str
        Label of each record.
    leg_kinds : mapping
        ``(record, leg)`` -> ``"heating"``, ``"cooling"`` or ``"steady"``.
    block_part : ndarray of int64
        Part of each block.
    block_elapsed_s : ndarray
        Time of each block's first sample since its record's start, s.
    part_span_c : sequence of (float, float), optional
        Lowest and highest temperature of each part, °C (none: not checked).
    """
    if folds not in SCHEMES:
        raise ParameterError(f"folds must be auto, runs, legs or blocks, got {folds!r}")
    runs = sorted(set(part_run))
    p_run = np.asarray(part_run, dtype=np.int64)
    p_leg = np.asarray(part_leg, dtype=np.int64)
    grav = np.asarray(part_gravity, dtype=np.float64).reshape(-1, 3)
    values = [np.unique(grav[:, i]).size for i in range(3)]

    spans = np.asarray(part_span_c, dtype=np.float64).reshape(-1, 2)
    whole_c = float(spans[:, 1].max() - spans[:, 0].min()) if spans.size else 0.0

    def diverse(part_fold: IntArray) -> bool:
        # Every fold's training data must keep each axis' gravity at two values or more
        # (offset and sensitivity told apart) wherever the whole session does, each
        # over a temperature span (their tempcos told apart too): a run of two minutes
        # at the cold soak left the only other value of z's gravity, and z's
        # sensitivity tempco rested on it when its pair was held out.
        for a_i in range(3):
            need = min(2, values[a_i])
            for k in np.unique(part_fold):
                train = part_fold != k
                g = grav[train, a_i]
                if g.size == 0 or np.unique(g).size < need:
                    return False
                if need < 2 or whole_c <= 0.0:
                    continue
                for v in np.unique(g):
                    s = spans[train & (grav[:, a_i] == v)]
                    if float(s[:, 1].max() - s[:, 0].min()) < MIN_SPAN_SHARE * whole_c:
                        return False
        return True

    if folds in ("auto", "runs") and len(runs) >= 3:
        pf = np.searchsorted(runs, p_run).astype(np.int64)
        if folds == "runs" or diverse(pf):
            return "runs", [f"run {run_labels[r]}" for r in runs], pf[block_part]
    n_legs = int(p_leg.max()) + 1
    if (folds == "auto" and n_legs >= 3) or (folds == "legs" and n_legs >= 2):
        names = []
        for leg in range(n_legs):
            kinds = sorted({leg_kinds[(r, lg)] for (r, lg) in leg_kinds if lg == leg})
            names.append(f"leg {leg + 1} ({'/'.join(kinds)})")
        return "legs", names, p_leg[block_part]
    if folds == "legs" and n_legs < 2:
        raise ParameterError("folds='legs' needs runs with at least two legs")
    # Every third block of each record in time, in turn (see the module).
    block_fold = np.zeros(block_part.size, dtype=np.int64)
    block_run = p_run[block_part]
    for r in runs:
        sel = np.flatnonzero(block_run == r)
        order = np.argsort(np.asarray(block_elapsed_s)[sel], kind="stable")
        block_fold[sel[order]] = np.arange(sel.size) % 3
    names = [f"blocks {k + 1}, {k + 4}, {k + 7}, … of each run" for k in range(3)]
    return "blocks", names, block_fold


def fold_spans(
    block_fold: NDArray[np.int64],
    block_start: NDArray[np.int64],
    block_stop: NDArray[np.int64],
    n_folds: int,
) -> list[list[tuple[int, int]]]:
    """Return each fold's samples as contiguous stretches (neighbouring blocks joined)."""
    spans: list[list[tuple[int, int]]] = [[] for _ in range(n_folds)]
    for k, s, e in zip(block_fold, block_start, block_stop, strict=True):
        fold = spans[k]
        if fold and fold[-1][1] == s:
            fold[-1] = (fold[-1][0], int(e))
        else:
            fold.append((int(s), int(e)))
    return spans
