"""Hostile inputs (issue 17), continued: the classes that already gave the right answer.

The issue tried 96 hostile inputs; ``tests/test_adversarial.py`` keeps the ones
that gave a wrong or weak answer. This module keeps a named test for each other
class the issue lists (docs/bad-input.md, "Files that are not logs" and after):

- files that are not logs: FIFOs, 2 GB sparse files, 64 MB lines, link loops,
  NUL bytes, in every place a file is read (run file, ``session.toml``,
  calibration file, a log given to ``compensate``, an orientation log);
- overflowing cells;
- tampered calibration files;
- odd NumPy layouts (Fortran order, strided, big-endian, float32, integers);
- threads;
- bulk runs killed with ``kill -9`` or run twice at once;

plus a property test that corrupts the *files* of a session at random and
accepts only a typed error, a ``not_identified`` term, or a calibration right
within noise, with every input file unchanged.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import accelcore
from accelcore import simulate
from accelcore.apps.bulk import bulk
from accelcore.constants import ORIENTATIONS
from accelcore.input.readers import read_orientation_log
from test_adversarial import SHORT, _compensated_error_g, run_main, untouched

GB = 1 << 30
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The simulation of ``test_adversarial._SIM`` (seed 23) written as a session folder."""
    folder = tmp_path_factory.mktemp("adv-more") / "S"
    simulate.session(folder, "ADXL335", seed=23, **SHORT)
    return folder


@pytest.fixture(scope="module")
def base_cal(base: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    target = tmp_path_factory.mktemp("adv-more-cal") / "cal.json"
    accelcore.calibrate(accelcore.load_session(base, cache=False)).save(target)
    return target


@pytest.fixture
def S(base: Path, tmp_path: Path) -> Path:
    folder = tmp_path / "S"
    shutil.copytree(base, folder)
    return folder


@pytest.fixture
def CAL(base_cal: Path, tmp_path: Path) -> Path:
    target = tmp_path / "cal.json"
    shutil.copyfile(base_cal, target)
    return target


def cli(*argv: str | Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """The command line in a fresh process; ``timeout`` bounds a hang, it does not time speed."""
    return subprocess.run(
        [sys.executable, "-m", "accelcore", *map(str, argv)],
        env=ENV,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def sparse(path: Path, size: int = 2 * GB) -> None:
    """Extend (or create) ``path`` to ``size`` bytes: the new part is a hole read as zeros."""
    with open(path, "ab") as fh:
        fh.truncate(size)


def set_cell(log: Path, line: int, column: int, text: str) -> None:
    """Put ``text`` in one cell of a CSV log (1-based line and column, as in the messages)."""
    lines = log.read_text().splitlines()
    cells = lines[line - 1].split(",")
    cells[column - 1] = text
    lines[line - 1] = ",".join(cells)
    log.write_text("\n".join(lines) + "\n")


def coefficients(cal: accelcore.Calibration) -> dict[str, np.ndarray]:
    return {a: np.asarray(cal.axes[a].coefficients) for a in "xyz"}


# ------------------------------------------------------------- files that are not logs
@pytest.mark.parametrize("where", ["whole file", "after the data"])
def test_a_2gb_sparse_run_file_is_refused_at_its_first_long_line(S: Path, where: str) -> None:
    """A hole reads as zeros with no line end: refused after 1 MiB, not read for 2 GB."""
    log = S / "x_pos.csv"
    n_lines = len(log.read_text().splitlines())
    if where == "whole file":
        log.write_bytes(b"")
    sparse(log)
    with pytest.raises(accelcore.ParseError, match="line longer than 1048576 bytes") as info:
        accelcore.load_session(S, cache=False)
    line = 1 if where == "whole file" else n_lines + 1
    assert (info.value.path, info.value.line, info.value.column) == (str(log), line, 1)


def test_a_2gb_sparse_run_file_is_refused_with_the_cache_on(S: Path) -> None:
    """The cache hashes the file while reading it: the same refusal, not a 2 GB hash."""
    sparse(S / "y_neg.csv")
    with pytest.raises(accelcore.ParseError, match="line longer than"):
        accelcore.load_session(S)


def test_a_64mb_line_in_a_run_file_names_its_line(S: Path) -> None:
    log = S / "z_pos.csv"
    lines = log.read_text().splitlines()
    lines.insert(100, "1," * (32 << 20))
    log.write_text("\n".join(lines) + "\n")
    with pytest.raises(accelcore.ParseError, match="line longer than") as info:
        accelcore.load_session(S, cache=False)
    assert (info.value.line, info.value.column) == (101, 1)


def test_a_2gb_sparse_session_toml_is_not_read(S: Path) -> None:
    sparse(S / "session.toml")
    with pytest.raises(accelcore.AccelcoreIOError, match=r"far more than a session\.toml") as info:
        accelcore.load_session(S, cache=False)
    assert info.value.path == str(S / "session.toml")


def test_a_session_toml_in_a_link_loop_is_named(S: Path) -> None:
    toml = S / "session.toml"
    toml.unlink()
    toml.symlink_to(toml)
    with pytest.raises(accelcore.AccelcoreIOError, match="symbolic links") as info:
        accelcore.load_session(S, cache=False)
    assert "missing" not in str(info.value) and str(toml) in str(info.value)


def test_a_2gb_sparse_calibration_file_is_not_read(tmp_path: Path) -> None:
    cal = tmp_path / "cal.json"
    sparse(cal)
    with pytest.raises(accelcore.AccelcoreIOError, match="far more than a calibration file"):
        accelcore.Calibration.load(cal)


@pytest.mark.parametrize("what", ["session.toml", "calibration file", "compensated log"])
def test_a_fifo_never_blocks_a_command(S: Path, CAL: Path, what: str) -> None:
    """Opening a FIFO would block until someone writes: it is refused before it is opened."""
    out = S.parent / "out.csv"
    argv: list[str | Path]
    if what == "session.toml":
        (S / "session.toml").unlink()
        os.mkfifo(S / "session.toml")
        fifo, argv = S / "session.toml", ["calibrate", S]
    elif what == "calibration file":
        fifo = S.parent / "fifo.json"
        os.mkfifo(fifo)
        argv = ["compensate", fifo, S / "x_pos.csv", "-o", out]
    else:
        fifo = S.parent / "fifo.csv"
        os.mkfifo(fifo)
        argv = ["compensate", CAL, fifo, "-o", out]
    with untouched(S, CAL):
        proc = cli(*argv)
    assert proc.returncode == 1, proc.stderr
    assert f"{fifo}: cannot read" in proc.stderr and "a FIFO (named pipe)" in proc.stderr
    assert not out.exists()


@pytest.mark.parametrize("where", ["whole file", "after the data", "64 MB line"])
def test_compensate_refuses_a_log_with_a_line_over_1_mib(S: Path, CAL: Path, where: str) -> None:
    log = S / "z_neg.csv"
    n_lines = len(log.read_text().splitlines())
    if where == "whole file":
        log.write_bytes(b"")
        sparse(log)
    elif where == "after the data":
        sparse(log)
    else:
        with open(log, "a") as fh:
            fh.write("1," * (32 << 20) + "\n")
    out = S.parent / "out.csv"
    with untouched(CAL):
        status, _, err = run_main("compensate", CAL, log, "-o", out)
    line = 1 if where == "whole file" else n_lines + 1
    assert status == 1 and f"{log}:{line}:1: line longer than 1048576 bytes" in err, err
    assert not out.exists()


@pytest.mark.parametrize("where", ["whole file", "after the data"])
def test_an_orientation_log_with_a_line_over_1_mib_is_refused(tmp_path: Path, where: str) -> None:
    log = tmp_path / "log.csv"
    head = "" if where == "whole file" else "time_s,temp_c,x,y,z,orientation\n0,25,1,2,3,OZ+\n"
    log.write_text(head)
    sparse(log)
    with pytest.raises(accelcore.ParseError, match="line longer than") as info:
        read_orientation_log(log, units="V", rate_hz=20.0)
    assert info.value.line == (1 if where == "whole file" else 3)


def test_a_nul_byte_in_a_cell_names_line_and_column(S: Path) -> None:
    log = S / "y_pos.csv"
    set_cell(log, 77, 4, "1.48\x00\x0031")
    with pytest.raises(accelcore.ParseError, match="column 'y'") as info:
        accelcore.load_session(S, cache=False)
    assert (info.value.line, info.value.column) == (77, 4)


# ----------------------------------------------------------------------- overflowing cells
@pytest.mark.parametrize("cell", ["1e999", "-1e999", "9" * 400])
def test_one_overflowing_cell_drops_its_row_and_nothing_else(
    S: Path, base: Path, cell: str
) -> None:
    """A cell beyond float range reads as ±inf: its row is left out like any non-finite row."""
    set_cell(S / "z_pos.csv", 51, 3, cell)
    cal = accelcore.calibrate(accelcore.load_session(S, cache=False))
    clean = accelcore.calibrate(accelcore.load_session(base, cache=False))
    for axis, c in coefficients(cal).items():
        np.testing.assert_allclose(c, coefficients(clean)[axis], rtol=1e-4, atol=1e-6)


def test_a_column_whose_block_means_overflow_is_named_not_called_mislabelled(S: Path) -> None:
    """Finite cells of 1e308 overflow when averaged: the run and column are named."""
    log = S / "z_pos.csv"
    lines = log.read_text().splitlines()
    for i in range(1, len(lines)):
        cells = lines[i].split(",")
        cells[3] = "1.7e308"
        lines[i] = ",".join(cells)
    log.write_text("\n".join(lines) + "\n")
    with pytest.raises(accelcore.SessionFormatError, match="no finite level") as info:
        accelcore.calibrate(accelcore.load_session(S, cache=False))
    assert "z_pos.csv (OZ+): the y output" in str(info.value)
    assert "mislabelled" not in str(info.value)


# --------------------------------------------------------------- tampered calibration files
def test_a_calibration_edited_without_its_checksum_is_refused(CAL: Path) -> None:
    doc = json.loads(CAL.read_text())
    doc["body"]["axes"]["x"]["coefficients"][0] += 0.001
    CAL.write_text(json.dumps(doc))
    with pytest.raises(accelcore.CalibrationFileError, match="checksum mismatch"):
        accelcore.Calibration.load(CAL)


@pytest.mark.parametrize("body", ["[]", '{"body": 1, "sha256": "0"}', '"text"', "\xff\xfe"])
def test_a_calibration_that_is_not_one_is_refused(tmp_path: Path, body: str) -> None:
    cal = tmp_path / "cal.json"
    cal.write_bytes(body.encode("latin-1"))
    with pytest.raises(accelcore.CalibrationFileError, match=str(cal)):
        accelcore.Calibration.load(cal)


# ------------------------------------------------------------------------ odd NumPy layouts
_LAYOUTS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "Fortran order": lambda a: np.asfortranarray(a),
    "strided slice": lambda a: np.repeat(a, 3, axis=0)[::3],
    "big-endian": lambda a: a.astype(a.dtype.newbyteorder(">")),
    "reversed twice": lambda a: a[::-1][::-1],
}


def _runs() -> list[tuple[str, dict[str, np.ndarray]]]:
    sim = simulate.arrays("ADXL335", seed=3, **SHORT)
    return [(r.orientation, {k: np.asarray(v) for k, v in r.columns.items()}) for r in sim.runs]


@pytest.mark.parametrize("layout", [*_LAYOUTS, "float32", "integers"])
def test_odd_numpy_layouts_give_the_same_calibration(layout: str) -> None:
    """Every layout gives the numbers of the plain C-contiguous float64 arrays of its values."""
    runs = _runs()
    plain: list[tuple[str, dict[str, np.ndarray]]]
    odd: list[tuple[str, dict[str, np.ndarray]]]
    if layout == "float32":
        plain = [
            (o, {k: v.astype(np.float32).astype(np.float64) for k, v in c.items()}) for o, c in runs
        ]
        odd = [(o, {k: v.astype(np.float32) for k, v in c.items()}) for o, c in runs]
    elif layout == "integers":  # ADC counts and whole degrees; time stays float
        scale = {"temp_c": 1.0, "x": 1000.0, "y": 1000.0, "z": 1000.0}
        ints = [
            (
                o,
                {
                    k: v if k == "time_s" else np.round(v * scale[k]).astype(np.int32)
                    for k, v in c.items()
                },
            )
            for o, c in runs
        ]
        plain = [(o, {k: v.astype(np.float64) for k, v in c.items()}) for o, c in ints]
        odd = ints
    else:
        plain = runs
        odd = [(o, {k: _LAYOUTS[layout](v) for k, v in c.items()}) for o, c in runs]
    options: dict[str, Any] = {"units": "V", "rate_hz": 20.0}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        want = accelcore.calibrate(accelcore.Session.from_arrays(plain, **options))
        got = accelcore.calibrate(accelcore.Session.from_arrays(odd, **options))
    for axis, c in coefficients(got).items():
        np.testing.assert_array_equal(c, coefficients(want)[axis])


@pytest.mark.parametrize("layout", [*_LAYOUTS, "float32", "integers"])
def test_odd_numpy_layouts_compensate_to_the_same_numbers(base_cal: Path, layout: str) -> None:
    cal = accelcore.Calibration.load(base_cal)
    sim = simulate.arrays("ADXL335", seed=9, orientations=("OY-",), **SHORT).runs[0].columns
    raw = np.column_stack([sim["x"], sim["y"], sim["z"]])
    temp, t = np.asarray(sim["temp_c"]), np.asarray(sim["time_s"])
    odd: list[np.ndarray]
    if layout == "float32":
        odd = [raw.astype(np.float32), temp.astype(np.float32), t.astype(np.float32)]
        plain = [a.astype(np.float64) for a in odd]
    elif layout == "integers":
        odd = [
            np.round(raw * 1000).astype(np.int32),
            np.round(temp).astype(np.int16),
            np.arange(len(t)),
        ]
        plain = [a.astype(np.float64) for a in odd]
    else:
        plain = [raw, temp, t]
        odd = [_LAYOUTS[layout](a) for a in plain]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the integer case reads far outside the fitted range
        np.testing.assert_array_equal(
            cal.compensate(odd[0], odd[1], odd[2]), cal.compensate(plain[0], plain[1], plain[2])
        )


# ----------------------------------------------------------------------------------- threads
def test_loading_and_calibrating_from_several_threads_at_once_agree(base: Path) -> None:
    want = coefficients(accelcore.calibrate(accelcore.load_session(base, cache=False)))
    results: list[dict[str, np.ndarray]] = []
    errors: list[BaseException] = []
    start = threading.Barrier(4)

    def work() -> None:
        try:
            start.wait()
            for _ in range(2):
                session = accelcore.load_session(base, cache=False)
                results.append(coefficients(accelcore.calibrate(session)))
        except BaseException as exc:  # re-raised below, in the test's thread
            errors.append(exc)

    threads = [threading.Thread(target=work) for _ in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert errors == []
    assert len(results) == 8
    for got in results:
        for axis in "xyz":
            np.testing.assert_array_equal(got[axis], want[axis])


def test_compensating_from_several_threads_at_once_agrees(base: Path, base_cal: Path) -> None:
    cal = accelcore.Calibration.load(base_cal)
    log = pd.read_csv(base / "x_neg.csv")
    args = (log[["x", "y", "z"]].to_numpy(), log["temp_c"].to_numpy(), log["time_s"].to_numpy())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        want = cal.compensate(*args)
        got: list[np.ndarray] = []
        threads = [
            threading.Thread(target=lambda: got.append(cal.compensate(*args))) for _ in range(6)
        ]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
    assert len(got) == 6
    for g in got:
        np.testing.assert_array_equal(g, want)


# -------------------------------------------------------------------------------------- bulk
def _children() -> dict[int, list[int]]:
    """Process id -> its children's ids, from /proc."""
    tree: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        ppid = int(stat.rsplit(")", 1)[1].split()[1])
        tree.setdefault(ppid, []).append(int(entry.name))
    return tree


def _descendants(pid: int) -> list[int]:
    tree, out, todo = _children(), [], [pid]
    while todo:
        for child in tree.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


def _running(pid: int) -> bool:
    """True while ``pid`` runs (a zombie, dead but not yet reaped, does not count)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")


def _archive(base: Path, root: Path, n: int) -> Path:
    archive = root / "archive"
    for i in range(n):
        shutil.copytree(base, archive / f"s{i:02d}")
    return archive


def _assert_whole(out: Path) -> None:
    """Every output under ``out`` is complete: JSON parses, CSV tables read."""
    for f in out.rglob("*"):
        if f.is_dir() or (f.name.startswith(".") and f.name.endswith(".tmp")):
            continue  # a temporary file of a write cut short is never an output
        if f.suffix == ".json":
            json.loads(f.read_text())
        elif f.suffix == ".csv":
            pd.read_csv(f)


@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="reads processes from /proc")
def test_kill_9_of_bulk_ends_its_workers_and_leaves_no_half_written_file(
    base: Path, tmp_path: Path
) -> None:
    """The issue's case: after ``kill -9`` of ``accelcore bulk`` its workers lived on.

    Workers end after their parent dies (each watches it); 60 s bounds the wait,
    it does not time it. Outputs are whole files or absent, and a rerun completes.
    """
    archive = _archive(base, tmp_path, 8)
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "accelcore", "bulk", archive, "-o", out, "--jobs", "2", "--quiet"],
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 120
        while len(workers) < 2 and proc.poll() is None and time.monotonic() < deadline:
            workers = [p for p in _descendants(proc.pid) if _running(p)]
            time.sleep(0.02)
        assert len(workers) >= 2, "bulk never started two workers"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
        deadline = time.monotonic() + 60
        while any(map(_running, workers)) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(map(_running, workers)), "workers live on after their parent died"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for pid in workers:  # only if the assertion above failed: leave nothing behind
            if _running(pid):
                os.kill(pid, signal.SIGKILL)
    assert proc.returncode == -signal.SIGKILL
    _assert_whole(out)
    with untouched(archive), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rerun = bulk(archive, out, jobs=1, progress=False)
    assert rerun.ok and rerun.n_sessions == 8
    assert sorted(set(rerun.fleet["session"])) == [f"s{i:02d}" for i in range(8)]


def test_two_bulk_runs_at_once_into_one_folder_end_with_whole_equal_tables(
    base: Path, tmp_path: Path
) -> None:
    archive = _archive(base, tmp_path, 2)
    out, alone = tmp_path / "out", tmp_path / "alone"
    argv: list[str | Path] = [sys.executable, "-m", "accelcore", "bulk", archive, "--jobs", "1"]
    argv.append("--quiet")
    with untouched(archive):
        both = [
            subprocess.Popen([*argv, "-o", out], env=ENV, stderr=subprocess.PIPE, text=True)
            for _ in range(2)
        ]
        errs = [p.communicate(timeout=300)[1] for p in both]
        assert [p.returncode for p in both] == [0, 0], errs
        assert cli("bulk", archive, "-o", alone, "--jobs", "1", "--quiet").returncode == 0
    _assert_whole(out)
    assert (out / "fleet.csv").read_bytes() == (alone / "fleet.csv").read_bytes()
    assert not [f for f in out.rglob(".*.tmp")]


# ---------------------------------------------------- property: corrupted files, never silent
def _rewrite(log: Path, edit: Callable[[list[str]], list[str]]) -> None:
    log.write_text("\n".join(edit(log.read_text().splitlines())) + "\n")


RUN_FILES = ("x_pos.csv", "x_neg.csv", "y_pos.csv", "y_neg.csv", "z_pos.csv", "z_neg.csv")


@st.composite
def file_corruptions(draw: st.DrawFn) -> list[tuple[str, Any]]:
    """One to three edits of a session's files (applied by :func:`_corrupt_files`)."""
    edits: list[tuple[str, Any]] = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(
            st.sampled_from(["label", "columns", "header", "units", "rate", "cell", "truncate"])
        )
        run = draw(st.sampled_from(RUN_FILES))
        if kind == "label":
            edits.append((kind, (run, draw(st.sampled_from(list(ORIENTATIONS))))))
        elif kind == "columns":
            edits.append((kind, draw(st.permutations(["x", "y", "z", "temp_c"]))))
        elif kind == "header":
            edits.append((kind, (run, draw(st.sampled_from(["x", "y", "z", "temp_c", "time_s"])))))
        elif kind == "units":
            edits.append((kind, draw(st.sampled_from(["LSB", "g", "m/s2"]))))
        elif kind == "rate":
            edits.append((kind, draw(st.sampled_from(["1e-9", "0.5", "2.0", "200.0", "1e12"]))))
        elif kind == "cell":
            text = draw(st.sampled_from(["", "nan", "inf", "1e999", "hot", "1,2", "0x1F", "1e30"]))
            edits.append((kind, (run, draw(st.integers(2, 3601)), draw(st.integers(1, 5)), text)))
        else:
            edits.append((kind, (run, draw(st.integers(0, 200_000)))))
    return edits


def _corrupt_files(folder: Path, edits: list[tuple[str, Any]]) -> None:
    toml = folder / "session.toml"
    for kind, arg in edits:
        text = toml.read_text()
        if kind == "label":
            run, label = arg
            pattern = rf'(file = "{re.escape(run)}"\norientation = ")[^"]*"'
            toml.write_text(re.sub(pattern, rf'\g<1>{label}"', text))
        elif kind == "columns":
            mapping = dict(zip(["x", "y", "z", "temperature"], arg, strict=True))
            for role, name in mapping.items():
                default = "temp_c" if role == "temperature" else role
                text = text.replace(f'\n{role} = "{default}"', f'\n{role} = "{name}"', 1)
            toml.write_text(text)
        elif kind == "header":
            run, name = arg

            def repeat(lines: list[str], name: str = name) -> list[str]:
                # A log truncated to nothing by an earlier edit has no header to extend.
                if not lines:
                    return lines
                return [lines[0] + f",{name}"] + [ln + ",0.5" for ln in lines[1:]]

            _rewrite(folder / run, repeat)
        elif kind == "units":
            toml.write_text(text.replace('units = "V"', f'units = "{arg}"', 1))
        elif kind == "rate":
            toml.write_text(text.replace("rate_hz = 20.0", f"rate_hz = {arg}", 1))
        elif kind == "cell":
            run, line, column, cell = arg
            log = folder / run
            if line <= len(log.read_text().splitlines()):
                set_cell(log, line, column, cell)
        else:
            run, size = arg
            log = folder / run
            log.write_bytes(log.read_bytes()[:size])


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(edits=file_corruptions())
def test_corrupted_session_files_give_a_typed_error_or_a_right_calibration(
    base: Path, edits: list[tuple[str, Any]]
) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "S"
        shutil.copytree(base, folder)
        _corrupt_files(folder, edits)
        try:
            with untouched(folder), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                cal = accelcore.calibrate(accelcore.load_session(folder, cache=False))
        except accelcore.AccelcoreError:
            return
    if cal.not_identified:
        return  # said, not given a number
    assert _compensated_error_g(cal) < 5e-3


def test_the_file_corruptions_reach_the_session(base: Path, tmp_path: Path) -> None:
    """Each kind of edit changes what is read (so the property test tests something)."""
    edits: list[tuple[str, Any]] = [
        ("label", ("x_neg.csv", "OX+")),
        ("columns", ["y", "x", "z", "temp_c"]),
        ("header", ("z_pos.csv", "y")),
        ("units", "LSB"),
        ("rate", "1e-9"),
        ("cell", ("y_pos.csv", 9, 4, "hot")),
        ("truncate", ("z_neg.csv", 0)),
    ]
    for edit in edits:
        folder = tmp_path / edit[0]
        shutil.copytree(base, folder)
        _corrupt_files(folder, [edit])
        with pytest.raises(accelcore.AccelcoreError), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            accelcore.calibrate(accelcore.load_session(folder, cache=False))
