"""Issue 7, the cases not covered elsewhere: data-quality findings, the error
hierarchy, no panic reaching Python, and a long log streaming with flat memory."""

from __future__ import annotations

import inspect
import json
import os
import shutil
import subprocess
import sys
import textwrap
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

import accelcore
import accelcore.errors
from accelcore import simulate
from accelcore._accelcore import read_run
from accelcore.errors import DataQualityWarning
from accelcore.input.quality import QualityIssue, check_session

ROOT = Path(__file__).resolve().parent.parent
FloatArray = NDArray[np.float64]


@pytest.fixture(scope="module")
def clean_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rel") / "s"
    simulate.session(path, "ADXL335", seed=11, duration_h=0.25, soak_min=1.0)
    return path


def _copy(src: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(src, tmp_path / "s"))


def _rewrite(path: Path, edit: Callable[[FloatArray], FloatArray]) -> None:
    """Load a run log (time_s,temp_c,x,y,z), edit the table, write it back."""
    header = path.read_text().splitlines()[0]
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    np.savetxt(path, edit(table), delimiter=",", header=header, comments="", fmt="%.10g")


def _run_file(folder: Path, orientation: str) -> Path:
    session = accelcore.load_session(folder)
    run = next(r for r in session.runs if r.orientation == orientation)
    assert run.source is not None
    return Path(run.source)


def _kinds(issues: list[QualityIssue]) -> list[str]:
    return [i.kind for i in issues]


def test_clean_simulated_sessions_have_no_finding(clean_session: Path) -> None:
    for sensor, seed in (("ADXL335", 1), ("MPU9255", 2), ("LIS344ALH", 3)):
        folder = clean_session.parent / f"clean-{sensor}"
        if not folder.exists():
            simulate.session(folder, sensor, seed=seed, duration_h=0.25, soak_min=1.0)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert check_session(accelcore.load_session(folder)) == []


def test_nonfinite_samples_are_skipped_and_counted_per_run_and_in_all(
    clean_session: Path, tmp_path: Path
) -> None:
    folder = _copy(clean_session, tmp_path)
    bad_rows = {"OX+": [5, 100, 101], "OZ-": [7, 2000]}
    for orientation, rows in bad_rows.items():

        def poison(t: FloatArray, rows: list[int] = rows) -> FloatArray:
            t[rows[0], 2] = np.nan
            t[rows[1], 3] = np.inf
            for r in rows[2:]:
                t[r, 1] = -np.inf
            return t

        _rewrite(_run_file(folder, orientation), poison)
    session = accelcore.load_session(folder)
    skipped = {r.orientation: r.stats.n_skipped_nonfinite for r in session.runs}
    assert skipped == {o: len(bad_rows.get(o, [])) for o in skipped}
    clean = accelcore.load_session(clean_session)
    for run, ref in zip(session.runs, clean.runs, strict=True):
        # Skipped, not zero-filled: every block count drops by the rows lost in it.
        assert int(run.count.sum()) == int(ref.count.sum()) - run.stats.n_skipped_nonfinite
        assert np.all(np.isfinite(run.output))
    with pytest.warns(DataQualityWarning) as record:
        issues = check_session(session)
    assert any("5 rows skipped in all runs" in str(w.message) for w in record)
    total = [i for i in issues if i.kind == "nonfinite" and i.run is None]
    assert [i.count for i in total] == [5]
    per_run = {i.run: i.count or 0 for i in issues if i.kind == "nonfinite" and i.run}
    assert sorted(per_run.values()) == [2, 3]


def test_nonfinite_counted_for_in_memory_sessions() -> None:
    t = np.arange(200) / 20.0
    x = np.full(200, 1.5)
    x[[3, 50]] = np.nan
    data = {"time_s": t, "temp_c": 20 + t / 10, "x": x, "y": x * 0 + 1.5, "z": x * 0 + 1.8}
    session = accelcore.Session.from_arrays([("OZ+", data)], units="V", rate_hz=20.0)
    assert session.runs[0].stats.n_skipped_nonfinite == 2
    issues = check_session(session, warn=False, window_c=None)
    assert sorted(_kinds(issues)) == ["nonfinite", "nonfinite"]


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        (
            "rate_hz = 20.0",
            "rate_hz = 10.0",
            r"mean sample rate 20 Hz differs from rate_hz = 10 Hz",
        ),
        ("rate_hz = 20.0", "rate_hz = 40.0", r"differs from rate_hz = 40 Hz .*time_unit is wrong"),
    ],
)
def test_rate_far_from_rate_hz_is_warned(
    clean_session: Path, tmp_path: Path, old: str, new: str, match: str
) -> None:
    folder = _copy(clean_session, tmp_path)
    toml = folder / "session.toml"
    assert old in toml.read_text()
    toml.write_text(toml.read_text().replace(old, new))
    session = accelcore.load_session(folder)
    with pytest.warns(DataQualityWarning, match=match):
        issues = check_session(session)
    assert set(_kinds(issues)) == {"rate"}  # a too-high rate_hz is not reported as gaps too
    assert len(issues) == len(session.runs)


def test_gaps_are_reported_and_blocks_stay_aligned(clean_session: Path, tmp_path: Path) -> None:
    folder = _copy(clean_session, tmp_path)
    path = _run_file(folder, "OY-")
    # Drop 30.5 s of rows starting at t = 200 s.
    _rewrite(path, lambda t: t[(t[:, 0] < 200.0) | (t[:, 0] >= 230.5)])
    run = next(r for r in accelcore.load_session(folder).runs if r.orientation == "OY-")
    assert run.stats.n_gaps == 1
    assert run.stats.max_interval_s == pytest.approx(30.55, abs=1e-6)
    # Block k still covers [k, k + 1) * 0.5 s: the block times sit on that grid.
    k = np.floor(run.time_s / 0.5)
    assert np.all(np.abs(run.time_s - (k + 0.5) * 0.5) < 0.25)
    issues = check_session(accelcore.load_session(folder), warn=False)
    gaps = [i for i in issues if i.kind == "gaps"]
    assert len(gaps) == 1 and gaps[0].run == path.name and "30.55 s" in gaps[0].message
    assert _kinds(issues) == ["gaps"]


def test_clipping_at_the_rail_is_reported_per_run(clean_session: Path, tmp_path: Path) -> None:
    folder = _copy(clean_session, tmp_path)
    path = _run_file(folder, "OZ+")
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    rail = float(np.quantile(table[:, 2], 0.9))
    n_clipped = int(np.count_nonzero(table[:, 2] >= rail))
    _rewrite(path, lambda t: np.column_stack([t[:, :2], np.minimum(t[:, 2], rail), t[:, 3:]]))
    with pytest.warns(DataQualityWarning, match="clipped at the rail"):
        issues = check_session(accelcore.load_session(folder))
    clipping = [i for i in issues if i.kind == "clipping"]
    assert [(i.run, i.channel, i.count) for i in clipping] == [(path.name, "x", n_clipped)]
    assert f"{rail:.9g}" in clipping[0].message and "maximum" in clipping[0].message


def test_spikes_are_reported_with_their_time(clean_session: Path, tmp_path: Path) -> None:
    folder = _copy(clean_session, tmp_path)
    path = _run_file(folder, "OX-")
    rows = [4000, 9001, 15002]

    def spike(t: FloatArray) -> FloatArray:
        t[rows, 3] += 0.8  # 0.8 V spikes on y, single raw samples
        return t

    _rewrite(path, spike)
    issues = check_session(accelcore.load_session(folder), warn=False)
    outliers = [i for i in issues if i.kind == "outliers"]
    assert [(i.run, i.channel, i.count) for i in outliers] == [(path.name, "y", 3)]
    assert outliers[0].time_s == pytest.approx(4000 / 20.0, abs=0.5)
    assert "outliers" in _kinds(issues) and "step" not in _kinds(issues)


def test_sensor_moved_is_detected_with_its_time(clean_session: Path, tmp_path: Path) -> None:
    folder = _copy(clean_session, tmp_path)
    path = _run_file(folder, "OZ+")
    t_move = 400.0

    def tilt(t: FloatArray) -> FloatArray:
        after = t[:, 0] >= t_move
        t[after, 2] += 0.006  # ~1 degree of tilt on a 0.3 V/g part
        return t

    _rewrite(path, tilt)
    with pytest.warns(DataQualityWarning, match=r"the sensor moved"):
        issues = check_session(accelcore.load_session(folder))
    steps = [i for i in issues if i.kind == "step"]
    assert [(i.run, i.channel) for i in steps] == [(path.name, "x")]
    assert steps[0].time_s == pytest.approx(t_move, abs=1.0)
    assert "+0.006" in steps[0].message


def test_temperature_not_covering_the_window_says_what_would_fix_it(tmp_path: Path) -> None:
    folder = tmp_path / "warm"
    simulate.session(
        folder, "ADXL335", seed=4, duration_h=0.1, soak_min=1.0, t_start_c=20.0, t_end_c=35.0
    )
    issues = check_session(accelcore.load_session(folder), warn=False, window_c=(0.0, 60.0))
    assert _kinds(issues) == ["temperature"]
    message = issues[0].message
    assert "covers" in message and "0…60 °C" in message
    assert "log sweeps that reach 0 and 60 °C" in message and "narrow window_c to (" in message


def test_too_few_temperature_bins_says_what_would_fix_it(tmp_path: Path) -> None:
    folder = tmp_path / "flat"
    simulate.session(
        folder, "ADXL335", seed=5, duration_h=0.05, soak_min=1.0, t_start_c=25.0, t_end_c=25.6
    )
    issues = check_session(accelcore.load_session(folder), warn=False, window_c=(25.0, 26.0))
    few = [i for i in issues if i.kind == "temperature" and i.channel]
    assert [i.channel for i in few] == ["x", "y", "z"]
    assert all(i.count is not None and i.count < 3 for i in few)
    assert "a fit needs at least 3" in few[0].message and "log both orientations" in few[0].message


def test_every_error_class_is_an_accelcore_error() -> None:
    classes = [
        obj
        for _, obj in inspect.getmembers(accelcore.errors, inspect.isclass)
        if issubclass(obj, BaseException) and obj.__module__ == "accelcore.errors"
    ]
    assert len(classes) >= 12
    for cls in classes:
        if issubclass(cls, Warning):
            assert issubclass(cls, accelcore.errors.AccelcoreWarning), cls
        else:
            assert issubclass(cls, accelcore.AccelcoreError), cls
    # ValueError / OSError semantics where they fit.
    assert issubclass(accelcore.ParseError, ValueError)
    assert issubclass(accelcore.SessionFormatError, ValueError)
    assert issubclass(accelcore.AccelcoreIOError, OSError)
    # What the package root exports is the same hierarchy.
    for name in accelcore.__all__:
        obj = getattr(accelcore, name)
        if inspect.isclass(obj) and issubclass(obj, BaseException):
            assert issubclass(obj, accelcore.AccelcoreError), name


# The reader configurations of fuzz/formats.rs (the first byte of an input picks one).
FUZZ_FORMATS: list[dict[str, object]] = [
    {},
    {
        "delimiter": ";",
        "keep_extra_columns": False,
        "time_scale_to_s": 1e-3,
        "factor": 1,
        "min_count": 2,
    },
    {"delimiter": "\t", "channel_columns": ["x"], "factor": 3, "rate_hz": 1e-300},
    {
        "time_column": "t",
        "temperature_column": "c",
        "channel_columns": ["x", "y"],
        "time_scale_to_s": 1e300,
        "factor": 1_000_000,
        "rate_hz": 1e300,
    },
]


def _fuzz_inputs() -> list[Path]:
    return sorted(
        p
        for d in ("fuzz/regressions", "fuzz/seeds")
        for p in (ROOT / d).glob("*")
        if p.is_file() and p.suffix != ".md"
    )


@pytest.mark.parametrize("path", _fuzz_inputs(), ids=lambda p: p.name)
def test_saved_fuzz_inputs_raise_only_accelcore_errors(path: Path, tmp_path: Path) -> None:
    """A Rust panic would surface as pyo3's PanicException (a BaseException, not
    an AccelcoreError): the core must have no reachable panic, so none may appear."""
    data = path.read_bytes()
    if not data:
        return
    log = tmp_path / "fuzz.csv"
    log.write_bytes(data[1:])
    try:
        read_run(str(log), **FUZZ_FORMATS[data[0] % len(FUZZ_FORMATS)])  # type: ignore[arg-type]
    except accelcore.AccelcoreError:
        pass
    except BaseException as exc:
        pytest.fail(f"{path.name}: {type(exc).__module__}.{type(exc).__name__}: {exc}")


# --------------------------------------------------------------------------- memory

_STREAM_SCRIPT = textwrap.dedent(
    """
    import json, subprocess, sys
    from accelcore._accelcore import read_run

    def vm_hwm_mb():
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
        raise RuntimeError("no VmHWM")

    fifo, n_rows = sys.argv[1], int(sys.argv[2])
    generator = '''
    import sys
    fifo, n_rows = sys.argv[1], int(sys.argv[2])
    tails = [b",%.3f,%.6f,%.6f,%.6f\\\\n" % (20 + i * 1e-3, 1.5 + i * 1e-6, 1.48, 1.84 - i * 1e-6)
             for i in range(1000)]
    with open(fifo, "wb", buffering=1 << 20) as out:
        for start in range(0, n_rows, 100_000):
            out.write(b"time_ms,temp_c,x,y,z\\\\n" if start == 0 else b"")
            out.write(b"".join(b"%d" % (50 * i) + tails[i % 1000]
                               for i in range(start, min(start + 100_000, n_rows))))
    '''
    base = vm_hwm_mb()
    writer = subprocess.Popen([sys.executable, "-c", generator, fifo, str(n_rows)])
    run = read_run(fifo, time_column="time_ms", time_scale_to_s=1e-3, factor=1000, rate_hz=20.0)
    assert writer.wait() == 0
    print(json.dumps({"base_mb": base, "peak_mb": vm_hwm_mb(), "n_rows": run.n_rows,
                      "n_blocks": len(run.blocks)}))
    """
)


@pytest.mark.skipif(
    not (Path("/proc/self/status").exists() and hasattr(os, "mkfifo")), reason="Linux only"
)
def test_a_long_log_streams_with_flat_memory(tmp_path: Path) -> None:
    """A scaled 10 GB log: ~200 MB of rows through a FIFO (never on disk, never whole
    in memory). The reader holds two 1 MiB buffers, one line (<= 1 MiB) and one batch
    (8192 rows x 6 values x 8 B = 0.4 MB); at factor 1000 the output is ~6000 blocks.
    So the peak RSS may grow by a few MB over the interpreter's, never by the log."""
    fifo = tmp_path / "log.fifo"
    os.mkfifo(fifo)
    n_rows = 6_000_000  # ~33 bytes a row: ~200 MB
    out = subprocess.run(
        [sys.executable, "-c", _STREAM_SCRIPT, str(fifo), str(n_rows)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result["n_rows"] == n_rows
    assert result["n_blocks"] == n_rows // 1000
    growth = result["peak_mb"] - result["base_mb"]
    assert growth < 24.0, result
    assert result["peak_mb"] < 150.0, result
