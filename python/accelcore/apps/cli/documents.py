"""The ``--json`` documents of the command line: the ``accelcore-cli/1`` envelope and its writer.

Part of the applications room; imports only the foundation.
"""

from __future__ import annotations

import errno
import json
import math
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import pandas as pd

from accelcore._accelcore import __version__
from accelcore.files import atomic_write

__all__ = ["JSON_SCHEMA", "json_document", "plain", "require_folder", "write_json"]

#: Version tag of every ``--json`` document; bumped on any incompatible change.
JSON_SCHEMA = "accelcore-cli/1"


def plain(value: Any) -> Any:
    """Convert to strict-JSON data: NumPy to Python, tuples to lists, NaN/inf to None.

    Parameters
    ----------
    value : Any
        Mappings, sequences, NumPy arrays and scalars, numbers, strings, paths,
        ``None`` and pandas' missing values.

    Returns
    -------
    Any
        The same data made of dicts, lists, str, int, float, bool and None.

    Raises
    ------
    TypeError
        A value of another type.
    """
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return [plain(v) for v in value.tolist()]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        f = float(value)
        return f if math.isfinite(f) else None
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, Path):
        return str(value)
    if value is pd.NA or value is pd.NaT:
        return None
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def json_document(command: str, result: Mapping[str, Any]) -> dict[str, Any]:
    """Wrap a command's result in the ``accelcore-cli/1`` envelope.

    Parameters
    ----------
    command : str
        The subcommand (``calibrate``, ``diagnose``, ``simulate``).
    result : mapping
        The command's result; converted to strict JSON (NaN and infinities
        become ``null``, NumPy values become Python numbers).

    Returns
    -------
    dict
        ``{"schema", "command", "accelcore_version", "result"}``.
    """
    return {
        "schema": JSON_SCHEMA,
        "command": command,
        "accelcore_version": __version__,
        "result": plain(result),
    }


def write_json(path: str | Path, document: Mapping[str, Any], stdout: TextIO | None = None) -> None:
    """Write a JSON document atomically (:func:`accelcore.files.atomic_write`).

    Parameters
    ----------
    path : str or Path
        Target file; ``"-"`` writes to ``stdout``.
    document : mapping
        Strict-JSON data.
    stdout : text stream, optional
        Where ``"-"`` writes (default ``sys.stdout``).
    """
    text = json.dumps(document, indent=2, sort_keys=False, allow_nan=False) + "\n"
    if str(path) == "-":
        (stdout or sys.stdout).write(text)
        return
    atomic_write(require_folder(path), text)


def require_folder(path: str | Path) -> Path:
    """Return ``path`` if its folder exists: the command line never creates a file's folder.

    Parameters
    ----------
    path : str or Path
        A file to be written.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    FileNotFoundError
        The folder is missing (a data error naming it, exit status 1).
    """
    target = Path(path)
    folder = target.parent
    if not folder.is_dir():
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), str(folder))
    return target
