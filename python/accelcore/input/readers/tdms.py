"""NI TDMS files as LabVIEW writes them (``pip install accelcore[tdms]``), one run per group.

npTDMS is optional: it is imported when :func:`read_tdms` is called, so that
``import accelcore`` works without it.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from accelcore.errors import DataQualityWarning, ParameterError, SessionFormatError
from accelcore.input.format import check_units, gravity_of
from accelcore.input.headers import check_unique_names
from accelcore.input.readers import common
from accelcore.input.readers.common import (
    _check_file,
    _check_rate,
    _check_settle,
    _column_names,
    _FloatArray,
    _missing_columns,
    _parse_error,
    _time_scale,
    _timestamp_seconds,
)
from accelcore.input.readers.segment import _RunBuilder
from accelcore.input.session import Run, Session, default_decimation_factor

__all__ = ["read_tdms"]


def _nominal_rate(rate_hz: float) -> float:
    """Round a rate computed from an interval to 10 significant digits (0.05 s gives 20 Hz).

    A rate a hair below the nominal one would shift every block boundary that
    falls exactly on a sample.
    """
    return float(f"{rate_hz:.10g}")


def _tdms_prop(obj: Any, name: str) -> Any:
    props = getattr(obj, "properties", {})
    return props.get(name)


def _tdms_time(data: NDArray[Any], origin: list[Any], scale: float) -> _FloatArray:
    """Seconds of a time channel chunk; timestamps count from the group's first one."""
    if np.issubdtype(data.dtype, np.datetime64):
        return _timestamp_seconds(data, origin)
    return np.asarray(data, dtype=np.float64) * scale


def read_tdms(
    path: str | os.PathLike[str],
    *,
    units: str,
    rate_hz: float | None = None,
    group: str | Sequence[str] | None = None,
    channel_map: Mapping[str, str] | None = None,
    orientation: str | Mapping[str, str] | None = None,
    time_unit: str = "s",
    sensor: str | None = None,
    serial: str | None = None,
    decimation_factor: int | None = None,
    min_count: int = 1,
    settle_s: float = 0.0,
) -> Session:
    """Read an NI TDMS file as LabVIEW writes it (needs ``pip install accelcore[tdms]``).

    Expected layout: one group per run, holding a channel per quantity (names
    from ``channel_map``, defaults ``time_s, temp_c, x, y, z``). The time channel
    is optional: without it, time is computed from the x channel's waveform
    properties, ``wf_start_offset + i / rate`` s with ``rate = 1 / wf_increment``
    rounded to 10 significant digits (``wf_start_time``,
    the absolute start, is not needed). Every other numeric channel of the group
    with the same length is kept as an extra observable. The group's
    ``orientation`` property names its orientation unless ``orientation`` is given.
    Channels are read in slices of :data:`CHUNK_ROWS` samples.

    Parameters
    ----------
    path : str or path-like
        The ``.tdms`` file (its ``.tdms_index``, if any, is used by npTDMS).
    units : str
        ``V``, ``LSB``, ``g``, ``mg`` or ``m/s2``.
    rate_hz : float, optional
        Nominal sample rate; default ``1 / wf_increment`` of the x channel, else
        1 / the median interval of the time channel's first 1000 intervals, both
        rounded to 10 significant digits.
    group : str or sequence of str, optional
        The group(s) to read, in this order; default every group holding the
        x, y, z and temperature channels, in file order.
    channel_map : mapping, optional
        Channel names of ``time``, ``temperature``, ``x``, ``y``, ``z``
        (``temperature=""``: none logged).
    orientation : str or mapping of group name to str, optional
        Orientation of every group (a one-run file), or of each group; default
        each group's ``orientation`` property.
    time_unit : str, default "s"
        Unit of a numeric time channel (``sample``, a sample index, needs
        ``rate_hz``); a timestamp channel counts seconds from the group's first
        sample.
    sensor, serial : str, optional
        Default: the file's (root) ``sensor`` and ``serial`` properties, if any.
    decimation_factor, min_count, settle_s
        As in :func:`read_orientation_log`.

    Returns
    -------
    Session
        ``path`` is None; each run's ``source`` is ``"FILE#GROUP"``.

    Raises
    ------
    ImportError
        npTDMS is not installed.
    accelcore.SessionFormatError
        No usable group, a group without orientation, or no way to get the rate.
    accelcore.ParseError
        Missing channels (the message names the file and group) or time not increasing.
    """
    try:
        from nptdms import TdmsFile
    except ImportError as exc:
        raise ImportError("read_tdms needs npTDMS: pip install accelcore[tdms]") from exc
    file = _check_file(path)
    units = check_units(units, "units")
    rate_arg = None if rate_hz is None else _check_rate(rate_hz)
    settle = _check_settle(settle_s)
    scale = _time_scale(time_unit, rate_arg)
    names = _column_names(channel_map)
    needed = [names[r] for r in ("temperature", "x", "y", "z") if names[r]]
    runs: list[Run] = []
    try:
        tdms = TdmsFile.open(file)
    except Exception as exc:  # npTDMS raises plain ValueError/KeyError on bad files
        raise _parse_error(file, 1, 1, f"not a TDMS file: {exc}", where=None) from None
    with tdms:
        all_groups = tdms.groups()
        by_name = {g.name: g for g in all_groups}
        if group is None:
            chosen = [
                g for g in all_groups if all(c in [ch.name for ch in g.channels()] for c in needed)
            ]
            if not chosen:
                listing = "; ".join(
                    f"{g.name!r}: {', '.join(repr(c.name) for c in g.channels())}"
                    for g in all_groups
                )
                raise SessionFormatError(
                    f"{file}: no group holds the channels {', '.join(map(repr, needed))} "
                    f"(groups: {listing or 'none'}); pass channel_map= or group= "
                    "([columns] or group = in session.toml)"
                )
        else:
            wanted_groups = [group] if isinstance(group, str) else list(group)
            unknown = [g for g in wanted_groups if g not in by_name]
            if unknown:
                raise SessionFormatError(
                    f"{file}: no group {', '.join(map(repr, unknown))}; "
                    f"found {', '.join(repr(g) for g in by_name)}"
                )
            chosen = [by_name[g] for g in wanted_groups]
        if isinstance(orientation, str) and len(chosen) > 1:
            raise ParameterError(
                f"{file}: orientation={orientation!r} given for {len(chosen)} groups; "
                "pass a mapping of group name to orientation"
            )
        root = tdms.properties
        sensor = (
            sensor if sensor is not None else (str(root["sensor"]) if "sensor" in root else None)
        )
        serial = (
            serial if serial is not None else (str(root["serial"]) if "serial" in root else None)
        )
        rate_used: float | None = rate_arg
        factor: int | None = decimation_factor
        for g in chosen:
            run, rate_g, factor = _tdms_group(
                file,
                g,
                names=names,
                orientation=orientation,
                rate_hz=rate_arg,
                scale=scale,
                factor=factor,
                min_count=min_count,
                settle_s=settle,
            )
            if rate_used is None:
                rate_used = rate_g
            if run is not None:
                runs.append(run)
    if not runs or rate_used is None or factor is None:
        raise SessionFormatError(f"{file}: no run with valid data")
    return Session(
        runs=tuple(runs),
        units=units,
        rate_hz=rate_used,
        sensor=sensor,
        serial=serial,
        path=None,
        decimation_factor=factor,
    )


def _tdms_group(
    file: str,
    g: Any,
    *,
    names: Mapping[str, str],
    orientation: str | Mapping[str, str] | None,
    rate_hz: float | None,
    scale: float,
    factor: int | None,
    min_count: int,
    settle_s: float,
) -> tuple[Run | None, float, int]:
    """Decimate one TDMS group into a run; also return the rate and the factor used.

    Without a ``factor``, the default of the group's rate
    (:func:`~accelcore.input.session.default_decimation_factor`).
    """
    where = f"{file}#{g.name}"
    check_unique_names(where, [c.name for c in g.channels()], header_line=False)
    channels = {c.name: c for c in g.channels()}
    needed = [names[r] for r in ("temperature", "x", "y", "z") if names[r]]
    if any(c not in channels for c in needed):
        raise _missing_columns(where, list(channels), needed, header_line=False)
    if orientation is None:
        label = _tdms_prop(g, "orientation")
        if label is None:
            raise SessionFormatError(
                f"{where}: the group has no 'orientation' property; pass orientation= "
                "(orientation = in session.toml)"
            )
    elif isinstance(orientation, str):
        label = orientation
    else:
        if g.name not in orientation:
            raise ParameterError(f"{where}: orientation= has no entry for group {g.name!r}")
        label = orientation[g.name]
    try:
        gravity_of(str(label))
        label = str(label).strip().upper()
    except SessionFormatError as exc:
        raise SessionFormatError(f"{where}: {exc}") from None
    x = channels[names["x"]]
    time_ch = channels.get(names["time"])
    increment = _tdms_prop(x, "wf_increment")
    if time_ch is None and not increment:
        raise SessionFormatError(
            f"{where}: no time channel {names['time']!r} and no wf_increment property "
            f"on channel {names['x']!r}: cannot tell when the samples were taken"
        )
    wf_rate = _nominal_rate(1.0 / float(increment)) if increment else None
    start = float(_tdms_prop(x, "wf_start_offset") or 0.0)
    lengths = {c: len(channels[c]) for c in needed}
    if time_ch is not None:
        lengths[time_ch.name] = len(time_ch)
    n = min(lengths.values())
    if len(set(lengths.values())) > 1:
        warnings.warn(
            f"{where}: channels of different lengths ({lengths}); reading the first {n} samples",
            DataQualityWarning,
            stacklevel=3,
        )
    extras = [
        c.name
        for c in g.channels()
        if c.name not in needed
        and c.name != names["time"]
        and len(c) == n
        and np.issubdtype(np.dtype(c.dtype), np.number)
    ]
    origin: list[Any] = []
    rate = rate_hz or wf_rate
    if rate is None:
        assert time_ch is not None
        head = _tdms_time(time_ch.read_data(0, min(n, 1001)), origin, scale)
        steps = np.diff(head[np.isfinite(head)])
        if steps.size == 0 or not np.median(steps) > 0:
            raise SessionFormatError(
                f"{where}: cannot infer the sample rate from the time channel; pass rate_hz="
            )
        rate = _nominal_rate(1.0 / float(np.median(steps)))
    if factor is None:
        factor = default_decimation_factor(rate)
    builder = _RunBuilder(
        label,
        source=where,
        path=where,
        time_column=1,
        n_channels=3 + len(extras),
        extra_names=extras,
        factor=factor,
        rate_hz=rate,
        min_count=min_count,
        settle_s=settle_s,
        row_word="sample",
        temperature=bool(names["temperature"]),
    )
    order = [names["x"], names["y"], names["z"], *extras]
    for a in range(0, n, common.CHUNK_ROWS):
        m = min(common.CHUNK_ROWS, n - a)
        if time_ch is not None:
            t = _tdms_time(time_ch.read_data(a, m), origin, scale)
        else:
            assert wf_rate is not None
            t = start + np.arange(a, a + m, dtype=np.float64) / wf_rate
        temp = (
            np.asarray(channels[names["temperature"]].read_data(a, m), dtype=np.float64)
            if names["temperature"]
            else t
        )
        data = np.column_stack(
            [np.asarray(channels[c].read_data(a, m), dtype=np.float64) for c in order]
        )
        builder.push(t, temp, data, np.arange(a + 1, a + m + 1, dtype=np.int64))
    if n == 0:
        warnings.warn(f"{where}: empty group, skipped", DataQualityWarning, stacklevel=3)
        return None, rate, factor
    return builder.finish(), rate, factor
