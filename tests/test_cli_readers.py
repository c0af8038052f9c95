"""Single logs, Parquet and TDMS files through every session command and ``init``.

A ``session.toml`` that names one log (``log = "chamber.csv"`` / ``.parquet`` /
``.tdms``) is a session like a folder of run files: ``calibrate``, ``diagnose``,
``report`` and ``bulk`` read it, and so does :func:`accelcore.load_session`. Each
layout is written here from ``simulate.arrays``; the command line's calibration
must equal the one of the Python reader called with the settings the
``session.toml`` states, to 1e-12 relative: the same file is read by the same
reader with the same arguments into the same blocks, and fitted by the same code,
so the two are the same floating-point computation (1e-12 only leaves room for a
change of summation order that no code path here makes).
"""

from __future__ import annotations

import importlib.util
import io
import json
import os
import subprocess
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

import accelcore
from accelcore import simulate
from accelcore._accelcore import digest_bytes
from accelcore.apps import cli
from accelcore.apps.bulk import find_sessions
from accelcore.constants import AXES
from accelcore.input import readers
from accelcore.input import session as folder_sessions
from accelcore.input.format import SessionFormat
from accelcore.input.readers.opener import input_files, open_input
from accelcore.input.session import Session
from accelcore.result.calibration import Calibration

RATE = 20.0
SENSOR = "ADXL335"
HEADER = 'format = "accelcore-session/1"\nunits = "V"\nrate_hz = 20\nsensor = "ADXL335"\n'
HAVE_MATPLOTLIB = importlib.util.find_spec("matplotlib") is not None


@pytest.fixture(scope="module")
def sim() -> simulate.SimulatedArrays:
    return simulate.arrays(SENSOR, seed=11, duration_h=0.1, soak_min=1.0)


def run_main(*argv: str | Path) -> tuple[int, str, str]:
    """Run the CLI in-process; return (status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    old = sys.stderr
    sys.stderr = err
    try:
        status = cli.main([str(a) for a in argv], stdout=out)
    finally:
        sys.stderr = old
    return status, out.getvalue(), err.getvalue()


def _frame(sim: simulate.SimulatedArrays, label: str = "orientation") -> pd.DataFrame:
    """The six runs one after the other, time running on, one label per row."""
    parts = []
    t0 = 0.0
    for r in sim.runs:
        part = pd.DataFrame({k: r.columns[k] for k in ("time_s", "temp_c", "x", "y", "z")})
        part["time_s"] += t0
        t0 = float(part["time_s"].iloc[-1]) + 1.0 / RATE
        part[label] = r.orientation
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def write_csv(path: Path, sim: simulate.SimulatedArrays, label: str = "orientation") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    _frame(sim, label).to_csv(path, index=False)
    return path


def write_parquet(
    path: Path, sim: simulate.SimulatedArrays, metadata: dict[bytes, bytes] | None = None
) -> Path:
    pa = pytest.importorskip("pyarrow", reason="pyarrow not installed (accelcore[parquet])")
    pq = pytest.importorskip("pyarrow.parquet")
    path.parent.mkdir(parents=True, exist_ok=True)
    table = pa.Table.from_pandas(_frame(sim), preserve_index=False)
    if metadata is not None:
        table = table.replace_schema_metadata({**(table.schema.metadata or {}), **metadata})
    pq.write_table(table, path, row_group_size=5_000)
    return path


def write_tdms(
    path: Path,
    sim: simulate.SimulatedArrays,
    *,
    properties: bool = True,
    names: dict[str, str] | None = None,
) -> Path:
    """One group per run, waveform channels; ``properties``: orientation and unit_string."""
    nptdms = pytest.importorskip("nptdms", reason="npTDMS not installed (accelcore[tdms])")
    path.parent.mkdir(parents=True, exist_ok=True)
    names = names or {}
    with nptdms.TdmsWriter(str(path)) as writer:
        objects: list[Any] = [nptdms.RootObject({"serial": "T-1"})]
        for j, r in enumerate(sim.runs):
            group = f"run{j + 1}"
            props = {"orientation": r.orientation} if properties else {}
            objects.append(nptdms.GroupObject(group, properties=props))
            for c in ("temp_c", "x", "y", "z"):
                cprops: dict[str, Any] = {"wf_increment": 1.0 / RATE, "wf_start_offset": 0.0}
                if properties and c in AXES:
                    cprops["unit_string"] = "V"
                objects.append(nptdms.ChannelObject(group, names.get(c, c), r.columns[c], cprops))
        writer.write_segment(objects)
    return path


#: Per layout: the writer, and the Python reader with the settings of ``HEADER``.
LAYOUTS: dict[str, tuple[Callable[..., Path], Callable[[Path], Session]]] = {
    "csv": (
        write_csv,
        lambda p: readers.read_orientation_log(p, units="V", rate_hz=RATE, sensor=SENSOR),
    ),
    "parquet": (
        write_parquet,
        lambda p: readers.read_parquet(
            p, units="V", rate_hz=RATE, orientation_column="orientation", sensor=SENSOR
        ),
    ),
    "tdms": (
        write_tdms,
        lambda p: readers.read_tdms(p, units="V", rate_hz=RATE, sensor=SENSOR),
    ),
}


def log_session(
    folder: Path, sim: simulate.SimulatedArrays, kind: str, extra: str = ""
) -> tuple[Path, Path]:
    """A session folder whose session.toml names one log; return (folder, log)."""
    write, _ = LAYOUTS[kind]
    log = write(folder / f"chamber.{kind}", sim)
    (folder / "session.toml").write_text(f'{HEADER}log = "{log.name}"\n{extra}')
    return folder, log


def assert_same_coefficients(a: Calibration, b: Calibration) -> None:
    assert a.not_identified == b.not_identified
    for axis in AXES:
        assert a.axes[axis].terms == b.axes[axis].terms
        np.testing.assert_allclose(
            a.axes[axis].coefficients, b.axes[axis].coefficients, rtol=1e-12, atol=0
        )


# ------------------------------------------------------------------ the three layouts


@pytest.mark.parametrize("kind", sorted(LAYOUTS))
def test_calibrate_diagnose_report_equal_the_python_reader(
    kind: str, sim: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    folder, log = log_session(tmp_path / "chamber", sim, kind)
    direct = LAYOUTS[kind][1](log)
    want = accelcore.calibrate(direct)
    before = log.read_bytes()

    session = accelcore.load_session(folder)
    assert session.orientations == direct.orientations
    for a, b in zip(session.runs, direct.runs, strict=True):
        np.testing.assert_array_equal(a.output, b.output)
        assert a.source == b.source and a.source is not None
        assert a.source.startswith(f"{log}#")
    assert session.path == str(folder) and session.format is not None
    assert session.file_digests == {
        "session.toml": digest_bytes((folder / "session.toml").read_bytes()),
        log.name: digest_bytes(before),
    }

    # calibrate: the folder and the log itself (the session.toml beside it names it)
    for arg, name in ((folder, "a.cal.json"), (log, "b.cal.json")):
        code, out, err = run_main("calibrate", arg, "--quiet", "--save", tmp_path / name)
        assert code == 0, err
        assert "Calibration (joint) of ADXL335" in out
        got = Calibration.load(tmp_path / name)
        assert_same_coefficients(got, want)
        assert got.provenance["session_path"] == str(folder)
        assert got.file_digests() == ("blake3", session.file_digests)

    code, out, err = run_main(
        "diagnose", folder, "--quiet", "--json", tmp_path / "d.json", "--save", tmp_path / "d.cal"
    )
    assert code == 0, err
    assert json.loads((tmp_path / "d.json").read_text())["command"] == "diagnose"
    assert_same_coefficients(
        Calibration.load(tmp_path / "d.cal"), accelcore.diagnose(direct).calibration
    )

    if HAVE_MATPLOTLIB:
        code, out, err = run_main("report", log, "-o", tmp_path / "rep", "--quiet")
        assert code == 0, err
        page = (tmp_path / "rep" / "index.html").read_text()
        assert "OZ-" in page and "ADXL335" in page
    assert log.read_bytes() == before


def test_bulk_takes_a_log_session(sim: simulate.SimulatedArrays, tmp_path: Path) -> None:
    archive = tmp_path / "archive"
    folder, log = log_session(archive / "part7", sim, "csv")
    assert find_sessions(archive) == ["part7"]
    assert input_files(folder) == (folder / "session.toml", log)
    out = tmp_path / "out"
    code, text, err = run_main(
        "bulk", archive, "-o", out, "--jobs", "1", "--quiet", "--no-diagnose"
    )
    assert code == 0, err
    assert "1 sessions (0 up to date, 0 failed)" in text
    want = accelcore.calibrate(LAYOUTS["csv"][1](log))
    assert_same_coefficients(Calibration.load(out / "part7" / "calibration.json"), want)
    # the log is an input of the session: touching it redoes the session
    os.utime(log, (log.stat().st_atime, log.stat().st_mtime + 10))
    code, text, _ = run_main("bulk", archive, "-o", out, "--jobs", "1", "--quiet", "--no-diagnose")
    assert code == 0 and "1 sessions (0 up to date" in text


def test_settings_of_session_toml_reach_the_reader(
    sim: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    """Other column names, a semicolon, ms, settle_s, a Parquet of one orientation."""
    frame = _frame(sim, label="pose").rename(columns={"time_s": "t_ms", "x": "ax"})
    frame["t_ms"] = np.round(frame["t_ms"] * 1000.0)
    folder = tmp_path / "s"
    folder.mkdir()
    frame.to_csv(folder / "log.txt", sep=";", index=False)
    (folder / "session.toml").write_text(
        HEADER
        + 'log = "log.txt"\ndelimiter = ";"\ntime_unit = "ms"\nsettle_s = 30\n'
        + '[columns]\ntime = "t_ms"\nx = "ax"\norientation = "pose"\n'
    )
    direct = readers.read_orientation_log(
        folder / "log.txt",
        units="V",
        rate_hz=RATE,
        sensor=SENSOR,
        orientation_column="pose",
        columns={"time": "t_ms", "x": "ax"},
        delimiter=";",
        time_unit="ms",
        settle_s=30.0,
    )
    session = accelcore.load_session(folder)
    assert [r.time_s.size for r in session.runs] == [r.time_s.size for r in direct.runs]
    assert session.runs[0].time_s[0] >= 30.0
    assert_same_coefficients(accelcore.calibrate(session), accelcore.calibrate(direct))

    one = tmp_path / "one"
    pytest.importorskip("pyarrow")
    one_run = _frame(sim)[lambda f: f["orientation"] == "OZ+"].drop(columns="orientation")
    one.mkdir()
    one_run.to_parquet(one / "z.parquet")
    (one / "session.toml").write_text(HEADER + 'log = "z.parquet"\norientation = "oz+"\n')
    got = accelcore.load_session(one)
    assert got.orientations == ("OZ+",)
    assert got.runs[0].source == f"{one / 'z.parquet'}#rows=1-{len(one_run)}"


def test_no_temperature_and_a_sample_index(sim: simulate.SimulatedArrays, tmp_path: Path) -> None:
    frame = _frame(sim).drop(columns="temp_c")
    frame["time_s"] = np.arange(len(frame))
    folder = tmp_path / "s"
    folder.mkdir()
    frame.rename(columns={"time_s": "k"}).to_csv(folder / "six.csv", index=False)
    (folder / "session.toml").write_text(
        HEADER + 'log = "six.csv"\ntime_unit = "sample"\n[columns]\ntime = "k"\ntemperature = ""\n'
    )
    session = accelcore.load_session(folder)
    assert not session.has_temperature
    assert session.runs[1].time_s[0] == pytest.approx((len(frame) // 6 + 4.5) / RATE)
    cal = accelcore.calibrate(session)
    assert any("no temperature logged" in n for n in cal.notes)


# ------------------------------------------------------------------ a log given alone


def test_a_log_alone_is_read_from_what_it_states(
    sim: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    parquet = write_parquet(tmp_path / "p" / "s.parquet", sim, {b"units": b"V"})
    code, out, err = run_main("calibrate", parquet, "--quiet", "--save", tmp_path / "p.cal")
    assert code == 0, err
    want = readers.read_parquet(parquet, units="V", rate_hz=RATE, orientation_column="orientation")
    assert_same_coefficients(Calibration.load(tmp_path / "p.cal"), accelcore.calibrate(want))

    tdms = write_tdms(tmp_path / "t" / "s.tdms", sim)
    code, out, err = run_main("calibrate", tdms, "--quiet", "--json", "-")
    assert code == 0, err
    got = json.loads(out)["result"]["calibration"]
    assert got["serial"] == "T-1" and got["units"] == "V"
    assert open_input(tdms).serial == "T-1"


@pytest.mark.parametrize("kind", ["csv", "parquet", "tdms"])
def test_a_log_that_does_not_say_enough_is_one_usage_line(
    kind: str, sim: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    write = LAYOUTS[kind][0]
    log = (
        write_tdms(tmp_path / "s.tdms", sim, properties=False)
        if kind == "tdms"
        else write(tmp_path / f"s.{kind}", sim)
    )
    for command in (["calibrate"], ["diagnose"], ["report", "-o", str(tmp_path / "r")]):
        code, out, err = run_main(command[0], log, *command[1:], "--quiet")
        assert code == 2, err
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        assert str(log) in lines[0] and f"accelcore init {log}" in lines[0]
        assert f'log = "{log.name}"' in lines[0] and out == ""
    assert not (tmp_path / "r").exists()
    with pytest.raises(accelcore.SessionFormatError, match="accelcore init"):
        open_input(log)


def test_a_run_file_of_a_folder_session_points_at_the_folder(tmp_path: Path) -> None:
    s = simulate.session(tmp_path / "s", SENSOR, duration_h=0.02, soak_min=0.2)
    code, _, err = run_main("calibrate", s.path / "x_pos.csv")
    assert code == 2 and f"give the session folder {s.path}" in err and err.count("\n") == 1


def test_instance_applies_to_flight_logs_only(
    sim: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    _, log = log_session(tmp_path / "s", sim, "csv")
    code, _, err = run_main("calibrate", log, "--instance", "1")
    assert code == 2 and "is a single log" in err


# ------------------------------------------------------------------ errors: one line each


def _one_error(code: int, out: str, err: str, *needles: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert out == "" and "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


def test_a_missing_orientation_column(sim: simulate.SimulatedArrays, tmp_path: Path) -> None:
    folder, log = log_session(tmp_path / "s", sim, "csv", '[columns]\norientation = "pose"\n')
    code, out, err = run_main("calibrate", folder)
    assert code == 1  # a data error naming the file, like every broken session
    _one_error(code, out, err, f"{log}:1:1", "missing column(s) 'pose'", "'orientation'")
    with pytest.raises(accelcore.ParseError) as caught:
        accelcore.load_session(folder)
    assert (caught.value.path, caught.value.line) == (str(log), 1)


def test_errors_of_a_log_session_name_the_file_and_the_key(
    sim: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    folder, _ = log_session(tmp_path / "s", sim, "csv")
    toml = folder / "session.toml"
    cases = {
        'log = "chamber.xlsx"\n': "log = 'chamber.xlsx': unknown suffix '.xlsx'",
        'log = "chamber.csv"\nsettle = 5\n': "unknown key 'settle'; did you mean 'settle_s'?",
        'log = "chamber.csv"\norientation = "OX+"\n': "key 'orientation' does not apply",
        'log = "chamber.csv"\ngroup = "g"\n': "key 'group' does not apply",
        'log = "chamber.csv"\nsettle_s = -1\n': "settle_s must be a number of seconds >= 0",
        'log = "none.csv"\n': "none.csv: log does not exist",
        'log = "chamber.csv"\n[[run]]\nfile = "a.csv"\norientation = "OX+"\n': "both log =",
        'settle_s = 2\n[[run]]\nfile = "chamber.csv"\norientation = "OX+"\n': (
            "key 'settle_s' applies to a session that names one log"
        ),
        'log = "chamber.csv"\n[columns]\norientation = "x"\n': "maps both x and orientation",
    }
    for body, needle in cases.items():
        toml.write_text(HEADER + body)
        with pytest.raises(accelcore.AccelcoreError, match=None) as caught:
            accelcore.load_session(folder)
        assert needle in str(caught.value), (needle, str(caught.value))
        code, out, err = run_main("calibrate", folder)
        assert code == 1
        _one_error(code, out, err, needle)
    toml.write_text(HEADER + 'log = "chamber.parquet"\ndelimiter = ";"\n')
    with pytest.raises(accelcore.SessionFormatError, match="key 'delimiter' does not apply"):
        SessionFormat.read(folder, check_files=False)
    toml.write_text(HEADER + 'log = "chamber.tdms"\n[columns]\norientation = "o"\n')
    with pytest.raises(accelcore.SessionFormatError, match=r"\[columns\] orientation' does not"):
        SessionFormat.read(folder, check_files=False)


def test_an_unknown_file_and_the_folder_reader(
    sim: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    sheet = tmp_path / "chamber.xlsx"
    sheet.write_bytes(b"PK\x03\x04")
    code, out, err = run_main("calibrate", sheet)
    assert code == 2
    _one_error(code, out, err, str(sheet), "not a session folder, nor a log accelcore reads")
    folder, _ = log_session(tmp_path / "s", sim, "csv")
    with pytest.raises(accelcore.SessionFormatError, match="names one log"):
        folder_sessions.load_session(folder)


def test_no_traceback_through_python_dash_m(sim: simulate.SimulatedArrays, tmp_path: Path) -> None:
    folder, _ = log_session(tmp_path / "s", sim, "csv", "settle = 5\n")
    done = subprocess.run(
        [sys.executable, "-m", "accelcore", "calibrate", str(folder)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env={**os.environ, "PYTHONWARNINGS": "error"},
    )
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert done.stderr.count("\n") == 1 and "'settle'" in done.stderr


# ------------------------------------------------------------------ init LOG


def _init(*argv: str | Path) -> tuple[int, str, str]:
    return run_main("init", *argv)


def test_init_a_single_log_writes_a_session_that_calibrates(
    sim: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    log = write_csv(tmp_path / "s" / "chamber.csv", sim, label="position")
    before = log.read_bytes()
    code, out, err = _init(log)
    assert code == 0, err
    assert "log chamber.csv (delimited log with an orientation column), 6 runs" in out
    assert "orientation=position" in out and "units V (guessed" in out
    assert "orientations: OX+ OX- OY+ OY- OZ+ OZ-" in out
    fmt = SessionFormat.read(log.parent)
    assert fmt.log is not None and fmt.log.orientation_column == "position"
    assert fmt.rate_hz == RATE and fmt.units == "V" and fmt.runs == ()
    code, _, err = run_main("calibrate", log, "--quiet", "--save", tmp_path / "c.json")
    assert code == 0, err
    direct = readers.read_orientation_log(
        log, units="V", rate_hz=RATE, orientation_column="position"
    )
    assert_same_coefficients(Calibration.load(tmp_path / "c.json"), accelcore.calibrate(direct))
    # never over an existing session.toml (nor the log)
    toml = (log.parent / "session.toml").read_text()
    code, out, err = _init(log)
    assert code == 2 and out == "" and "exists; --force" in err and err.count("\n") == 1
    assert (log.parent / "session.toml").read_text() == toml and log.read_bytes() == before


def test_init_never_writes_over_its_input(sim: simulate.SimulatedArrays, tmp_path: Path) -> None:
    log = write_csv(tmp_path / "s" / "chamber.csv", sim)
    before = log.read_bytes()
    (log.parent / "session.toml").symlink_to(log.name)
    code, _, err = _init(log, "--force")
    assert code == 2 and err.count("\n") == 1
    assert log.read_bytes() == before


def test_init_a_parquet_and_a_tdms_file(sim: simulate.SimulatedArrays, tmp_path: Path) -> None:
    parquet = write_parquet(tmp_path / "p" / "sweep.parquet", sim, {b"rate_hz": b"20"})
    code, out, err = _init(parquet, "--sensor", SENSOR)
    assert code == 0, err
    assert "rate 20 Hz (stated by the file)" in out and "orientation=orientation" in out
    got = accelcore.calibrate(accelcore.load_session(parquet.parent))
    want = readers.read_parquet(
        parquet, units="V", rate_hz=RATE, orientation_column="orientation", sensor=SENSOR
    )
    assert_same_coefficients(got, accelcore.calibrate(want))

    names = {"temp_c": "Temperature", "x": "ax", "y": "ay", "z": "az"}
    tdms = write_tdms(tmp_path / "t" / "sweep.tdms", sim, properties=False, names=names)
    code, out, err = _init(tdms)
    assert code == 0, err
    assert "6 runs" in out and "(mean output (gravity))" in out
    fmt = SessionFormat.read(tdms.parent)
    assert fmt.log is not None and isinstance(fmt.log.orientation, Mapping)
    assert dict(fmt.log.orientation) == {
        f"run{j + 1}": r.orientation for j, r in enumerate(sim.runs)
    }
    session = accelcore.load_session(tdms.parent)
    want_t = readers.read_tdms(
        tdms,
        units="V",
        rate_hz=RATE,
        channel_map={"temperature": "Temperature", "x": "ax", "y": "ay", "z": "az"},
        orientation=dict(fmt.log.orientation),
    )
    assert_same_coefficients(accelcore.calibrate(session), accelcore.calibrate(want_t))


def test_init_a_delimited_log_without_labels_is_one_run(tmp_path: Path) -> None:
    s = simulate.session(tmp_path / "s", SENSOR, duration_h=0.02, soak_min=0.2)
    (s.path / "session.toml").unlink()
    code, out, err = _init(s.path / "z_neg.csv")
    assert code == 0, err
    assert "z_neg.csv  OZ-  (file name)" in out
    fmt = SessionFormat.read(s.path)
    assert fmt.log is None and [(r.file, r.orientation) for r in fmt.runs] == [("z_neg.csv", "OZ-")]
