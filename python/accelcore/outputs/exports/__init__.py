"""Exports room: a calibration in the formats other tools load.

- :func:`export_px4`: PX4's ``TC_A<i>_*`` thermal compensation, as a
  QGroundControl parameter file;
- :func:`export_ardupilot`: ArduPilot's ``INS_TCAL<n>_*`` temperature calibration,
  as a ``.param`` file;
- :func:`export_imucal`: imucal's ``FerrarisCalibrationInfo`` JSON at one temperature.

The flight stacks hold one cubic offset polynomial per axis, so those two exports
are least-squares approximations of our model over the calibrated range and report
what they lose (residual, max and RMS in mg, and the sensitivity drift they cannot
carry). Each result has ``.text()`` (a summary), ``.file_text()`` and ``.write(path)``.
The import of imucal's file is :func:`accelcore.result.foreign.read_imucal`.
Conventions, units and signs, with their sources: ``docs/interop.md``.

May import: the foundation, the model room and the result room only.
"""

from accelcore.outputs.exports._model import CubicOffset, CubicOffsetFit
from accelcore.outputs.exports.ardupilot import ArduPilotExport, export_ardupilot
from accelcore.outputs.exports.imucal import ImucalExport, export_imucal
from accelcore.outputs.exports.px4 import Px4Export, export_px4

__all__ = [
    "ArduPilotExport",
    "CubicOffset",
    "CubicOffsetFit",
    "ImucalExport",
    "Px4Export",
    "export_ardupilot",
    "export_imucal",
    "export_px4",
]
