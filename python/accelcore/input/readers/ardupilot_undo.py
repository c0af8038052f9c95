"""What ArduPilot did to an IMU's samples before it logged them, and how it is undone.

ArduPilot corrects every accelerometer sample in the sensor's frame, then rotates it
into the vehicle's body frame, where the ``IMU`` messages log it
(``AP_InertialSensor_Backend::_rotate_and_correct_accel``)::

    logged  = R · (S ⊙ (a − tcal(T) − offs))
    tcal(T) = P(clip(T) − 35) − P(clip(T_cal) − 35)      only with INS_TCAL<n>_ENABLE = 1
    P(t)    = (ACC1·t + ACC2·t² + ACC3·t³) · 1e-6

``R`` is the board rotation ``AHRS_ORIENTATION`` names (pymavlink's table of
ArduPilot's rotations, the one ArduPilot's ``tempcal_IMU.py`` reads), ``S`` and
``offs`` the accelerometer calibration (``INS_ACCSCAL_*``/``INS_ACCOFFS_*``, from the
second IMU on ``INS_ACC<n>SCAL_*``/``INS_ACC<n>OFFS_*``), ``T`` the IMU's temperature,
clipped to ``[INS_TCAL<n>_TMIN, INS_TCAL<n>_TMAX]`` as ``T_cal``
(``INS_ACC<n>_CALTEMP``) is (``AP_InertialSensor_TCal::correct_sensor``).
:class:`LoggedCorrections` inverts it, ``a = offs + (Rᵀ·logged) / S + tcal(T)``: the
sensor's own reading, which a calibration is of and which ArduPilot's ``INS_TCAL``
correction acts on.

ArduPilot writes its parameter dump while it already logs ``IMU``, so the parameters
are read from every ``PARM`` message first (:meth:`LoggedCorrections.scan`): each
one's first value holds from the start of the log, a later change from its time stamp.

May import: the foundation, :mod:`accelcore.input.format` and
:mod:`accelcore.input.readers.flightlog`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from accelcore.constants import ARDUPILOT_SCALE, ARDUPILOT_T_REF_C, AXES, ORIENTATIONS
from accelcore.errors import ParameterError
from accelcore.input.format import gravity_of
from accelcore.input.readers.flightlog import require

__all__ = ["ROTATION", "LoggedCorrections", "rotation_matrix"]

FloatArray = NDArray[np.float64]

#: Board rotation parameter.
ROTATION = "AHRS_ORIENTATION"

#: A value of a parameter ArduPilot has not been given (its defaults).
_DEFAULTS = {"ENABLE": 0.0, "SCAL": 1.0, "OFFS": 0.0, "CALTEMP": -300.0}

#: A rotation is taken as taking an axis onto an axis within this (pymavlink computes
#: its matrices with sines and cosines: 6e-17 where 0 is meant).
_AXIS_TOLERANCE = 1e-9


def rotation_matrix(rotation: float) -> FloatArray | None:
    """Return the matrix of ArduPilot's board rotation ``rotation`` (body = R · board).

    None for a rotation pymavlink's table does not hold (the custom rotations, 100 and
    up, and those ArduPilot added after pymavlink's table).
    """
    rotations = require("pymavlink.rotmat", "ardupilot", "read_dataflash").rotations
    if rotation < 0 or rotation >= len(rotations) or rotation != int(rotation):
        return None
    r = rotations[int(rotation)].r
    return np.array(
        [[row.x, row.y, row.z] for row in (r.a, r.b, r.c)],
        dtype=np.float64,
    )


def _label_of(gravity: FloatArray) -> str | None:
    """Return the orientation label of an axis-aligned gravity vector, else None."""
    for label, g in ORIENTATIONS.items():
        if np.all(np.abs(gravity - np.asarray(g)) <= _AXIS_TOLERANCE):
            return label
    return None


class LoggedCorrections:
    """The corrections ArduPilot applied to one IMU's logged samples, over the log's time.

    Parameters
    ----------
    instance : int
        The IMU instance (0-based; ``n = instance + 1`` in the parameter names).
    parms : iterable of (float, str, float)
        Every ``PARM`` message of the log: time stamp (µs), name, value, in log order.
    file : str
        The log, for messages.
    """

    def __init__(self, instance: int, parms: Iterable[tuple[float, str, float]], file: str):
        n = instance + 1
        cal = "" if n == 1 else str(n)
        tcal = f"INS_TCAL{n}"
        self._names = {
            f"{tcal}_ENABLE": "ENABLE",
            f"{tcal}_TMIN": "TMIN",
            f"{tcal}_TMAX": "TMAX",
            f"INS_ACC{n}_CALTEMP": "CALTEMP",
            ROTATION: "ROTATION",
        }
        for a in AXES:
            u = a.upper()
            self._names[f"INS_ACC{cal}OFFS_{u}"] = f"OFFS_{u}"
            self._names[f"INS_ACC{cal}SCAL_{u}"] = f"SCAL_{u}"
            for k in (1, 2, 3):
                self._names[f"{tcal}_ACC{k}_{u}"] = f"ACC{k}_{u}"
        first: dict[str, float] = {}
        changes: list[tuple[float, str, float]] = []
        current: dict[str, float] = {}
        for time_us, name, value in parms:
            key = self._names.get(name)
            if key is None:
                continue
            if key not in first:
                first[key] = current[key] = float(value)
            elif float(value) != current[key]:
                current[key] = float(value)
                changes.append((float(time_us), key, float(value)))
        self.starts_us: list[float] = [-np.inf]
        self.regimes: list[dict[str, float]] = [dict(first)]
        for time_us, key, value in sorted(changes, key=lambda c: c[0]):
            if time_us == self.starts_us[-1]:
                self.regimes[-1][key] = value
            else:
                self.starts_us.append(time_us)
                self.regimes.append({**self.regimes[-1], key: value})
        rotations = {r.get("ROTATION", 0.0) for r in self.regimes}
        if len(rotations) > 1:
            seen = ", ".join(f"{r:g}" for r in sorted(rotations))
            raise ParameterError(
                f"{file}: {ROTATION} changes during the log ({seen}): "
                "its IMU data are in more than one frame"
            )
        self.rotation = rotations.pop()
        matrix = rotation_matrix(self.rotation) if self.rotation else np.eye(3)
        #: Whether the rotation is known: if not, nothing is undone (the frame it was
        #: corrected in cannot be reached).
        self.known = matrix is not None
        self.matrix = np.eye(3) if matrix is None else matrix

    @classmethod
    def scan(cls, reader: Any, instance: int, file: str) -> LoggedCorrections:
        """Read every ``PARM`` message of a pymavlink DataFlash reader, then rewind it."""
        parms: list[tuple[float, str, float]] = []
        while (m := reader.recv_match(type="PARM")) is not None:
            parms.append((float(m.TimeUS), str(m.Name), float(m.Value)))
        reader.rewind()
        return cls(instance, parms, file)

    @staticmethod
    def _get(values: dict[str, float], key: str) -> float:
        return values.get(key, _DEFAULTS.get(key.split("_")[0], 0.0))

    def sensor_label(self, body_label: str) -> str | None:
        """Return the sensor-frame label of a body-frame orientation (None: off any axis)."""
        return _label_of(self.matrix.T @ gravity_of(body_label))

    @property
    def changes_data(self) -> bool:
        """Whether :meth:`undo` changes the logged samples.

        A rotation, an accelerometer calibration or a temperature correction in force,
        and every one of them undoable.
        """
        corrected = any(
            self._get(r, "ENABLE") == 1.0
            or any(
                self._get(r, f"OFFS_{a}") != 0.0 or self._get(r, f"SCAL_{a}") not in (0.0, 1.0)
                for a in "XYZ"
            )
            for r in self.regimes
        )
        return self.known and (bool(self.rotation) or corrected)

    def undo(
        self, time_us: FloatArray, temperature_c: FloatArray, accel: FloatArray, *, rotate: bool
    ) -> FloatArray:
        """Return the sensor's own reading of logged samples (m/s², shape (n, 3)).

        ``rotate``: leave it in the sensor's frame (else rotated back into the logged
        body frame, corrections undone).
        """
        out = np.empty_like(accel)
        which = np.searchsorted(np.asarray(self.starts_us), time_us, side="right") - 1
        for k in np.unique(which):
            rows = which == k
            out[rows] = self._undo(self.regimes[int(k)], temperature_c[rows], accel[rows])
        return out if rotate else out @ self.matrix.T

    def _undo(
        self, values: dict[str, float], temperature_c: FloatArray, body: FloatArray
    ) -> FloatArray:
        get = self._get
        scale = np.array([get(values, f"SCAL_{a}") for a in "XYZ"])
        # ArduPilot multiplies by the scale as set; a 0 would have zeroed the axis.
        scale = np.where(scale == 0.0, 1.0, scale)
        offs = np.array([get(values, f"OFFS_{a}") for a in "XYZ"])
        # Row vectors: Rᵀ·v for each row is v @ R.
        a = offs + (body @ self.matrix) / scale
        if get(values, "ENABLE") == 1.0:
            lo, hi = get(values, "TMIN"), get(values, "TMAX")
            c = np.array([[get(values, f"ACC{k}_{u}") for u in "XYZ"] for k in (1, 2, 3)])
            a = (
                a
                + _poly(_constrain(temperature_c, lo, hi), c)
                - _poly(_constrain(np.array([get(values, "CALTEMP")]), lo, hi), c)
            )
        return np.asarray(a, dtype=np.float64)


def _constrain(t: FloatArray, lo: float, hi: float) -> FloatArray:
    """ArduPilot's ``constrain_float``: below ``lo`` is ``lo``, else above ``hi`` is ``hi``."""
    return np.where(t < lo, lo, np.where(t > hi, hi, t))


def _poly(t_c: FloatArray, coefficients: Sequence[Sequence[float]] | FloatArray) -> FloatArray:
    """ArduPilot's ``P(t)`` at ``t_c - 35`` for each axis: shape (n, 3), m/s²."""
    c = np.asarray(coefficients, dtype=np.float64) / ARDUPILOT_SCALE
    t = (np.asarray(t_c, dtype=np.float64) - ARDUPILOT_T_REF_C)[:, None]
    return np.asarray(((c[0] + (c[1] + c[2] * t) * t) * t), dtype=np.float64)
