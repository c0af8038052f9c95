"""The two ends of the diagnosis: where it starts in the model space, what it returns.

:func:`starting_point` reads the base calibration into each axis' point of the
model space (:class:`~accelcore.diagnosis.space.Spec`); :func:`usable_extras` lists
the extra columns to try; :func:`improved_calibration` fits the chosen terms and
returns the calibration of method ``diagnosed``, without the session events
(:func:`without_events`); :func:`engine_beside_checks` sets up the engine beside the
session's data-quality checks.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np

from accelcore.errors import ParameterError
from accelcore.fitting.calibrate import calibrate
from accelcore.input.quality import QualityIssue, check_session
from accelcore.input.session import Session
from accelcore.model import AXES
from accelcore.pools import beside, shared_pool
from accelcore.result.calibration import AxisModel, Calibration

from . import search
from .engine import Engine
from .parameters import fit_models
from .result import Step
from .space import Spec, is_event, spec_from_terms

__all__ = [
    "engine_beside_checks",
    "improved_calibration",
    "starting_point",
    "usable_extras",
    "without_events",
]


def without_events(
    models: Mapping[str, AxisModel], eng: Engine
) -> tuple[dict[str, AxisModel], list[str]]:
    """Drop the session-event terms of each model; say what each was fitted to."""
    out: dict[str, AxisModel] = {}
    notes: list[str] = []
    for a, m in models.items():
        keep = np.array([not is_event(t.effect) for t in m.terms], dtype=bool)
        for t, c in zip(m.terms, m.coefficients, strict=True):
            if is_event(t.effect):
                notes.append(
                    f"{a}: session event {t.effect[len('event: ') :]}, {t.name} = "
                    f"{c * 1000.0 / eng.scale[a]:.4g} mg per unit of the basis; fitted on "
                    "this session only, not carried into the calibration"
                )
        if keep.all():
            out[a] = m
            continue
        out[a] = AxisModel(
            m.axis,
            tuple(t for t, k in zip(m.terms, keep, strict=True) if k),
            m.coefficients[keep],
            m.covariance[np.ix_(keep, keep)],
            m.estimated[keep],
            m.n_samples,
            m.rms_residual,
        )
    return out, notes


def starting_point(
    session: Session,
    calibration: Calibration | None,
    t_ref_c: float,
    window_c: tuple[float, float] | None,
) -> tuple[Calibration, dict[str, Spec], list[str]]:
    """Return the base calibration, each axis' point in the model space, and notes.

    A given calibration outside the model space (or the seed paper's per-pair
    method) is replaced by the joint fit of the seed paper's model, with a note.
    """
    notes: list[str] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if calibration is None:
            base = calibrate(session, t_ref_c=t_ref_c, window_c=window_c)
        else:
            base = calibration
    specs: dict[str, Spec] = {}
    for a in AXES:
        if a not in base.axes:
            raise ParameterError(f"the calibration has no model of axis {a}")
        spec = spec_from_terms(a, base.axes[a].terms) if base.method != "paper" else None
        if spec is None:
            notes.append(
                f"axis {a}: the starting model is outside the diagnosis' model space "
                f"(method {base.method}); started from the seed paper's model, joint fit"
            )
            spec = Spec()
        specs[a] = spec
    if calibration is not None and (
        base.method == "paper" or any(spec_from_terms(a, base.axes[a].terms) is None for a in AXES)
    ):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            win = None if not np.all(np.isfinite(base.window_c)) else base.window_c
            base = calibrate(session, t_ref_c=base.t_ref_c, window_c=win)
    return base, specs, notes


def usable_extras(
    session: Session, eng: Engine, extras: Sequence[str] | None, notes: list[str]
) -> list[str]:
    """Extra columns to try: those asked for (default all) that are present and vary."""
    usable = [
        e
        for e in (session.extra_columns if extras is None else extras)
        if e in eng.extras and float(np.nanstd(eng.extras[e])) > 0
    ]
    if extras is not None:
        missing = [e for e in extras if e not in usable]
        if missing:
            notes.append(f"extra columns not usable (absent or constant): {', '.join(missing)}")
    return usable


def improved_calibration(
    base: Calibration, eng: Engine, specs: Mapping[str, Spec], steps: Sequence[Step]
) -> Calibration:
    """Return the calibration of the chosen terms (core least squares), method ``diagnosed``.

    Session-event terms are fitted with the rest (so that they do not bias it), then
    left out of the calibration, with a note of each.
    """
    models, fixed, fit_notes = fit_models(eng, specs)
    models, event_notes = without_events(models, eng)
    fit_notes = [*fit_notes, *event_notes]
    added = [
        f"{s.effect} on {','.join(s.axes)} ({'; '.join(s.variant.values())})" for s in steps[1:]
    ]
    return Calibration(
        method="diagnosed",
        units=base.units,
        t_ref_c=base.t_ref_c,
        window_c=base.window_c,
        temperature_range_c=(float(eng.temperature.min()), float(eng.temperature.max())),
        axes=models,
        not_identified=tuple(fixed),
        # The final fit finds again what the starting one noted: each note once.
        notes=tuple(
            dict.fromkeys((*base.notes, *fit_notes, *(f"diagnosis added {x}" for x in added)))
        ),
        sensor=base.sensor,
        serial=base.serial,
        references=dict(eng.references),
        options={
            **base.options,
            "method": "diagnosed",
            "diagnosis": {"effects": [s.effect for s in steps[1:]], "scheme": eng.scheme},
        },
        provenance=dict(base.provenance),
    )


def engine_beside_checks(
    session: Session,
    base: Calibration,
    quality: Sequence[QualityIssue] | None,
    **options: Any,
) -> tuple[Engine, Sequence[QualityIssue] | None]:
    """Set up the engine; without ``quality``, run the data-quality checks beside it.

    The checks read the session only: on a pool thread, beside the engine's set-up
    (both spend most of their time in the core and NumPy), with the interpreter's
    short switch interval (:func:`accelcore.pools.beside`).
    """
    threads = search.search_threads or os.cpu_count() or 1
    if quality is not None:
        return Engine(session, base, threads=threads, **options), quality
    window: tuple[float, float] | Literal["logged"] = (
        base.window_c if all(map(math.isfinite, base.window_c)) else "logged"
    )
    with beside():
        pool = shared_pool("accelcore-quality", 1)
        checked = pool.submit(check_session, session, window_c=window, warn=False)
        return Engine(session, base, threads=threads, **options), checked.result()
