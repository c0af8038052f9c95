"""The calibration file's envelope: canonical bytes, checksum, schema, reading and writing.

A calibration file is ``{"body": {...}, "sha256": "<hex>"}``. The checksum is the
SHA-256 of the body's canonical JSON bytes as RFC 8785 (the JSON Canonicalization
Scheme) defines them: keys sorted by UTF-16 code units, no whitespace, numbers as
ECMAScript prints them (the shortest form that reads back the same double),
strings escaped minimally, UTF-8. So pretty-printing the file or reordering its
keys keeps it valid, changing a number does not, and any language with a JCS
library (or these forty lines) can verify it. Strict JSON has no NaN or
infinity: a number that is not finite is written as the string ``"NaN"``,
``"Infinity"`` or ``"-Infinity"`` and read back as that float.

Files written before the checksum was canonical hold the SHA-256 of Python's
``json.dumps(body, sort_keys=True)``; :func:`read_body` still accepts it.
The file's fields are described by ``calibration.schema.json`` beside this
module (:func:`schema`), and in ``docs/calibration-file.md``.

Part of the result room: imports the foundation only.
"""

from __future__ import annotations

import hashlib
import json
import math
from decimal import Decimal
from importlib import resources
from pathlib import Path
from typing import Any

from accelcore.errors import AccelcoreIOError, CalibrationFileError
from accelcore.files import atomic_write, check_input_file

__all__ = [
    "CALIBRATION_FORMAT",
    "canonical_json",
    "checksum",
    "json_safe",
    "read_body",
    "schema",
    "write_body",
]

CALIBRATION_FORMAT = "accelcore-calibration/1"

#: A calibration file is a few kB; anything this large is not one (it is not read).
MAX_CALIBRATION_BYTES = 64 << 20

#: The JSON Schema of the file, shipped beside this module.
SCHEMA_FILE = "calibration.schema.json"


def schema() -> dict[str, Any]:
    """Return the JSON Schema (draft 2020-12) of the calibration file.

    Returns
    -------
    dict
    """
    text = resources.files("accelcore.result").joinpath(SCHEMA_FILE).read_text("utf-8")
    loaded: dict[str, Any] = json.loads(text)
    return loaded


#: How a number that is not finite is written (strict JSON has none).
NON_FINITE = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}

#: Body fields that hold text only: never read back as numbers.
_TEXT_FIELDS = frozenset(
    {"format", "method", "units", "sensor", "serial", "notes", "not_identified", "terms"}
)


def json_safe(value: Any) -> Any:
    """Return ``value`` with every non-finite float as its string and tuples as lists.

    Parameters
    ----------
    value : JSON-like data
        Dicts, lists, tuples, strings, numbers, booleans and None.

    Returns
    -------
    The same data, strict-JSON ready (``nan`` as ``"NaN"``, ``inf`` as
    ``"Infinity"``, ``-inf`` as ``"-Infinity"``).
    """
    if isinstance(value, float):
        if math.isfinite(value):
            return value
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


def canonical_json(value: Any) -> bytes:
    """Serialize ``value`` as RFC 8785 canonical JSON (UTF-8).

    Parameters
    ----------
    value : JSON data
        Dicts with string keys, lists, strings, finite numbers, booleans, None.

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        A number that is not finite, or a value JSON cannot hold.
    """
    return "".join(_canonical(value)).encode("utf-8")


def _canonical(value: Any) -> list[str]:
    if value is None:
        return ["null"]
    if value is True:
        return ["true"]
    if value is False:
        return ["false"]
    if isinstance(value, str):
        return [json.dumps(value, ensure_ascii=False)]
    if isinstance(value, int):
        return [str(value) if abs(value) <= 2**53 else _number(float(value))]
    if isinstance(value, float):
        return [_number(value)]
    if isinstance(value, (list, tuple)):
        out = ["["]
        for i, item in enumerate(value):
            out += ([","] if i else []) + _canonical(item)
        return [*out, "]"]
    if isinstance(value, dict):
        if not all(isinstance(k, str) for k in value):
            raise ValueError("canonical JSON needs string keys")
        out = ["{"]
        for i, key in enumerate(sorted(value, key=lambda k: k.encode("utf-16-be"))):
            out += [","] if i else []
            out += [json.dumps(key, ensure_ascii=False), ":", *_canonical(value[key])]
        return [*out, "}"]
    raise ValueError(f"canonical JSON cannot hold a {type(value).__name__}")


def _number(x: float) -> str:
    """ECMAScript's Number::toString of a double (RFC 8785 section 3.2.2.3)."""
    if not math.isfinite(x):
        raise ValueError(f"canonical JSON has no {x!r}: write it as null")
    if x == 0:
        return "0"
    if x < 0:
        return "-" + _number(-x)
    # repr is the shortest string that reads back the same double, as ECMAScript asks;
    # normalize() drops its trailing zeros ("100.0" -> 1E+2).
    _, digit_tuple, exp = Decimal(repr(x)).normalize().as_tuple()
    digits = "".join(map(str, digit_tuple))
    k, n = len(digits), int(exp) + len(digits)  # x = 0.digits × 10^n
    if k <= n <= 21:
        return digits + "0" * (n - k)
    if 0 < n <= 21:
        return digits[:n] + "." + digits[n:]
    if -6 < n <= 0:
        return "0." + "0" * -n + digits
    e = n - 1
    mantissa = digits if k == 1 else digits[0] + "." + digits[1:]
    return f"{mantissa}e{'+' if e > 0 else '-'}{abs(e)}"


def checksum(body: Any) -> str:
    """Return the file's checksum of ``body``: hex SHA-256 of its canonical JSON bytes.

    Parameters
    ----------
    body : dict
        The file's body (non-finite numbers are taken as their strings, :func:`json_safe`).

    Returns
    -------
    str
    """
    return hashlib.sha256(canonical_json(json_safe(body))).hexdigest()


def _legacy_checksum(body: Any) -> str:
    """Return the checksum files held before it was canonical (Python's ``json.dumps``)."""
    return hashlib.sha256(json.dumps(body, sort_keys=True, allow_nan=True).encode()).hexdigest()


def write_body(path: str | Path, body: dict[str, Any]) -> None:
    """Write a calibration file (atomically) holding ``body`` and its checksum.

    Parameters
    ----------
    path : str or Path
    body : dict
        :meth:`Calibration.to_dict`; non-finite numbers are written as strings.
    """
    safe = json_safe(body)
    doc = {"body": safe, "sha256": checksum(safe)}
    # Python's float repr reads back bit for bit; the file is strict JSON.
    atomic_write(path, json.dumps(doc, indent=1, sort_keys=True, allow_nan=False))


def read_body(path: str | Path) -> dict[str, Any]:
    """Read a calibration file and return its body, checksum and format checked.

    The strings written for non-finite numbers come back as floats.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict

    Raises
    ------
    accelcore.AccelcoreIOError
        Missing, not a regular file (a FIFO, a folder) or over 64 MiB.
    accelcore.CalibrationFileError
        Not JSON, not a calibration file, of another format, or a checksum mismatch.
    """
    where = str(path)
    check_input_file(path, "calibration file", max_bytes=MAX_CALIBRATION_BYTES)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise AccelcoreIOError(f"{where}: cannot read calibration file: {exc.strerror}") from exc
    try:
        doc = json.loads(data.decode("utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise CalibrationFileError(
            f"{where}: not a calibration file (truncated or corrupted JSON: {exc})"
        ) from exc
    if not isinstance(doc, dict) or "body" not in doc or "sha256" not in doc:
        raise CalibrationFileError(f"{where}: not an accelcore calibration file")
    body = doc["body"]
    fmt = body.get("format") if isinstance(body, dict) else None
    if fmt != CALIBRATION_FORMAT:
        raise CalibrationFileError(
            f"{where}: format {fmt!r} is not supported; expected {CALIBRATION_FORMAT!r}"
        )
    try:
        ok = doc["sha256"] in (checksum(body), _legacy_checksum(body))
    except ValueError:
        ok = False
    if not ok:
        raise CalibrationFileError(
            f"{where}: checksum mismatch: the file was modified or corrupted after it was written"
        )
    restored: dict[str, Any] = _restore_non_finite(body)
    return restored


def _restore_non_finite(value: Any) -> Any:
    """Read the strings written for non-finite numbers back as floats (text fields aside)."""
    if isinstance(value, str):
        return NON_FINITE.get(value, value)
    if isinstance(value, dict):
        return {k: v if k in _TEXT_FIELDS else _restore_non_finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_restore_non_finite(v) for v in value]
    return value
