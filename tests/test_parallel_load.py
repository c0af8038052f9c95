"""``load_session`` reads a session's logs on several threads and gets what one thread gets.

With more than one run to read and more than one core, the logs are read
concurrently (the Rust reader releases the GIL); the Session, its digests, the
warnings and the error raised must not depend on it.
"""

from __future__ import annotations

import dataclasses
import os
import threading
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import accelcore
from accelcore import simulate
from accelcore.input import session as session_module
from accelcore.input.session import Session, load_session

real_read_run = accelcore._accelcore.read_run


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("parallel") / "session"
    simulate.session(path, duration_h=0.25, seed=11)
    return path


def _fields(value: Any) -> Any:
    """Everything a value holds, arrays as (dtype, shape, bytes): equal means identical."""
    if isinstance(value, np.ndarray):
        return (value.dtype.str, value.shape, value.tobytes())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return tuple(_fields(getattr(value, f.name)) for f in dataclasses.fields(value))
    if isinstance(value, dict):
        return tuple((k, _fields(v)) for k, v in value.items())
    if isinstance(value, (tuple, list)):
        return tuple(_fields(v) for v in value)
    return value


def _load(folder: Path, cores: int, monkeypatch: pytest.MonkeyPatch, **kwargs: Any) -> Any:
    """``load_session`` as on a machine with ``cores`` cores: the session and its warnings."""
    monkeypatch.setattr(os, "cpu_count", lambda: cores)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        session = load_session(folder, cache=False, **kwargs)
    return session, [(w.category, str(w.message)) for w in caught]


@pytest.mark.parametrize("digest", ["blake3", "sha256"])
def test_parallel_and_serial_loads_are_identical(
    folder: Path, monkeypatch: pytest.MonkeyPatch, digest: str
) -> None:
    serial, serial_warnings = _load(folder, 1, monkeypatch, digest=digest)
    parallel, parallel_warnings = _load(folder, 4, monkeypatch, digest=digest)
    assert isinstance(parallel, Session) and len(parallel.runs) == 6
    assert _fields(parallel) == _fields(serial)
    assert list(parallel.file_digests.items()) == list(serial.file_digests.items())
    assert parallel_warnings == serial_warnings
    cal = [accelcore.calibrate(s, method=m) for s in (serial, parallel) for m in ("joint", "paper")]
    assert _fields(cal[2].axes) == _fields(cal[0].axes)
    assert _fields(cal[3].axes) == _fields(cal[1].axes)


def test_the_logs_are_read_on_several_threads(
    folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    readers: set[int] = set()

    def slow_read(*args: Any, **kwargs: Any) -> Any:
        readers.add(threading.get_ident())
        time.sleep(0.05)  # every read overlaps another one
        return real_read_run(*args, **kwargs)

    monkeypatch.setattr(session_module, "read_run", slow_read)
    _load(folder, 2, monkeypatch)
    assert len(readers) == 2
    assert threading.get_ident() not in readers
    readers.clear()
    _load(folder, 1, monkeypatch)
    assert len(readers) == 1


def test_the_first_broken_log_in_run_order_is_reported(
    folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    broken = tmp_path / "broken"
    broken.mkdir()
    for f in folder.iterdir():
        (broken / f.name).write_bytes(f.read_bytes())
    # The third and fifth runs of session.toml (y_pos.csv, z_pos.csv) are broken.
    for name, line in (("y_pos.csv", 7), ("z_pos.csv", 3)):
        lines = (broken / name).read_text().splitlines(keepends=True)
        lines[line - 1] = "1.0,oops,2,3,4\n"
        (broken / name).write_text("".join(lines))
    messages = []
    for cores in (1, 2, 6):
        monkeypatch.setattr(os, "cpu_count", lambda cores=cores: cores)
        with pytest.raises(accelcore.ParseError) as info:
            load_session(broken, cache=False)
        assert info.value.line == 7 and "y_pos.csv" in str(info.value)
        messages.append(str(info.value))
    assert len(set(messages)) == 1
