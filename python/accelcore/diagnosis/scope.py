"""What a diagnosis tries: its options checked, the families a quality finding rules out."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

from accelcore.errors import ParameterError
from accelcore.input.quality import QualityIssue
from accelcore.input.session import Session

from .space import FAMILIES

__all__ = [
    "QUALITY_EXPLAINS",
    "check_options",
    "explained",
    "found_in",
    "not_explained_by",
    "without_findings",
]

#: Effect families each kind of data-quality finding
#: (:func:`accelcore.input.quality.check_session`) could explain, and so are not
#: tried when it is found: a run cut short holds only the start of the sweep, its lag
#: state and temperature path unlike the other runs', so a lag fitted across the runs
#: may only mirror the cut.
QUALITY_EXPLAINS: Mapping[str, tuple[str, ...]] = {
    "short": ("thermal_lag", "two_way_lag", "smooth:dtemp_dt_c_per_min", "smooth:elapsed_h")
}


def explained(quality: Sequence[QualityIssue]) -> list[str]:
    """Families (and ``smooth:OBSERVABLE``) that the session's findings could explain."""
    kinds = {i.kind for i in quality}
    return [f for kind, fams in QUALITY_EXPLAINS.items() if kind in kinds for f in fams]


def not_explained_by(
    families: Sequence[str],
    quality: Sequence[QualityIssue],
    found_without: Sequence[str] = (),
) -> tuple[list[str], list[str]]:
    """Drop the families a quality finding could explain; one warning per finding kind.

    ``found_without``: families (and ``smooth:OBSERVABLE``) that a diagnosis of the
    runs without the finding added: the finding does not explain them, they are kept
    (and said so).
    """
    kept = list(families)
    notes = []
    for kind, explained in QUALITY_EXPLAINS.items():
        found = [i for i in quality if i.kind == kind]
        if not found:
            continue
        runs = sorted({i.run for i in found if i.run})
        where = f" ({', '.join(runs)})" if runs else ""
        cleared = [f for f in explained if f in found_without]
        if cleared:
            notes.append(
                f"data-quality finding '{kind}'{where} could explain "
                f"{', '.join(_readable(f) for f in cleared)}: tried, as the runs without "
                "it show it too"
            )
        explained = tuple(f for f in explained if f not in cleared)
        dropped = [f for f in explained if f in kept]
        kept = [f for f in kept if f not in dropped]
        if "smooth" in kept:
            dropped += [
                f"generic terms vs {f.split(':', 1)[1]}"
                for f in explained
                if f.startswith("smooth:")
            ]
        if not dropped:
            continue
        notes.append(
            f"data-quality finding '{kind}'{where} could explain {', '.join(dropped)}: "
            "not tried (fix the data, or diagnose with quality=[] to try it anyway)"
        )
    return kept, notes


def without_findings(session: Session, quality: Sequence[QualityIssue]) -> Session | None:
    """Return the session without the runs of the findings that rule families out.

    None when there is no such finding or fewer than two runs would be left. What a
    finding could explain is tried on the runs it is not about: a lag (or a term of
    dT/dt or of elapsed time) that the other runs show too is the part's, not the cut's.
    """
    labels = {i.run for i in quality if i.kind in QUALITY_EXPLAINS and i.run}
    runs = tuple(r for r in session.runs if r.label not in labels)
    if not labels or len(runs) < 2 or len(runs) == len(session.runs):
        return None
    return replace(session, runs=runs)


def found_in(effects: Sequence[str]) -> list[str]:
    """Return what of :data:`QUALITY_EXPLAINS` (families, ``smooth:OBS``) is in ``effects``."""
    out = []
    for families in QUALITY_EXPLAINS.values():
        for f in families:
            obs = f.split(":", 1)[1] if f.startswith("smooth:") else None
            if (obs is None and f in effects) or (
                obs is not None and any(e.endswith(f" vs {obs}") for e in effects)
            ):
                out.append(f)
    return out


def _readable(family: str) -> str:
    """``thermal_lag``, or ``generic terms vs OBSERVABLE`` for ``smooth:OBSERVABLE``."""
    if family.startswith("smooth:"):
        return f"generic terms vs {family.split(':', 1)[1]}"
    return family


def check_options(
    families: Sequence[str], max_steps: int, min_improvement: float, alpha: float
) -> None:
    """Raise ParameterError for an unknown family or an option out of its range."""
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        raise ParameterError(f"unknown effect families {unknown}; available: {list(FAMILIES)}")
    if max_steps < 0 or not 0 <= min_improvement < 1 or not 0 < alpha < 1:
        raise ParameterError("max_steps >= 0, 0 <= min_improvement < 1 and 0 < alpha < 1 needed")
