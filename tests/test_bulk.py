"""Bulk processing of an archive: outputs, failures, determinism, reruns, kill -9, Dask."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from accelcore import simulate
from accelcore.apps.bulk import FAILURE_COLUMNS, FLEET_COLUMNS, bulk, find_sessions
from accelcore.apps.cli import main
from accelcore.errors import OutputConflictError

SENSORS = ("ADXL335", "MPU-9255", "ADXL327", "LIS344ALH")
N_GOOD = 47
BROKEN = {
    "lot9/bad-toml": "load",
    "lot9/bad-cell": "load",
    "lot9/no-run-file": "load",
}
TABLES = ("fleet.csv", "fleet.parquet", "failures.csv")


def _make_archive(root: Path, n_good: int) -> Path:
    for i in range(n_good):
        simulate.session(
            root / f"lot{i % 5}" / f"part{i:02d}",
            SENSORS[i % 4],
            seed=i,
            duration_h=0.08,
            soak_min=0.5,
            serial=f"S{i:03d}",
        )
    return root


def _break(root: Path) -> None:
    src = root / "lot0" / "part00"
    for rel in BROKEN:
        shutil.copytree(src, root / rel)
    toml = root / "lot9/bad-toml/session.toml"
    toml.write_text(toml.read_text().replace('units = "V"', 'units = "volts"'))
    csv = root / "lot9/bad-cell/x_pos.csv"
    lines = csv.read_text().splitlines()
    lines[10] = lines[10].replace(",", ",oops,", 1)
    csv.write_text("\n".join(lines) + "\n")
    (root / "lot9/no-run-file/z_neg.csv").unlink()


@pytest.fixture(scope="module")
def archive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = _make_archive(tmp_path_factory.mktemp("archive"), N_GOOD)
    _break(root)
    return root


@pytest.fixture(scope="module")
def run_two_jobs(archive: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("out2")
    bulk(archive, out, jobs=2, progress=False)
    return out


def test_finds_sessions_at_any_depth(archive: Path) -> None:
    found = find_sessions(archive)
    assert len(found) == N_GOOD + len(BROKEN)
    assert found == sorted(found)
    assert "lot9/bad-toml" in found


def test_outputs_fleet_table_and_failures(archive: Path, run_two_jobs: Path) -> None:
    out = run_two_jobs
    fleet = pd.read_csv(out / "fleet.csv")
    assert list(fleet.columns) == list(FLEET_COLUMNS)
    assert len(fleet) == 3 * N_GOOD  # one row per session and axis
    assert set(fleet["sensor"]) == set(SENSORS)
    parquet = pd.read_parquet(out / "fleet.parquet")
    # Same content; the CSV reads a missing in/out-of-spec flag back as NaN, Parquet as None.
    text = {"session", "serial", "sensor", "units", "axis", "not_identified", "effects"}
    numeric = [c for c in FLEET_COLUMNS if c not in text and not c.endswith("_in_spec")]
    pd.testing.assert_frame_equal(parquet[numeric], fleet[numeric], check_exact=True)
    for column in ("zero_g_offset_in_spec", "offset_tc_in_spec", "session", "effects"):
        as_text = [("" if pd.isna(v) else str(v)) for v in parquet[column]]
        assert as_text == [("" if pd.isna(v) else str(v)) for v in fleet[column]], column
    failures = pd.read_csv(out / "failures.csv")
    assert list(failures.columns) == list(FAILURE_COLUMNS)
    assert dict(zip(failures["session"], failures["stage"], strict=True)) == BROKEN
    reasons = dict(zip(failures["session"], failures["reason"], strict=True))
    assert "units" in reasons["lot9/bad-toml"]
    assert "oops" in reasons["lot9/bad-cell"] and "x_pos.csv:11:2" in reasons["lot9/bad-cell"]
    assert "z_neg.csv" in reasons["lot9/no-run-file"]
    for rel in find_sessions(archive):
        if rel in BROKEN:
            continue
        assert (out / rel / "calibration.json").is_file()
        assert (out / rel / "diagnosis.json").is_file()
    assert not list(out.rglob("*.tmp")), "a temporary file was left behind"


def test_tables_are_byte_identical_whatever_the_jobs(
    archive: Path, run_two_jobs: Path, tmp_path: Path
) -> None:
    bulk(archive, tmp_path, jobs=1, progress=False)
    for name in TABLES:
        assert (tmp_path / name).read_bytes() == (run_two_jobs / name).read_bytes(), name


def test_rerun_reuses_up_to_date_sessions_and_redoes_changed_ones(
    archive: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    first = bulk(archive, out, jobs=2, progress=False)
    second = bulk(archive, out, jobs=2, progress=False)
    assert second.n_reused == N_GOOD  # failed sessions are always retried
    changed = archive / "lot1" / "part01" / "x_pos.csv"
    later = time.time() + 5
    os.utime(changed, (later, later))
    third = bulk(archive, out, jobs=2, progress=False)
    assert third.n_reused == N_GOOD - 1
    for name in TABLES:
        assert (out / name).read_bytes() == (out / name).read_bytes()
    pd.testing.assert_frame_equal(first.fleet, third.fleet)


def test_cli_exit_code_says_some_failed(archive: Path, tmp_path: Path) -> None:
    status = main(["bulk", str(archive), "-o", str(tmp_path), "--jobs", "2", "--quiet"])
    assert status == 1


def test_kill_9_then_rerun_gives_the_uninterrupted_table(tmp_path: Path) -> None:
    root = _make_archive(tmp_path / "arch", 10)
    reference = tmp_path / "ref"
    bulk(root, reference, jobs=1, progress=False)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "accelcore", "bulk", str(root), "-o", str(out), "--jobs", "1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while len(list(out.rglob("fleet_rows.json"))) < 3:
            assert proc.poll() is None, "bulk finished before it could be killed"
            assert time.monotonic() < deadline, "bulk made no progress"
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert not (out / "fleet.csv").exists()
    rerun = bulk(root, out, jobs=1, progress=False)
    assert rerun.n_reused >= 3
    for name in TABLES:
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::UserWarning")
def test_dask_local_cluster_gives_the_local_fleet_table(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed", reason="dask[distributed] not installed")
    root = _make_archive(tmp_path / "arch", 6)
    local = tmp_path / "local"
    bulk(root, local, jobs=1, progress=False)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        result = bulk(root, tmp_path / "dask", client=client, progress=False)
    assert result.ok
    for name in TABLES:
        assert (tmp_path / "dask" / name).read_bytes() == (local / name).read_bytes(), name


def test_outputs_that_would_write_over_a_session_are_refused(tmp_path: Path) -> None:
    """bulk arch -o arch/p with sessions a/ and p/a/: a's results would land in p/a."""
    arch = tmp_path / "arch"
    for rel in ("a", "p/a"):
        simulate.session(arch / rel, "ADXL335", seed=1, duration_h=0.05, soak_min=0.5)
    # p/a's run file named as bulk names its outputs.
    inner = arch / "p" / "a"
    (inner / "x_pos.csv").rename(inner / "calibration.json")
    toml = inner / "session.toml"
    toml.write_text(toml.read_text().replace('"x_pos.csv"', '"calibration.json"'))
    before = {p: p.read_bytes() for p in arch.rglob("*") if p.is_file()}
    with pytest.raises(OutputConflictError) as info:
        bulk(arch, arch / "p", jobs=1, progress=False)
    assert info.value.input == str(inner / "calibration.json")
    assert before == {p: p.read_bytes() for p in arch.rglob("*") if p.is_file()}
    # A run file outside its session, named as a fleet table of the output.
    out = tmp_path / "out"
    out.mkdir()
    (out / "fleet.csv").write_text((arch / "a" / "x_neg.csv").read_text())
    toml = arch / "a" / "session.toml"
    toml.write_text(toml.read_text().replace('"x_neg.csv"', '"../../out/fleet.csv"'))
    code = main(["bulk", str(arch), "-o", str(out), "--quiet"])
    assert code == 2
    assert (out / "fleet.csv").read_text() == (arch / "a" / "x_neg.csv").read_text()
