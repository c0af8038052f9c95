"""``calibrate``: fit zero-g offset and sensitivity against temperature.

Two methods, one result type (:class:`accelcore.result.calibration.Calibration`):

``method="paper"``
    Sawicki & Walendziuk: decimate 20 Hz to 2 Hz, bin by temperature (0.5 °C
    bins over the window: the paper's 0–60 °C when it is passed, by default
    the logged range on the same grid of multiples of the bin width), per bin
    ``V0g = (V+ + V-)/2`` and ``S = (V+ - V-)/2`` from the axis' two
    orientations (equations 8–10), then a line fit of each against temperature.
``method="joint"`` (default)
    One weighted least-squares fit per axis over every decimated sample of
    every run, with the gravity each orientation implies on that axis
    (including the 0 g axes, which pin the offset down too). It uses every
    sample rather than bin means of paired runs, needs no pairing (so one
    orientation still calibrates what it identifies), and takes any list of
    model terms (:mod:`accelcore.model`), which is how the diagnosis adds effects.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from accelcore import core
from accelcore._accelcore import MAX_TEMPERATURE_C, MIN_TEMPERATURE_C, __version__
from accelcore.constants import MIN_TEMPERATURE_SPAN_C
from accelcore.errors import (
    DataQualityWarning,
    InsufficientDataError,
    ParameterError,
    SingularSystemError,
)
from accelcore.fitting.plausibility import implausible_sensitivities
from accelcore.fitting.reduced import Reduced, functions_of, shared
from accelcore.fitting.spans import session_temperature_span_c, thin_temperature_terms
from accelcore.fitting.stacking import CutFeatures, Stacked, block_weights, stack_session
from accelcore.input.session import Session
from accelcore.model import (
    AXES,
    Constant,
    TemperaturePower,
    Term,
    base_terms,
    full_gain_terms,
)
from accelcore.result.calibration import AxisModel, Calibration, nominal_sensitivity
from accelcore.result.compensator import needs_temperature

__all__ = ["CutFeatures", "Stacked", "block_weights", "calibrate", "fit_axis", "stack_session"]


def fit_axis(
    axis: str,
    terms: Sequence[Term],
    data: Stacked,
    nominal: float | None,
    references: Mapping[str, float],
    rows: Sequence[int] | None = None,
    reduced: Reduced | None = None,
) -> tuple[AxisModel, list[str], list[str]]:
    """Weighted least squares of one axis; fix what the data cannot identify.

    ``reduced``: the stretches already reduced to functions that cover ``terms``
    (:mod:`accelcore.fitting.reduced`; shared by the axes of one fit), else reduced
    here. Returns the model, the names of terms held fixed, and notes.
    """
    a = AXES.index(axis)
    parts = range(len(data.features)) if rows is None else rows
    if reduced is None or not reduced.covers(terms):
        reduced = Reduced.of(data, functions_of(terms), references)
    maps = {i: reduced.map(terms, data.gravity[i]) for i in parts}
    p = len(terms)
    fixed = np.zeros(p)
    estimated = np.ones(p, dtype=bool)
    fixed_names: list[str] = []
    notes: list[str] = []
    names = [f"{axis}:{_public_name(t, axis)}" for t in terms]
    # Drop all-zero columns first (e.g. the sensitivity of an axis that never saw gravity):
    # a column is its stretch's constant times one function, so sum w x² is exact from
    # the functions' sums of squares (only compared with 0).
    col_ss = sum((np.square(maps[i]) * reduced.sum_squares[i][:, None]).sum(axis=0) for i in parts)
    n_used = sum(int(np.count_nonzero(data.weight[i] > 0)) for i in parts)
    for j, span, span_all in thin_temperature_terms(axis, terms, data, parts):
        estimated[j] = False
        notes.append(
            f"{axis}: {_public_name(terms[j], axis)} not identified: the samples that carry it "
            f"span {span:.3g} °C of the {span_all:.3g} °C fitted; held at 0 (log the "
            "orientations of this axis over the whole sweep)"
        )
    while True:
        for j in range(p):
            if estimated[j] and col_ss[j] == 0.0:
                estimated[j] = False
        cols = np.flatnonzero(estimated)
        if cols.size == 0:
            raise InsufficientDataError(f"axis {axis}: no term of the model is identified")
        if n_used <= cols.size:
            raise InsufficientDataError(
                f"axis {axis}: {n_used} decimated sample(s) for {cols.size} model terms; a fit "
                "needs more samples than terms (log longer sweeps, or check rate_hz)"
            )
        lsq = _pushed(reduced, maps, a, estimated, fixed, [names[j] for j in cols])
        try:
            sol = lsq.finish()
            break
        except SingularSystemError as exc:
            for name in exc.columns:
                estimated[names.index(name)] = False
    for j in range(p):
        if estimated[j]:
            continue
        t = terms[j]
        if t.kind == "gain" and t.source not in (None, axis) and t.basis == Constant():
            if col_ss[j] > 0:
                # Held for want of the opposite run: the offset and sensitivity are then
                # fitted with it at 0, which is a choice, not a measurement.
                src = str(t.source).upper()
                notes.append(
                    f"{axis}: {_public_name(t, axis)} held at 0 (these orientations cannot "
                    f"tell it from {axis}'s offset and sensitivity), and those are fitted "
                    f"with it at 0: what {axis} reads in the runs at ±1 g on {t.source} (a "
                    f"tilt of them) is taken as its offset; log O{src}+ and O{src}- to "
                    "tell them apart"
                )
        if t.kind == "gain" and t.source == axis and t.basis == Constant():
            if nominal is None:
                raise InsufficientDataError(
                    f"axis {axis}: offset and sensitivity cannot be told apart with these "
                    "orientations and no nominal sensitivity is known; log the opposite "
                    f"orientation (O{axis.upper()}+ and O{axis.upper()}-) or name the sensor"
                )
            fixed[j] = nominal
            notes.append(
                f"{axis}: sensitivity held at nominal {nominal:g} (not identified by "
                "these orientations); the fitted offset absorbs the rest"
            )
        fixed_names.append(names[j])
        if t.kind == "gain" and t.source == axis and col_ss[j] > 0:
            # The axis saw gravity, but one value of it only: this gain term is
            # collinear with the offset term of the same basis, which then carries
            # their sum. Say so rather than report it as the offset.
            twin = next(
                (k for k, u in enumerate(terms) if u.kind == "offset" and u.basis == t.basis),
                None,
            )
            if twin is not None and estimated[twin]:
                fixed_names.append(names[twin])
                notes.append(
                    f"{axis}: {_public_name(terms[twin], axis)} is identified only combined "
                    f"with {_public_name(t, axis)} (one orientation of this axis); compensation "
                    "of that orientation is right, the separate value is not"
                )
    # Refit if a nominal was introduced after the loop (response changed).
    if np.any(fixed != 0):
        cols = np.flatnonzero(estimated)
        sol = _pushed(reduced, maps, a, estimated, fixed, [names[j] for j in cols]).finish()
    coefficients = fixed.copy()
    coefficients[estimated] = sol.coefficients
    covariance = np.zeros((p, p))
    cols = np.flatnonzero(estimated)
    covariance[np.ix_(cols, cols)] = sol.covariance
    weight_total = sum(float(data.weight[i].sum()) for i in parts)
    rms = math.sqrt(sol.residual_sum_squares / weight_total)
    n_samples = sum(len(data.features[i]) for i in parts)
    model = AxisModel(axis, tuple(terms), coefficients, covariance, estimated, n_samples, rms)
    return model, fixed_names, notes


def _pushed(
    reduced: Reduced,
    maps: Mapping[int, NDArray[np.float64]],
    response: int,
    estimated: NDArray[np.bool_],
    fixed: NDArray[np.float64],
    names: list[str],
) -> core.LeastSquares:
    """Return the least squares of the estimated columns, the fixed ones' part taken out.

    Each stretch's factor pushed through its map (``push_mapped``): its estimated
    columns, and the fixed columns times their values as a shift of the response.
    """
    lsq = core.LeastSquares(int(np.count_nonzero(estimated)), column_names=names)
    some_fixed = not estimated.all()
    for i, m in maps.items():
        shift = (m[:, ~estimated] @ fixed[~estimated])[:, None] if some_fixed else None
        lsq.push_mapped(reduced.factors[i], m[:, estimated], [response], shift)
    return lsq


def _public_name(term: Term, axis: str) -> str:
    if term.kind == "offset":
        names = {Constant(): "offset", TemperaturePower(1): "offset_tc"}
    elif term.source == axis:
        names = {Constant(): "sensitivity", TemperaturePower(1): "sensitivity_tc"}
    else:
        return term.name
    return names.get(term.basis, term.name)


def _extra_references(session: Session, terms: Mapping[str, Sequence[Term]]) -> dict[str, float]:
    refs: dict[str, float] = {}
    for ts in terms.values():
        for t in ts:
            name = t.basis.column
            if name is not None and t.basis.name not in refs:
                values = np.concatenate([r.extras[name] for r in session.runs if name in r.extras])
                refs[t.basis.name] = float(np.median(values))
    return refs


def _fit_joint(
    session: Session,
    terms: Mapping[str, Sequence[Term]],
    t_ref_c: float,
    window_c: tuple[float, float] | None,
    references: Mapping[str, float] | None = None,
    runs: Sequence[int] | None = None,
    robust: bool = True,
) -> tuple[dict[str, AxisModel], list[str], list[str], tuple[float, float], dict[str, float]]:
    data = stack_session(session, t_ref_c, window_c, runs, robust)
    nominal = nominal_sensitivity(session.units, session.sensor, session.gravity_m_s2)
    refs = dict(references) if references is not None else _extra_references(session, terms)
    axes: dict[str, AxisModel] = {}
    not_identified: list[str] = []
    notes: list[str] = list(data.notes)
    # One QR per stretch for the three axes.
    reduced = shared(data, [t for a in AXES for t in terms[a]], refs)
    for i, a in enumerate(AXES):
        model, fixed, axis_notes = fit_axis(
            a, terms[a], data, None if nominal is None else nominal[i], refs, reduced=reduced
        )
        axes[a] = model
        not_identified += fixed
        notes += axis_notes
    return axes, not_identified, notes, data.temperature_range_c, refs


def _fit_paper(
    session: Session,
    t_ref_c: float,
    window_c: tuple[float, float],
    bin_width_c: float,
    robust: bool = True,
) -> tuple[dict[str, AxisModel], list[str], list[str], tuple[float, float]]:
    """Equations 8–10 per temperature bin, then line fits (the seed paper's method)."""
    binners: dict[str, core.TemperatureBinner] = {}
    excluded: list[str] = []
    for run in session.runs:
        b = core.TemperatureBinner(
            lo_c=window_c[0], hi_c=window_c[1], width_c=bin_width_c, n_channels=3
        )
        weight, note = block_weights(run, robust)
        if note:
            excluded.append(note)
        use = weight > 0
        if use.all():
            b.push(run.time_s, run.temperature_c, run.output)
        else:
            # Row selection by index: boolean indexing of a 2-D array is several times slower.
            rows = np.flatnonzero(use)
            b.push(run.time_s[rows], run.temperature_c[rows], run.output.take(rows, axis=0))
        if run.orientation in binners:
            binners[run.orientation].merge(b)  # repeat sweeps of one orientation
        else:
            binners[run.orientation] = b
    stats = {o: b.finish() for o, b in binners.items()}
    axes: dict[str, AxisModel] = {}
    not_identified: list[str] = []
    notes: list[str] = excluded
    t_lo, t_hi = math.inf, -math.inf
    for i, a in enumerate(AXES):
        plus, minus = stats.get(f"O{a.upper()}+"), stats.get(f"O{a.upper()}-")
        terms = base_terms(a)
        if plus is None or minus is None:
            not_identified += [
                f"{a}:offset",
                f"{a}:offset_tc",
                f"{a}:sensitivity",
                f"{a}:sensitivity_tc",
            ]
            notes.append(
                f"{a}: the paper's method needs both O{a.upper()}+ and "
                f"O{a.upper()}- runs; use method='joint' for partial sessions"
            )
            axes[a] = AxisModel(
                a,
                terms,
                np.full(4, np.nan),
                np.full((4, 4), np.nan),
                np.zeros(4, dtype=bool),
                0,
                math.nan,
            )
            continue
        both = (plus.count > 0) & (minus.count > 0)
        if np.count_nonzero(both) < 3:
            raise InsufficientDataError(
                f"axis {a}: only {np.count_nonzero(both)} temperature bins hold both "
                f"O{a.upper()}+ and O{a.upper()}- data; need at least 3 (log sweeps that "
                f"overlap in {window_c[0]}…{window_c[1]} °C)"
            )
        v_pos, v_neg = plus.mean[both, i], minus.mean[both, i]
        temp = 0.5 * (plus.temperature_c[both] + minus.temperature_c[both])
        zero_g = 0.5 * (v_pos + v_neg)  # equation (8)
        sens = 0.5 * (v_pos - v_neg)  # equations (9)-(10) with g = ±1
        design = np.column_stack([np.ones_like(temp), temp - t_ref_c])
        coefficients = np.zeros(4)
        covariance = np.zeros((4, 4))
        rss = 0.0
        for k, y in ((0, zero_g), (2, sens)):
            lsq = core.LeastSquares(2, column_names=["value_at_t_ref", "slope_per_c"])
            lsq.push(design, y)
            sol = lsq.finish()
            coefficients[k : k + 2] = sol.coefficients
            covariance[k : k + 2, k : k + 2] = sol.covariance
            rss += sol.residual_sum_squares
        axes[a] = AxisModel(
            a,
            terms,
            coefficients,
            covariance,
            np.ones(4, dtype=bool),
            int(np.count_nonzero(both)),
            math.sqrt(rss / (2 * both.sum())),
        )
        t_lo, t_hi = min(t_lo, float(temp.min())), max(t_hi, float(temp.max()))
    if math.isinf(t_lo):
        raise InsufficientDataError(
            "the paper's method needs, for at least one axis, both of its orientations "
            f"(runs here: {', '.join(session.orientations)}); use method='joint'"
        )
    return axes, not_identified, notes, (t_lo, t_hi)


def _logged_bins(session: Session, width_c: float) -> tuple[float, float]:
    """Whole bins of ``width_c`` on the grid of its multiples that hold every logged temperature."""
    ranges = []
    for r in session.runs:
        t = r.temperature_c
        if t.size:
            # Both finite: so is every value (a NaN makes min NaN), none to leave out.
            lo, hi = float(t.min()), float(t.max())
            if not (math.isfinite(lo) and math.isfinite(hi)):
                t = t[np.isfinite(t)]
                lo, hi = (float(t.min()), float(t.max())) if t.size else (math.nan, math.nan)
            if t.size:
                ranges.append((lo, hi))
    if not ranges:
        raise InsufficientDataError(
            "the paper's method bins by temperature, and no run logged one; use method='joint'"
        )
    lo = min(r[0] for r in ranges)
    hi = max(r[1] for r in ranges)
    # Bins are [lo, hi): the top edge lies a whole bin above the warmest sample's bin.
    return math.floor(lo / width_c) * width_c, (math.floor(hi / width_c) + 1) * width_c


def _parameter(name: str, text: str) -> ParameterError:
    err = ParameterError(f"{name} {text}")
    err.parameter = name
    return err


def _finite(value: object) -> bool:
    return (
        isinstance(value, (int, float, np.integer, np.floating))
        and not isinstance(value, bool)
        and math.isfinite(float(value))
    )


def _check_options(
    t_ref_c: object, window_c: tuple[float, float] | None, bin_width_c: object
) -> None:
    """Argument errors before any data is touched, named after the argument."""
    # 1e308 °C gave a design of inf (T - t_ref), named as the data's fault.
    if not _finite(t_ref_c) or not MIN_TEMPERATURE_C <= float(t_ref_c) <= MAX_TEMPERATURE_C:  # type: ignore[arg-type]
        raise _parameter(
            "t_ref_c",
            f"must be a temperature in °C ({MIN_TEMPERATURE_C:g} to {MAX_TEMPERATURE_C:g}), "
            f"got {t_ref_c!r}",
        )
    if window_c is not None:
        if len(window_c) != 2 or not all(_finite(v) for v in window_c):
            raise _parameter("window_c", f"must be two finite temperatures, got {window_c!r}")
        if not window_c[0] < window_c[1]:
            raise _parameter(
                "window_c", f"must be (low, high) with low < high, got {tuple(window_c)!r}"
            )
    if not _finite(bin_width_c) or not float(bin_width_c) > 0:  # type: ignore[arg-type]
        raise _parameter("bin_width_c", f"must be a positive number, got {bin_width_c!r}")


def calibrate(
    session: Session,
    method: Literal["joint", "paper"] = "joint",
    *,
    t_ref_c: float = 25.0,
    window_c: tuple[float, float] | None = None,
    bin_width_c: float = 0.5,
    terms: Mapping[str, Sequence[Term]] | None = None,
    robust: bool = True,
) -> Calibration:
    """Calibrate zero-g offset and sensitivity against temperature.

    Parameters
    ----------
    session : Session
        From :func:`accelcore.load_session` or :meth:`Session.from_arrays`.
    method : {"joint", "paper"}, default "joint"
        See the module docs.
    t_ref_c : float, default 25.0
        Reference temperature of the reported offset and sensitivity, °C.
    window_c : (float, float) or None, default None
        Only samples with logged temperature in this window are used; None
        (the default): every sample, the whole logged range. The seed paper
        used 0–60 °C, away from its chamber's unstable ends: pass
        ``window_c=(0.0, 60.0)`` to reproduce it. The paper's method bins the
        window, or without one the logged range, in ``bin_width_c`` bins on
        the grid of multiples of ``bin_width_c``.
    bin_width_c : float, default 0.5
        Temperature bin width of the paper's method, °C.
    terms : mapping of axis to sequence of Term, optional
        Model terms of the joint fit; default :func:`accelcore.model.full_gain_terms`
        (offset and sensitivity linear in T, and the cross-axis gain: the full 3x3
        gain where the orientations identify it, the rest in ``not_identified``).
    robust : bool, default True
        Leave out decimated blocks that are spikes or clipped at a rail
        (:func:`accelcore.input.quality.excluded_blocks`); what was left out is listed in
        :attr:`Calibration.notes`. Clean data loses nothing.

    Returns
    -------
    Calibration

    Raises
    ------
    accelcore.InsufficientDataError
        No data in the window, too few bins, fewer samples than terms, or
        nothing identifiable; the message says what data would fix it.
    accelcore.ParameterError
        ``t_ref_c`` not finite, ``window_c`` reversed or not finite,
        ``bin_width_c`` not positive.
    accelcore.SessionFormatError
        The runs contradict their orientation labels, the units or the rate
        (:meth:`Session.check_orientations`).
    """
    if method not in ("joint", "paper"):
        raise ParameterError(f"method must be 'joint' or 'paper', got {method!r}")
    _check_options(t_ref_c, window_c, bin_width_c)
    session.check_orientations()
    options: dict[str, Any] = {
        "method": method,
        "t_ref_c": t_ref_c,
        "window_c": None if window_c is None else list(window_c),
        "bin_width_c": bin_width_c,
        "decimation_factor": session.decimation_factor,
        "robust": robust,
        "gravity_m_s2": session.gravity_m_s2,
    }
    refs: dict[str, float] = {}
    if not session.has_temperature:
        if method == "paper":
            raise InsufficientDataError(
                "no temperature logged: the paper's method bins by temperature; use "
                "method='joint' (a calibration at one temperature)"
            )
        if window_c is not None:
            raise _parameter("window_c", "cannot apply: the session logged no temperature")
    if method == "paper":
        if terms is not None:
            raise ParameterError("terms= applies to method='joint' only")
        axes, not_identified, notes, t_range = _fit_paper(
            session, t_ref_c, window_c or _logged_bins(session, bin_width_c), bin_width_c, robust
        )
    else:
        model_terms = {
            a: tuple(terms[a]) if terms and a in terms else full_gain_terms(a) for a in AXES
        }
        # A calibration at one temperature: none logged, or (by default) one that does
        # not move; the model's temperature terms are left out and said so.
        at_one = ""
        if not session.has_temperature:
            at_one = (
                "no temperature logged: calibration at one temperature (offset, sensitivity "
                "and cross-axis gain; no temperature terms, T_ref does not apply)"
            )
        elif terms is None and (span := session_temperature_span_c(session)) < (
            MIN_TEMPERATURE_SPAN_C
        ):
            at_one = (
                f"the temperature spans {span:.2f} °C (5th to 95th percentile), less than "
                f"{MIN_TEMPERATURE_SPAN_C:g} °C: calibration at one temperature, no "
                "temperature terms (over so little, a temperature coefficient takes any "
                "difference between runs, a re-placement or a slow settling, for "
                "temperature, and extrapolates it; pass terms= to fit them anyway)"
            )
        dropped = [
            f"{a}:{_public_name(t, a)}"
            for a in AXES
            for t in model_terms[a]
            if at_one and needs_temperature(t.basis)
        ]
        if dropped:
            model_terms = {
                a: tuple(t for t in ts if not needs_temperature(t.basis))
                for a, ts in model_terms.items()
            }
        axes, not_identified, notes, t_range, refs = _fit_joint(
            session, model_terms, t_ref_c, window_c, robust=robust
        )
        if dropped:
            not_identified = [*dropped, *not_identified]
            notes = [at_one, *notes]
    lo, hi = t_range
    # T_ref is where a model with temperature terms reports its offset and sensitivity.
    reads_t = any(needs_temperature(t.basis) for m in axes.values() for t in m.terms)
    if reads_t and math.isfinite(lo) and not lo <= t_ref_c <= hi:
        away = lo - t_ref_c if t_ref_c < lo else t_ref_c - hi
        notes = [
            *notes,
            f"T_ref {t_ref_c:g} °C lies {away:.1f} °C outside the fitted range "
            f"{lo:.1f}…{hi:.1f} °C: the offset and sensitivity at T_ref are extrapolated "
            "(pass t_ref_c inside the data to report them where they were measured)",
        ]
    # A sensitivity the runs' own levels contradict: said, as a warning and a note.
    implausible = implausible_sensitivities(session.runs, axes, session.units)
    for line in implausible:
        warnings.warn(f"{session.path or 'session'}: {line}", DataQualityWarning, stacklevel=2)
    notes = [*notes, *implausible]
    provenance: dict[str, Any] = {
        "accelcore_version": __version__,
        "session_path": session.path,
        "digest": session.digest,
        f"files_{session.digest}": session.file_hashes(),
    }
    if session.format is not None and session.format.lab:
        provenance["lab"] = dict(session.format.lab)
    if session.log_sensor:
        provenance["log_sensor"] = dict(session.log_sensor)
    return Calibration(
        method=method,
        units=session.units,
        t_ref_c=float(t_ref_c),
        window_c=(-math.inf, math.inf)
        if window_c is None
        else (float(window_c[0]), float(window_c[1])),
        temperature_range_c=t_range,
        axes=axes,
        not_identified=tuple(not_identified),
        notes=tuple(notes),
        sensor=session.sensor,
        serial=session.serial,
        references=refs,
        options=options,
        provenance=provenance,
    )
