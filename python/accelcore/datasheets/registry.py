"""The parts known to accelcore: built in, from ``ACCELCORE_DATASHEETS``, or registered.

Lookups go to :func:`register`-ed parts first, then to the directories of
``ACCELCORE_DATASHEETS`` (the first directory wins, as in ``PATH``), then to the
built-in files next to this module. Files are read once and cached until
:func:`reload`; the environment variable is read again on every lookup.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import fields
from pathlib import Path
from typing import Any, Final

from accelcore.datasheets.limits import DatasheetError
from accelcore.datasheets.parsing import (
    MEASURED_SCHEMA,
    normalize,
    parse_datasheet,
    parse_measured,
    read_toml,
)
from accelcore.datasheets.sheet import Datasheet, MeasuredReference

__all__ = [
    "ENV_VAR",
    "load",
    "measured",
    "measured_names",
    "names",
    "register",
    "reload",
    "unregister",
]

ENV_VAR: Final = "ACCELCORE_DATASHEETS"
"""Environment variable listing extra datasheet directories (``os.pathsep``-separated)."""


_DATA_DIR: Final = Path(__file__).resolve().parent


def _keys(ds: Datasheet) -> list[str]:
    return list(dict.fromkeys(normalize(n) for n in (ds.name, *ds.aliases) if normalize(n)))


def _index(parts: list[Datasheet], what: str) -> dict[str, Datasheet]:
    """Map every normalised name and alias to its part, refusing duplicates."""
    out: dict[str, Datasheet] = {}
    for ds in parts:
        for key in _keys(ds):
            other = out.get(key)
            if other is not None and other is not ds:
                raise DatasheetError(
                    f"{what}: the name {key!r} is used by both {other.origin} and {ds.origin}"
                )
            out[key] = ds
    return out


def _read_dir(directory: Path, what: str) -> dict[str, Datasheet]:
    parts = []
    for path in sorted(directory.glob("*.toml")):
        data = read_toml(path)
        if data.get("schema") == MEASURED_SCHEMA:
            continue
        parts.append(parse_datasheet(data, str(path)))
    return _index(parts, what)


_builtin: dict[str, Datasheet] | None = None
_env: tuple[str, dict[str, Datasheet]] | None = None
_registered: dict[str, Datasheet] = {}
_measured: dict[str, MeasuredReference] | None = None


def _builtin_parts() -> dict[str, Datasheet]:
    global _builtin
    if _builtin is None:
        parts = _read_dir(_DATA_DIR, "built-in datasheets")
        _builtin = {k: _with_origin(v, "builtin") for k, v in parts.items()}
    return _builtin


def _with_origin(ds: Datasheet, origin: str) -> Datasheet:
    values = {f.name: getattr(ds, f.name) for f in fields(ds)}
    values["origin"] = origin
    return Datasheet(**values)


def _env_parts() -> dict[str, Datasheet]:
    global _env
    value = os.environ.get(ENV_VAR, "")
    if _env is not None and _env[0] == value:
        return _env[1]
    merged: dict[str, Datasheet] = {}
    for entry in value.split(os.pathsep):
        if not entry.strip():
            continue
        directory = Path(entry).expanduser()
        if not directory.is_dir():
            raise DatasheetError(f"{ENV_VAR} lists {entry!r}, which is not a directory")
        for key, ds in _read_dir(directory, f"{ENV_VAR} directory {entry!r}").items():
            merged.setdefault(key, ds)  # the first directory wins, as in PATH
    _env = (value, merged)
    return merged


def _lookup(key: str) -> Datasheet | None:
    for source in (_registered, _env_parts(), _builtin_parts()):
        if key in source:
            return source[key]
    return None


def load(name: str) -> Datasheet:
    """Return the datasheet of a part.

    Parameters
    ----------
    name : str
        Part name or alias, case-insensitive, punctuation ignored
        (``"mpu9255"`` finds ``"MPU-9255"``).

    Returns
    -------
    Datasheet
        From :func:`register`, else from ``ACCELCORE_DATASHEETS``, else built in.

    Raises
    ------
    DatasheetError
        If no part of that name is known, or a datasheet file is invalid.
    """
    ds = _lookup(normalize(name))
    if ds is None:
        raise DatasheetError(f"unknown sensor {name!r}; known parts: {', '.join(names())}")
    return ds


def names() -> list[str]:
    """Return the canonical names of every known part, sorted.

    Returns
    -------
    list of str
        Built-in, ``ACCELCORE_DATASHEETS`` and registered parts.
    """
    seen: dict[str, str] = {}
    for source in (_registered, _env_parts(), _builtin_parts()):
        for ds in source.values():
            key = normalize(ds.name)
            if key not in seen and _lookup(key) is ds:
                seen[key] = ds.name
    return sorted(seen.values(), key=str.lower)


def register(
    source: str | os.PathLike[str] | Mapping[str, Any], *, replace: bool = False
) -> Datasheet:
    """Add a part from a TOML file or a mapping of the datasheet schema.

    Parameters
    ----------
    source : str, path-like or mapping
        Path of a ``.toml`` file, or its content as a mapping.
    replace : bool, optional
        Allow the part to shadow an existing part of the same name or alias.

    Returns
    -------
    Datasheet
        The validated datasheet, now returned by :func:`load`.

    Raises
    ------
    DatasheetError
        If the content breaks the schema, or a name is taken and not ``replace``.
    """
    if isinstance(source, Mapping):
        ds = parse_datasheet(source, "<mapping>")
    else:
        path = Path(source)
        ds = parse_datasheet(read_toml(path), str(path))
    keys = _keys(ds)
    if not replace:
        for key in keys:
            existing = _lookup(key)
            if existing is not None:
                raise DatasheetError(
                    f"a part named {existing.name!r} ({existing.origin}) already answers to "
                    f"{key!r}; pass replace=True to shadow it"
                )
    for key in keys:
        _registered[key] = ds
    return ds


def unregister(name: str) -> None:
    """Remove a part added with :func:`register` (all its names).

    Parameters
    ----------
    name : str
        Any of its names.

    Raises
    ------
    DatasheetError
        If no registered part has that name.
    """
    ds = _registered.get(normalize(name))
    if ds is None:
        raise DatasheetError(f"no part named {name!r} was registered")
    for key in [k for k, v in _registered.items() if v is ds]:
        del _registered[key]


def reload() -> None:
    """Forget cached files: built-in data and ``ACCELCORE_DATASHEETS`` are read again."""
    global _builtin, _env, _measured
    _builtin = None
    _env = None
    _measured = None


def _measured_parts() -> dict[str, MeasuredReference]:
    global _measured
    if _measured is None:
        merged: dict[str, MeasuredReference] = {}
        for path in sorted(_DATA_DIR.glob("*.toml")):
            data = read_toml(path)
            if data.get("schema") == MEASURED_SCHEMA:
                merged.update(parse_measured(data, str(path)))
        _measured = merged
    return _measured


def measured(name: str) -> MeasuredReference:
    """Return the paper's measured parameters of a part (Tables 3-6).

    Parameters
    ----------
    name : str
        Part name, matched as in :func:`load`.

    Returns
    -------
    MeasuredReference
        Sensitivity, zero-g offset and ±1 g outputs at 25 °C, and the two
        temperature coefficients, per axis, as printed in the paper.

    Raises
    ------
    DatasheetError
        If the paper did not measure that part.
    """
    ref = _measured_parts().get(normalize(name))
    if ref is None:
        raise DatasheetError(
            f"no measured reference for {name!r}; available: {', '.join(measured_names())}"
        )
    return ref


def measured_names() -> list[str]:
    """Return the names of the parts with a measured reference, sorted."""
    return sorted((m.sensor for m in _measured_parts().values()), key=str.lower)
