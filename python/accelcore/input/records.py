"""Records: the runs of a session with the pieces of one continuous log joined.

A chamber log cut into several files — by the logger's file size limit, or by a
user who stores each leg of the cycle apart — is still one record of one part in
one orientation. Everything that depends on a sample's history (a thermal lag's
state, the smoothed dT/dt, the time since the start, the legs of the temperature
cycle, the held-out folds) must see it whole, or the answer would depend on where
the files were cut. :func:`records` joins what ``session.toml`` says continues
(``continues = true``), and runs of the same orientation whose absolute times follow
each other within a few block intervals; runs that restart their clock, overlap, or
leave a real pause stay apart unless declared, and ``continues = false`` keeps a run
apart whatever its clock (a new power-on).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from accelcore.errors import SessionFormatError
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


def _follow_on(parts: Sequence[Run]) -> list[Run]:
    """Return the pieces with a restarted clock moved to follow the piece before them.

    A piece declared to continue (``continues = true``) whose clock starts at or before
    the previous piece's end (a logger that restarts its clock with every file) is
    shifted to start one block interval after it; a clock that runs on is kept.
    """
    out = [parts[0]]
    for p in parts[1:]:
        prev = out[-1]
        if len(p) and len(prev) and p.time_s[0] <= prev.time_s[-1]:
            step = _interval_s(prev) or _interval_s(p) or 1.0
            p = dataclasses.replace(p, time_s=p.time_s + (prev.time_s[-1] + step - p.time_s[0]))
        out.append(p)
    return out


def _join(parts: Sequence[Run]) -> Run:
    if len(parts) == 1:
        return parts[0]
    parts = _follow_on(parts)
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
        continues=parts[0].continues,
    )


def _declared(runs: Sequence[Run]) -> list[list[int]]:
    """Chains of runs in listing order, each run that says ``continues`` after the one before."""
    chains: list[list[int]] = []
    for i, run in enumerate(runs):
        if run.continues and chains and runs[chains[-1][-1]].orientation == run.orientation:
            prev = runs[chains[-1][-1]]
            if set(prev.extras) != set(run.extras):
                raise SessionFormatError(
                    f"{run.label} says continues = true, but its extra columns "
                    f"({', '.join(sorted(run.extras)) or 'none'}) are not those of "
                    f"{prev.label} ({', '.join(sorted(prev.extras)) or 'none'}), the run it "
                    "continues"
                )
            chains[-1].append(i)
        else:
            chains.append([i])
    return chains


def records(session: Session) -> tuple[Run, ...]:
    """Return the session's runs with contiguous pieces of one log joined, in session order.

    What ``session.toml`` says comes first: a run whose ``continues`` is true is
    joined to the run listed before it (its clock, if restarted, moved to follow on);
    one whose ``continues`` is false starts a record. The others are told from the
    clock: runs of one orientation are joined when, in absolute time, one starts after
    another ends by at most :data:`CONTIGUOUS_BLOCKS` block intervals (whatever order
    the session lists them in) and they log the same extra columns. Where a piece could
    continue more than one run (two power-ons, each timed from 0, cut into files with
    their clocks kept), it continues the one that ends nearest before it, then the one
    listed nearest before it. Every other run is returned as it is, so a session of one
    file per orientation gives back its runs unchanged.

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
    runs = session.runs
    chains = _declared(runs)
    pieces = [_join([runs[i] for i in c]) for c in chains]
    first = [c[0] for c in chains]
    order = sorted(
        range(len(pieces)),
        key=lambda k: (
            pieces[k].orientation,
            float(pieces[k].time_s[0]) if len(pieces[k]) else np.inf,
            first[k],
        ),
    )
    typical_s = _typical_interval_s(runs)
    groups: list[list[int]] = []
    for k in order:
        if pieces[k].continues is False:
            groups.append([k])
            continue
        near = [
            (float(pieces[k].time_s[0] - pieces[g[-1]].time_s[-1]), abs(first[k] - first[g[-1]]), n)
            for n, g in enumerate(groups)
            if _continues(pieces[g[-1]], pieces[k], typical_s)
        ]
        if near:
            groups[min(near)[2]].append(k)
        else:
            groups.append([k])
    groups.sort(key=lambda g: min(first[k] for k in g))
    return tuple(_join([pieces[k] for k in g]) for g in groups)


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
