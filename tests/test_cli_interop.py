"""Flight logs through every command that takes a session, --instance, and missing extras.

The thermal sweeps are the synthetic ULog and DataFlash logs of
``test_flight_logs`` (two IMU instances, 20 → 60 °C, a z offset of 2 mm/s² per °C).
A missing optional dependency is simulated by ``sys.modules[name] = None`` (an
import of it then raises ImportError): each must end in one line naming the extra
and exit status 2, never a traceback.
"""

from __future__ import annotations

import io
import json
import os
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from accelcore import simulate
from accelcore.apps.bulk import find_sessions
from accelcore.apps.cli import main
from test_flight_logs import N, _sweep, _write_dataflash, _write_ulog

G = 9.80665


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("logs")
    (root / "px4").mkdir()
    ulg, binlog = root / "px4" / "sweep.ulg", root / "sweep.bin"
    _write_ulog(ulg, {"sensor_accel": {0: _sweep(0), 1: _sweep(1)}})
    _write_dataflash(binlog, {0: _sweep(0), 1: _sweep(1)})
    return {"ulog": ulg, "dataflash": binlog}


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    out = io.StringIO()
    code = main(argv, stdout=out)
    return code, out.getvalue(), capsys.readouterr().err


@pytest.fixture(scope="module")
def cal_files(logs: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A calibration of instance 1 of each log."""
    root = tmp_path_factory.mktemp("cal")
    files = {}
    for kind, log in logs.items():
        files[kind] = root / f"{kind}.cal.json"
        argv = ["calibrate", str(log), "--instance", "1", "--save", str(files[kind])]
        assert main(argv, stdout=io.StringIO()) == 0
    return files


@pytest.mark.parametrize("kind", ["ulog", "dataflash"])
def test_instance_chooses_the_imu_and_a_bad_one_names_file_and_instances(
    kind: str, logs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    log = logs[kind]
    temps = {}
    for instance in (0, 1):
        code, out, _ = _run(
            ["calibrate", str(log), "--instance", str(instance), "--json", "-"], capsys
        )
        assert code == 0
        temps[instance] = json.loads(out)["result"]["calibration"]["temperature_range_c"][0]
    assert temps[1] == pytest.approx(temps[0] + 1.0, abs=0.05)  # instance 1 runs 1 °C warmer
    for command in (["calibrate"], ["diagnose"], ["report", "-o", str(log.parent / "r")]):
        code, _, err = _run([command[0], str(log), *command[1:], "--instance", "4"], capsys)
        assert code == 1
        assert str(log) in err and "instance 4" in err and "0, 1" in err
        assert len(err.strip().splitlines()) == 1
    code, _, err = _run(["calibrate", str(log), "--instance", "-1"], capsys)
    assert code == 2 and "must be >= 0" in err


def test_instance_on_a_session_folder_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sim = simulate.session(tmp_path / "s", "ADXL335", duration_h=0.05, soak_min=0.5)
    code, _, err = _run(["diagnose", str(sim.path), "--instance", "1"], capsys)
    assert code == 2 and "--instance applies to flight logs" in err


@pytest.mark.parametrize("kind", ["ulog", "dataflash"])
def test_report_of_a_flight_log(
    kind: str, logs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("matplotlib")
    log = logs[kind]
    before = log.read_bytes()
    code, _, err = _run(["report", str(log), "-o", str(tmp_path / "rep")], capsys)
    assert code == 0, err
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "<html" in page.lower() and "OZ-" in page
    assert log.read_bytes() == before
    code, _, err = _run(["report", str(log)], capsys)
    assert code == 2 and "needs -o DIR" in err


def test_bulk_takes_flight_logs_beside_sessions(
    logs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    archive = tmp_path / "archive"
    archive.mkdir()
    for log in logs.values():
        (archive / log.name).write_bytes(log.read_bytes())
    sim = simulate.session(archive / "chamber", "ADXL335", duration_h=0.08, soak_min=0.5)
    # a log inside a session folder belongs to that session, not to bulk
    (sim.path / "stray.bin").write_bytes(logs["dataflash"].read_bytes())
    assert find_sessions(archive) == ["chamber", "sweep.bin", "sweep.ulg"]
    out = tmp_path / "out"
    argv = ["bulk", str(archive), "-o", str(out), "--jobs", "1", "--quiet", "--no-diagnose"]
    code, text, err = _run(argv, capsys)
    assert code == 0, err
    assert "3 sessions (0 up to date, 0 failed)" in text
    fleet = pd.read_csv(out / "fleet.csv")
    assert sorted(set(fleet["session"])) == ["chamber", "sweep.bin", "sweep.ulg"]
    assert (out / "sweep.ulg" / "calibration.json").is_file()
    logged = fleet[fleet["session"] != "chamber"]
    assert set(logged["units"]) == {"m/s2"}
    z = logged[logged["axis"] == "z"]["offset_tc_mg_per_c"]
    assert np.allclose(z, 2.0 / G, rtol=1e-3)
    # a rerun with another instance redoes the flight logs, not the session folder
    code, text, _ = _run([*argv, "--instance", "1"], capsys)
    assert code == 0 and "3 sessions (1 up to date, 0 failed)" in text
    # an instance a log does not have: a failure naming the file and the instances found
    code, _, err = _run([*argv, "--instance", "3"], capsys)
    assert code == 1
    failures = pd.read_csv(out / "failures.csv")
    assert sorted(failures["session"]) == ["sweep.bin", "sweep.ulg"]
    for reason in failures["reason"]:
        assert "instance 3" in reason and "0, 1" in reason
    assert "sweep.ulg" in err and "sweep.bin" in err


@pytest.mark.parametrize("kind", ["ulog", "dataflash"])
def test_compensate_a_flight_log(
    kind: str,
    logs: dict[str, Path],
    cal_files: dict[str, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    log, cal = logs[kind], cal_files[kind]
    before = log.read_bytes()
    target = tmp_path / "g.csv"
    argv = ["compensate", str(cal), str(log), "--instance", "1", "-o", str(target)]
    code, text, err = _run(argv, capsys)
    assert code == 0, err
    assert f"compensated {N} rows" in text
    frame = pd.read_csv(target)
    assert list(frame.columns) == ["time_s", "temperature_c", "x_g", "y_g", "z_g"]
    truth = _sweep(1)
    np.testing.assert_allclose(frame["time_s"], truth["timestamp"] * 1e-6, rtol=1e-9)
    # written with 6 significant digits
    np.testing.assert_allclose(frame["temperature_c"], truth["temperature"], atol=1e-4)
    # the raw z drifts 80 mm/s² (8 mg) over the sweep; the compensated z does not
    raw_drift = np.ptp(truth["z"].astype(np.float64)) / G
    assert raw_drift > 7e-3
    assert np.ptp(frame["z_g"]) < raw_drift / 50
    assert frame["z_g"].mean() == pytest.approx(-1.0, abs=0.02)
    assert log.read_bytes() == before
    # never over an input, and a bad instance names the file and the instances
    assert _run([*argv[:-2], "-o", str(log)], capsys)[0] == 2
    assert log.read_bytes() == before
    code, _, err = _run([*argv[:3], "--instance", "7", "-o", str(tmp_path / "x.csv")], capsys)
    assert code == 1 and str(log) in err and "instance 7" in err and "0, 1" in err
    assert not (tmp_path / "x.csv").exists()
    code, _, err = _run([*argv, "--column", "x=ax"], capsys)
    assert code == 2 and "flight log" in err


def _one_usage_line(code: int, err: str, extra: str) -> None:
    assert code == 2, err
    lines = [line for line in err.splitlines() if "error:" in line]
    assert len(lines) == 1, err
    assert lines[0].endswith(f"pip install accelcore[{extra}]"), err
    assert "Traceback" not in err


@pytest.mark.parametrize(("kind", "module", "extra"), [
    ("ulog", "pyulog", "px4"),
    ("dataflash", "pymavlink.DFReader", "ardupilot"),
])  # fmt: skip
def test_flight_log_without_its_reader(
    kind: str,
    module: str,
    extra: str,
    logs: dict[str, Path],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setitem(sys.modules, module, None)
    code, _, err = _run(["calibrate", str(logs[kind])], capsys)
    _one_usage_line(code, err, extra)


def test_bulk_without_pyarrow_writes_the_csv_tables(
    logs: dict[str, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    archive = tmp_path / "archive"
    archive.mkdir()
    (archive / "a.ulg").write_bytes(logs["ulog"].read_bytes())
    out = tmp_path / "out"
    out.mkdir()
    (out / "fleet.parquet").write_bytes(b"stale")
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    argv = ["bulk", str(archive), "-o", str(out), "--jobs", "1", "--quiet", "--no-diagnose"]
    code, text, err = _run(argv, capsys)
    monkeypatch.undo()  # pandas itself reads strings with pyarrow when it has it
    _one_usage_line(code, err, "parquet")
    assert "fleet.parquet" in err
    assert "1 sessions" in text and "fleet.parquet" not in text
    assert len(pd.read_csv(out / "fleet.csv")) == 3
    assert (out / "failures.csv").is_file()
    assert not (out / "fleet.parquet").exists()  # a stale table would disagree with fleet.csv


def test_bulk_scheduler_without_dask(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)
    (tmp_path / "archive").mkdir()
    argv = ["bulk", str(tmp_path / "archive"), "-o", str(tmp_path / "out")]
    code, _, err = _run([*argv, "--scheduler", "tcp://127.0.0.1:1"], capsys)
    _one_usage_line(code, err, "dask")
    assert not (tmp_path / "out").exists()  # refused before any work


def test_compensate_parquet_with_and_without_pyarrow(
    cal_files: dict[str, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    pytest.importorskip("pyarrow")
    truth = _sweep(1)
    frame = pd.DataFrame(
        {
            "time_s": truth["timestamp"] * 1e-6,
            "temp_c": truth["temperature"].astype(np.float64),
            "x": truth["x"].astype(np.float64),
            "y": truth["y"].astype(np.float64),
            "z": truth["z"].astype(np.float64),
        }
    )
    source = tmp_path / "raw.parquet"
    frame.to_parquet(source)
    argv = ["compensate", str(cal_files["ulog"]), str(source), "-o", str(tmp_path / "g.csv")]
    code, text, err = _run([*argv, "--chunk-rows", "1000"], capsys)
    assert code == 0, err
    assert f"compensated {N} rows" in text
    got = pd.read_csv(tmp_path / "g.csv")
    assert list(got.columns) == ["time_s", "temp_c", "x_g", "y_g", "z_g"]
    assert np.ptp(got["z_g"]) < 2e-4
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    code, _, err = _run([*argv[:-1], str(tmp_path / "g2.csv")], capsys)
    _one_usage_line(code, err, "parquet")
    assert str(source) in err and not (tmp_path / "g2.csv").exists()


def test_compensate_a_binary_file_that_is_not_text(
    cal_files: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source = tmp_path / "raw.dat"
    source.write_bytes(b"PAR1" + bytes(range(128, 256)) * 8)  # Parquet under another name
    argv = ["compensate", str(cal_files["ulog"]), str(source), "-o", str(tmp_path / "g.csv")]
    code, _, err = _run(argv, capsys)
    assert code == 1 and "not a text log" in err and "Traceback" not in err


def test_report_without_matplotlib(
    logs: dict[str, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    code, _, err = _run(["report", str(logs["ulog"]), "-o", str(tmp_path / "r")], capsys)
    _one_usage_line(code, err, "plot")


def test_packaging_metadata_agrees() -> None:
    """One license and one repository URL everywhere; [all] pulls every other extra."""
    import tomllib

    root = Path(__file__).resolve().parents[1]
    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    cargo = tomllib.loads((root / "Cargo.toml").read_text())["workspace"]["package"]
    assert project["license"] == cargo["license"] == "MIT"
    assert "MIT License" in (root / "LICENSE").read_text()
    assert project["license-files"] == ["LICENSE"]
    assert project["urls"]["Repository"] == cargo["repository"]
    assert all(u.startswith(cargo["repository"]) for u in project["urls"].values())
    extras = project["optional-dependencies"]
    (everything,) = extras["all"]
    listed = everything.removeprefix("accelcore[").removesuffix("]").split(",")
    assert sorted(listed) == sorted(k for k in extras if k != "all")
    assert any(c.startswith("License") for c in project["classifiers"]) is False  # PEP 639


def test_a_base_install_imports_and_calibrates_without_any_extra(tmp_path: Path) -> None:
    """In a fresh interpreter where no optional package can be imported."""
    import subprocess

    sim = simulate.session(tmp_path / "s", "ADXL335", duration_h=0.05, soak_min=0.5)
    blocked = ["matplotlib", "pyarrow", "nptdms", "pyulog", "pymavlink", "dask", "distributed"]
    code = (
        "import sys\n"
        f"for name in {blocked!r}:\n"
        "    sys.modules[name] = None\n"
        "from accelcore.apps.cli import main\n"
        f"assert main(['calibrate', {str(sim.path)!r}, '--no-cache']) == 0\n"
        f"sys.exit(main(['report', {str(sim.path)!r}, '-o', {str(tmp_path / 'r')!r}]))\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=False
    )
    assert done.returncode == 2, done.stderr
    assert "offset" in done.stdout
    assert done.stderr.strip().splitlines()[-1] == (
        "accelcore report: error: accelcore report needs matplotlib: pip install accelcore[plot]"
    )
    assert "Traceback" not in done.stderr
