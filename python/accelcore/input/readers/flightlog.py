"""What the flight-stack log readers share: one IMU's samples streamed into a one-run Session.

A flight log holds the accelerometer of each IMU as logged by the autopilot (m/s²,
its own temperature, microsecond timestamps). :func:`read_ulog` and
:func:`read_dataflash` turn the samples of one instance into chunks of
:class:`FlightRows`; :func:`flight_session` decimates them into a :class:`Session`
through the same segmenter as every other reader.

May import: the foundation, :mod:`accelcore.input.format`, :mod:`accelcore.input.session`
and the rest of :mod:`accelcore.input.readers`.
"""

from __future__ import annotations

import importlib
import itertools
from collections.abc import Iterator
from dataclasses import dataclass
from types import ModuleType

import numpy as np

from accelcore.errors import AccelcoreError, ParameterError, SessionFormatError
from accelcore.input.format import gravity_of
from accelcore.input.readers.common import _check_rate, _check_settle, _FloatArray
from accelcore.input.readers.segment import _Chunk, _Layout, _segment
from accelcore.input.session import Session, default_decimation_factor

__all__ = ["FlightRows", "flight_session", "require"]

#: Orientation of a board lying flat: PX4 and ArduPilot log the body frame FRD
#: (z down), so a level, resting IMU reads about -9.8 m/s² on z.
LEVEL_ORIENTATION = "OZ-"


@dataclass
class FlightRows:
    """Consecutive samples of one IMU: time (s), temperature (°C), acceleration (n, 3)."""

    time_s: _FloatArray
    temperature_c: _FloatArray
    accel: _FloatArray


def require(module: str, extra: str, who: str) -> ModuleType:
    """Import an optional dependency, or raise one line naming the extra to install.

    Raises
    ------
    accelcore.AccelcoreError
        The module is not installed.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        raise AccelcoreError(
            f"{who} needs {module.split('.')[0]}: pip install accelcore[{extra}]"
        ) from None


def check_orientation(orientation: str, who: str) -> str:
    """Return the canonical orientation label, or raise a ParameterError."""
    try:
        gravity_of(orientation)
    except (SessionFormatError, AttributeError):
        raise ParameterError(
            f"{who}: unknown orientation {orientation!r}; expected one of OX+ OX- OY+ OY- OZ+ OZ-"
        ) from None
    return orientation.strip().upper()


def estimate_rate(time_s: _FloatArray) -> float:
    """Estimate the log's sample rate from the median interval between finite time stamps.

    Rounded to 6 significant digits, so that jitter in the last microsecond does
    not move the block grid from one log to the next.
    """
    t = time_s[np.isfinite(time_s)]
    steps = np.diff(t)
    steps = steps[steps > 0]
    if steps.size == 0:
        raise ParameterError("fewer than two distinct time stamps: give rate_hz")
    return float(f"{1.0 / float(np.median(steps)):.6g}")


def flight_session(
    rows: Iterator[FlightRows],
    *,
    file: str,
    stream: str,
    orientation: str,
    rate_hz: float | None,
    sensor: str | None,
    serial: str | None,
    decimation_factor: int | None,
    min_count: int,
    settle_s: float,
) -> Session:
    """Decimate one IMU's samples into a Session of one run in ``m/s2``.

    ``stream`` names the samples in messages and sources (``sensor_accel[0]``);
    each run's ``source`` is ``FILE#<stream>:messages=<first>-<last>`` (1-based
    message numbers of that instance).
    """
    settle = _check_settle(settle_s)
    label = check_orientation(orientation, stream)
    if rate_hz is None:
        first = next(rows, None)
        if first is None:
            raise SessionFormatError(f"{file}: {stream}: no sample")
        try:
            rate = estimate_rate(first.time_s)
        except ParameterError as exc:
            raise ParameterError(f"{file}: {stream}: {exc}") from None
        rows = itertools.chain([first], rows)
    else:
        rate = _check_rate(rate_hz)
    factor = default_decimation_factor(rate) if decimation_factor is None else decimation_factor
    layout = _Layout(
        path=file,
        time_column=1,
        temperature_column=5,  # time, x, y, z, temperature: as the messages' rows
        extra_names=[],
        n_channels=3,
        row_word=f"{stream} message",
        fragment=f"{stream}:messages=",
    )

    def chunks() -> Iterator[_Chunk]:
        first_pos = 1
        for r in rows:
            n = r.time_s.shape[0]
            yield _Chunk(
                time_s=np.ascontiguousarray(r.time_s, dtype=np.float64),
                temperature_c=np.ascontiguousarray(r.temperature_c, dtype=np.float64),
                channels=np.ascontiguousarray(r.accel, dtype=np.float64).reshape(n, 3),
                positions=np.arange(first_pos, first_pos + n, dtype=np.int64),
                labels=None,
            )
            first_pos += n

    runs = _segment(
        chunks(),
        layout,
        orientation=label,
        factor=factor,
        rate_hz=rate,
        min_count=min_count,
        settle_s=settle,
    )
    return Session(
        runs=tuple(runs),
        units="m/s2",
        rate_hz=rate,
        sensor=sensor,
        serial=serial,
        path=None,
        decimation_factor=factor,
    )
