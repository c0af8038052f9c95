"""What the flight-stack log readers share: one IMU's samples streamed into a one-run Session.

A flight log holds the accelerometer of each IMU as logged by the autopilot (m/s²,
its own temperature, microsecond timestamps). :func:`read_ulog` and
:func:`read_dataflash` turn the samples of one instance into chunks of
:class:`FlightRows`; :func:`flight_session` decimates them into a :class:`Session`
through the same segmenter as every other reader (with a factor of 1, every sample as
logged).

May import: the foundation, :mod:`accelcore.input.format`, :mod:`accelcore.input.session`
and the rest of :mod:`accelcore.input.readers`.
"""

from __future__ import annotations

import importlib
import itertools
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from types import ModuleType

import numpy as np

from accelcore._accelcore import RunTally
from accelcore.errors import AccelcoreError, ParameterError, SessionFormatError
from accelcore.input.format import gravity_of
from accelcore.input.readers.common import _check_rate, _check_settle, _FloatArray, _parse_error
from accelcore.input.readers.segment import _Chunk, _Layout, _segment
from accelcore.input.run import Run, RunStats
from accelcore.input.session import Session, default_decimation_factor
from accelcore.input.temperature_units import impossible_temperature, not_a_temperature

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
    log_sensor: Mapping[str, int] | None = None,
) -> Session:
    """Decimate one IMU's samples into a Session of one run in ``m/s2``.

    ``log_sensor``: the sensor's identity in the flight stack (:attr:`Session.log_sensor`).

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

    if factor == 1:
        # No decimation: every sample as logged. The block grid of factor 1 (one
        # interval wide, from the first sample) would put two jittered or exactly
        # gridded samples in one block and leave the next empty: compensate, which
        # asks for every sample, wrote averages at times the log does not hold.
        runs = [_every_sample(list(chunks()), layout, label, rate, settle)]
    else:
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
        log_sensor=dict(log_sensor or {}),
    )


def _every_sample(
    chunks: list[_Chunk], layout: _Layout, label: str, rate: float, settle_s: float
) -> Run:
    """One run of every sample as logged (one per block, count 1), checked as _segment checks."""
    pos = np.concatenate([c.positions for c in chunks])
    t = np.concatenate([c.time_s for c in chunks])
    temp = np.concatenate([c.temperature_c for c in chunks])
    acc = np.concatenate([c.channels for c in chunks])
    if t.size == 0:
        raise SessionFormatError(f"{layout.path}: {layout.row_word}s: no sample")
    where = f"{layout.path}:{layout.row_word}"
    if (k := impossible_temperature(temp)) is not None:
        raise _parse_error(
            layout.path,
            int(pos[k]),
            layout.temperature_column,
            not_a_temperature(float(temp[k])),
            where=f"{layout.row_word} {int(pos[k])}",
        )
    keep = np.isfinite(t) & np.isfinite(temp) & np.isfinite(acc).all(axis=1)
    if settle_s > 0 and keep.any():
        keep &= t >= t[keep][0] + settle_s
    back = np.flatnonzero(np.diff(t[keep]) <= 0)
    if back.size:
        i = int(pos[keep][back[0] + 1])
        before, after = t[keep][back[0]], t[keep][back[0] + 1]
        raise _parse_error(
            layout.path,
            i,
            layout.time_column,
            f"time is not strictly increasing: {before!r} s then {after!r} s",
            where=f"{layout.row_word} {i}",
        )
    if not keep.any():
        raise SessionFormatError(f"{where}s: no sample with finite values")
    tally = RunTally(n_channels=3, rate_hz=rate)
    tally.push(t, temp, acc)
    kept = pos[keep]
    return Run(
        orientation=label,
        gravity_g=gravity_of(label),
        time_s=t[keep].copy(),
        temperature_c=temp[keep].copy(),
        output=np.ascontiguousarray(acc[keep]),
        count=np.ones(int(keep.sum()), dtype=np.int64),
        extras={},
        source=f"{layout.path}#{layout.fragment}{int(kept[0])}-{int(kept[-1])}",
        stats=RunStats.from_raw(tally.finish()),
    )
