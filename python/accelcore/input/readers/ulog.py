"""PX4 ULog files (``pip install accelcore[px4]``): one ``sensor_accel`` instance.

pyulog is optional: it is imported when :func:`read_ulog` is called, so that
``import accelcore`` works without it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np

from accelcore.errors import ParameterError
from accelcore.input.readers import common
from accelcore.input.readers.common import _check_file, _parse_error
from accelcore.input.readers.flightlog import (
    LEVEL_ORIENTATION,
    FlightRows,
    flight_session,
    require,
)
from accelcore.input.session import Session

__all__ = ["read_ulog"]

#: The first bytes of every ULog file ("ULog" then 0x01 0x12 0x35).
ULOG_MAGIC = b"ULog\x01\x12\x35"
TOPIC = "sensor_accel"
FIELDS = ("timestamp", "x", "y", "z", "temperature")


def read_ulog(
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
    """Read one accelerometer of a PX4 ULog file (needs ``pip install accelcore[px4]``).

    Reads the ``sensor_accel`` topic of one instance (``multi_id``): ``x``, ``y``,
    ``z`` in m/s² as the driver published them (before PX4's calibration and
    thermal compensation), ``temperature`` in °C and ``timestamp`` (µs since
    boot, kept as seconds since boot). PX4 logs ``sensor_accel`` when the
    ``SDLOG_PROFILE`` parameter asks for it (its thermal calibration or sensor
    comparison profiles); ``sensor_combined`` and ``vehicle_imu`` carry no
    temperature and are not read.

    Parameters
    ----------
    path : str or path-like
        The ``.ulg`` file.
    instance : int, default 0
        The ``multi_id`` of the ``sensor_accel`` instance (0 is the first IMU).
    orientation : str, default "OZ-"
        The orientation of the whole log (one run). PX4's sensor frame is FRD
        (z down), so a board lying flat reads -1 g on z: ``OZ-``.
    rate_hz : float, optional
        Sample rate of the logged topic; by default the median interval of the
        first chunk of samples (rounded to 6 significant digits).
    sensor, serial : str, optional
        Part name (for datasheet comparison) and serial of the session.
    decimation_factor, min_count, settle_s
        As in :func:`read_orientation_log`.

    Returns
    -------
    Session
        One run in ``m/s2``; ``path`` is None and the run's ``source`` is
        ``"FILE#sensor_accel[<instance>]:messages=<first>-<last>"``.

    Raises
    ------
    accelcore.AccelcoreError
        pyulog is not installed (the message names the extra).
    accelcore.ParseError
        Not a ULog file, a file pyulog cannot parse, no ``sensor_accel`` topic,
        or a field missing from it (the message names the file).
    accelcore.ParameterError
        No ``sensor_accel`` instance ``instance`` (the message lists those found).
    """
    pyulog = require("pyulog", "px4", "read_ulog")
    file = _check_file(path)
    if not isinstance(instance, int) or isinstance(instance, bool) or instance < 0:
        raise ParameterError(f"instance must be an integer >= 0, got {instance!r}")
    with open(file, "rb") as handle:
        magic = handle.read(len(ULOG_MAGIC))
    if magic != ULOG_MAGIC:
        raise _parse_error(file, 1, 1, "not a PX4 ULog file (no ULog header)", where=None)
    try:
        with open(file, "rb") as handle:
            ulog = pyulog.ULog(handle, message_name_filter_list=[TOPIC])
    except Exception as exc:  # pyulog raises ULogException, struct.error, ValueError...
        raise _parse_error(file, 1, 1, f"not a readable ULog file: {exc}", where=None) from None
    found = {d.multi_id: d for d in ulog.data_list if d.name == TOPIC}
    if not found:
        raise _parse_error(
            file,
            1,
            1,
            f"no '{TOPIC}' topic in the log (PX4 logs it when SDLOG_PROFILE asks for "
            "thermal calibration or sensor comparison topics)",
            where=None,
        )
    if instance not in found:
        raise ParameterError(
            f"{file}: no '{TOPIC}' instance {instance}; the log has instance(s) "
            f"{', '.join(str(k) for k in sorted(found))}"
        )
    data = found[instance].data
    missing = [f for f in FIELDS if f not in data]
    if missing:
        raise _parse_error(
            file,
            1,
            1,
            f"'{TOPIC}' instance {instance} has no field(s) {', '.join(missing)}",
            where=None,
        )

    def rows() -> Iterator[FlightRows]:
        n = len(data["timestamp"])
        for a in range(0, n, common.CHUNK_ROWS):
            b = min(a + common.CHUNK_ROWS, n)
            yield FlightRows(
                time_s=data["timestamp"][a:b].astype(np.float64) * 1e-6,
                temperature_c=data["temperature"][a:b].astype(np.float64),
                accel=np.column_stack([data[k][a:b].astype(np.float64) for k in "xyz"]),
            )

    # Who the sensor is on the vehicle: PX4 matches a thermal calibration to it
    # (TC_A<i>_ID); one device id over the log, else none.
    log_sensor = {"px4_instance": instance}
    ids = np.unique(data["device_id"]) if "device_id" in data else np.zeros(0)
    if ids.size == 1:
        log_sensor["px4_device_id"] = int(ids[0])
    return flight_session(
        rows(),
        file=file,
        stream=f"{TOPIC}[{instance}]",
        orientation=orientation,
        rate_hz=rate_hz,
        sensor=sensor,
        serial=serial,
        decimation_factor=decimation_factor,
        min_count=min_count,
        settle_s=settle_s,
        log_sensor=log_sensor,
    )
