"""A calibration: per-axis model terms and coefficients, compensation, datasheet comparison, files.

:class:`Calibration` is what :func:`accelcore.calibrate` returns and what every
consumer (diagnosis, reports, exports, the CLI) reads. Per axis an :class:`AxisModel`
holds the model terms (:mod:`accelcore.model`), their fitted coefficients, which of
them were estimated and their covariance. :class:`Compensator` turns raw output
back into acceleration in g (the 3×3 model solved per sample in Rust), streaming.
:meth:`Calibration.save` / :meth:`Calibration.load` write and read the versioned,
checksummed JSON file (its envelope, canonical checksum and schema:
:mod:`accelcore.result.calibration_file`).

What the data could not identify is said, never invented: with one orientation
the vertical axis' offset and sensitivity cannot be told apart, so its
sensitivity is held at its nominal value (datasheet typical, or exactly 1 g/g
for sessions already in g) and reported in :attr:`Calibration.not_identified`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from accelcore.errors import AccelcoreError, CalibrationFileError, InsufficientDataError
from accelcore.files import check_outputs
from accelcore.model import AXES, Basis, TemperaturePower, Term
from accelcore.result import datasheet
from accelcore.result.calibration_file import CALIBRATION_FORMAT, read_body, write_body
from accelcore.result.compensator import Compensator
from accelcore.result.datasheet import nominal_sensitivity
from accelcore.result.frame import compensated_frame
from accelcore.result.summary import AxisSummary

__all__ = [
    "CALIBRATION_FORMAT",
    "AxisModel",
    "AxisSummary",
    "Calibration",
    "Compensator",
    "nominal_sensitivity",
]


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

    def index(self, kind: str, basis: Basis | str, source: str | None = None) -> int | None:
        """Position of a term, or None.

        A ``dT^k`` basis that the model only has through a thermal lag
        (``lag(tau):dT^k``, added by the diagnosis) matches that term.
        """
        wanted = Basis.parse(basis)
        for i, t in enumerate(self.terms):
            if t.kind == kind and t.basis == wanted and (kind == "offset" or t.source == source):
                return i
        if isinstance(wanted, TemperaturePower):
            for i, t in enumerate(self.terms):
                if (
                    t.kind == kind
                    and t.basis.lag_s is not None
                    and t.basis.without_lag() == wanted
                    and (kind == "offset" or t.source == source)
                ):
                    return i
        return None

    def value(
        self, kind: str, basis: Basis | str, source: str | None = None
    ) -> tuple[float, float]:
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
        Range of temperatures actually fitted, °C; compensation outside it warns,
        extrapolates the linear terms and continues the powers of the temperature
        of order 2 and more along their tangent at the range's edge
        (:func:`accelcore.result.compensator.continued_beyond_range`).
        NaN, NaN for a session that logged no temperature (a calibration at one
        temperature: :attr:`has_temperature` is False).
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
        accelcore version, the digest's algorithm (``"digest"``: ``"blake3"``,
        or ``"sha256"``) and the digests of the input files (``"files_blake3"``
        or ``"files_sha256"``; files written before the algorithm was recorded
        hold ``"files_sha256"`` only). :meth:`file_digests` reads either.
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

    @property
    def has_temperature(self) -> bool:
        """False for a calibration at one temperature (the session logged none)."""
        return not all(math.isnan(v) for v in self.temperature_range_c)

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
        if not self.has_temperature:  # at one temperature: no coefficient, not a zero one
            offset_tc = offset_tc_se = sens_tc = sens_tc_se = math.nan
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
                    "rms_residual_mg": 1000.0 * m.rms_residual / abs(s.sensitivity)
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
        summaries = {a: self.axis(a) for a in self.axes}
        return datasheet.compare(summaries, self.units, self.not_identified, self.sensor, sheet)

    def datasheet_text(self, sheet: Any = None) -> str:
        """Plain-text rendering of :meth:`compare_datasheet` for the terminal."""
        return datasheet.text(self.compare_datasheet(sheet))

    # ------------------------------------------------------------------ compensation
    def _coefficient_matrices(
        self,
    ) -> tuple[list[Basis], NDArray[np.float64], NDArray[np.float64]]:
        bases: list[Basis] = []
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
        temp_c: ArrayLike | None,
        time_s: ArrayLike | None = None,
        extras: Mapping[str, ArrayLike] | None = None,
    ) -> NDArray[np.float64]:
        """Turn raw readings into acceleration in g (vectorised in Rust).

        Parameters
        ----------
        raw : array_like, shape (n, 3)
            Raw x, y, z output in session units.
        temp_c : array_like, shape (n,), or None
            Logged temperature, °C. None for a model without temperature terms
            (a calibration of a session that logged no temperature).
        time_s : array_like, shape (n,), optional
            Time, s; needed when the model has time-dependent terms (thermal lag,
            dT/dt, drift).
        extras : mapping, optional
            Extra observables the model uses (e.g. ``supply_v``).

        Returns
        -------
        ndarray of float64, shape (n, 3)
            Acceleration in g. Rows with non-finite input are NaN.

        Raises
        ------
        accelcore.ParameterError
            ``temp_c`` is None and the model has temperature terms.

        Warns
        -----
        TemperatureRangeWarning
            When a temperature lies outside :attr:`temperature_range_c`; the
            model's linear terms are then extrapolated, its curvature (powers of
            the temperature of order 2 and more) continued along its tangent at the
            range's edge.
        """
        return self.compensator(warn_stacklevel=4).push(raw, temp_c, time_s, extras)

    def compensate_frame(
        self, data: Mapping[str, Any] | Any, *, columns: Mapping[str, str] | None = None
    ) -> pd.DataFrame:
        """Compensate a table and return a labelled frame: time, temperature, ``x_g, y_g, z_g``.

        Parameters
        ----------
        data : mapping of str to array_like, or DataFrame
            A mapping of column name to 1-D array, a pandas DataFrame, or any
            DataFrame :meth:`accelcore.Session.from_arrays` takes (polars,
            pyarrow, ... through narwhals: ``pip install accelcore[frames]``),
            with the time (s, or date/times), temperature (°C), x, y, z columns
            and the extra columns the model reads. Other columns are ignored.
        columns : mapping of str to str, optional
            Column names by role (``time``, ``temperature``, ``x``, ``y``,
            ``z``), defaults ``time_s``, ``temp_c``, ``x``, ``y``, ``z``, as in
            :meth:`accelcore.Session.from_arrays`.

        Returns
        -------
        pandas.DataFrame
            The time column (as given when date/times, else in s) and the
            temperature column under their own names, then the acceleration in
            g as ``x_g``, ``y_g``, ``z_g``; a pandas input's index is kept.
            Rows with non-finite input are NaN.

        Raises
        ------
        accelcore.AccelcoreError
            A column is missing or a cell is not a number (naming the column
            and the row), as :meth:`accelcore.Session.from_arrays` raises.

        Warns
        -----
        TemperatureRangeWarning
            When a temperature lies outside :attr:`temperature_range_c`.
        """
        extras = sorted(
            {t.basis.column for m in self.axes.values() for t in m.terms if t.basis.column}
        )
        return compensated_frame(self.compensator(warn_stacklevel=5), data, columns, extras)

    def compensator(self, *, warn_stacklevel: int = 3) -> Compensator:
        """Return a streaming compensator for logs larger than memory.

        Feed it consecutive chunks of one continuous log with
        :meth:`Compensator.push`; terms that depend on earlier samples (thermal
        lag, dT/dt) carry their state across chunks, so any chunking gives the
        result of one :meth:`compensate` call over the whole log.
        """
        bases, offset, gain = self._coefficient_matrices()
        return Compensator(
            bases,
            offset,
            gain,
            references=self.references,
            t_ref_c=self.t_ref_c,
            temperature_range_c=self.temperature_range_c,
            warn_stacklevel=warn_stacklevel,
        )

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

    def file_digests(self) -> tuple[str, dict[str, str]]:
        """Return the input files' digests recorded in the provenance, and their algorithm.

        Returns
        -------
        algorithm : str
            ``"blake3"`` or ``"sha256"`` (files without a ``"digest"`` entry,
            written before BLAKE3, hold SHA-256).
        files : dict of str to str
            File name to hex digest; empty for a session built in memory.
        """
        algorithm = str(self.provenance.get("digest", "sha256"))
        files = self.provenance.get(f"files_{algorithm}") or {}
        return algorithm, {str(k): str(v) for k, v in dict(files).items()}

    def save(self, path: str | Path) -> None:
        """Write a versioned JSON file (atomically: temporary name, then rename).

        Floats are written with Python's shortest round-trip repr, so :meth:`load`
        gives back exactly the same numbers (a non-finite one as null, read back
        as NaN). The checksum is the SHA-256 of the body's RFC 8785 canonical
        JSON bytes: reformatting the file keeps it valid, changing a number
        does not (:mod:`accelcore.result.calibration_file`).

        Raises
        ------
        accelcore.errors.OutputConflictError
            ``path`` is (or links to) one of the session files this calibration
            was fitted on (:func:`accelcore.files.check_outputs`).
        """
        folder = self.provenance.get("session_path")
        _, files = self.file_digests()
        if folder:
            check_outputs([Path(folder) / name for name in files], [path])
        write_body(path, self.to_dict())

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
        accelcore.AccelcoreIOError
            Missing, not a regular file (a FIFO, a folder) or over 64 MiB.
        """
        where = str(path)
        body = read_body(path)
        if sensor is not None and (body.get("sensor") or "").lower() != sensor.lower():
            raise CalibrationFileError(
                f"{where}: calibration is for sensor {body.get('sensor')!r}, not {sensor!r}"
            )
        if serial is not None and body.get("serial") != serial:
            raise CalibrationFileError(
                f"{where}: calibration is for serial {body.get('serial')!r}, not {serial!r}"
            )
        try:
            cal = cls(
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
        _check_loaded(cal, where)
        return cal


def _check_loaded(cal: Calibration, where: str) -> None:
    """Validate a loaded calibration whole, so that a bad file fails at load, not in use.

    Every axis has a model; its coefficients are all finite (or all NaN: an axis
    the method could not calibrate); a calibrated axis has a nonzero, finite
    sensitivity; the terms combine into compensation matrices.
    """
    missing = [a for a in AXES if a not in cal.axes]
    if missing:
        raise CalibrationFileError(f"{where}: no model of axis {', '.join(missing)}")
    for a, m in cal.axes.items():
        c = m.coefficients
        nan = np.isnan(c)
        if nan.all():
            continue
        bad = [t.name for t, v in zip(m.terms, c, strict=True) if not math.isfinite(v)]
        if bad:
            raise CalibrationFileError(
                f"{where}: axis {a}: non-finite coefficient(s) {', '.join(bad)}; the file is "
                "corrupted"
            )
        gain = sum(
            float(v)
            for t, v in zip(m.terms, c, strict=True)
            if t.kind == "gain" and (t.source or a) == a and t.basis == Basis.parse("1")
        )
        if gain == 0.0:
            raise CalibrationFileError(
                f"{where}: axis {a}: the sensitivity is 0, so no reading could be turned into "
                "acceleration; the file is corrupted"
            )
    if all(not np.isnan(m.coefficients).all() for m in cal.axes.values()):
        try:
            cal._coefficient_matrices()
        except (AccelcoreError, ValueError) as exc:
            raise CalibrationFileError(f"{where}: the model cannot compensate: {exc}") from exc
