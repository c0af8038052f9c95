"""What a diagnosis tries: its options checked, the families a quality finding rules out."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from accelcore.errors import ParameterError
from accelcore.input.quality import QualityIssue

from .space import FAMILIES

__all__ = ["QUALITY_EXPLAINS", "check_options", "explained", "not_explained_by"]

#: Effect families each kind of data-quality finding
#: (:func:`accelcore.input.quality.check_session`) could explain, and so are not
#: tried when it is found: a run cut short holds only the start of the sweep, its lag
#: state and temperature path unlike the other runs', so a lag fitted across the runs
#: may only mirror the cut.
QUALITY_EXPLAINS: Mapping[str, tuple[str, ...]] = {
    "short": ("thermal_lag", "smooth:dtemp_dt_c_per_min", "smooth:elapsed_h")
}


def explained(quality: Sequence[QualityIssue]) -> list[str]:
    """Families (and ``smooth:OBSERVABLE``) that the session's findings could explain."""
    kinds = {i.kind for i in quality}
    return [f for kind, fams in QUALITY_EXPLAINS.items() if kind in kinds for f in fams]


def not_explained_by(
    families: Sequence[str], quality: Sequence[QualityIssue]
) -> tuple[list[str], list[str]]:
    """Drop the families a quality finding could explain; one warning per finding kind."""
    kept = list(families)
    notes = []
    for kind, explained in QUALITY_EXPLAINS.items():
        found = [i for i in quality if i.kind == kind]
        if not found:
            continue
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
        runs = sorted({i.run for i in found if i.run})
        where = f" ({', '.join(runs)})" if runs else ""
        notes.append(
            f"data-quality finding '{kind}'{where} could explain {', '.join(dropped)}: "
            "not tried (fix the data, or diagnose with quality=[] to try it anyway)"
        )
    return kept, notes


def check_options(
    families: Sequence[str], max_steps: int, min_improvement: float, alpha: float
) -> None:
    """Raise ParameterError for an unknown family or an option out of its range."""
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        raise ParameterError(f"unknown effect families {unknown}; available: {list(FAMILIES)}")
    if max_steps < 0 or not 0 <= min_improvement < 1 or not 0 < alpha < 1:
        raise ParameterError("max_steps >= 0, 0 <= min_improvement < 1 and 0 < alpha < 1 needed")
