"""Hypothesis-driven fuzzing of the log reader and the session loader (issue 7).

Random bytes and mutated real logs and session folders (byte flips, truncation,
inserted delimiters, quotes, NULs and line ends, huge numbers, very long lines)
go through :func:`accelcore._accelcore.read_run` and :func:`accelcore.load_session`.
Every outcome must be a success or an :class:`accelcore.AccelcoreError`: never
another exception type (a Rust panic would surface as pyo3's ``PanicException``),
never a crash or a hang. The number of examples, and so the time, is bounded by
the hypothesis profile (``ACCELCORE_HYPOTHESIS_PROFILE``, see ``conftest.py``).
The Rust side has its own fuzzers: ``fuzz/`` (cargo fuzz) and
``rust/accelcore-core/tests/reader_fuzz_regressions.rs``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import accelcore
from accelcore import simulate
from accelcore._accelcore import read_run
from test_reliability import FUZZ_FORMATS

HEADER = b"time_s,temp_c,x,y,z\n"


def _real_log() -> bytes:
    """The first rows of a simulated chamber log (the same bytes every time)."""
    with tempfile.TemporaryDirectory() as tmp:
        sim = simulate.session(Path(tmp) / "s", "ADXL335", seed=0, duration_h=0.01, soak_min=0.1)
        text = (sim.path / sim.runs[0].file).read_bytes()
    return b"".join(text.splitlines(keepends=True)[:120])


REAL_LOG = _real_log()
with tempfile.TemporaryDirectory() as _tmp:
    _sim = simulate.session(
        Path(_tmp) / "s",
        "ADXL335",
        seed=1,
        duration_h=0.01,
        soak_min=0.1,
        orientations=["OZ+", "OZ-"],
    )
    REAL_TOML = (_sim.path / "session.toml").read_bytes()
    RUN_FILES = [r.file for r in _sim.runs]

INSERTS = [
    b",", b";", b"\t", b"\n", b"\r\n", b"\r", b'"', b"'", b"\x00", b"\xef\xbb\xbf", b"\xff",
    b"nan", b"-inf", b"1e999", b"-1e-400", b"9" * 400, b"0x1F", b"1,2", b"[", b"]", b"=", b"#",
]  # fmt: skip


@st.composite
def mutated(draw: st.DrawFn, base: bytes, max_ops: int = 6) -> bytes:
    """``base`` with a few random edits: flips, deletions, insertions, truncation."""
    data = bytearray(base)
    for _ in range(draw(st.integers(1, max_ops))):
        op = draw(st.sampled_from(["flip", "delete", "insert", "truncate", "duplicate"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if op == "flip" and data:
            data[at] ^= 1 << draw(st.integers(0, 7))
        elif op == "delete" and data:
            del data[at : at + draw(st.integers(1, 40))]
        elif op == "insert":
            data[at:at] = draw(st.sampled_from(INSERTS) | st.binary(min_size=1, max_size=8))
        elif op == "truncate":
            del data[at:]
        elif op == "duplicate" and data:
            data[at:at] = data[at : at + draw(st.integers(1, 200))]
    return bytes(data)


def _must_be_ok_or_accelcore_error(call: Any, *args: Any, **kwargs: Any) -> None:
    try:
        call(*args, **kwargs)
    except accelcore.AccelcoreError:
        pass
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):
            raise
        pytest.fail(f"{type(exc).__module__}.{type(exc).__qualname__}: {exc!r}")


def _read(data: bytes, pick: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.csv"
        path.write_bytes(data)
        kwargs = FUZZ_FORMATS[pick % len(FUZZ_FORMATS)]
        _must_be_ok_or_accelcore_error(read_run, str(path), **kwargs)


@given(data=st.binary(max_size=4096), pick=st.integers(0, 255))
def test_random_bytes(data: bytes, pick: int) -> None:
    _read(data, pick)


@given(data=st.binary(max_size=2048), pick=st.integers(0, 255))
def test_random_bytes_after_a_valid_header(data: bytes, pick: int) -> None:
    _read(HEADER + data, pick)


@given(data=mutated(REAL_LOG), pick=st.integers(0, 255))
def test_mutated_real_log(data: bytes, pick: int) -> None:
    _read(data, pick)


@given(
    rows=st.lists(
        st.lists(
            st.one_of(
                st.floats(allow_nan=True, allow_infinity=True).map(repr),
                st.sampled_from(["", " ", "1e999", "-1e999", "9" * 500, "0x10", "1_0", "+.5"]),
                st.text(max_size=6),
            ),
            min_size=3,
            max_size=7,
        ),
        max_size=40,
    ),
    ending=st.sampled_from(["\n", "\r\n"]),
    final_newline=st.booleans(),
)
def test_huge_odd_and_random_cells(rows: list[list[str]], ending: str, final_newline: bool) -> None:
    body = ending.join(",".join(r) for r in rows) + (ending if final_newline else "")
    _read(HEADER + body.encode("utf-8", "surrogatepass"), 0)


@settings(max_examples=8, deadline=None)
@given(
    where=st.integers(0, 3),
    length=st.sampled_from([(1 << 20) - 30, 1 << 20, (1 << 20) + 1, 3 << 20]),
    fill=st.sampled_from([b"7", b",", b"\x00"]),
)
def test_very_long_lines(where: int, length: int, fill: bytes) -> None:
    lines = REAL_LOG.splitlines(keepends=True)[:4]
    lines.insert(where, fill * length + b"\n")
    _read(b"".join(lines), 0)


def _write_session(folder: Path, toml: bytes, runs: dict[str, bytes]) -> None:
    folder.mkdir()
    (folder / "session.toml").write_bytes(toml)
    for name, data in runs.items():
        (folder / name).write_bytes(data)


@settings(suppress_health_check=[HealthCheck.too_slow])
@given(
    toml=st.one_of(st.just(REAL_TOML), mutated(REAL_TOML, max_ops=3)),
    logs=st.lists(st.one_of(st.just(REAL_LOG), mutated(REAL_LOG)), min_size=2, max_size=2),
)
def test_mutated_session_folder(toml: bytes, logs: list[bytes]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "s"
        _write_session(folder, toml, dict(zip(RUN_FILES, logs, strict=True)))
        _must_be_ok_or_accelcore_error(accelcore.load_session, folder)


@given(
    value=st.one_of(
        st.integers(),
        st.floats(),
        st.booleans(),
        st.lists(st.integers(), max_size=2),
        st.text(max_size=5),
        st.dictionaries(st.sampled_from(["x", "time", "file"]), st.text(max_size=3), max_size=2),
    ),
    key=st.sampled_from(
        [
            "format",
            "units",
            "rate_hz",
            "delimiter",
            "time_unit",
            "columns",
            "sensor",
            "serial",
            "run",
        ]
    ),
)
def test_session_toml_values_of_any_type(value: object, key: str) -> None:
    """Each top-level key of session.toml replaced by a value of any TOML type."""
    meta: dict[str, object] = {
        "format": "accelcore-session/1",
        "units": "V",
        "rate_hz": 20.0,
        "run": [{"file": RUN_FILES[0], "orientation": "OZ+"}],
    }
    meta[key] = value
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "s"
        _write_session(folder, _toml(meta).encode(), {RUN_FILES[0]: REAL_LOG})
        _must_be_ok_or_accelcore_error(accelcore.load_session, folder)


def _toml_value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return {"nan": "nan", "inf": "inf", "-inf": "-inf"}.get(repr(v), repr(v))
    if isinstance(v, str):
        return '"' + v.encode("unicode_escape").decode("ascii").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def _toml(meta: dict[str, object]) -> str:
    return "\n".join(f"{k} = {_toml_value(v)}" for k, v in meta.items()) + "\n"
