"""PX4's accelerometer thermal compensation: ``TC_A<i>_*`` in a QGroundControl parameter file.

PX4 (``src/modules/temperature_compensation``) computes, per axis ``j`` (0 = x,
1 = y, 2 = z), with the temperature clipped to ``[TC_A<i>_TMIN, TC_A<i>_TMAX]``::

    d = T - TC_A<i>_TREF
    offset_j = X0_j + X1_j·d + X2_j·d² + X3_j·d³        (m/s²)
    corrected = (reading - offset - CAL_ACC<n>_xOFF) · CAL_ACC<n>_xSCALE

so the polynomial is the offset itself, in m/s², and PX4 subtracts it. The set
applies to the sensor whose device id equals ``TC_A<i>_ID``, and only with
``TC_A_ENABLE = 1``. PX4's own ``Tools/process_sensor_caldata.py`` fits the reading
minus its median, so its ``X0`` holds only the offset's change and the constant is
left to the accelerometer calibration; :func:`export_px4` does the same by default
(``relative=True``).

QGroundControl's parameter file (``ParameterManager::writeParametersToStream``) is
text: comment lines start with ``#``; every other line is five tab-separated fields
``vehicle-id  component-id  name  value  type``, ``type`` a ``MAV_PARAM_TYPE``
(6 = INT32, 9 = REAL32). QGroundControl refuses a file whose vehicle id differs from
the connected vehicle's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

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

__all__ = ["MAV_PARAM_TYPE_INT32", "MAV_PARAM_TYPE_REAL32", "Px4Export", "export_px4"]

#: MAVLink ``MAV_PARAM_TYPE`` codes used in the file.
MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9


@dataclass(frozen=True)
class Px4Export:
    """PX4 ``TC_A<i>_*`` parameters approximating a calibration.

    Attributes
    ----------
    instance : int
        The ``i`` of ``TC_A<i>`` (0 to 3).
    device_id : int
        ``TC_A<i>_ID``: the sensor's device id (PX4's ``CAL_ACC<n>_ID``).
    fit : CubicOffsetFit
        The cubic approximation and its residuals.
    params : dict of str to (value, MAV_PARAM_TYPE)
        Every parameter written, in file order.
    system_id, component_id : int
        The file's vehicle and component ids.
    source : str
        Which calibration was exported (for the file's comments).
    """

    instance: int
    device_id: int
    fit: CubicOffsetFit
    params: dict[str, tuple[float, int]]
    system_id: int
    component_id: int
    source: str

    def text(self) -> str:
        """Human summary: what was exported and what the cubic loses against our model."""
        lines = [f"PX4 thermal compensation TC_A{self.instance}_* from {self.source}"]
        lines += self.fit.lines()
        if self.device_id == 0:
            lines.append(
                f"  note: TC_A{self.instance}_ID is 0 and matches no sensor; pass device_id= "
                "(the value of the sensor's CAL_ACCn_ID)"
            )
        if self.fit.relative:
            lines.append(
                "  note: X0 holds the offset's change from T_ref; the constant offset is left to "
                "PX4's accelerometer calibration (recalibrate after loading, as PX4 advises)"
            )
        return "\n".join(lines)

    def file_text(self) -> str:
        """Return the QGroundControl parameter file."""
        head = [
            f"# Onboard parameters for Vehicle {self.system_id}",
            "#",
            f"# Accelerometer thermal compensation exported by accelcore from {self.source}",
            f"# cubic-offset approximation: max residual {self.fit.max_residual_mg:.4f} mg, "
            f"rms {self.fit.rms_residual_mg:.4f} mg",
            "#",
            "# Vehicle-Id Component-Id Name Value Type",
        ]
        rows = []
        for name, (value, kind) in self.params.items():
            text = str(int(value)) if kind == MAV_PARAM_TYPE_INT32 else float32_text(value)
            rows.append(f"{self.system_id}\t{self.component_id}\t{name}\t{text}\t{kind}")
        return "\n".join(head + rows) + "\n"

    def write(self, path: str | Path) -> None:
        """Write :meth:`file_text` to ``path`` (atomically)."""
        atomic_write(path, self.file_text())


def export_px4(
    cal: Calibration,
    *,
    instance: int | None = None,
    device_id: int | None = None,
    t_ref_c: float | None = None,
    ramp_c_per_min: float = 1.0,
    gravity_g: Sequence[float] | None = None,
    relative: bool = True,
    enable: bool = True,
    system_id: int = 1,
    component_id: int = 1,
) -> Px4Export:
    """Approximate a calibration by PX4's cubic thermal offsets.

    Parameters
    ----------
    cal : Calibration
    instance : int, optional
        ``i`` of ``TC_A<i>``, 0 to 3. Default: the ``sensor_accel`` instance of the
        ULog the calibration was fitted on (its provenance's ``log_sensor``), else 0.
    device_id : int, optional
        The sensor's device id (``CAL_ACC<n>_ID`` on the vehicle); 0 matches none.
        Default: the ``device_id`` that ULog logged (as PX4's int32 parameter holds
        it), else 0.
    t_ref_c : float, optional
        ``TC_A<i>_TREF``; default the middle of the calibrated range (as PX4's script).
    ramp_c_per_min : float
        Rate of the thermal cycle on which history-dependent terms are evaluated.
    gravity_g : sequence of 3 float, optional
        Gravity on the sensor axes (g) in the attitude the vehicle mostly holds; its
        sensitivity drift is then folded into the offsets (PX4's own calibration does
        this for the attitude it was logged in). Default: zero-g offset only.
    relative : bool
        Give the offset's change from ``t_ref_c`` (PX4's convention); False puts the
        whole offset in ``X0`` (then set ``CAL_ACC<n>_xOFF`` to 0).
    enable : bool
        Also write ``TC_A_ENABLE = 1``.
    system_id, component_id : int
        The vehicle and component ids of the file's lines.

    Returns
    -------
    Px4Export
    """
    logged = log_sensor(cal)
    if instance is None:
        instance = logged.get("px4_instance", 0)
    if device_id is None:
        # A uint32 in the log; PX4's parameter is an int32 of the same bits.
        found = logged.get("px4_device_id", 0)
        device_id = found - 2**32 if found >= 2**31 else found
    if not 0 <= instance <= 3:
        raise ParameterError(f"PX4 has TC_A0 … TC_A3; instance {instance} is out of range")
    if not -(2**31) <= device_id < 2**31:
        raise ParameterError(f"device_id {device_id} does not fit PX4's int32 parameter")
    lo, hi = cal.temperature_range_c
    ref = 0.5 * (lo + hi) if t_ref_c is None else float(t_ref_c)
    fit = fit_cubic_offsets(
        cal, t_ref_c=ref, ramp_c_per_min=ramp_c_per_min, gravity_g=gravity_g, relative=relative
    )
    p = f"TC_A{instance}"
    params: dict[str, tuple[float, int]] = {}
    if enable:
        params["TC_A_ENABLE"] = (1, MAV_PARAM_TYPE_INT32)
    params[f"{p}_ID"] = (device_id, MAV_PARAM_TYPE_INT32)
    params[f"{p}_TMAX"] = (fit.range_c[1], MAV_PARAM_TYPE_REAL32)
    params[f"{p}_TMIN"] = (fit.range_c[0], MAV_PARAM_TYPE_REAL32)
    params[f"{p}_TREF"] = (fit.t_ref_c, MAV_PARAM_TYPE_REAL32)
    for k in range(4):
        for j, axis in enumerate(fit.axes):
            params[f"{p}_X{k}_{j}"] = (axis.coefficients_m_s2[k], MAV_PARAM_TYPE_REAL32)
    return Px4Export(
        instance=instance,
        device_id=device_id,
        fit=fit,
        params=dict(sorted(params.items())),
        system_id=system_id,
        component_id=component_id,
        source=describe(cal),
    )
