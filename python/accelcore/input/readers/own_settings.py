"""What a single log says of itself: enough to read it without ``session.toml``, or why not.

A log given alone, with no ``session.toml`` naming it, is read with the settings
it states and the defaults of everything else (no setting is guessed):

- a Parquet file states its units in its key-value metadata (``units``; optional
  ``rate_hz``, ``time_unit``, ``sensor``, ``serial``), the rate else coming from
  the median step of its first 1000 time stamps; its columns have the default
  names (``time_s``, ``temp_c``, ``x``, ``y``, ``z``, ``orientation``);
- a TDMS file states its units in the ``unit_string`` property of its x, y, z
  channels (the property NI's software writes), each group's orientation in an
  ``orientation`` property, and its rate in ``wf_increment`` or its time
  channel (as :func:`~accelcore.input.readers.read_tdms` reads them); its
  channels have the default names;
- a delimited log states neither its units nor its rate.

May import: the foundation, :mod:`accelcore.input.log_format` and the rest of
:mod:`accelcore.input.readers`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

import numpy as np

from accelcore.constants import AXES, DEFAULT_COLUMNS, TIME_UNITS, UNITS
from accelcore.errors import ParameterError
from accelcore.input.log_format import ORIENTATION_COLUMN, PARQUET, TDMS, log_layout
from accelcore.input.readers.common import _check_file, _parse_error, _timestamp_seconds
from accelcore.input.readers.flightlog import estimate_rate

__all__ = ["UNIT_STRINGS", "own_settings"]

#: A channel's ``unit_string`` (stripped, lower case) and the units it means.
UNIT_STRINGS: Mapping[str, str] = MappingProxyType(
    {"g": "g", "mg": "mg", "m/s^2": "m/s2", "m/s2": "m/s2", "m/s²": "m/s2", "v": "V", "lsb": "LSB"}
)


def own_settings(path: str | os.PathLike[str]) -> dict[str, Any] | str:
    """Return the reader's arguments a single log states, or why it cannot be read alone.

    Parameters
    ----------
    path : str or path-like
        A Parquet, TDMS or delimited log.

    Returns
    -------
    dict or str
        Keyword arguments of :func:`~accelcore.input.readers.read_parquet` or
        :func:`~accelcore.input.readers.read_tdms` (``units`` and what else the
        file states), or a short reason (``"the file does not say its units
        (...)"``).

    Raises
    ------
    ImportError
        pyarrow or npTDMS is not installed (the message names the extra).
    accelcore.ParseError
        Not a Parquet (TDMS) file.
    accelcore.AccelcoreIOError
        The file does not exist.
    """
    layout = log_layout(path)
    file = _check_file(path)
    if layout == PARQUET:
        return _parquet(file)
    if layout == TDMS:
        return _tdms(file)
    return "a delimited log does not say its units or rate"


def _parquet(file: str) -> dict[str, Any] | str:
    try:
        import pyarrow as pa
        import pyarrow.compute as pc
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise ImportError(f"reading {file} needs pyarrow: pip install accelcore[parquet]") from exc
    try:
        pf = pq.ParquetFile(file)
    except (pa.ArrowInvalid, OSError) as exc:
        raise _parse_error(file, 1, 1, f"not a Parquet file: {exc}", where=None) from None
    schema = pf.schema_arrow
    meta = {
        k.decode("utf-8", "replace"): v.decode("utf-8", "replace")
        for k, v in (schema.metadata or {}).items()
    }
    units = meta.get("units")
    if units is None:
        return f"the file does not say its units (Parquet metadata 'units': {', '.join(UNITS)})"
    if units not in UNITS:
        return f"Parquet metadata units {units!r} is not one of {', '.join(UNITS)}"
    wanted = [*DEFAULT_COLUMNS.values(), ORIENTATION_COLUMN]
    missing = [c for c in wanted if c not in schema.names]
    if missing:
        return (
            f"no column {', '.join(map(repr, missing))} (read alone, a Parquet log has the "
            f"columns {', '.join(wanted)})"
        )
    time_unit = meta.get("time_unit", "s")
    if time_unit not in TIME_UNITS:
        return f"Parquet metadata time_unit {time_unit!r} is not one of {', '.join(TIME_UNITS)}"
    settings: dict[str, Any] = {
        "units": units,
        "orientation_column": ORIENTATION_COLUMN,
        "time_unit": time_unit,
        "sensor": meta.get("sensor") or None,
        "serial": meta.get("serial") or None,
    }
    if "rate_hz" in meta:
        try:
            rate = float(meta["rate_hz"])
        except ValueError:
            rate = math.nan
        if not (math.isfinite(rate) and rate > 0):
            return f"Parquet metadata rate_hz {meta['rate_hz']!r} is not a positive number"
        return {**settings, "rate_hz": rate}
    time_name = DEFAULT_COLUMNS["time"]
    kind = schema.field(time_name).type
    batch = next(pf.iter_batches(batch_size=1001, columns=[time_name]), None)
    if batch is None:
        return "the file holds no rows"
    column = batch.column(0)
    if pa.types.is_timestamp(kind):
        stamps = pc.cast(column, pa.timestamp("ns")).to_numpy(zero_copy_only=False)
        seconds = _timestamp_seconds(np.asarray(stamps, dtype="datetime64[ns]"), [])
    elif pa.types.is_integer(kind) or pa.types.is_floating(kind):
        values = pc.cast(column, pa.float64()).to_numpy(zero_copy_only=False)
        seconds = np.asarray(values, dtype=np.float64) * TIME_UNITS[time_unit]
    else:
        return f"column {time_name!r} is {kind}, neither numbers nor timestamps"
    try:
        return {**settings, "rate_hz": estimate_rate(seconds)}
    except ParameterError:
        return "fewer than two distinct time stamps, and no Parquet metadata rate_hz"


def _tdms(file: str) -> dict[str, Any] | str:
    try:
        from nptdms import TdmsFile
    except ImportError as exc:
        raise ImportError(f"reading {file} needs npTDMS: pip install accelcore[tdms]") from exc
    try:
        tdms = TdmsFile.open(file)
    except Exception as exc:  # npTDMS raises plain ValueError/KeyError on bad files
        raise _parse_error(file, 1, 1, f"not a TDMS file: {exc}", where=None) from None
    needed = [DEFAULT_COLUMNS[r] for r in ("temperature", *AXES)]
    with tdms:
        groups = [
            g for g in tdms.groups() if all(c in [ch.name for ch in g.channels()] for c in needed)
        ]
        if not groups:
            return (
                f"no group holds the channels {', '.join(needed)} (the default names, "
                "which a TDMS log read alone has)"
            )
        unlabelled = [g.name for g in groups if "orientation" not in g.properties]
        if unlabelled:
            return f"group {unlabelled[0]!r} has no 'orientation' property"
        found = {
            str(g[DEFAULT_COLUMNS[a]].properties.get("unit_string", "")).strip().lower()
            for g in groups
            for a in AXES
        }
    units = {UNIT_STRINGS.get(u) for u in found}
    if len(units) != 1 or None in units:
        shown = ", ".join(sorted(repr(u) for u in found))
        return (
            "its x, y, z channels do not state one unit accelcore knows (unit_string "
            f"g, mg, m/s^2, V or LSB; found {shown})"
        )
    return {"units": units.pop()}
