"""imucal's ``FerrarisCalibrationInfo`` JSON: bias, scale and misalignment at one temperature.

imucal (``imucal.FerrarisCalibrationInfo``) models the raw accelerometer output as
``raw = K_a · R_a · a + b_a`` with ``a`` the acceleration in ``acc_unit`` (m/s²),
``K_a`` a diagonal scale, ``R_a`` a matrix whose rows are the (unit-length)
sensitive directions and ``b_a`` the bias in ``from_acc_unit``; ``calibrate`` returns
``R_a⁻¹ K_a⁻¹ (raw - b_a)``. Ours at a held temperature is ``raw = o + G · a/g0``
with ``G`` in session units per g, so ``K_a R_a = G / g0`` (g0 = standard gravity):
``K_a`` holds the row norms of ``G / g0`` and ``R_a`` the normalised rows. The file is
the JSON of ``CalibrationInfo.to_json_file``: the dataclass fields, ``cal_type`` and
``_format_version`` ``"2.0.0"``. imucal also requires the gyroscope fields; they are
written as identity (``K_g``, ``R_g``) and zero (``K_ga``, ``b_g``), which leaves the
gyroscope untouched, and the ``comment`` says so.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from accelcore.errors import InsufficientDataError, ParameterError, TemperatureRangeWarning
from accelcore.files import atomic_write
from accelcore.outputs.exports._model import describe, local_gravity, model_at
from accelcore.result.calibration import Calibration

#: Our units spelled as imucal spells them: its ``calibrate`` compares ``acc_unit`` with
#: the file's ``from_acc_unit`` as strings, and writes m/s² as ``"m/s^2"``.
IMUCAL_UNITS = {"m/s2": "m/s^2"}

__all__ = ["IMUCAL_FORMAT_VERSION", "ImucalExport", "export_imucal"]

#: The ``_format_version`` imucal 2.x writes and accepts.
IMUCAL_FORMAT_VERSION = "2.0.0"
#: Gyroscope unit of the placeholder gyroscope fields.
_GYR_UNIT = "deg/s"


@dataclass(frozen=True)
class ImucalExport:
    """A calibration at one temperature in imucal's Ferraris form.

    Attributes
    ----------
    temperature_c : float
        The temperature the model was held at, °C.
    K_a, R_a : ndarray, shape (3, 3)
        Scale (diagonal, ``from_acc_unit`` per m/s²) and misalignment (unit rows).
    b_a : ndarray, shape (3,)
        Bias, ``from_acc_unit``.
    from_acc_unit : str
        Units of the raw data (our session units).
    comment : str
    offset_change_mg : float
        Largest change of any axis' offset over the calibrated range from its value at
        ``temperature_c``, mg: what a one-temperature file loses (NaN without a range).
    sensitivity_change_pct : float
        The same for the own-axis sensitivity, % of its value at ``temperature_c``.
    """

    temperature_c: float
    K_a: NDArray[np.float64]
    R_a: NDArray[np.float64]
    b_a: NDArray[np.float64]
    from_acc_unit: str
    comment: str
    offset_change_mg: float
    sensitivity_change_pct: float

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON body, key for key as imucal writes it."""
        eye = np.eye(3).tolist()
        return {
            "acc_unit": "m/s^2",
            "gyr_unit": _GYR_UNIT,
            "from_acc_unit": self.from_acc_unit,
            "from_gyr_unit": _GYR_UNIT,
            "comment": self.comment,
            "K_a": self.K_a.tolist(),
            "R_a": self.R_a.tolist(),
            "b_a": self.b_a.tolist(),
            "K_g": eye,
            "R_g": eye,
            "K_ga": np.zeros((3, 3)).tolist(),
            "b_g": [0.0, 0.0, 0.0],
            "cal_type": "Ferraris",
            "_format_version": IMUCAL_FORMAT_VERSION,
        }

    def file_text(self) -> str:
        """Return the JSON file."""
        return json.dumps(self.to_dict(), indent=4) + "\n"

    def text(self) -> str:
        """Human summary: what was exported and what one temperature loses."""
        lines = [
            f"imucal FerrarisCalibrationInfo at {self.temperature_c:.2f} °C "
            f"(raw units {self.from_acc_unit!r}, output m/s^2)",
            "  bias b_a: " + ", ".join(f"{v:.6g}" for v in self.b_a),
            "  scale K_a: " + ", ".join(f"{v:.6g}" for v in np.diag(self.K_a)),
        ]
        if math.isfinite(self.offset_change_mg):
            lines.append(
                f"  lost over the calibrated range: offset changes up to "
                f"{self.offset_change_mg:.4f} mg, sensitivity up to "
                f"{self.sensitivity_change_pct:.4f} %"
            )
        lines.append("  gyroscope fields are identity/zero placeholders")
        return "\n".join(lines)

    def write(self, path: str | Path) -> None:
        """Write :meth:`file_text` to ``path`` (atomically); imucal wants a ``.json`` name."""
        atomic_write(path, self.file_text())


def export_imucal(cal: Calibration, *, temperature_c: float | None = None) -> ImucalExport:
    """Hold a calibration at one temperature and write it as imucal's Ferraris calibration.

    Parameters
    ----------
    cal : Calibration
    temperature_c : float, optional
        Default the calibration's T_ref. Lagged temperatures are taken as settled,
        dT/dt as 0, drift at its start and extra columns at their reference values.

    Returns
    -------
    ImucalExport
    """
    t = cal.t_ref_c if temperature_c is None else float(temperature_c)
    lo, hi = cal.temperature_range_c
    if not math.isfinite(t):
        raise ParameterError(f"temperature_c must be a finite temperature in °C, got {t!r}")
    if math.isfinite(lo) and math.isfinite(hi) and not lo <= t <= hi:
        warnings.warn(
            f"imucal export held at {t:g} °C, outside the calibrated range {lo:.2f}…{hi:.2f} °C: "
            "the model is extrapolated there",
            TemperatureRangeWarning,
            stacklevel=2,
        )
    offset, gain = model_at(cal, t)
    g0 = local_gravity(cal)
    scaled = gain / g0
    k = np.sqrt(np.sum(scaled**2, axis=1))
    if not np.all(k > 0):
        raise InsufficientDataError(f"an axis has no sensitivity at {t} °C: no imucal scale")
    offset_change, sens_change = _changes(cal, t, offset, gain)
    comment = (
        f"accelcore calibration of {describe(cal)} held at {t:.2f} °C; raw units "
        f"{cal.units!r}, output m/s^2 with g0 = {g0} m/s^2. Gyroscope fields "
        "K_g, R_g (identity), K_ga, b_g (zero) are placeholders: accelcore calibrates "
        "accelerometers only."
    )
    return ImucalExport(
        temperature_c=t,
        K_a=np.diag(k),
        R_a=scaled / k[:, None],
        b_a=offset.copy(),
        from_acc_unit=IMUCAL_UNITS.get(cal.units, cal.units),
        comment=comment,
        offset_change_mg=offset_change,
        sensitivity_change_pct=sens_change,
    )


def _changes(
    cal: Calibration, t: float, offset: NDArray[np.float64], gain: NDArray[np.float64]
) -> tuple[float, float]:
    lo, hi = cal.temperature_range_c
    if not (math.isfinite(lo) and math.isfinite(hi) and hi >= lo):
        return math.nan, math.nan
    sens = np.diag(gain)
    worst_offset, worst_sens = 0.0, 0.0
    for temp in np.linspace(lo, hi, 61):
        o, g = model_at(cal, float(temp))
        worst_offset = max(worst_offset, float(np.max(np.abs((o - offset) / sens))))
        worst_sens = max(worst_sens, float(np.max(np.abs(np.diag(g) / sens - 1.0))))
    return 1000.0 * worst_offset, 100.0 * worst_sens
