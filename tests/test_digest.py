"""Content digests of the logs (provenance): BLAKE3 by default, SHA-256 on request.

The BLAKE3 oracle is the reference implementation's output for the same bytes
(``b3sum``; the values below were taken with the ``blake3`` package from PyPI),
written here as known answers, so these tests need no extra package. When the
``blake3`` package is importable, one more test compares against it directly.
"""

from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path

import pytest

import accelcore
from accelcore import simulate
from accelcore._accelcore import digest_bytes, read_run
from accelcore.errors import OutputConflictError, ParameterError
from accelcore.input import cache
from accelcore.result.calibration import Calibration

CUT = "time_s,temp_c,x,y,z\n0.00,20.0,1,2,3\n0.05,20.0,1,2,3\n0.10,20.1,1,2"
CUT_BLAKE3 = "f23ac4630b5adfb38dfd526ed1859513db6ebd46b2765abc0120dea164361096"
EMPTY_BLAKE3 = "af1349b9f5f9a1a6a0404dea36dcc9499bcb25c9adc112b7cc9a93cae41f3262"
BIG_BLAKE3 = "a983d7c3d9929d592d8fae3720281c5c5b3d54d676047c15ad20a940ad000320"


def big_log() -> str:
    """About 4.4 MB (several fills of the reader's 1 MiB buffer), last line cut off."""
    rows = [
        f"{0.05 * i:.3f},{20 + 1e-4 * i:.4f},{1.5 + 1e-6 * (i % 997):.6f},"
        f"{1.48 + 1e-5 * (i % 13):.6f},{1.8 - 1e-6 * (i % 31):.6f}\n"
        for i in range(100_000)
    ]
    return "time_s,temp_c,x,y,z\n" + "".join(rows) + "5000.000,70.0,1.5"


def _write(tmp_path: Path, text: str, name: str = "log.csv") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode())
    return path


@pytest.mark.parametrize(("text", "expected"), [(CUT, CUT_BLAKE3), (big_log(), BIG_BLAKE3)])
def test_blake3_is_b3sum_of_the_bytes_read(tmp_path: Path, text: str, expected: str) -> None:
    path = _write(tmp_path, text)
    hashed = read_run(str(path), digest="blake3")
    plain = read_run(str(path))
    assert hashed.n_truncated_rows == 1  # the cut-off last line is dropped, yet hashed
    assert (hashed.digest, hashed.digest_algorithm) == (expected, "blake3")
    assert hashed.sha256 is None and plain.digest is None and plain.digest_algorithm is None
    assert digest_bytes(path.read_bytes()) == expected  # the one-shot of the same bytes
    assert hashed.n_rows == plain.n_rows
    assert hashed.blocks.channels.tobytes() == plain.blocks.channels.tobytes()


def test_blake3_matches_the_pypi_package(tmp_path: Path) -> None:
    blake3 = pytest.importorskip("blake3")
    path = _write(tmp_path, big_log())
    assert (
        read_run(str(path), digest="blake3").digest == blake3.blake3(path.read_bytes()).hexdigest()
    )


def test_sha256_on_request_and_the_older_spelling(tmp_path: Path) -> None:
    path = _write(tmp_path, big_log())
    want = hashlib.sha256(path.read_bytes()).hexdigest()
    for run in (read_run(str(path), digest="sha256"), read_run(str(path), sha256=True)):
        assert (run.digest, run.digest_algorithm, run.sha256) == (want, "sha256", want)
    assert read_run(str(path), sha256=True, digest="sha256").sha256 == want
    assert digest_bytes(b"", "sha256") == hashlib.sha256(b"").hexdigest()
    assert digest_bytes(b"") == EMPTY_BLAKE3


def test_bad_digest_requests_are_parameter_errors(tmp_path: Path) -> None:
    path = _write(tmp_path, CUT)
    with pytest.raises(ParameterError, match="md5"):
        read_run(str(path), digest="md5")
    with pytest.raises(ParameterError, match="sha256=True"):
        read_run(str(path), digest="blake3", sha256=True)
    with pytest.raises(ParameterError, match="md5"):
        digest_bytes(b"x", "md5")


def test_the_digest_survives_pickling(tmp_path: Path) -> None:
    path = _write(tmp_path, CUT)
    for asked in ("blake3", "sha256"):
        run = read_run(str(path), digest=asked)
        back = pickle.loads(pickle.dumps(run))
        assert (back.digest, back.digest_algorithm, back.sha256) == (
            run.digest,
            run.digest_algorithm,
            run.sha256,
        )
    assert pickle.loads(pickle.dumps(read_run(str(path)))).digest is None


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("digest") / "s"
    simulate.session(path, duration_h=0.1, soak_min=1.0, seed=4)
    return path


def _files(folder: Path) -> dict[str, bytes]:
    return {
        f.name: f.read_bytes()
        for f in folder.iterdir()
        if f.suffix in (".csv", ".toml") and f.name != "truth.toml"
    }


def test_sessions_take_blake3_by_default_and_sha256_on_request(folder: Path) -> None:
    session = accelcore.load_session(folder, cache=False)
    files = _files(folder)
    assert session.digest == "blake3" and session.file_sha256 == {}
    assert session.file_hashes() == {name: digest_bytes(data) for name, data in files.items()}
    sha = accelcore.load_session(folder, cache=False, digest="sha256")
    want = {name: hashlib.sha256(data).hexdigest() for name, data in files.items()}
    assert sha.digest == "sha256" and sha.file_hashes() == want == sha.file_sha256
    with pytest.raises(ParameterError, match="digest"):
        accelcore.load_session(folder, cache=False, digest="md5")


def test_cache_entries_hold_the_digest_of_their_algorithm(
    folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Keep the simulated files out of the racy window, so that they are cached.
    monkeypatch.setattr(cache, "RACY_WINDOW_NS", 0)
    cold = {d: accelcore.load_session(folder, cache=False, digest=d) for d in ("blake3", "sha256")}
    store = tmp_path / "cache"
    accelcore.load_session(folder, cache=store)
    runs = len(cold["blake3"].runs)
    assert len(list(store.glob("*.acrun"))) == runs
    # Another algorithm is another key: a miss, then its own entries.
    assert accelcore.load_session(folder, cache=store, digest="sha256").file_hashes() == (
        cold["sha256"].file_hashes()
    )
    entries = sorted(store.glob("*.acrun"))
    assert len(entries) == 2 * runs
    seen = set()
    for entry in entries:
        buf = entry.read_bytes()
        meta_len = int.from_bytes(buf[8:16], "little")
        meta = json.loads(buf[40 : 40 + meta_len])
        assert meta["format"] == cache.FORMAT == 3
        algorithm = meta["digest_algorithm"]
        assert meta["params"]["digest"] == algorithm
        assert meta["digest"] == cold[algorithm].file_hashes()[Path(meta["path"]).name]
        seen.add(algorithm)
    assert seen == {"blake3", "sha256"}
    for d in ("blake3", "sha256"):
        hits = cache.RunCache(store)
        warm = accelcore.load_session(folder, cache=store, digest=d)
        assert warm.file_hashes() == cold[d].file_hashes() and warm.digest == d
        lookups = hits.lookup_all(
            [folder / f"{name}" for name in cold[d].file_hashes() if name.endswith(".csv")],
            {
                "delimiter": ",",
                "time_column": "time_s",
                "temperature_column": "temp_c",
                "channel_columns": ["x", "y", "z"],
                "keep_extra_columns": True,
                "time_scale_to_s": 1.0,
                "factor": 10,
                "rate_hz": 20.0,
                "min_count": 1,
            },
            d,
        )
        assert all(hit is not None for hit, _ in lookups)


def test_provenance_records_the_algorithm_and_round_trips(folder: Path, tmp_path: Path) -> None:
    session = accelcore.load_session(folder, cache=False)
    cal = accelcore.calibrate(session)
    assert cal.provenance["digest"] == "blake3"
    assert cal.provenance["files_blake3"] == session.file_hashes()
    assert "files_sha256" not in cal.provenance
    path = tmp_path / "cal.json"
    cal.save(path)
    back = Calibration.load(path)
    assert back.provenance == cal.provenance
    assert back.file_digests() == ("blake3", session.file_hashes())
    # The session's files are still protected from being overwritten.
    with pytest.raises(OutputConflictError):
        cal.save(folder / "x_pos.csv")
    sha = accelcore.calibrate(accelcore.load_session(folder, cache=False, digest="sha256"))
    assert sha.provenance["digest"] == "sha256"
    assert sha.file_digests() == ("sha256", sha.provenance["files_sha256"])


def test_files_written_before_the_algorithm_was_recorded_still_read(
    folder: Path, tmp_path: Path
) -> None:
    session = accelcore.load_session(folder, cache=False, digest="sha256")
    cal = accelcore.calibrate(session)
    path = tmp_path / "old.json"
    cal.save(path)
    doc = json.loads(path.read_text())
    del doc["body"]["provenance"]["digest"]  # what an older accelcore wrote
    text = json.dumps(doc["body"], sort_keys=True, allow_nan=True)
    doc["sha256"] = hashlib.sha256(text.encode()).hexdigest()
    path.write_text(json.dumps(doc))
    old = Calibration.load(path)
    assert "digest" not in old.provenance
    assert old.file_digests() == ("sha256", session.file_hashes())
    with pytest.raises(OutputConflictError):
        old.save(folder / "session.toml")
