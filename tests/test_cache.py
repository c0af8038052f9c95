"""The persistent run cache of load_session (accelcore.input.cache): a hit gives the very
Session a cold read gives, and nothing that changed a file, or the way it is read,
is ever served from the cache."""

from __future__ import annotations

import dataclasses
import io
import json
import os
import shutil
import struct
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import accelcore
from accelcore import simulate
from accelcore.apps.cli import build_parser, main
from accelcore.input import cache
from accelcore.input import session as session_module
from accelcore.input.cache import CacheWarning
from accelcore.input.session import Session, load_session

real_read_run = accelcore._accelcore.read_run

#: Every test that changes files gets its own copy, aged once for the module.
COPIES = (
    "shared",
    "append",
    "rewrite",
    "mapping",
    "during",
    "cli",
    "unwritable",
    "prune",
    "corrupt",
    "archive/part0",
)


def age(paths: list[Path]) -> None:
    """Put mtimes 10 s back and wait until ctimes are RACY_WINDOW_NS old (utime sets ctime)."""
    back = time.time_ns() - 10_000_000_000
    for p in paths:
        os.utime(p, ns=(back, back))
    newest = max(p.stat().st_ctime_ns for p in paths)
    wait_ns = newest + cache.RACY_WINDOW_NS + 50_000_000 - time.time_ns()
    if wait_ns > 0:
        time.sleep(wait_ns / 1e9)


def files_of(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file())


@pytest.fixture(scope="module")
def aged(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Small six-run sessions (with an extra column) whose files the racy rule allows caching."""
    root = tmp_path_factory.mktemp("aged")
    simulate.session(
        root / "shared", duration_h=0.05, soak_min=0.5, seed=5, extra_columns=("supply_v",)
    )
    for name in COPIES[1:]:
        shutil.copytree(root / "shared", root / name)
    age([f for name in COPIES for f in files_of(root / name)])
    return {name: root / name for name in COPIES}


def entries(folder: Path) -> list[Path]:
    return sorted(folder.glob(f"*{cache.SUFFIX}")) if folder.is_dir() else []


#: The entry layout, as docs/cache.md describes it (written out again here, on purpose).
HEADER = struct.Struct("<8sQQQQ")  # magic, meta_len, n_floats, n_ints, checksum
MAGIC = b"ACRUN\x00\x01\x00"


def word_sum(body: bytes) -> int:
    return int(np.frombuffer(body, dtype="<u8").sum(dtype=np.uint64))


def read_entry(entry: Path) -> tuple[dict[str, Any], np.ndarray, np.ndarray]:
    """(metadata, floats, ints) of an entry, checking its header."""
    raw = entry.read_bytes()
    magic, meta_len, n_floats, n_ints, checksum = HEADER.unpack_from(raw)
    assert magic == MAGIC and meta_len % 8 == 0
    assert len(raw) == HEADER.size + meta_len + 8 * (n_floats + n_ints)
    assert word_sum(raw[HEADER.size :]) == checksum
    text = raw[HEADER.size : HEADER.size + meta_len]
    assert text == text.rstrip(b" ") + b" " * (len(text) - len(text.rstrip(b" ")))
    meta = json.loads(text.decode())
    start = HEADER.size + meta_len
    floats = np.frombuffer(raw, dtype="<f8", count=n_floats, offset=start)
    ints = np.frombuffer(raw, dtype="<i8", count=n_ints, offset=start + 8 * n_floats)
    return meta, floats, ints


def write_entry(
    entry: Path,
    meta: dict[str, Any] | bytes,
    floats: np.ndarray,
    ints: np.ndarray,
    magic: bytes = MAGIC,
    checksum_delta: int = 0,
) -> None:
    """Write an entry in the documented layout (a consistent header unless told otherwise)."""
    text = meta if isinstance(meta, bytes) else json.dumps(meta).encode()
    text += b" " * (-len(text) % 8)
    body = text + floats.astype("<f8").tobytes() + ints.astype("<i8").tobytes()
    checksum = (word_sum(body) + checksum_delta) % (1 << 64)
    entry.write_bytes(HEADER.pack(magic, len(text), len(floats), len(ints), checksum) + body)


def assert_identical(a: Any, b: Any, where: str = "session") -> None:
    """Equal field by field; arrays bit for bit, with the same dtype and shape."""
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray), where
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert a.tobytes() == b.tobytes(), where
        assert b.flags.c_contiguous, where
    elif dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            assert_identical(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            assert_identical(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_identical(x, y, f"{where}[{i}]")
    else:
        assert type(a) is type(b) and a == b, f"{where}: {a!r} != {b!r}"


@pytest.fixture
def no_reading(monkeypatch: pytest.MonkeyPatch) -> Callable[[], None]:
    """Call it to make any read of a log fail: what follows must come from the cache."""

    def forbid() -> None:
        def fail(*args: Any, **kwargs: Any) -> Any:
            raise AssertionError(f"read_run called on a hit: {args}")

        monkeypatch.setattr(session_module, "read_run", fail)

    return forbid


def test_warm_hit_is_identical_to_a_cold_read(
    aged: dict[str, Path], tmp_path: Path, no_reading: Callable[[], None]
) -> None:
    folder, store = aged["shared"], tmp_path / "cache"
    cold = load_session(folder, cache=False)
    assert not store.exists()
    first = load_session(folder, cache=store)
    assert len(entries(store)) == 6
    no_reading()
    warm = load_session(folder, cache=store)
    assert warm.runs[0].extras and warm.runs[0].stats.n_rows == 3600
    assert_identical(cold, first)
    assert_identical(cold, warm)
    assert warm.file_hashes() == cold.file_hashes()
    assert len(warm.file_digests) == 7
    # Everything downstream is the same too.
    assert_identical(
        accelcore.calibrate(cold, method="paper").to_dict(),
        accelcore.calibrate(warm, method="paper").to_dict(),
    )


def test_entries_have_the_documented_layout_and_say_what_they_are(
    aged: dict[str, Path], tmp_path: Path
) -> None:
    cold = load_session(aged["shared"], cache=False)
    load_session(aged["shared"], cache=tmp_path)
    assert cache.FORMAT == 3 and cache.SUFFIX == ".acrun"
    by_source = {Path(str(run.source)).name: run for run in cold.runs}
    for entry in entries(tmp_path):
        meta, floats, ints = read_entry(entry)
        assert meta["format"] == cache.FORMAT and meta["accelcore"] == accelcore.__version__
        assert Path(meta["path"]).is_absolute() and meta["path"].endswith(".csv")
        assert meta["params"]["factor"] == 10 and meta["params"]["delimiter"] == ","
        assert len(meta["fingerprint"]) == 5 and len(meta["digest"]) == 64
        assert entry.name == f"{meta['key']}.acrun"
        # The vectors hold the arrays in the documented order.
        run = by_source[Path(meta["path"]).name]
        n, k = meta["n_blocks"], len(meta["channel_names"])
        assert n == len(run.time_s) and k == 4 and meta["channel_names"][3] == "supply_v"
        assert len(floats) == n * (2 + k) + 2 * k + 3
        assert len(ints) == n * (1 + meta["block_index"]) + 2 * k
        np.testing.assert_array_equal(floats[:n], run.time_s)
        np.testing.assert_array_equal(floats[n : 2 * n], run.temperature_c)
        channels = floats[2 * n : (2 + k) * n].reshape(n, k)
        np.testing.assert_array_equal(channels[:, :3], run.output)
        np.testing.assert_array_equal(channels[:, 3], run.extras["supply_v"])
        ranges = floats[(2 + k) * n : (2 + k) * n + 2 * k]
        np.testing.assert_array_equal(ranges, np.r_[run.stats.channel_min, run.stats.channel_max])
        assert floats[-3] == run.stats.max_interval_s
        assert floats[-1] - floats[-2] == run.stats.duration_s
        np.testing.assert_array_equal(ints[:n], run.count)
        np.testing.assert_array_equal(ints[-k:].view(np.uint64), run.stats.n_at_max)


def test_appending_a_row_is_a_miss_and_the_row_shows_up(
    aged: dict[str, Path], tmp_path: Path
) -> None:
    folder, store = aged["append"], tmp_path
    before = load_session(folder, cache=store)
    log = folder / "x_pos.csv"
    with log.open("a") as fh:
        fh.write("180.00,65.010,1.793518,1.486816,1.495667,3.00037\n")
    after = load_session(folder, cache=store)
    assert after.runs[0].stats.n_rows == before.runs[0].stats.n_rows + 1
    assert after.runs[0].stats.duration_s == pytest.approx(180.0)
    assert after.file_digests["x_pos.csv"] != before.file_digests["x_pos.csv"]
    assert_identical(after, load_session(folder, cache=False))
    # The other runs were hits and are unchanged.
    assert_identical(after.runs[1:], before.runs[1:])


def test_same_size_rewrite_with_the_old_mtime_is_a_miss(
    aged: dict[str, Path], tmp_path: Path
) -> None:
    """ctime catches a rewrite that keeps the size and puts the mtime back."""
    folder, store = aged["rewrite"], tmp_path
    log = folder / "y_neg.csv"
    before = load_session(folder, cache=store)
    st = log.stat()
    lines = log.read_text().splitlines(keepends=True)
    fields = lines[5].split(",")
    fields[2] = fields[2][:-1] + ("1" if fields[2][-1] != "1" else "2")  # same width
    lines[5] = ",".join(fields)
    log.write_text("".join(lines))
    os.utime(log, ns=(st.st_atime_ns, st.st_mtime_ns))
    now = log.stat()
    assert (now.st_size, now.st_mtime_ns, now.st_ino) == (st.st_size, st.st_mtime_ns, st.st_ino)
    after = load_session(folder, cache=store)
    assert after.file_digests["y_neg.csv"] != before.file_digests["y_neg.csv"]
    assert_identical(after, load_session(folder, cache=False))
    assert after.runs[3].output[0, 0] != before.runs[3].output[0, 0]


def test_a_decimation_factor_is_a_separate_entry(
    aged: dict[str, Path], tmp_path: Path, no_reading: Callable[[], None]
) -> None:
    folder = aged["shared"]
    cold10 = load_session(folder, cache=False)
    cold5 = load_session(folder, decimation_factor=5, cache=False)
    cold5_min = load_session(folder, decimation_factor=5, min_count=5, cache=False)
    load_session(folder, cache=tmp_path)
    assert len(entries(tmp_path)) == 6
    load_session(folder, decimation_factor=5, cache=tmp_path)
    assert len(entries(tmp_path)) == 12
    load_session(folder, decimation_factor=5, min_count=5, cache=tmp_path)
    assert len(entries(tmp_path)) == 18
    no_reading()
    assert_identical(load_session(folder, cache=tmp_path), cold10)
    assert_identical(load_session(folder, decimation_factor=5, cache=tmp_path), cold5)
    warm5_min = load_session(folder, decimation_factor=5, min_count=5, cache=tmp_path)
    assert_identical(warm5_min, cold5_min)
    assert len(cold5.runs[0]) == 2 * len(cold10.runs[0])


def _rewrite(entry: Path, **changes: Any) -> None:
    """Rewrite an entry with a consistent header (and checksum) but other contents."""
    meta, floats, ints = read_entry(entry)
    meta.update(changes.pop("meta", {}))
    arrays = {"floats": floats, "ints": ints, **changes}
    write_entry(entry, meta, **arrays)


def _not_json(entry: Path) -> None:
    meta, floats, ints = read_entry(entry)
    write_entry(entry, json.dumps(meta).encode()[:-1], floats, ints)  # no closing brace


def _other_magic(entry: Path) -> None:
    size = entry.stat().st_size
    meta, floats, ints = read_entry(entry)
    write_entry(entry, meta, floats, ints, magic=b"ACRUN\x00\x02\x00")
    assert entry.stat().st_size == size  # the right size: only the magic says no


def _pickled(entry: Path) -> None:
    with entry.open("wb") as fh:
        np.savez(fh, meta=np.array([{"format": cache.FORMAT}], dtype=object))


def _flip(entry: Path, at: int) -> None:
    b = bytearray(entry.read_bytes())
    b[at] ^= 0xFF
    entry.write_bytes(bytes(b))


CORRUPTIONS: dict[str, Callable[[Path], object]] = {
    "truncated": lambda e: e.write_bytes(e.read_bytes()[: e.stat().st_size // 2]),
    "empty": lambda e: e.write_bytes(b""),
    "garbage": lambda e: e.write_bytes(os.urandom(4096)),
    "flipped byte in the data": lambda e: _flip(e, 2000),
    "flipped byte in the metadata": lambda e: _flip(e, HEADER.size + 40),
    "flipped byte in the header": lambda e: _flip(e, 20),
    "last byte cut": lambda e: e.write_bytes(e.read_bytes()[:-1]),
    "a byte more": lambda e: e.write_bytes(e.read_bytes() + b" "),
    "a zero word more": lambda e: e.write_bytes(e.read_bytes() + bytes(8)),  # same checksum
    "other magic, right size": _other_magic,
    "wrong checksum": lambda e: _rewrite(e, checksum_delta=1),
    "old npz format": lambda e: _old_format_entry(e, e),
    "metadata not json": _not_json,
    "metadata not a dict": lambda e: write_entry(e, b"[2]", *read_entry(e)[1:]),
    "other format": lambda e: _rewrite(e, meta={"format": cache.FORMAT + 1}),
    "format 1": lambda e: _rewrite(e, meta={"format": 1}),
    "other version": lambda e: _rewrite(e, meta={"accelcore": "0.0.0-other"}),
    "other key": lambda e: _rewrite(e, meta={"key": "0" * 64}),
    "bad fingerprint type": lambda e: _rewrite(e, meta={"fingerprint": "x"}),
    "bad hash": lambda e: _rewrite(e, meta={"digest": "not a hash"}),
    "negative count": lambda e: _rewrite(e, meta={"n_rows": -1}),
    "wrong block count": lambda e: _rewrite(e, meta={"n_blocks": 3}),
    "no ints": lambda e: _rewrite(e, ints=np.zeros(0, np.int64)),
    "short floats": lambda e: _rewrite(e, floats=read_entry(e)[1][:-1]),
    "pickled": _pickled,
}


@pytest.mark.parametrize("how", list(CORRUPTIONS))
def test_a_bad_entry_is_a_miss_and_is_replaced(
    aged: dict[str, Path], tmp_path: Path, how: str
) -> None:
    folder = aged["shared"]
    cold = load_session(folder, cache=False)
    load_session(folder, cache=tmp_path)
    for entry in entries(tmp_path)[:2]:
        CORRUPTIONS[how](entry)
    csvs = [f for f in files_of(folder) if f.suffix == ".csv"]
    lookups = cache.RunCache(tmp_path).lookup_all(csvs, _params_of(folder))
    assert sum(hit is not None for hit, _ in lookups) == 4  # the good ones share one buffer
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = load_session(folder, cache=tmp_path)
    assert_identical(again, cold)
    assert len(entries(tmp_path)) == 6
    hits = cache.RunCache(tmp_path)
    for f in files_of(folder):
        if f.suffix == ".csv":
            [(hit, _)] = hits.lookup_all([f], _params_of(folder))
            assert hit is not None, f  # replaced by a good entry
    assert_identical(load_session(folder, cache=tmp_path), cold)


def _params_of(folder: Path, factor: int = 10) -> dict[str, Any]:
    """The reader parameters load_session uses for the simulated sessions."""
    return {
        "delimiter": ",",
        "time_column": "time_s",
        "temperature_column": "temp_c",
        "channel_columns": ["x", "y", "z"],
        "keep_extra_columns": True,
        "time_scale_to_s": 1.0,
        "factor": factor,
        "rate_hz": 20.0,
        "min_count": 1,
    }


def test_a_corrupt_entry_in_the_default_folder_is_a_miss(
    aged: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ACCELCORE_CACHE_DIR", str(tmp_path))
    folder = aged["corrupt"]
    first = load_session(folder)
    assert len(entries(tmp_path)) == 6
    for entry in entries(tmp_path):
        entry.write_bytes(b"PK\x03\x04 not really a zip")
    assert_identical(load_session(folder), first)


def test_a_fresh_file_is_not_cached(tmp_path: Path) -> None:
    """The racy rule: a file changed less than 2 s ago may still be growing."""
    folder = tmp_path / "fresh"
    simulate.session(folder, duration_h=0.05, soak_min=0.5, seed=6)
    session = load_session(folder, cache=tmp_path / "cache")
    assert entries(tmp_path / "cache") == []
    assert_identical(session, load_session(folder, cache=False))


def test_an_old_mtime_with_a_fresh_ctime_is_not_cached(tmp_path: Path) -> None:
    """Putting the mtime back does not make a just-written file safe to cache."""
    folder = tmp_path / "touched"
    simulate.session(folder, duration_h=0.05, soak_min=0.5, seed=6)
    back = time.time_ns() - 3600 * 1_000_000_000
    for f in files_of(folder):
        os.utime(f, ns=(back, back))
    load_session(folder, cache=tmp_path / "cache")
    assert entries(tmp_path / "cache") == []


def test_a_file_that_changes_while_it_is_read_is_not_cached(
    aged: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = aged["during"]
    real = real_read_run
    log = folder / "z_pos.csv"

    def read_then_append(path: str, **kwargs: Any) -> Any:
        result = real(path, **kwargs)
        if Path(path) == log:
            with log.open("a") as fh:
                fh.write("180.00,65.010,1.793518,1.486816,1.495667,3.00037\n")
        return result

    monkeypatch.setattr(session_module, "read_run", read_then_append)
    first = load_session(folder, cache=tmp_path)
    monkeypatch.setattr(session_module, "read_run", real)
    assert len(entries(tmp_path)) == 5  # all but the one that changed
    second = load_session(folder, cache=tmp_path)
    assert second.runs[4].stats.n_rows == first.runs[4].stats.n_rows + 1
    assert_identical(second, load_session(folder, cache=False))


def test_cache_false_writes_nothing(
    aged: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ACCELCORE_CACHE_DIR", str(tmp_path / "default"))
    load_session(aged["shared"], cache=False)
    assert not (tmp_path / "default").exists()
    monkeypatch.setenv("ACCELCORE_CACHE", "0")
    load_session(aged["shared"])
    assert not (tmp_path / "default").exists()
    load_session(aged["shared"], cache=tmp_path / "explicit")  # a folder given still counts
    assert len(entries(tmp_path / "explicit")) == 6
    monkeypatch.delenv("ACCELCORE_CACHE")
    load_session(aged["shared"])
    assert len(entries(tmp_path / "default")) == 6


def test_the_default_folder(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("ACCELCORE_CACHE_DIR", str(tmp_path / "a"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.resolve_dir(True) == tmp_path / "a"
    monkeypatch.delenv("ACCELCORE_CACHE_DIR")
    assert cache.resolve_dir(True) == tmp_path / "xdg" / "accelcore" / "runs"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.resolve_dir(True) == tmp_path / "home" / ".cache" / "accelcore" / "runs"
    assert cache.default_dir() == cache.resolve_dir(True)
    for off in ("0", "false", "off"):
        monkeypatch.setenv("ACCELCORE_CACHE", off)
        assert cache.resolve_dir(True) is None
    assert cache.resolve_dir(False) is None
    assert cache.resolve_dir(tmp_path / "b") == tmp_path / "b"
    assert cache.resolve_dir(str(tmp_path / "c")) == tmp_path / "c"
    with pytest.raises(TypeError, match="cache must be"):
        cache.resolve_dir(1)  # type: ignore[arg-type]


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root ignores file permissions"
)
def test_an_unwritable_cache_folder_warns_once(aged: dict[str, Path], tmp_path: Path) -> None:
    store = tmp_path / "ro"
    store.mkdir()
    store.chmod(0o500)
    try:
        with pytest.warns(CacheWarning, match="cannot write the run cache") as caught:
            session = load_session(aged["unwritable"], cache=store)
    finally:
        store.chmod(0o700)
    assert len(caught) == 1
    assert_identical(session, load_session(aged["unwritable"], cache=False))
    assert entries(store) == []


def test_a_cache_path_that_is_a_file_warns_once(aged: dict[str, Path], tmp_path: Path) -> None:
    """Cannot be written, even by root: the result is the same, with one warning."""
    store = tmp_path / "a-file"
    store.write_text("not a folder")
    with pytest.warns(CacheWarning, match="cannot write the run cache") as caught:
        session = load_session(aged["unwritable"], cache=store / "runs")
    assert len(caught) == 1
    assert issubclass(CacheWarning, accelcore.errors.AccelcoreWarning)
    assert_identical(session, load_session(aged["unwritable"], cache=False))


def test_a_full_disk_warns_once_and_leaves_no_temporary_file(
    aged: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def full(*args: Any, **kwargs: Any) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(cache, "_write_entry", full)
    with pytest.warns(CacheWarning, match="No space left") as caught:
        session = load_session(aged["unwritable"], cache=tmp_path)
    assert len(caught) == 1
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    assert_identical(session, load_session(aged["unwritable"], cache=False))


def _set_mtime(paths: list[Path], seconds_ago: float) -> None:
    t = time.time_ns() - int(seconds_ago * 1e9)
    for p in paths:
        os.utime(p, ns=(t, t))


def test_pruning_keeps_the_folder_under_its_bound(
    aged: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder, store = aged["prune"], tmp_path / "cache"
    load_session(folder, decimation_factor=5, cache=tmp_path / "scratch")
    size5 = sum(e.stat().st_size for e in entries(tmp_path / "scratch"))
    load_session(folder, cache=store)
    tens = entries(store)
    largest10 = max(e.stat().st_size for e in tens)
    _set_mtime(tens, 100)
    # Room for the six factor-5 entries and two factor-10 entries.
    bound = size5 + 2 * largest10
    monkeypatch.setenv("ACCELCORE_CACHE_MAX_MB", str(bound / 1e6))
    load_session(folder, decimation_factor=5, cache=store)
    kept = entries(store)
    assert sum(e.stat().st_size for e in kept) <= bound
    assert len(set(kept) - set(tens)) == 6  # the new entries stay ...
    assert 1 <= len(set(kept) & set(tens)) <= 2  # ... the least recently used went first
    monkeypatch.setenv("ACCELCORE_CACHE_MAX_MB", "0")
    load_session(folder, decimation_factor=4, cache=store)
    assert entries(store) == []


def test_a_hit_counts_as_a_use_for_pruning(aged: dict[str, Path], tmp_path: Path) -> None:
    folder = aged["prune"]
    load_session(folder, cache=tmp_path)
    tens = entries(tmp_path)
    load_session(folder, decimation_factor=5, cache=tmp_path)
    fives = sorted(set(entries(tmp_path)) - set(tens))
    _set_mtime(tens, 200)
    _set_mtime(fives, 100)  # the factor-5 entries were used more recently ...
    load_session(folder, cache=tmp_path)  # ... until the factor-10 ones are hits
    size10 = sum(e.stat().st_size for e in tens)
    assert cache.prune(tmp_path, max_bytes=size10 + 100) == 6
    assert entries(tmp_path) == tens


def test_pruning_removes_stale_temporary_files_only(tmp_path: Path) -> None:
    old, new = tmp_path / ".tmp-old.acrun", tmp_path / ".tmp-new.acrun"
    old_npz, new_npz = tmp_path / ".tmp-old.npz", tmp_path / ".tmp-new.npz"  # earlier format's
    other = tmp_path / "notes.txt"
    for p in (old, new, old_npz, new_npz, other):
        p.write_bytes(b"x" * 10)
    _set_mtime([old, old_npz], 7200)
    assert cache.prune(tmp_path, max_bytes=1e9) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        ".tmp-new.acrun",
        ".tmp-new.npz",
        "notes.txt",
    ]


def _old_format_entry(path: Path, entry: Path) -> None:
    """Write at ``path`` the FORMAT 1 (numpy.savez) entry holding what ``entry`` holds."""
    meta, floats, ints = read_entry(entry)
    meta["format"] = 1
    raw = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    with path.open("wb") as fh:
        np.savez(fh, meta=raw, floats=floats, ints=ints)


def test_old_format_entries_are_ignored_and_removed(
    aged: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = aged["shared"]
    cold = load_session(folder, cache=False)
    load_session(folder, cache=tmp_path)
    stems = [e.stem for e in entries(tmp_path)]
    for stem in stems:  # under the very keys of today's entries, which are then removed
        _old_format_entry(tmp_path / f"{stem}.npz", tmp_path / f"{stem}{cache.SUFFIX}")
        (tmp_path / f"{stem}{cache.SUFFIX}").unlink()
    (tmp_path / "notes.npz").write_bytes(b"not an entry name")
    reads: list[str] = []

    def counting(path: str, **kwargs: Any) -> Any:
        reads.append(path)
        return real_read_run(path, **kwargs)

    monkeypatch.setattr(session_module, "read_run", counting)
    assert_identical(load_session(folder, cache=tmp_path), cold)
    assert len(reads) == 6  # no old entry was read ...
    assert [e.stem for e in entries(tmp_path)] == stems
    assert sorted(p.name for p in tmp_path.glob("*.npz")) == ["notes.npz"]  # ... and all went
    # prune removes them even when the folder is within its bound, and counts them.
    for stem in stems[:2]:
        _old_format_entry(tmp_path / f"{stem}.npz", tmp_path / f"{stem}{cache.SUFFIX}")
    assert cache.prune(tmp_path, max_bytes=1e12) == 2
    assert len(entries(tmp_path)) == 6 and len(list(tmp_path.glob("*.npz"))) == 1
    # clear removes and counts them too.
    for stem in stems[:3]:
        _old_format_entry(tmp_path / f"{stem}.npz", tmp_path / f"{stem}{cache.SUFFIX}")
    assert cache.clear(tmp_path) == 6 + 3
    assert [p.name for p in tmp_path.iterdir()] == ["notes.npz"]


def test_clear(aged: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    load_session(aged["shared"], cache=tmp_path)
    (tmp_path / "keep.txt").write_text("not an entry")
    assert cache.clear(tmp_path) == 6
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
    assert cache.clear(tmp_path / "missing") == 0
    monkeypatch.setenv("ACCELCORE_CACHE_DIR", str(tmp_path / "default"))
    load_session(aged["shared"])
    assert cache.clear() == 6


def test_the_key_covers_everything_that_changes_the_result(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    base = _params_of(Path("."))
    key = cache.entry_key("/data/s/x_pos.csv", base)
    assert key == cache.entry_key("/data/s/x_pos.csv", dict(reversed(list(base.items()))))
    changed = {
        "delimiter": ";",
        "time_column": "t",
        "temperature_column": "die_c",
        "channel_columns": ["y", "x", "z"],
        "keep_extra_columns": False,
        "time_scale_to_s": 1e-3,
        "factor": 5,
        "rate_hz": 100.0,
        "min_count": 2,
    }
    assert set(changed) == set(base)
    keys = {key, cache.entry_key("/data/t/x_pos.csv", base)}
    for name, value in changed.items():
        keys.add(cache.entry_key("/data/s/x_pos.csv", {**base, name: value}))
    monkeypatch.setattr(cache, "__version__", "9.9.9")
    keys.add(cache.entry_key("/data/s/x_pos.csv", base))
    monkeypatch.setattr(cache, "FORMAT", cache.FORMAT + 1)
    keys.add(cache.entry_key("/data/s/x_pos.csv", base))
    assert len(keys) == 2 + len(changed) + 2


def test_a_new_column_mapping_is_a_miss(
    aged: dict[str, Path], tmp_path: Path, no_reading: Callable[[], None]
) -> None:
    folder = aged["mapping"]
    original = load_session(folder, cache=tmp_path)
    toml = folder / "session.toml"
    text = toml.read_text()
    swapped = text.replace('x = "x"\ny = "y"\n', 'x = "y"\ny = "x"\n')
    assert swapped != text
    toml.write_text(swapped)
    remapped = load_session(folder, cache=tmp_path)
    assert len(entries(tmp_path)) == 12
    np.testing.assert_array_equal(remapped.runs[0].output[:, 0], original.runs[0].output[:, 1])
    assert remapped.file_digests["session.toml"] != original.file_digests["session.toml"]
    no_reading()
    assert_identical(load_session(folder, cache=tmp_path), remapped)
    toml.write_text(text)
    assert_identical(load_session(folder, cache=tmp_path), original)


def test_every_command_that_loads_a_session_has_no_cache() -> None:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    choices: dict[str, Any] = sub.choices  # type: ignore[assignment]
    for command in ("calibrate", "diagnose", "report", "bulk", "demo"):
        assert "--no-cache" in choices[command].format_help(), command


@pytest.fixture
def cli_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    monkeypatch.setenv("ACCELCORE_CACHE_DIR", str(tmp_path / "cli-cache"))
    yield tmp_path / "cli-cache"


@pytest.mark.parametrize("command", ["calibrate", "diagnose"])
def test_cli_no_cache(aged: dict[str, Path], cli_cache: Path, command: str) -> None:
    folder = str(aged["cli"])
    out = io.StringIO()
    assert main([command, folder, "--no-cache", "--json", "-"], stdout=out) == 0
    assert entries(cli_cache) == []
    assert main([command, folder, "--json", "-"], stdout=io.StringIO()) == 0
    assert len(entries(cli_cache)) == 6
    again = io.StringIO()
    assert main([command, folder, "--json", "-"], stdout=again) == 0
    assert json.loads(again.getvalue())["result"] == json.loads(out.getvalue())["result"]


def test_bulk_passes_the_cache_setting(aged: dict[str, Path], tmp_path: Path) -> None:
    from accelcore.apps.bulk import bulk

    archive = aged["archive/part0"].parent
    bulk(archive, tmp_path / "off", jobs=1, diagnose=False, progress=False, cache=False)
    assert entries(tmp_path / "cache") == []
    bulk(archive, tmp_path / "on", jobs=1, diagnose=False, progress=False, cache=tmp_path / "cache")
    assert len(entries(tmp_path / "cache")) == 6


def test_warm_arrays_are_writeable_exactly_when_cold_ones_are(
    aged: dict[str, Path], tmp_path: Path, no_reading: Callable[[], None]
) -> None:
    """Views of the entry's buffer: writeable as a cold read's, and writing stays in memory."""
    folder = aged["shared"]
    cold = load_session(folder, cache=False)
    load_session(folder, cache=tmp_path)
    no_reading()
    warm = load_session(folder, cache=tmp_path)

    def arrays(run: Any) -> dict[str, np.ndarray]:
        st = run.stats
        found = {
            "time_s": run.time_s,
            "temperature_c": run.temperature_c,
            "output": run.output,
            "count": run.count,
            "channel_min": st.channel_min,
            "channel_max": st.channel_max,
            "n_at_min": st.n_at_min,
            "n_at_max": st.n_at_max,
        }
        return found | {f"extras[{k}]": v for k, v in run.extras.items()}

    for c, w in zip(cold.runs, warm.runs, strict=True):
        a, b = arrays(c), arrays(w)
        assert list(a) == list(b)
        for name in a:
            assert b[name].flags.writeable == a[name].flags.writeable, name
            assert b[name].flags.aligned, name
    assert warm.runs[0].time_s.flags.writeable  # the cold path's are
    # Writing into a warm run changes neither the entry nor the next load.
    warm.runs[0].time_s[0] += 1.0
    warm.runs[0].output[:] = 0.0
    assert_identical(load_session(folder, cache=tmp_path), cold)


def test_session_from_a_hit_is_a_plain_session(aged: dict[str, Path], tmp_path: Path) -> None:
    load_session(aged["shared"], cache=tmp_path)
    warm = load_session(aged["shared"], cache=tmp_path)
    assert isinstance(warm, Session)
    warm.check_orientations()
    for run in warm.runs:
        for a in (run.time_s, run.temperature_c, run.output, run.count):
            assert a.flags.c_contiguous


def test_entries_are_private_and_stale_temporaries_of_atomic_writes_are_pruned(
    aged: dict[str, Path], tmp_path: Path
) -> None:
    load_session(aged["prune"], cache=tmp_path / "c")
    written = entries(tmp_path / "c")
    assert written and all(e.stat().st_mode & 0o777 == 0o600 for e in written)
    key = "ab" * 32
    old, new = (
        tmp_path / f".{key}{cache.SUFFIX}.x1y2z3.tmp",
        tmp_path / f".{key}{cache.SUFFIX}.a.tmp",
    )
    other = tmp_path / f".{key[:-1]}{cache.SUFFIX}.old.tmp"  # not an entry's name
    for p in (old, new, other):
        p.write_bytes(b"x" * 10)
    _set_mtime([old, other], 7200)
    assert cache.prune(tmp_path, max_bytes=1e9) == 0
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == sorted(
        [new.name, other.name]
    )
    assert cache.clear(tmp_path) == 0
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == [other.name]
