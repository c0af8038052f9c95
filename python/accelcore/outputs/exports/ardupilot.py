"""ArduPilot's IMU temperature calibration: ``INS_TCAL<n>_*`` in a ``.param`` file.

ArduPilot (``libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp``) corrects the
accelerometer reading (m/s², sensor frame) before its offsets and scale::

    P(t) = (ACC1·t + ACC2·t² + ACC3·t³) · 1e-6            t = T - 35 °C
    reading -= P(clip(T) - 35) - P(clip(T_cal) - 35)

with ``T`` clipped to ``[INS_TCAL<n>_TMIN, INS_TCAL<n>_TMAX]``, a fixed reference of
35 °C and ``T_cal`` the temperature of the accelerometer calibration
(``INS_ACC<n>_CALTEMP``). The polynomial has no constant: the offset at ``T_cal`` is
``INS_ACC<n>OFFS``'s job, so only the offset's temperature dependence is exported
(the fit has a free constant, then drops it). Coefficients are m/s²/°C^k times 1e6,
the scale ArduPilot and ``Tools/scripts/tempcal_IMU.py`` use so they read well in
parameter editors. ``INS_TCAL<n>_ENABLE = 1`` applies them; ``n`` counts IMUs from 1.

The ``.param`` file (Mission Planner's, read by MAVProxy and pymavlink's
``MAVParmDict.load``) is one ``NAME,VALUE`` per line, ``#`` starting a comment.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from accelcore.constants import ARDUPILOT_SCALE, ARDUPILOT_T_REF_C
from accelcore.errors import ParameterError
from accelcore.files import atomic_write
from accelcore.outputs.exports._model import (
    CubicOffsetFit,
    describe,
    fit_cubic_offsets,
    float32_text,
    log_sensor,
)
from accelcore.result.calibration import Calibration

__all__ = ["ARDUPILOT_SCALE", "ARDUPILOT_T_REF_C", "ArduPilotExport", "export_ardupilot"]

#: ArduPilot's documented range of TMIN and TMAX, °C.
_T_LIMITS = (-70.0, 80.0)


@dataclass(frozen=True)
class ArduPilotExport:
    """ArduPilot ``INS_TCAL<n>_*`` parameters approximating a calibration.

    Attributes
    ----------
    imu : int
        The ``n`` of ``INS_TCAL<n>`` (1 to 3).
    fit : CubicOffsetFit
        The cubic approximation (about 35 °C) and its residuals.
    params : dict of str to float
        Every parameter written, in file order.
    source : str
        Which calibration was exported (for the file's comments).
    """

    imu: int
    fit: CubicOffsetFit
    params: dict[str, float]
    source: str

    def text(self) -> str:
        """Human summary: what was exported and what the cubic loses against our model."""
        lines = [f"ArduPilot temperature calibration INS_TCAL{self.imu}_* from {self.source}"]
        lines += self.fit.lines()
        lines.append(
            "  note: the polynomial carries the offset's change only; ArduPilot takes the "
            f"constant from INS_ACC{'' if self.imu == 1 else self.imu}OFFS at INS_ACC"
            f"{self.imu}_CALTEMP"
        )
        lo, hi = self.fit.range_c
        if lo < _T_LIMITS[0] or hi > _T_LIMITS[1]:
            lines.append(
                f"  warning: the range {lo:.1f}…{hi:.1f} °C exceeds ArduPilot's documented "
                f"TMIN/TMAX limits {_T_LIMITS[0]:g}…{_T_LIMITS[1]:g} °C"
            )
        return "\n".join(lines)

    def file_text(self) -> str:
        """Return the ``.param`` file."""
        head = [
            f"# IMU temperature calibration exported by accelcore from {self.source}",
            f"# cubic-offset approximation: max residual {self.fit.max_residual_mg:.4f} mg, "
            f"rms {self.fit.rms_residual_mg:.4f} mg",
        ]
        rows = [
            f"{name},{int(v) if name.endswith('_ENABLE') else float32_text(v)}"
            for name, v in self.params.items()
        ]
        return "\n".join(head + rows) + "\n"

    def write(self, path: str | Path) -> None:
        """Write :meth:`file_text` to ``path`` (atomically)."""
        atomic_write(path, self.file_text())


def export_ardupilot(
    cal: Calibration,
    *,
    imu: int | None = None,
    ramp_c_per_min: float = 1.0,
    gravity_g: Sequence[float] | None = None,
) -> ArduPilotExport:
    """Approximate a calibration by ArduPilot's cubic temperature correction.

    Parameters
    ----------
    cal : Calibration
    imu : int, optional
        ``n`` of ``INS_TCAL<n>``, 1 to 3. Default: the IMU of the DataFlash log the
        calibration was fitted on (its provenance's ``log_sensor``), else 1.
    ramp_c_per_min : float
        Rate of the thermal cycle on which history-dependent terms are evaluated.
    gravity_g : sequence of 3 float, optional
        Gravity on the sensor axes (g) in the attitude the vehicle mostly holds; its
        sensitivity drift is then folded into the offsets. Default: zero-g offset only.

    Returns
    -------
    ArduPilotExport
    """
    if imu is None:
        imu = log_sensor(cal).get("ardupilot_imu", 1)
    if not 1 <= imu <= 3:
        raise ParameterError(f"ArduPilot has INS_TCAL1 … INS_TCAL3; imu {imu} is out of range")
    fit = fit_cubic_offsets(
        cal,
        t_ref_c=ARDUPILOT_T_REF_C,
        ramp_c_per_min=ramp_c_per_min,
        gravity_g=gravity_g,
        relative=False,
    )
    p = f"INS_TCAL{imu}"
    params: dict[str, float] = {
        f"{p}_ENABLE": 1,
        f"{p}_TMIN": fit.range_c[0],
        f"{p}_TMAX": fit.range_c[1],
    }
    for k in (1, 2, 3):
        for axis in fit.axes:
            params[f"{p}_ACC{k}_{axis.axis.upper()}"] = axis.coefficients_m_s2[k] * ARDUPILOT_SCALE
    return ArduPilotExport(imu=imu, fit=fit, params=params, source=describe(cal))
