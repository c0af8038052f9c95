"""Records: the runs of a session with the pieces of one continuous log joined.

A chamber log cut into several files — by the logger's file size limit, or by a
user who stores each leg of the cycle apart — is still one record of one part in
one orientation. Everything that depends on a sample's history (a thermal lag's
state, the smoothed dT/dt, the time since the start, the legs of the temperature
cycle, the held-out folds) must see it whole, or the answer would depend on where
the files were cut. :func:`records` joins runs of the same orientation whose
absolute times follow each other within a few block intervals; runs that restart
their clock, overlap, or leave a real pause stay apart.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from accelcore.input.session import Run, RunStats, Session

__all__ = ["CONTIGUOUS_BLOCKS", "record_names", "records"]

#: Two runs continue one record when the second starts at most this many block
#: intervals (the median spacing of either run's decimated blocks) after the first ends.
CONTIGUOUS_BLOCKS = 10.0


def _interval_s(run: Run) -> float:
    if len(run) < 2:
        return 0.0
    return float(np.median(np.diff(run.time_s)))


def _continues(prev: Run, nxt: Run, typical_s: float) -> bool:
    """Tell whether ``nxt`` continues ``prev``; ``typical_s``: the session's block interval."""
    if prev.orientation != nxt.orientation or len(prev) == 0 or len(nxt) == 0:
        return False
    if set(prev.extras) != set(nxt.extras):
        return False
    gap = float(nxt.time_s[0] - prev.time_s[-1])
    # A piece of one block has no spacing of its own: the session's is used.
    limit = CONTIGUOUS_BLOCKS * (max(_interval_s(prev), _interval_s(nxt)) or typical_s)
    return 0.0 < gap <= limit


def _typical_interval_s(runs: Sequence[Run]) -> float:
    """Median block interval of the runs of two blocks or more (0 when there is none)."""
    spacings = [_interval_s(r) for r in runs if len(r) >= 2]
    return float(np.median(spacings)) if spacings else 0.0


def _stats(parts: Sequence[Run]) -> RunStats:
    """Return what the reader saw over the joined pieces: sums, extremes, counts at them."""
    first = parts[0].stats
    ranged = [p.stats for p in parts if p.stats.channel_min.size]
    extremes: dict[str, object] = {}
    if ranged:
        lo = np.min([s.channel_min for s in ranged], axis=0)
        hi = np.max([s.channel_max for s in ranged], axis=0)
        extremes = {
            "channel_min": lo,
            "channel_max": hi,
            # Samples at the joined extreme: those of every piece whose extreme it is.
            "n_at_min": sum(
                (np.where(s.channel_min == lo, s.n_at_min, 0) for s in ranged),
                np.zeros(lo.size, dtype=np.uint64),
            ).astype(np.uint64),
            "n_at_max": sum(
                (np.where(s.channel_max == hi, s.n_at_max, 0) for s in ranged),
                np.zeros(hi.size, dtype=np.uint64),
            ).astype(np.uint64),
        }
    return dataclasses.replace(
        first,
        n_rows=sum(p.stats.n_rows for p in parts),
        n_skipped_nonfinite=sum(p.stats.n_skipped_nonfinite for p in parts),
        n_truncated_rows=sum(p.stats.n_truncated_rows for p in parts),
        n_gaps=sum(p.stats.n_gaps for p in parts),
        max_interval_s=max(p.stats.max_interval_s for p in parts),
        duration_s=float(parts[-1].time_s[-1] - parts[0].time_s[0]),
        **extremes,  # type: ignore[arg-type]
    )


def _join(parts: Sequence[Run]) -> Run:
    if len(parts) == 1:
        return parts[0]
    return Run(
        orientation=parts[0].orientation,
        gravity_g=parts[0].gravity_g,
        time_s=np.concatenate([p.time_s for p in parts]),
        temperature_c=np.concatenate([p.temperature_c for p in parts]),
        output=np.concatenate([p.output for p in parts]),
        count=np.concatenate([p.count for p in parts]),
        extras={k: np.concatenate([p.extras[k] for p in parts]) for k in parts[0].extras},
        source=parts[0].source,
        stats=_stats(parts),
    )


def records(session: Session) -> tuple[Run, ...]:
    """Return the session's runs with contiguous pieces of one log joined, in session order.

    Runs of one orientation are joined when, in absolute time, each starts after
    the previous one ends by at most :data:`CONTIGUOUS_BLOCKS` block intervals
    (whatever order the session lists them in) and they log the same extra
    columns. Every other run is returned as it is,
    so a session of one file per orientation gives back its runs unchanged.

    Parameters
    ----------
    session : Session

    Returns
    -------
    tuple of Run
        A joined record keeps its first piece's (in time) orientation and source;
        its arrays are the pieces' in time order. Records come in the order of
        their first-listed piece.
    """
    order = sorted(
        range(len(session.runs)),
        key=lambda i: (
            session.runs[i].orientation,
            float(session.runs[i].time_s[0]) if len(session.runs[i]) else np.inf,
            i,
        ),
    )
    typical_s = _typical_interval_s(session.runs)
    groups: list[list[int]] = []
    for i in order:
        if groups and _continues(session.runs[groups[-1][-1]], session.runs[i], typical_s):
            groups[-1].append(i)
        else:
            groups.append([i])
    groups.sort(key=lambda g: min(g))
    return tuple(_join([session.runs[i] for i in g]) for g in groups)


def record_names(recs: Sequence[Run]) -> list[str]:
    """Return a name of each record that does not depend on file names.

    Its orientation, numbered (``"OZ- #2"``) when the orientation has several records.
    """
    counts: dict[str, int] = {}
    for rec in recs:
        counts[rec.orientation] = counts.get(rec.orientation, 0) + 1
    seen: dict[str, int] = {}
    names: list[str] = []
    for rec in recs:
        seen[rec.orientation] = seen.get(rec.orientation, 0) + 1
        several = counts[rec.orientation] > 1
        names.append(f"{rec.orientation} #{seen[rec.orientation]}" if several else rec.orientation)
    return names
