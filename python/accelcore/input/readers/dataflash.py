"""ArduPilot DataFlash ``.bin`` logs (``pip install accelcore[ardupilot]``): one ``IMU`` instance.

The logged samples are taken back to what the sensor read: the board rotation and
ArduPilot's temperature correction and accelerometer calibration are undone with the
log's own parameters (:mod:`accelcore.input.readers.ardupilot_undo`).

pymavlink is optional: it is imported when :func:`read_dataflash` is called, so
that ``import accelcore`` works without it.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator
from typing import Any

import numpy as np

from accelcore.errors import DataQualityWarning, ParameterError
from accelcore.input.readers import common
from accelcore.input.readers.ardupilot_undo import ROTATION, LoggedCorrections
from accelcore.input.readers.common import _check_file, _parse_error
from accelcore.input.readers.flightlog import (
    LEVEL_ORIENTATION,
    FlightRows,
    check_orientation,
    flight_session,
    require,
)
from accelcore.input.session import Session

__all__ = ["read_dataflash"]

#: Every binary DataFlash log starts with a message header (0xA3 0x95) and the
#: format message (FMT, type 0x80) that describes FMT itself.
DATAFLASH_MAGIC = b"\xa3\x95\x80"
FIELDS = ("TimeUS", "AccX", "AccY", "AccZ", "T")


def _stream_name(reader: Any, file: str, instance: int) -> tuple[str, bool]:
    """Find the message type to read and whether it carries an instance field ``I``.

    ArduPilot 4.1 and later log every IMU as ``IMU`` with an instance field;
    older logs use ``IMU``, ``IMU2``, ``IMU3``.
    """
    if "IMU" not in reader.name_to_id:
        raise _parse_error(file, 1, 1, "no IMU message format (FMT) in the log", where=None)
    columns = reader.formats[reader.name_to_id["IMU"]].columns
    if "I" in columns:
        name, by_field = "IMU", True
    else:
        name, by_field = ("IMU" if instance == 0 else f"IMU{instance + 1}"), False
        if name not in reader.name_to_id:
            olds = [n for n in ("IMU", "IMU2", "IMU3") if n in reader.name_to_id]
            raise ParameterError(
                f"{file}: no IMU instance {instance}; the log has instance(s) "
                f"{', '.join(str(k) for k in range(len(olds)))}"
            )
        columns = reader.formats[reader.name_to_id[name]].columns
    missing = [f for f in FIELDS if f not in columns]
    if missing:
        raise _parse_error(
            file, 1, 1, f"message {name} has no field(s) {', '.join(missing)}", where=None
        )
    return name, by_field


def read_dataflash(
    path: str | os.PathLike[str],
    *,
    instance: int = 0,
    orientation: str = LEVEL_ORIENTATION,
    rate_hz: float | None = None,
    sensor: str | None = None,
    serial: str | None = None,
    decimation_factor: int | None = None,
    min_count: int = 1,
    settle_s: float = 0.0,
) -> Session:
    """Read one accelerometer of an ArduPilot DataFlash log (``pip install accelcore[ardupilot]``).

    Reads the ``IMU`` messages of one instance (field ``I``; ``IMU2``/``IMU3``
    in logs older than ArduPilot 4.1): ``AccX``, ``AccY``, ``AccZ`` in m/s², ``T``
    in °C and ``TimeUS`` (µs since boot, kept as seconds since boot). Only binary
    logs (``.bin``) are read.

    ArduPilot logs the acceleration after its own corrections, in the body frame:
    what the log's parameters say it did is undone, as ArduPilot's ``tempcal_IMU.py``
    does before it fits (:mod:`accelcore.input.readers.ardupilot_undo`). The board
    rotation ``AHRS_ORIENTATION`` is turned back, and the run labelled in the sensor's
    frame (a board mounted upside down, ``AHRS_ORIENTATION = 8``, lying level is
    ``OZ+``); the temperature correction (``INS_TCAL<n>_ENABLE = 1``) and the
    accelerometer offsets and scale are taken back out. The calibration is then the
    sensor's own, in the frame ArduPilot's ``INS_TCAL`` parameters act in. Where
    the rotation would put gravity off the sensor's axes (a board turned by 45°),
    the data stay in the body frame, corrections undone, with a
    :class:`~accelcore.DataQualityWarning`.

    Parameters
    ----------
    path : str or path-like
        The ``.bin`` file.
    instance : int, default 0
        The IMU instance (0 is the first IMU).
    orientation : str, default "OZ-"
        The orientation of the whole log (one run) in the body frame as logged.
        ArduPilot's body frame is FRD (z down), so a vehicle standing level reads
        -1 g on z: ``OZ-``.
    rate_hz : float, optional
        Logging rate of the IMU messages; by default the median interval of the
        first chunk of samples (rounded to 6 significant digits).
    sensor, serial : str, optional
        Part name (for datasheet comparison) and serial of the session.
    decimation_factor, min_count, settle_s
        As in :func:`read_orientation_log`.

    Returns
    -------
    Session
        One run in ``m/s2``; ``path`` is None and the run's ``source`` is
        ``"FILE#IMU[<instance>]:messages=<first>-<last>"``.

    Raises
    ------
    accelcore.AccelcoreError
        pymavlink is not installed (the message names the extra).
    accelcore.ParseError
        Not a binary DataFlash log, no ``IMU`` message format, or a field
        missing from it (the message names the file).
    accelcore.ParameterError
        No IMU instance ``instance`` (the message lists those found), or an
        ``AHRS_ORIENTATION`` that changes during the log. One pymavlink's table of
        rotations does not hold (a custom rotation) is warned of, and the data are
        read as logged.
    """
    dfreader = require("pymavlink.DFReader", "ardupilot", "read_dataflash")
    file = _check_file(path)
    if not isinstance(instance, int) or isinstance(instance, bool) or instance < 0:
        raise ParameterError(f"instance must be an integer >= 0, got {instance!r}")
    with open(file, "rb") as handle:
        magic = handle.read(len(DATAFLASH_MAGIC))
    if magic != DATAFLASH_MAGIC:
        raise _parse_error(
            file, 1, 1, "not an ArduPilot DataFlash log (no binary FMT header)", where=None
        )
    try:
        reader = dfreader.DFReader_binary(file, zero_time_base=False)
    except Exception as exc:  # pymavlink raises struct.error, ValueError, KeyError...
        raise _parse_error(file, 1, 1, f"not a readable DataFlash log: {exc}", where=None) from None
    with reader:  # closes the file and its memory map
        return _read(
            reader,
            file,
            instance,
            orientation,
            rate_hz,
            sensor,
            serial,
            decimation_factor,
            min_count,
            settle_s,
        )


def _read(
    reader: Any,
    file: str,
    instance: int,
    orientation: str,
    rate_hz: float | None,
    sensor: str | None,
    serial: str | None,
    decimation_factor: int | None,
    min_count: int,
    settle_s: float,
) -> Session:
    name, by_field = _stream_name(reader, file, instance)
    seen: set[int] = set()
    logged = LoggedCorrections.scan(reader, instance, file)
    undo = logged.changes_data
    body_label = check_orientation(orientation, f"IMU[{instance}]")
    sensor_label = logged.sensor_label(body_label)
    # Back to the sensor's frame, unless gravity would then lie off its axes (a
    # board turned by 45° or 7°): then corrections undone, in the logged frame.
    rotate = sensor_label is not None

    def rows() -> Iterator[FlightRows]:
        buffer: list[tuple[float, float, float, float, float]] = []
        n_kept = 0

        def flush() -> FlightRows:
            a = np.asarray(buffer, dtype=np.float64).reshape(-1, 5)
            buffer.clear()
            accel = a[:, 1:4]
            if undo:
                accel = logged.undo(a[:, 0], a[:, 4], accel, rotate=rotate)
            return FlightRows(time_s=a[:, 0] * 1e-6, temperature_c=a[:, 4], accel=accel)

        while True:
            m = reader.recv_match(type=name)
            if m is None:
                break
            if by_field:
                seen.add(int(m.I))
                if m.I != instance:
                    continue
            buffer.append((m.TimeUS, m.AccX, m.AccY, m.AccZ, m.T))
            n_kept += 1
            if len(buffer) == common.CHUNK_ROWS:
                yield flush()
        if buffer:
            yield flush()
        if n_kept == 0:
            if by_field and instance not in seen:
                found = ", ".join(str(k) for k in sorted(seen)) or "none"
                raise ParameterError(
                    f"{file}: no IMU instance {instance}; the log has instance(s) {found}"
                )
            raise _parse_error(file, 1, 1, f"no {name} message in the log", where=None)

    session = flight_session(
        rows(),
        file=file,
        stream=f"IMU[{instance}]",
        orientation=sensor_label or body_label,
        rate_hz=rate_hz,
        sensor=sensor,
        serial=serial,
        decimation_factor=decimation_factor,
        min_count=min_count,
        settle_s=settle_s,
        log_sensor={"ardupilot_imu": instance + 1},  # INS_TCAL<n>: n is 1-based
    )
    if not logged.known:
        warnings.warn(
            f"{file}: {ROTATION} = {logged.rotation:g} in the log is not one of the board "
            "rotations pymavlink's table holds: its IMU data are read as logged, in the "
            "board's rotated (body) frame and with ArduPilot's corrections in them; an "
            "ArduPilot export of this calibration would correct the wrong axes",
            DataQualityWarning,
            stacklevel=3,
        )
    elif logged.rotation and not rotate:
        warnings.warn(
            f"{file}: {ROTATION} = {logged.rotation:g} in the log turns {body_label} off the "
            "sensor's axes, so its IMU data stay in the board's rotated (body) frame "
            "(ArduPilot's corrections undone); ArduPilot applies a temperature correction "
            "in the sensor's frame, so an ArduPilot export of this calibration would "
            "correct the wrong axes",
            DataQualityWarning,
            stacklevel=3,
        )
    return session
