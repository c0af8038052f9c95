"""Thermal calibration: fit zero-g offset and sensitivity against temperature.

Two methods, one result type (:class:`Calibration`):

``method="paper"``
    Sawicki & Walendziuk: decimate 20 Hz to 2 Hz, bin by temperature (0.5 °C
    over 0–60 °C), per bin ``V0g = (V+ + V-)/2`` and ``S = (V+ - V-)/2`` from the
    axis' two orientations (equations 8–10), then a line fit of each against
    temperature.
``method="joint"`` (default)
    One weighted least-squares fit per axis over every decimated sample of
    every run, with the gravity each orientation implies on that axis
    (including the 0 g axes, which pin the offset down too). It uses every
    sample rather than bin means of paired runs, needs no pairing (so one
    orientation still calibrates what it identifies), and takes any list of
    model terms (:mod:`accelcore.model`), which is how the diagnosis adds effects.

What the data cannot identify is said, never invented: with one orientation
the vertical axis' offset and sensitivity cannot be told apart, so its
sensitivity is held at its nominal value (datasheet typical, or exactly 1 g/g
for sessions already in g) and reported in :attr:`Calibration.not_identified`.
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from accelcore import core
from accelcore._accelcore import __version__, first_order_lag
from accelcore._accelcore import compensate as _compensate
from accelcore.errors import (
    AccelcoreIOError,
    CalibrationFileError,
    InsufficientDataError,
    ParameterError,
    SingularSystemError,
    TemperatureRangeWarning,
)
from accelcore.model import AXES, Features, Term, base_terms, design_columns, evaluate_basis
from accelcore.session import Run, Session

__all__ = [
    "CALIBRATION_FORMAT",
    "AxisModel",
    "Calibration",
    "Compensator",
    "calibrate",
    "nominal_sensitivity",
]

CALIBRATION_FORMAT = "accelcore-calibration/1"
STANDARD_GRAVITY = 9.80665


def nominal_sensitivity(units: str, sensor: str | None) -> tuple[float, float, float] | None:
    """Nominal sensitivity per axis in ``units``/g, or None when unknown.

    ``g`` gives 1, ``m/s2`` gives 9.80665 (standard gravity); ``V`` and ``LSB``
    take the datasheet typical of ``sensor``.
    """
    if units == "g":
        return (1.0, 1.0, 1.0)
    if units == "m/s2":
        return (STANDARD_GRAVITY,) * 3
    if sensor:
        from accelcore import datasheets

        try:
            sheet = datasheets.load(sensor)
        except (KeyError, ValueError):
            return None
        typ = sheet.typical("sensitivity")
        if all(t is not None for t in typ):
            return (float(typ[0]), float(typ[1]), float(typ[2]))  # type: ignore[arg-type]
    return None


@dataclass(frozen=True)
class AxisModel:
    """The fitted model of one axis.

    Attributes
    ----------
    axis : str
    terms : tuple of Term
    coefficients : ndarray
        One per term, in session units (offset terms) or units per g (gain terms),
        per unit of the term's basis.
    covariance : ndarray, shape (p, p)
        Of the coefficients; rows and columns of fixed terms are zero.
    estimated : ndarray of bool
        False for a term held fixed because the data cannot identify it.
    n_samples : int
        Decimated samples the fit used.
    rms_residual : float
        Weighted RMS residual in session units.
    """

    axis: str
    terms: tuple[Term, ...]
    coefficients: NDArray[np.float64]
    covariance: NDArray[np.float64]
    estimated: NDArray[np.bool_]
    n_samples: int
    rms_residual: float

    def index(self, kind: str, basis: str, source: str | None = None) -> int | None:
        """Position of a term, or None.

        A ``dT^k`` basis that the model only has through a thermal lag
        (``lag(tau):dT^k``, added by the diagnosis) matches that term.
        """
        for i, t in enumerate(self.terms):
            if t.kind == kind and t.basis == basis and (kind == "offset" or t.source == source):
                return i
        if basis.startswith("dT^"):
            for i, t in enumerate(self.terms):
                if (
                    t.kind == kind
                    and t.basis.startswith("lag(")
                    and t.basis.endswith(f"):{basis}")
                    and (kind == "offset" or t.source == source)
                ):
                    return i
        return None

    def value(self, kind: str, basis: str, source: str | None = None) -> tuple[float, float]:
        """Coefficient and its standard error (0 for a fixed term, 0 and 0 if absent)."""
        i = self.index(kind, basis, source)
        if i is None:
            return 0.0, 0.0
        return float(self.coefficients[i]), float(math.sqrt(max(self.covariance[i, i], 0.0)))

    def _cov(self, i: int | None, j: int | None) -> float:
        return 0.0 if i is None or j is None else float(self.covariance[i, j])

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form for JSON."""
        return {
            "terms": [t.to_dict() for t in self.terms],
            "coefficients": [float(c) for c in self.coefficients],
            "covariance": [[float(v) for v in row] for row in self.covariance],
            "estimated": [bool(e) for e in self.estimated],
            "n_samples": int(self.n_samples),
            "rms_residual": float(self.rms_residual),
        }

    @classmethod
    def from_dict(cls, axis: str, data: Mapping[str, Any]) -> AxisModel:
        """Inverse of :meth:`to_dict`."""
        terms = tuple(Term.from_dict(t) for t in data["terms"])
        coefficients = np.asarray(data["coefficients"], dtype=np.float64)
        covariance = np.asarray(data["covariance"], dtype=np.float64).reshape(
            len(terms), len(terms)
        )
        estimated = np.asarray(data["estimated"], dtype=bool)
        if coefficients.shape != (len(terms),) or estimated.shape != (len(terms),):
            raise CalibrationFileError(f"axis {axis}: terms and coefficients differ in number")
        return cls(
            axis,
            terms,
            coefficients,
            covariance,
            estimated,
            int(data["n_samples"]),
            float(data["rms_residual"]),
        )


@dataclass(frozen=True)
class AxisSummary:
    """The seed paper's four parameters of one axis at ``t_ref_c``, with standard errors."""

    axis: str
    zero_g_offset: float
    zero_g_offset_se: float
    sensitivity: float
    sensitivity_se: float
    offset_tc_mg_per_c: float
    offset_tc_mg_per_c_se: float
    sensitivity_tc_pct_per_c: float
    sensitivity_tc_pct_per_c_se: float


def _ratio_se(num: float, var_num: float, den: float, var_den: float, cov: float) -> float:
    """Return the standard error of num/den by the delta method."""
    if den == 0:
        return math.nan
    r = num / den
    var = (var_num - 2 * r * cov + r * r * var_den) / (den * den)
    return math.sqrt(max(var, 0.0))


@dataclass(frozen=True)
class Calibration:
    """A thermal calibration of one three-axis accelerometer.

    Build one with :func:`calibrate`; read one with :meth:`load`. Per axis it
    holds a list of named terms and their coefficients (:class:`AxisModel`);
    the seed paper's parameters come from :meth:`axis` and :meth:`summary`.

    Attributes
    ----------
    method : str
        ``"joint"`` or ``"paper"`` (or ``"diagnosed"`` after :func:`accelcore.diagnose`).
    units : str
        Session units of the raw output.
    t_ref_c : float
        Reference temperature of offset and sensitivity, °C.
    window_c : tuple of float
        Temperature window the data was taken from, °C.
    temperature_range_c : tuple of float
        Range of temperatures actually fitted, °C; compensation outside it warns.
    axes : dict of str to AxisModel
    not_identified : tuple of str
        Terms the data could not identify, held at nominal (sensitivity) or 0.
    notes : tuple of str
        What was assumed and why.
    sensor, serial : str or None
    references : dict
        Reference value of every ``extra:NAME`` basis.
    options : dict
        Every option used, for reproducibility.
    provenance : dict
        accelcore version and SHA-256 of the input files.
    """

    method: str
    units: str
    t_ref_c: float
    window_c: tuple[float, float]
    temperature_range_c: tuple[float, float]
    axes: dict[str, AxisModel]
    not_identified: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    sensor: str | None = None
    serial: str | None = None
    references: dict[str, float] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------------ parameters
    def axis(self, axis: str) -> AxisSummary:
        """Zero-g offset, sensitivity and their temperature coefficients of one axis.

        Offset is in session units and sensitivity in units per g, both at
        ``t_ref_c``; the offset coefficient is in mg/°C (offset slope divided by
        the sensitivity), the sensitivity coefficient in %/°C of the sensitivity
        at ``t_ref_c``. Standard errors come from the fit's covariance (delta
        method for the ratios).
        """
        m = self.axes[axis]
        o0, o0_se = m.value("offset", "1")
        o1, _ = m.value("offset", "dT^1")
        s0, s0_se = m.value("gain", "1", axis)
        s1, _ = m.value("gain", "dT^1", axis)
        i_o1, i_s0 = m.index("offset", "dT^1"), m.index("gain", "1", axis)
        i_s1 = m.index("gain", "dT^1", axis)
        var_s0 = m._cov(i_s0, i_s0)
        offset_tc = 1000.0 * o1 / s0 if s0 else math.nan
        offset_tc_se = 1000.0 * _ratio_se(o1, m._cov(i_o1, i_o1), s0, var_s0, m._cov(i_o1, i_s0))
        sens_tc = 100.0 * s1 / s0 if s0 else math.nan
        sens_tc_se = 100.0 * _ratio_se(s1, m._cov(i_s1, i_s1), s0, var_s0, m._cov(i_s1, i_s0))
        return AxisSummary(axis, o0, o0_se, s0, s0_se, offset_tc, offset_tc_se, sens_tc, sens_tc_se)

    def summary(self) -> pd.DataFrame:
        """One row per axis: the four parameters with standard errors and the fit's RMS in mg."""
        rows = []
        for a in self.axes:
            s = self.axis(a)
            m = self.axes[a]
            rows.append(
                {
                    "axis": a,
                    f"zero_g_offset_{self.units}": s.zero_g_offset,
                    "zero_g_offset_se": s.zero_g_offset_se,
                    f"sensitivity_{self.units}_per_g": s.sensitivity,
                    "sensitivity_se": s.sensitivity_se,
                    "offset_tc_mg_per_c": s.offset_tc_mg_per_c,
                    "offset_tc_mg_per_c_se": s.offset_tc_mg_per_c_se,
                    "sensitivity_tc_pct_per_c": s.sensitivity_tc_pct_per_c,
                    "sensitivity_tc_pct_per_c_se": s.sensitivity_tc_pct_per_c_se,
                    "rms_residual_mg": 1000.0 * m.rms_residual / s.sensitivity
                    if s.sensitivity
                    else math.nan,
                    "n_samples": m.n_samples,
                }
            )
        return pd.DataFrame(rows).set_index("axis")

    def __str__(self) -> str:
        head = (
            f"Calibration ({self.method}) of {self.sensor or 'unknown sensor'}"
            f"{' #' + self.serial if self.serial else ''}, units {self.units}, "
            f"T_ref {self.t_ref_c:g} °C, fitted over {self.temperature_range_c[0]:.1f}"
            f"…{self.temperature_range_c[1]:.1f} °C"
        )
        lines = [head, self.summary().to_string(float_format=lambda v: f"{v:.6g}")]
        lines += (
            [f"not identified: {', '.join(self.not_identified)}"] if self.not_identified else []
        )
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    # ------------------------------------------------------------------ datasheet
    def compare_datasheet(self, sheet: Any = None) -> pd.DataFrame:
        """Compare with the datasheet, laid out like the paper's Tables 3/4 and 5/6.

        Parameters
        ----------
        sheet : accelcore.datasheets.Datasheet or str, optional
            Default: the session's sensor.

        Returns
        -------
        pandas.DataFrame
            Index (table, parameter, axis); columns ``min``, ``typ``, ``max``
            (datasheet, NaN where it gives none), ``measured``, ``measured_se``,
            ``unit`` and ``in_spec`` (True/False, or None without limits).
            ``table`` is ``"at T_ref"`` (Tables 3/4) or ``"temperature coefficients"``
            (Tables 5/6).
        """
        from accelcore import datasheets

        if sheet is None or isinstance(sheet, str):
            name = sheet or self.sensor
            if not name:
                raise ParameterError("no sensor named: pass sheet= or set sensor in session.toml")
            sheet = datasheets.load(name)
        u = self.units
        rows = []
        for a in self.axes:
            s = self.axis(a)
            unknown = {n.split(":", 1)[1] for n in self.not_identified if n.startswith(f"{a}:")}
            needs = {
                "sensitivity": {"sensitivity"},
                "zero_g_offset": {"offset"},
                "output_at_plus_1g": {"offset", "sensitivity"},
                "output_at_minus_1g": {"offset", "sensitivity"},
                "sensitivity_tc_pct_per_c": {"sensitivity", "sensitivity_tc"},
                "offset_tc_mg_per_c": {"offset_tc"},
            }
            params: list[tuple[str, str, str, float, float, str]] = [
                (
                    "at T_ref",
                    "sensitivity",
                    "sensitivity",
                    s.sensitivity,
                    s.sensitivity_se,
                    f"{u}/g",
                ),
                (
                    "at T_ref",
                    "zero_g_offset",
                    "zero_g_offset",
                    s.zero_g_offset,
                    s.zero_g_offset_se,
                    u,
                ),
                (
                    "at T_ref",
                    "+1 g",
                    "output_at_plus_1g",
                    s.zero_g_offset + s.sensitivity,
                    math.hypot(s.zero_g_offset_se, s.sensitivity_se),
                    u,
                ),
                (
                    "at T_ref",
                    "-1 g",
                    "output_at_minus_1g",
                    s.zero_g_offset - s.sensitivity,
                    math.hypot(s.zero_g_offset_se, s.sensitivity_se),
                    u,
                ),
                (
                    "temperature coefficients",
                    "sensitivity_tc",
                    "sensitivity_tc_pct_per_c",
                    s.sensitivity_tc_pct_per_c,
                    s.sensitivity_tc_pct_per_c_se,
                    "%/°C",
                ),
                (
                    "temperature coefficients",
                    "offset_tc",
                    "offset_tc_mg_per_c",
                    s.offset_tc_mg_per_c,
                    s.offset_tc_mg_per_c_se,
                    "mg/°C",
                ),
            ]
            for table, label, parameter, value, se, unit in params:
                lim = sheet.limits(parameter, a)
                if needs[parameter] & unknown:
                    value, se = math.nan, math.nan
                in_spec = None if lim is None or math.isnan(value) else lim.contains(value)
                rows.append(
                    {
                        "table": table,
                        "parameter": label,
                        "axis": a,
                        "min": _lim(lim, "min"),
                        "typ": _lim(lim, "typ"),
                        "max": _lim(lim, "max"),
                        "measured": value,
                        "measured_se": se,
                        "unit": unit,
                        "in_spec": in_spec,
                    }
                )
        return pd.DataFrame(rows).set_index(["table", "parameter", "axis"])

    def datasheet_text(self, sheet: Any = None) -> str:
        """Plain-text rendering of :meth:`compare_datasheet` for the terminal."""
        df = self.compare_datasheet(sheet).reset_index()
        out = []
        for table, part in df.groupby("table", sort=False):
            out.append(f"{table}:")
            lines = [
                f"  {'parameter':<15}{'axis':<5}{'min':>10}{'typ':>10}{'max':>10}"
                f"{'measured':>12}{'± se':>10}  {'unit':<6}{'spec':<5}"
            ]
            for r in part.to_dict(orient="records"):
                spec = {True: "ok", False: "OUT"}.get(r["in_spec"], "-")
                lines.append(
                    f"  {r['parameter']:<15}{r['axis']:<5}{_fmt(r['min']):>10}"
                    f"{_fmt(r['typ']):>10}{_fmt(r['max']):>10}{_fmt(r['measured'], 5):>12}"
                    f"{_fmt(r['measured_se'], 2):>10}  {r['unit']:<6}{spec:<5}"
                )
            out += lines
        return "\n".join(out)

    # ------------------------------------------------------------------ plots
    def plot_raw(self, session: Session, run: int | str | None = None, ax: Any = None) -> Any:
        """Figure 4 of the paper: one run's raw, decimated and binned output vs temperature."""
        from accelcore import plots

        return plots.plot_raw_vs_decimated(session, run, ax=ax, calibration=self)

    def plot_sensitivity(self, session: Session, ax: Any = None) -> Any:
        """Figure 6 of the paper: per-bin (V+ - V-)/2 and this model's sensitivity vs T."""
        from accelcore import plots

        return plots.plot_sensitivity_vs_temperature(session, self, ax=ax)

    def plot_offset(self, session: Session, ax: Any = None) -> Any:
        """Figure 7 of the paper: per-bin (V+ + V-)/2 and this model's zero-g offset vs T."""
        from accelcore import plots

        return plots.plot_offset_vs_temperature(session, self, ax=ax)

    # ------------------------------------------------------------------ compensation
    def _coefficient_matrices(
        self,
    ) -> tuple[list[str], NDArray[np.float64], NDArray[np.float64]]:
        bases: list[str] = []
        for m in self.axes.values():
            for t in m.terms:
                if t.basis not in bases:
                    bases.append(t.basis)
        offset = np.zeros((3, len(bases)))
        gain = np.zeros((9, len(bases)))
        for a_i, a in enumerate(AXES):
            if a not in self.axes:
                raise InsufficientDataError(f"the calibration has no model of axis {a}")
            m = self.axes[a]
            if not np.all(np.isfinite(m.coefficients)):
                raise InsufficientDataError(
                    f"axis {a} is not calibrated ({'; '.join(self.notes) or 'no model'}); "
                    "it cannot be compensated"
                )
            for t, c in zip(m.terms, m.coefficients, strict=True):
                k = bases.index(t.basis)
                if t.kind == "offset":
                    offset[a_i, k] += c
                else:
                    gain[3 * a_i + AXES.index(t.source or a), k] += c
        return bases, offset, gain

    def compensate(
        self,
        raw: ArrayLike,
        temp_c: ArrayLike,
        time_s: ArrayLike | None = None,
        extras: Mapping[str, ArrayLike] | None = None,
    ) -> NDArray[np.float64]:
        """Turn raw readings into acceleration in g (vectorised in Rust).

        Parameters
        ----------
        raw : array_like, shape (n, 3)
            Raw x, y, z output in session units.
        temp_c : array_like, shape (n,)
            Logged temperature, °C.
        time_s : array_like, shape (n,), optional
            Time, s; needed when the model has time-dependent terms (thermal lag,
            dT/dt, drift).
        extras : mapping, optional
            Extra observables the model uses (e.g. ``supply_v``).

        Returns
        -------
        ndarray of float64, shape (n, 3)
            Acceleration in g. Rows with non-finite input are NaN.

        Warns
        -----
        TemperatureRangeWarning
            When a temperature lies outside :attr:`temperature_range_c`; the
            model is then extrapolated, never clamped.
        """
        return self.compensator(warn_stacklevel=4).push(raw, temp_c, time_s, extras)

    def compensator(self, *, warn_stacklevel: int = 3) -> Compensator:
        """Return a streaming compensator for logs larger than memory.

        Feed it consecutive chunks of one continuous log with
        :meth:`Compensator.push`; terms that depend on earlier samples (thermal
        lag, dT/dt) carry their state across chunks, so any chunking gives the
        result of one :meth:`compensate` call over the whole log.
        """
        return Compensator(self, warn_stacklevel=warn_stacklevel)

    def residuals(self, session: Session) -> pd.DataFrame:
        """Error in mg of every decimated sample, with the observables.

        See :func:`accelcore.diagnosis.residuals`.
        """
        from accelcore.diagnosis import residuals

        return residuals(self, session)

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (the JSON file's body)."""
        return {
            "format": CALIBRATION_FORMAT,
            "method": self.method,
            "units": self.units,
            "sensor": self.sensor,
            "serial": self.serial,
            "t_ref_c": self.t_ref_c,
            "window_c": list(self.window_c),
            "temperature_range_c": list(self.temperature_range_c),
            "axes": {a: m.to_dict() for a, m in self.axes.items()},
            "not_identified": list(self.not_identified),
            "notes": list(self.notes),
            "references": dict(self.references),
            "options": dict(self.options),
            "provenance": dict(self.provenance),
        }

    def save(self, path: str | Path) -> None:
        """Write a versioned JSON file (atomically: temporary name, then rename).

        Floats are written with Python's shortest round-trip repr, so :meth:`load`
        gives back exactly the same numbers. A SHA-256 checksum of the body
        detects corruption.
        """
        body = self.to_dict()
        text = json.dumps(body, sort_keys=True, allow_nan=True)
        doc = {"body": body, "sha256": hashlib.sha256(text.encode()).hexdigest()}
        target = Path(path)
        tmp = target.with_name(f".{target.name}.tmp")
        tmp.write_text(json.dumps(doc, indent=1, sort_keys=True, allow_nan=True))
        tmp.replace(target)

    @classmethod
    def load(
        cls, path: str | Path, *, sensor: str | None = None, serial: str | None = None
    ) -> Calibration:
        """Read a file written by :meth:`save`.

        Parameters
        ----------
        path : str or Path
        sensor, serial : str, optional
            When given, the file must be for this sensor / serial.

        Raises
        ------
        accelcore.CalibrationFileError
            Corrupted, truncated, of another format version, or for another sensor.
        """
        where = str(path)
        try:
            data = Path(path).read_bytes()
        except OSError as exc:
            raise AccelcoreIOError(
                f"{where}: cannot read calibration file: {exc.strerror}"
            ) from exc
        try:
            doc = json.loads(data.decode("utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise CalibrationFileError(
                f"{where}: not a calibration file (truncated or corrupted JSON: {exc})"
            ) from exc
        if not isinstance(doc, dict) or "body" not in doc or "sha256" not in doc:
            raise CalibrationFileError(f"{where}: not an accelcore calibration file")
        body = doc["body"]
        fmt = body.get("format") if isinstance(body, dict) else None
        if fmt != CALIBRATION_FORMAT:
            raise CalibrationFileError(
                f"{where}: format {fmt!r} is not supported; expected {CALIBRATION_FORMAT!r}"
            )
        text = json.dumps(body, sort_keys=True, allow_nan=True)
        if hashlib.sha256(text.encode()).hexdigest() != doc["sha256"]:
            raise CalibrationFileError(
                f"{where}: checksum mismatch: the file was modified or "
                "corrupted after it was written"
            )
        if sensor is not None and (body.get("sensor") or "").lower() != sensor.lower():
            raise CalibrationFileError(
                f"{where}: calibration is for sensor {body.get('sensor')!r}, not {sensor!r}"
            )
        if serial is not None and body.get("serial") != serial:
            raise CalibrationFileError(
                f"{where}: calibration is for serial {body.get('serial')!r}, not {serial!r}"
            )
        try:
            return cls(
                method=str(body["method"]),
                units=str(body["units"]),
                t_ref_c=float(body["t_ref_c"]),
                window_c=(float(body["window_c"][0]), float(body["window_c"][1])),
                temperature_range_c=(
                    float(body["temperature_range_c"][0]),
                    float(body["temperature_range_c"][1]),
                ),
                axes={a: AxisModel.from_dict(a, m) for a, m in body["axes"].items()},
                not_identified=tuple(body["not_identified"]),
                notes=tuple(body["notes"]),
                sensor=body.get("sensor"),
                serial=body.get("serial"),
                references={k: float(v) for k, v in body["references"].items()},
                options=dict(body["options"]),
                provenance=dict(body["provenance"]),
            )
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise CalibrationFileError(f"{where}: malformed calibration body: {exc!r}") from exc


class _CarriedFeatures(Features):
    """Features of one chunk whose lag filters start from the previous chunk's state."""

    carried: dict[float, tuple[float, float, float]]

    def lagged_temperature_c(self, tau_s: float) -> NDArray[np.float64]:
        if tau_s not in self._lag_cache:
            time_s = self._need_time(f"lag({tau_s})")
            state = self.carried.get(tau_s)
            if state is None:
                y = first_order_lag(time_s, self.temperature_c, tau_s)
            else:
                last_t, last_x, last_y = state
                t_ext = np.concatenate([[last_t], time_s])
                x_ext = np.concatenate([[last_x], self.temperature_c])
                y = first_order_lag(t_ext, x_ext, tau_s, last_y)[1:]
            self._lag_cache[tau_s] = y
        return self._lag_cache[tau_s]


class Compensator:
    """Streaming compensation: push consecutive chunks of one log, get acceleration in g.

    Made by :meth:`Calibration.compensator`. Time is measured from the first
    chunk's first sample; lag filters continue from the previous chunk's last
    sample, so the result does not depend on the chunking.

    Attributes
    ----------
    n_out_of_range : int
        Samples so far outside the calibrated temperature range (warned once).
    n_rows : int
        Samples so far.
    """

    def __init__(self, calibration: Calibration, *, warn_stacklevel: int = 3) -> None:
        self.calibration = calibration
        self._bases, self._offset, self._gain = calibration._coefficient_matrices()
        self._t0: float | None = None
        self._carried: dict[float, tuple[float, float, float]] = {}
        self._warned = False
        self._stacklevel = warn_stacklevel
        self.n_out_of_range = 0
        self.n_rows = 0

    def push(
        self,
        raw: ArrayLike,
        temp_c: ArrayLike,
        time_s: ArrayLike | None = None,
        extras: Mapping[str, ArrayLike] | None = None,
    ) -> NDArray[np.float64]:
        """Compensate the next chunk; see :meth:`Calibration.compensate` for the arguments."""
        cal = self.calibration
        raw_a = np.ascontiguousarray(raw, dtype=np.float64)
        if raw_a.ndim != 2 or raw_a.shape[1] != 3:
            raise ParameterError(f"raw must have shape (n, 3), got {raw_a.shape}")
        temp = np.ascontiguousarray(temp_c, dtype=np.float64).reshape(-1)
        if temp.shape[0] != raw_a.shape[0]:
            raise ParameterError(f"temp_c has {temp.shape[0]} values for {raw_a.shape[0]} rows")
        self._check_range(temp)
        rel = None
        if time_s is not None:
            time_a = np.asarray(time_s, dtype=np.float64).reshape(-1)
            if time_a.shape[0] != temp.shape[0]:
                raise ParameterError(f"time_s has {time_a.shape[0]} values for {temp.shape[0]}")
            if self._t0 is None and time_a.size:
                self._t0 = float(time_a[0])
            rel = time_a - (self._t0 or 0.0)
        feats = _CarriedFeatures(
            temp,
            rel,
            {k: np.asarray(v, dtype=np.float64) for k, v in (extras or {}).items()},
            cal.t_ref_c,
        )
        feats.carried = self._carried
        n = raw_a.shape[0]
        if self._bases:
            basis = np.column_stack([evaluate_basis(b, feats, cal.references) for b in self._bases])
        else:
            basis = np.zeros((n, 0))
        g = _compensate(raw_a, np.ascontiguousarray(basis), self._offset, self._gain)
        if n and rel is not None:
            for tau, y in feats._lag_cache.items():
                self._carried[tau] = (float(rel[-1]), float(temp[-1]), float(y[-1]))
        self.n_rows += n
        return g

    def _check_range(self, temp: NDArray[np.float64]) -> None:
        finite = temp[np.isfinite(temp)]
        if finite.size == 0:
            return
        lo, hi = self.calibration.temperature_range_c
        outside = int(np.count_nonzero((finite < lo) | (finite > hi)))
        self.n_out_of_range += outside
        if outside and not self._warned:
            self._warned = True
            warnings.warn(
                TemperatureRangeWarning(
                    f"{outside} of {finite.size} samples lie outside the calibrated range "
                    f"{lo:.2f}…{hi:.2f} °C (data spans {finite.min():.2f}…{finite.max():.2f} "
                    "°C); the model is extrapolated there, not clamped"
                ),
                stacklevel=self._stacklevel,
            )


def _lim(lim: Any, which: str) -> float:
    v = None if lim is None else getattr(lim, which)
    return math.nan if v is None else float(v)


def _fmt(v: object, digits: int = 4) -> str:
    if not isinstance(v, (int, float)) or math.isnan(v):
        return ""
    return f"{v:.{digits}g}"


# ---------------------------------------------------------------------- fitting
@dataclass
class _Stacked:
    """Decimated samples of every run inside the window, with per-run features."""

    features: list[Features]
    gravity: list[NDArray[np.float64]]
    output: list[NDArray[np.float64]]
    weight: list[NDArray[np.float64]]
    run_index: list[int]
    notes: list[str] = field(default_factory=list)

    @property
    def temperature_range_c(self) -> tuple[float, float]:
        temps = np.concatenate([f.temperature_c for f in self.features])
        return float(temps.min()), float(temps.max())


def block_weights(run: Run, robust: bool = True) -> tuple[NDArray[np.float64], str | None]:
    """Least-squares weight of each decimated block of a run, and a note on what was left out.

    A block mean of ``count`` samples has variance ``sigma² / count``, so its
    weight is its count. With ``robust``, spikes and blocks clipped at a rail
    (:func:`accelcore.quality.excluded_blocks`) get weight 0.
    """
    weight = run.count.astype(np.float64)
    if not robust:
        return weight, None
    from accelcore.quality import excluded_blocks

    mask, n_spikes, n_clipped = excluded_blocks(run)
    if not mask.any():
        return weight, None
    weight[mask] = 0.0
    parts = [f"{n} spike block(s)" for n in (n_spikes,) if n] + [
        f"{n} clipped block(s)" for n in (n_clipped,) if n
    ]
    return weight, f"{run.label}: left out {' and '.join(parts)} of {len(run)}"


def stack_session(
    session: Session,
    t_ref_c: float,
    window_c: tuple[float, float] | None,
    runs: Sequence[int] | None = None,
    robust: bool = True,
) -> _Stacked:
    """Per run: features, gravity, output and weights of the samples inside the window.

    Features (elapsed time, lagged temperature) are computed on the whole run
    first and then cut to the window, so a lag filter sees the run's history.
    With ``robust``, spikes and clipped blocks get weight 0 (see :func:`block_weights`).
    """
    feats: list[Features] = []
    grav, out, wts, idx = [], [], [], []
    notes: list[str] = []
    for i, run in enumerate(session.runs):
        if runs is not None and i not in runs:
            continue
        time_s = run.time_s - run.time_s[0] if len(run) else run.time_s
        whole = Features(run.temperature_c, time_s, run.extras, t_ref_c)
        if window_c is None:
            keep = np.ones(len(run), dtype=bool)
        else:
            keep = (run.temperature_c >= window_c[0]) & (run.temperature_c <= window_c[1])
        if not keep.any():
            continue
        weight, note = block_weights(run, robust)
        if note:
            notes.append(note)
        feats.append(_CutFeatures.cut(whole, keep))
        grav.append(run.gravity_g)
        out.append(run.output[keep])
        wts.append(weight[keep])
        idx.append(i)
    if not feats:
        lo, hi = window_c if window_c else (-math.inf, math.inf)
        raise InsufficientDataError(
            f"no decimated sample lies in the window {lo}…{hi} °C; widen window_c or log a "
            "sweep that covers it"
        )
    return _Stacked(feats, grav, out, wts, idx, notes)


class _CutFeatures(Features):
    """Features of a run restricted to a mask, lag computed on the whole run."""

    @classmethod
    def cut(cls, whole: Features, keep: NDArray[np.bool_]) -> _CutFeatures:
        obj = cls(
            whole.temperature_c[keep],
            None if whole.time_s is None else whole.time_s[keep],
            {k: v[keep] for k, v in whole.extras.items()},
            whole.t_ref_c,
        )
        obj._whole = whole
        obj._keep = keep
        return obj

    _whole: Features
    _keep: NDArray[np.bool_]

    def lagged_temperature_c(self, tau_s: float) -> NDArray[np.float64]:
        return self._whole.lagged_temperature_c(tau_s)[self._keep]


def fit_axis(
    axis: str,
    terms: Sequence[Term],
    data: _Stacked,
    nominal: float | None,
    references: Mapping[str, float],
    rows: Sequence[int] | None = None,
) -> tuple[AxisModel, list[str], list[str]]:
    """Weighted least squares of one axis; fix what the data cannot identify.

    Returns the model, the names of terms held fixed, and notes.
    """
    a = AXES.index(axis)
    parts = range(len(data.features)) if rows is None else rows
    design = np.vstack(
        [design_columns(terms, data.features[i], data.gravity[i], references) for i in parts]
    )
    response = np.concatenate([data.output[i][:, a] for i in parts])
    weight = np.concatenate([data.weight[i] for i in parts])
    p = len(terms)
    fixed = np.zeros(p)
    estimated = np.ones(p, dtype=bool)
    fixed_names: list[str] = []
    notes: list[str] = []
    names = [f"{axis}:{_public_name(t, axis)}" for t in terms]
    # Drop all-zero columns first (e.g. the sensitivity of an axis that never saw gravity).
    col_norm = np.sqrt((weight[:, None] * design**2).sum(axis=0))
    while True:
        for j in range(p):
            if estimated[j] and col_norm[j] == 0.0:
                estimated[j] = False
        cols = np.flatnonzero(estimated)
        if cols.size == 0:
            raise InsufficientDataError(f"axis {axis}: no term of the model is identified")
        y = response - design[:, ~estimated] @ fixed[~estimated]
        lsq = core.LeastSquares(int(cols.size), column_names=[names[j] for j in cols])
        lsq.push(np.ascontiguousarray(design[:, cols]), y, weight)
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
        if t.kind == "gain" and t.source == axis and t.basis == "1":
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
        if t.kind == "gain" and t.source == axis and col_norm[j] > 0:
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
        y = response - design[:, ~estimated] @ fixed[~estimated]
        lsq = core.LeastSquares(int(cols.size), column_names=[names[j] for j in cols])
        lsq.push(np.ascontiguousarray(design[:, cols]), y, weight)
        sol = lsq.finish()
    coefficients = fixed.copy()
    coefficients[estimated] = sol.coefficients
    covariance = np.zeros((p, p))
    cols = np.flatnonzero(estimated)
    covariance[np.ix_(cols, cols)] = sol.covariance
    rms = math.sqrt(sol.residual_sum_squares / weight.sum())
    model = AxisModel(
        axis, tuple(terms), coefficients, covariance, estimated, int(response.shape[0]), rms
    )
    return model, fixed_names, notes


def _public_name(term: Term, axis: str) -> str:
    if term.kind == "offset":
        return {"1": "offset", "dT^1": "offset_tc"}.get(term.basis, term.name)
    if term.source == axis:
        return {"1": "sensitivity", "dT^1": "sensitivity_tc"}.get(term.basis, term.name)
    return term.name


def _extra_references(session: Session, terms: Mapping[str, Sequence[Term]]) -> dict[str, float]:
    refs: dict[str, float] = {}
    for ts in terms.values():
        for t in ts:
            if t.basis.startswith("extra:") and t.basis not in refs:
                name = t.basis[len("extra:") :]
                values = np.concatenate([r.extras[name] for r in session.runs if name in r.extras])
                refs[t.basis] = float(np.median(values))
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
    nominal = nominal_sensitivity(session.units, session.sensor)
    refs = dict(references) if references is not None else _extra_references(session, terms)
    axes: dict[str, AxisModel] = {}
    not_identified: list[str] = []
    notes: list[str] = list(data.notes)
    for i, a in enumerate(AXES):
        model, fixed, axis_notes = fit_axis(
            a, terms[a], data, None if nominal is None else nominal[i], refs
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


def calibrate(
    session: Session,
    method: Literal["joint", "paper"] = "joint",
    *,
    t_ref_c: float = 25.0,
    window_c: tuple[float, float] | None = (0.0, 60.0),
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
    window_c : (float, float) or None, default (0, 60)
        Only samples with logged temperature in this window are used (the
        paper's 0–60 °C, away from the chamber's unstable ends). None: all.
    bin_width_c : float, default 0.5
        Temperature bin width of the paper's method, °C.
    terms : mapping of axis to sequence of Term, optional
        Model terms of the joint fit; default :func:`accelcore.model.base_terms`.
    robust : bool, default True
        Leave out decimated blocks that are spikes or clipped at a rail
        (:func:`accelcore.quality.excluded_blocks`); what was left out is listed in
        :attr:`Calibration.notes`. Clean data loses nothing.

    Returns
    -------
    Calibration

    Raises
    ------
    accelcore.InsufficientDataError
        No data in the window, too few bins, or nothing identifiable; the
        message says what data would fix it.
    """
    if method not in ("joint", "paper"):
        raise ParameterError(f"method must be 'joint' or 'paper', got {method!r}")
    session.check_orientations()
    options: dict[str, Any] = {
        "method": method,
        "t_ref_c": t_ref_c,
        "window_c": None if window_c is None else list(window_c),
        "bin_width_c": bin_width_c,
        "decimation_factor": session.decimation_factor,
        "robust": robust,
    }
    refs: dict[str, float] = {}
    if method == "paper":
        if terms is not None:
            raise ParameterError("terms= applies to method='joint' only")
        axes, not_identified, notes, t_range = _fit_paper(
            session, t_ref_c, window_c or (-273.15, 1000.0), bin_width_c, robust
        )
    else:
        model_terms = {a: tuple(terms[a]) if terms and a in terms else base_terms(a) for a in AXES}
        axes, not_identified, notes, t_range, refs = _fit_joint(
            session, model_terms, t_ref_c, window_c, robust=robust
        )
    provenance: dict[str, Any] = {
        "accelcore_version": __version__,
        "session_path": session.path,
        "files_sha256": session.file_hashes(),
    }
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
