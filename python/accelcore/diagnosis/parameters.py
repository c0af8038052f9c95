"""Final fits of the chosen models and their added parameters in readable units.

:func:`fit_models` fits each axis' chosen terms with
:func:`accelcore.fitting.calibrate.fit_axis` (the core's QR least squares, with
standard errors); :func:`added_parameters` reads off the parameters a family added,
in mg, %, degrees or seconds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from functools import partial
from typing import Any

import numpy as np

from accelcore.fitting.calibrate import fit_axis
from accelcore.fitting.reduced import functions_of, shared
from accelcore.model import (
    AXES,
    Basis,
    Decay,
    Elapsed,
    Extra,
    Hinge,
    LaggedTemperaturePower,
    RunRate,
    RunStep,
    SquaredGravity,
    TemperatureRate,
)
from accelcore.result.calibration import AxisModel, nominal_sensitivity

from .engine import Engine
from .generic import observable_unit
from .search import profile_se, tau_se, with_warm_up
from .space import EVENT_PREFIX, TWO_WAY_LAG, Spec, is_event

__all__ = ["added_parameters", "event_parameters", "fit_models", "variance_inflation"]


def added_parameters(
    eng: Engine,
    models: Mapping[str, AxisModel],
    axes: Sequence[str],
    family: str,
    specs: Mapping[str, Spec],
) -> list[dict[str, Any]]:
    """Return the added parameters with standard errors, in readable units."""
    out: list[dict[str, Any]] = []
    for a in axes:
        m = models[a]
        s = eng.scale[a]
        # Standard errors as the fit gives them take the samples' errors as independent.
        widen = math.sqrt(variance_inflation(eng, a, specs[a]))
        if family in ("thermal_lag", TWO_WAY_LAG):
            spec = specs[a]
            tau = spec.tau if spec.tau is not None else spec.rate_tau
            se_tau = tau_se(eng, a, spec) * widen
            if spec.tau_cool is None:
                out.append({"axis": a, "name": "tau", "value": tau, "se": se_tau, "unit": "s"})
            else:
                # A die lag of one time constant while heating, another while cooling.
                se_cool = tau_se(eng, a, spec, cooling=True) * widen
                out += [
                    {"axis": a, "name": "tau heating", "value": tau, "se": se_tau, "unit": "s"},
                    {
                        "axis": a,
                        "name": "tau cooling",
                        "value": spec.tau_cool,
                        "se": se_cool,
                        "unit": "s",
                    },
                ]
            if spec.rate_tau is not None:
                # offset c·(T_lag - T_ref) beside c1·(T - T_ref): c·(T_lag - T) ≈ -c·tau·dT/dt.
                c, se = m.value("offset", LaggedTemperaturePower(spec.rate_tau, 1))
                k = -spec.rate_tau / 60.0 * 1000.0 / s
                out.append(
                    {
                        "axis": a,
                        "name": "rate coefficient",
                        "value": c * k,
                        "se": abs(se * k) * widen,
                        "unit": "mg per °C/min",
                    }
                )
            continue
        for t, c, var, est in zip(
            m.terms, m.coefficients, np.diag(m.covariance), m.estimated, strict=True
        ):
            if t.effect != (family if not family.startswith("extra:") else "extra"):
                continue
            if family.startswith("extra:") and t.basis.name != family:
                continue
            se = math.sqrt(max(float(var), 0.0)) * widen if est else math.nan
            order = t.basis.temperature_order
            per = _per_unit(t.basis)
            if t.kind == "offset":
                if isinstance(t.basis, (Decay, RunStep)):
                    unit = "mg"  # at the run's start; the size of the step
                elif per is not None:
                    unit = f"mg/{per}"
                elif isinstance(t.basis, Elapsed):
                    unit = "mg/h"
                elif isinstance(t.basis, SquaredGravity):
                    unit = "mg/g²"
                else:
                    unit = f"mg/°C^{order}" if order is not None else "mg/unit"
                factor = 1000.0 / s
            elif t.source == a:
                if isinstance(t.basis, Elapsed):
                    unit = "%/h"
                else:
                    unit = f"%/{per}" if per is not None else f"%/°C^{order or ''}"
                factor = 100.0 / s
            else:
                if per is not None:
                    unit = f"deg/{per}"
                elif isinstance(t.basis, Elapsed):
                    unit = "deg/h"
                else:
                    unit = f"deg/°C^{order}" if order else "deg"
                factor = math.degrees(1.0) / s
            out.append(
                {
                    "axis": a,
                    "name": t.name,
                    "value": float(c) * factor,
                    "se": se * factor,
                    "unit": unit,
                }
            )
            if isinstance(t.basis, Decay):
                tau = t.basis.tau_s
                se_tau = profile_se(eng, a, partial(with_warm_up, specs[a]), tau) * widen
                out.append({"axis": a, "name": "tau", "value": tau, "se": se_tau, "unit": "s"})
    return out


def event_parameters(
    eng: Engine, models: Mapping[str, AxisModel], specs: Mapping[str, Spec]
) -> list[dict[str, Any]]:
    """Return the session events' parameters, one row each.

    A step or a run's level in mg; a run's temperature out of step in mg per °C/min.
    """
    out: list[dict[str, Any]] = []
    for a in AXES:
        m = models[a]
        k = 1000.0 / eng.scale[a]
        widen = math.sqrt(variance_inflation(eng, a, specs[a]))
        for t, c, var, est in zip(
            m.terms, m.coefficients, np.diag(m.covariance), m.estimated, strict=True
        ):
            if is_event(t.effect) and isinstance(t.basis, (RunStep, RunRate)):
                se = math.sqrt(max(float(var), 0.0)) * k * widen if est else math.nan
                out.append(
                    {
                        "event": t.effect[len(EVENT_PREFIX) :],
                        "axis": a,
                        "parameter": t.name,
                        "value": float(c) * k,
                        "se": se,
                        "unit": "mg" if isinstance(t.basis, RunStep) else "mg per °C/min",
                    }
                )
    return out


def _per_unit(basis: Basis) -> str | None:
    """Return the unit a generic term's coefficient is per (None: not such a basis)."""
    if isinstance(basis, Hinge):
        return observable_unit(basis.inner)
    if isinstance(basis, (TemperatureRate, Extra)):
        return observable_unit(basis)
    return None


def fit_models(
    eng: Engine, specs: Mapping[str, Spec], axes: Sequence[str] = AXES
) -> tuple[dict[str, AxisModel], list[str], list[str]]:
    """Fit the chosen terms of ``axes``: the models, the names held fixed, and notes."""
    nominal = nominal_sensitivity(eng.session.units, eng.session.sensor, eng.session.gravity_m_s2)
    models: dict[str, AxisModel] = {}
    fixed_all: list[str] = []
    notes: list[str] = []
    chosen = {a: tuple(specs[a].terms(a)) for a in axes}
    # One QR per stretch of the functions the axes' models use, for the three axes
    # (accelcore.fitting.reduced), kept for the models asked for again.
    used = [t for a in axes for t in chosen[a]]
    reduced = (
        eng.kept("_reduced", functions_of(used), lambda: shared(eng.data, used, eng.references), 8)
        if any((a, chosen[a]) not in eng.fitted for a in axes)
        else None
    )
    for a in axes:
        i = AXES.index(a)
        terms = chosen[a]
        # The selection asks again for models it has fitted (a step's figures, then the
        # final calibration): each is fitted once.
        done = eng.fitted.get((a, terms))
        if done is None:
            done = fit_axis(
                a,
                terms,
                eng.data,
                None if nominal is None else nominal[i],
                eng.references,
                reduced=reduced,
            )
            eng.fitted[(a, terms)] = done
        model, fixed, axis_notes = done
        models[a] = model
        fixed_all += fixed
        notes += axis_notes
    return models, fixed_all, notes


def variance_inflation(eng: Engine, axis: str, spec: Spec) -> float:
    """Return how much the residual's own correlation widens a coefficient's variance (>= 1).

    The fit's covariance takes the samples' errors as independent; what a model leaves
    (a kink where a ramp starts, a slow wave) is not, and a step of a few hundredths of
    a milligram where a soak ends passed as a 9-sigma event. Batch means over the
    engine's blocks (300 s): the mean over blocks of ``n_b · mean_b²`` (``n_b`` the
    block's weight) against the samples' weighted mean square per sample, 1 for white
    noise (a decimated sample of weight ``w``, the raw samples it averages, has the
    variance of one raw sample over ``w``). The reported standard errors of the added
    parameters and of the session events are widened by its square root.
    """
    fit = eng.fit(axis, spec.terms(axis))  # the in-sample fit alone (no fold's)
    y = eng.y[axis]
    r = y - fit.fitted(fit.beta_in) if fit.columns else y
    n_b = np.bincount(eng.sample_block, weights=eng.w)
    s_b = np.bincount(eng.sample_block, weights=eng.w * r)
    keep = n_b > 0
    n = np.count_nonzero(eng.w > 0)
    per_sample = float(np.sum(eng.w * r * r) / n) if n else 0.0
    if not (np.count_nonzero(keep) >= 2 and per_sample > 0):
        return 1.0
    long_run = float(np.mean(s_b[keep] ** 2 / n_b[keep]))
    return max(1.0, long_run / per_sample)
