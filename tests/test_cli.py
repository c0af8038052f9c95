"""The ``accelcore`` command line: exit codes, messages, ``--json`` schema, compensate, demo."""

from __future__ import annotations

import dataclasses
import importlib.util
import io
import json
import math
import os
import subprocess
import sys
import types
import warnings
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import pandas as pd
import pytest

import accelcore
from accelcore import simulate
from accelcore.apps import cli
from accelcore.model import Term, base_terms


class Short(TypedDict):
    duration_h: float
    soak_min: float


SHORT: Short = {"duration_h": 0.2, "soak_min": 1.0}  # 14400 rows per run at 20 Hz
HAVE_DIAGNOSIS = importlib.util.find_spec("accelcore.diagnosis") is not None


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


def run_subprocess(*argv: str | Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONWARNINGS": "error"}
    return subprocess.run(
        [sys.executable, "-m", "accelcore", *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        check=False,
    )


def strict_json(path: Path) -> dict[str, Any]:
    def no_constants(name: str) -> None:
        raise AssertionError(f"non-standard JSON constant {name}")

    doc = json.loads(path.read_text(encoding="utf-8"), parse_constant=no_constants)
    assert isinstance(doc, dict)
    return doc


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> simulate.SimulatedSession:
    folder = tmp_path_factory.mktemp("cli") / "adxl335"
    return simulate.session(folder, "ADXL335", seed=11, serial="S-1", **SHORT)


@pytest.fixture(scope="module")
def cal_file(sim: simulate.SimulatedSession, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cal") / "adxl335.cal.json"
    status, _, err = run_main("calibrate", sim.path, "--save", path)
    assert status == 0, err
    return path


# ---------------------------------------------------------------------- help and usage
@pytest.mark.parametrize("command", ["calibrate", "compensate", "diagnose", "simulate", "demo"])
def test_help_of_each_command_shows_an_example(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main([command, "--help"]) == 0
    text = capsys.readouterr().out
    assert f"usage: accelcore {command}" in text
    assert "example:" in text and f"accelcore {command}" in text.split("example:")[1]


def test_top_level_help_lists_the_commands(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["--help"]) == 0
    text = capsys.readouterr().out
    for command in (
        "calibrate",
        "compensate",
        "diagnose",
        "report",
        "bulk",
        "simulate",
        "bench",
        "demo",
    ):
        assert command in text


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["frobnicate"],
        ["calibrate"],
        ["calibrate", "S", "--method", "magic"],
        ["calibrate", "S", "--window", "0"],
        ["calibrate", "S", "--t-ref", "warm"],
        ["calibrate", "S", "--t-ref", "nan"],
        ["compensate", "cal.json", "in.csv"],  # -o missing
        ["simulate"],
    ],
)
def test_usage_errors_exit_2(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(argv) == 2
    assert "usage: accelcore" in capsys.readouterr().err


def test_usage_error_exit_code_through_python_dash_m() -> None:
    proc = run_subprocess("calibrate", "S", "--method", "magic")
    assert proc.returncode == 2
    assert "invalid choice" in proc.stderr


def test_version() -> None:
    proc = run_subprocess("--version")
    assert proc.returncode == 0
    assert proc.stdout.strip() == f"accelcore {accelcore.__version__}"


# ---------------------------------------------------------------------- calibrate
def test_calibrate_prints_summary_and_datasheet_tables(sim: simulate.SimulatedSession) -> None:
    status, out, err = run_main("calibrate", sim.path)
    assert status == 0, err
    assert "Calibration (joint) of ADXL335 #S-1" in out
    assert "Datasheet comparison, ADXL335" in out
    assert "at T_ref:" in out and "temperature coefficients:" in out
    assert "offset_tc      z" in out  # the paper's Table 6 row of the Z axis


def test_calibrate_json_schema(sim: simulate.SimulatedSession, tmp_path: Path) -> None:
    target = tmp_path / "result.json"
    saved = tmp_path / "cal.json"
    status, _, err = run_main(
        "calibrate", sim.path, "--method", "paper", "--t-ref", "20", "--window", "5", "55",
        "--json", target, "--save", saved,
    )  # fmt: skip
    assert status == 0, err
    doc = strict_json(target)
    assert list(doc) == ["schema", "command", "accelcore_version", "result"]
    assert doc["schema"] == "accelcore-cli/1" == cli.JSON_SCHEMA
    assert doc["command"] == "calibrate"
    assert doc["accelcore_version"] == accelcore.__version__
    result = doc["result"]
    assert set(result) == {"session", "saved_to", "summary", "datasheet", "calibration", "quality"}
    assert result["quality"] == []  # clean simulated data: no data-quality finding
    assert result["session"] == str(sim.path) and result["saved_to"] == str(saved)
    assert [row["axis"] for row in result["summary"]] == ["x", "y", "z"]
    assert {"offset_tc_mg_per_c", "sensitivity_tc_pct_per_c_se"} <= set(result["summary"][0])
    assert len(result["datasheet"]) == 18  # 6 parameters x 3 axes
    assert {"table", "parameter", "axis", "min", "typ", "max", "measured", "in_spec"} <= set(
        result["datasheet"][0]
    )
    body = result["calibration"]
    assert body["format"] == "accelcore-calibration/1"
    assert body["method"] == "paper" and body["t_ref_c"] == 20.0 and body["window_c"] == [5, 55]
    # The saved calibration is the same one, to the last bit.
    loaded = accelcore.Calibration.load(saved)
    assert loaded.to_dict() == body
    z = result["summary"][2]
    assert z["offset_tc_mg_per_c"] == pytest.approx(sim.truth.offset_tc_mg_per_c[2], abs=0.1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json", "result.json"]  # no temp


def test_calibrate_json_to_stdout(sim: simulate.SimulatedSession) -> None:
    status, out, err = run_main("calibrate", sim.path, "--json", "-")
    assert status == 0, err
    doc = json.loads(out)  # stdout holds the JSON document only
    assert doc["schema"] == "accelcore-cli/1"


def test_calibrate_json_has_null_for_what_was_not_identified(tmp_path: Path) -> None:
    folder = tmp_path / "z-only"
    simulate.session(folder, "ADXL335", seed=3, orientations=("OZ+", "OZ-"), **SHORT)
    target = tmp_path / "r.json"
    status, out, err = run_main("calibrate", folder, "--method", "paper", "--json", target)
    assert status == 0, err
    doc = strict_json(target)  # NaN of the unidentified axes became null
    x = doc["result"]["summary"][0]
    assert x["axis"] == "x" and x["offset_tc_mg_per_c"] is None
    assert "not identified" in out


def test_calibrate_subprocess_success(sim: simulate.SimulatedSession, tmp_path: Path) -> None:
    target = tmp_path / "r.json"
    proc = run_subprocess("calibrate", sim.path, "--json", target)
    assert proc.returncode == 0, proc.stderr
    assert "Datasheet comparison" in proc.stdout
    assert strict_json(target)["command"] == "calibrate"


# ---------------------------------------------------------------------- data errors
def _broken_sessions(root: Path, good: Path) -> dict[str, tuple[Path, Path]]:
    """Name -> (session folder, file the message must name)."""
    out: dict[str, tuple[Path, Path]] = {}
    missing = root / "does-not-exist"
    out["missing folder"] = (missing, missing)
    bad_toml = root / "bad-toml"
    bad_toml.mkdir()
    (bad_toml / "session.toml").write_text('format = "accelcore-session/9"\nunits = "V"\n')
    out["wrong format"] = (bad_toml, bad_toml / "session.toml")
    bad_csv = root / "bad-csv"
    bad_csv.mkdir()
    for f in good.iterdir():
        (bad_csv / f.name).write_bytes(f.read_bytes())
    lines = (bad_csv / "y_neg.csv").read_text().splitlines()
    lines[100] = "0.1,hot,1.0,1.0,1.0"
    (bad_csv / "y_neg.csv").write_text("\n".join(lines) + "\n")
    out["unparsable log"] = (bad_csv, bad_csv / "y_neg.csv")
    no_run = root / "no-run"
    no_run.mkdir()
    toml = (good / "session.toml").read_text().replace("x_pos.csv", "gone.csv")
    (no_run / "session.toml").write_text(toml)
    out["missing run file"] = (no_run, no_run / "gone.csv")
    return out


@pytest.mark.parametrize(
    "case", ["missing folder", "wrong format", "unparsable log", "missing run file"]
)
@pytest.mark.parametrize("command", ["calibrate", "diagnose"])
def test_broken_session_exits_1_naming_the_file(
    case: str, command: str, sim: simulate.SimulatedSession, tmp_path: Path
) -> None:
    if command == "diagnose" and not HAVE_DIAGNOSIS:
        pytest.skip("accelcore.diagnosis is not written yet")
    folder, named = _broken_sessions(tmp_path, sim.path)[case]
    status, out, err = run_main(command, folder, "--json", tmp_path / "r.json")
    assert status == 1
    assert out == ""
    assert not (tmp_path / "r.json").exists()
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"accelcore {command}: error: ")
    assert str(named) in lines[0]


def test_broken_session_through_python_dash_m(tmp_path: Path) -> None:
    proc = run_subprocess("calibrate", tmp_path / "nothing-here")
    assert proc.returncode == 1
    assert proc.stderr.count("\n") == 1 and str(tmp_path / "nothing-here") in proc.stderr
    assert "Traceback" not in proc.stderr


def test_unwritable_json_target_is_a_data_error(
    sim: simulate.SimulatedSession, tmp_path: Path
) -> None:
    target = tmp_path / "no-such-dir" / "r.json"
    status, _, err = run_main("calibrate", sim.path, "--json", target)
    assert status == 1
    assert "no-such-dir" in err and err.count("\n") == 1


# ---------------------------------------------------------------------- compensate
def test_compensate_into_a_missing_folder_is_a_data_error(
    sim: simulate.SimulatedSession, cal_file: Path, tmp_path: Path
) -> None:
    target = tmp_path / "no-such-dir" / "out.csv"
    status, _, err = run_main("compensate", cal_file, sim.path / "z_pos.csv", "-o", target)
    assert status == 1
    assert "no-such-dir" in err and err.count("\n") == 1
    assert not target.parent.exists()


def test_compensate_round_trip_gives_gravity(
    sim: simulate.SimulatedSession, cal_file: Path, tmp_path: Path
) -> None:
    out_csv = tmp_path / "z_pos_g.csv"
    source = sim.path / "z_pos.csv"
    status, out, err = run_main("compensate", cal_file, source, "-o", out_csv)
    assert status == 0, err
    assert f"compensated {sim.runs[4].n_samples} rows" in out
    # The sweep starts at -2 °C and ends at 65 °C, outside the 0..60 °C fit: one warning.
    assert err.count("outside the calibrated range") == 1
    table = pd.read_csv(out_csv)
    assert list(table.columns) == ["time_s", "temp_c", "x_g", "y_g", "z_g"]
    assert len(table) == sim.runs[4].n_samples
    g = table[["x_g", "y_g", "z_g"]].to_numpy()
    noise = np.asarray(sim.noise_g)
    n = g.shape[0]
    # OZ+: (0, 0, 1) g. Per sample the error is the sensor noise (plus a quantum
    # of the ADC, 1 mg at most); the mean is off by noise/sqrt(n) and the
    # calibration's own error, both far below 0.2 mg.
    residual = g - np.array([0.0, 0.0, 1.0])
    assert np.all(np.abs(residual.mean(axis=0)) < 10 * noise / math.sqrt(n) + 5e-5)
    assert np.all(residual.std(axis=0) < 1.3 * noise + 1e-3 / math.sqrt(12))
    assert np.all(np.abs(residual) < 6 * noise + 1e-3)
    # Same numbers as the in-memory API (the file holds 7 decimals of g).
    raw = pd.read_csv(source)
    cal = accelcore.Calibration.load(cal_file)
    with pytest.warns(accelcore.errors.TemperatureRangeWarning):
        expected = cal.compensate(raw[["x", "y", "z"]].to_numpy(), raw["temp_c"].to_numpy())
    np.testing.assert_allclose(g, expected, rtol=0, atol=6e-8)


def test_compensate_is_independent_of_chunking_with_stateful_terms(
    sim: simulate.SimulatedSession, tmp_path: Path
) -> None:
    session = accelcore.load_session(sim.path)
    terms = {
        a: (
            *base_terms(a),
            Term("offset", "lag(300):dT^1", effect="lag"),
            Term("offset", "dTdt", effect="rate"),
            Term("offset", "elapsed_h", effect="drift"),
            Term("offset", "lag(50,250):dT^1", effect="lag"),
        )
        for a in "xyz"
    }
    cal = accelcore.calibrate(session, terms=terms, window_c=None)
    # Make the stateful terms matter whatever the fit found.
    axes = {}
    for a, m in cal.axes.items():
        coefficients = m.coefficients.copy()
        coefficients[4:] = [0.01, 0.02, 0.03, -0.01]
        axes[a] = dataclasses.replace(m, coefficients=coefficients)
    cal = dataclasses.replace(cal, axes=axes)
    cal_path = tmp_path / "stateful.json"
    cal.save(cal_path)
    source = sim.path / "x_neg.csv"
    # Time in milliseconds and other column names: --column and --time-unit.
    raw = pd.read_csv(source)
    renamed = raw.rename(columns={"time_s": "t_ms", "temp_c": "T"})
    renamed["t_ms"] = raw["time_s"] * 1000.0
    renamed_csv = tmp_path / "renamed.csv"
    renamed.to_csv(renamed_csv, index=False, sep=";")
    outputs = []
    for rows in ("1000", "7", "1000000"):
        out_csv = tmp_path / f"out-{rows}.csv"
        status, _, err = run_main(
            "compensate", cal_path, renamed_csv, "-o", out_csv, "--chunk-rows", rows,
            "--column", "time=t_ms", "--column", "temperature=T",
            "--time-unit", "ms", "--delimiter", ";",
        )  # fmt: skip
        assert status == 0, err
        outputs.append(pd.read_csv(out_csv))
    assert list(outputs[0].columns) == ["t_ms", "T", "x_g", "y_g", "z_g"]
    with warnings.catch_warnings():  # raw samples a little beyond the decimated range
        warnings.simplefilter("ignore", accelcore.errors.TemperatureRangeWarning)
        expected = cal.compensate(
            raw[["x", "y", "z"]].to_numpy(), raw["temp_c"].to_numpy(), raw["time_s"].to_numpy()
        )
    for table in outputs:
        np.testing.assert_allclose(
            table[["x_g", "y_g", "z_g"]].to_numpy(), expected, rtol=0, atol=6e-8
        )


def test_compensate_takes_the_format_from_a_session(
    sim: simulate.SimulatedSession, cal_file: Path, tmp_path: Path
) -> None:
    out_csv = tmp_path / "o.csv"
    status, _, err = run_main(
        "compensate", cal_file, sim.path / "x_pos.csv", "-o", out_csv, "--session", sim.path
    )
    assert status == 0, err
    assert pd.read_csv(out_csv)["x_g"].mean() == pytest.approx(1.0, abs=1e-3)


def test_compensate_errors(sim: simulate.SimulatedSession, cal_file: Path, tmp_path: Path) -> None:
    out_csv = tmp_path / "o.csv"
    # A log without the named columns: exit 1 naming the log, no output left behind.
    status, _, err = run_main(
        "compensate", cal_file, sim.path / "x_pos.csv", "-o", out_csv, "--column", "x=ax"
    )
    assert status == 1 and str(sim.path / "x_pos.csv") in err and "ax" in err
    # A corrupted calibration file: exit 1 naming it.
    broken = tmp_path / "broken.json"
    broken.write_text(cal_file.read_text().replace('"V"', '"LSB"'))
    status, _, err = run_main("compensate", broken, sim.path / "x_pos.csv", "-o", out_csv)
    assert status == 1 and str(broken) in err and "checksum" in err
    # Missing input file.
    status, _, err = run_main("compensate", cal_file, tmp_path / "none.csv", "-o", out_csv)
    assert status == 1 and str(tmp_path / "none.csv") in err
    # A non-numeric cell.
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,temp_c,x,y,z\n0,20,1.5,1.5,1.8\n0.05,warm,1.5,1.5,1.8\n")
    status, _, err = run_main("compensate", cal_file, bad, "-o", out_csv)
    assert status == 1 and str(bad) in err and err.count("\n") == 1
    assert not out_csv.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv", "broken.json"]
    # Usage errors.
    assert run_main("compensate", cal_file, bad, "-o", out_csv, "--column", "speed=v")[0] == 2
    assert run_main("compensate", cal_file, bad, "-o", out_csv, "--delimiter", "|")[0] == 2


def test_compensate_refuses_what_would_give_a_wrong_number(
    sim: simulate.SimulatedSession, cal_file: Path, tmp_path: Path
) -> None:
    """Each was a wrong number with exit 0 (the adversarial round of session 20)."""
    out_csv = tmp_path / "o.csv"
    rows = (sim.path / "x_pos.csv").read_text().splitlines()
    # A repeated column name: pandas renamed it "x.1", and the first x was read in silence.
    dup = tmp_path / "dup.csv"
    dup.write_text(
        "\n".join(
            [rows[0].replace("x,", "x,x,", 1)]
            + [r.replace(",", ",0,", 2).replace(",0,", ",", 1) for r in rows[1:50]]
        )
        + "\n"
    )
    status, _, err = run_main("compensate", cal_file, dup, "-o", out_csv)
    assert status == 1 and "column name 'x' appears twice" in err, err
    # --session in other units than the calibration.
    other = tmp_path / "other"
    other.mkdir()
    toml = (sim.path / "session.toml").read_text().replace('units = "V"', 'units = "g"')
    (other / "session.toml").write_text(toml)
    status, _, err = run_main(
        "compensate", cal_file, sim.path / "x_pos.csv", "-o", out_csv, "--session", other
    )
    assert status == 1 and "in g but the calibration" in err and "is in V" in err, err
    # --session says ms for a log in seconds: every step read 1000x short.
    ms = tmp_path / "ms"
    ms.mkdir()
    toml = (sim.path / "session.toml").read_text()
    (ms / "session.toml").write_text(toml.replace('time_unit = "s"', 'time_unit = "ms"', 1))
    status, _, err = run_main(
        "compensate", cal_file, sim.path / "x_pos.csv", "-o", out_csv, "--session", ms
    )
    assert status == 1 and "rate_hz or time_unit is wrong" in err, err
    # Spaces after the commas: read as the session reader reads them.
    spaced = tmp_path / "spaced.csv"
    spaced.write_text("\n".join(r.replace(",", ", ") for r in rows[:200]) + "\n")
    status, _, err = run_main("compensate", cal_file, spaced, "-o", out_csv)
    assert status == 0, err
    plain = tmp_path / "plain.csv"
    plain.write_text("\n".join(rows[:200]) + "\n")
    assert run_main("compensate", cal_file, plain, "-o", tmp_path / "p.csv")[0] == 0
    pd.testing.assert_frame_equal(pd.read_csv(out_csv), pd.read_csv(tmp_path / "p.csv"))
    assert not any(p.name.startswith("o.csv.") for p in tmp_path.iterdir())
    # An empty time cell, a time that goes back, under a model with a lag (the time
    # matters): the line and column, as the readers say (was "row 4999, column 0" and
    # "at sample 9999").
    session = accelcore.load_session(sim.path)
    lagged = {a: (*base_terms(a), Term("offset", "lag(300):dT^1", effect="lag")) for a in "xyz"}
    stateful = tmp_path / "stateful.json"
    accelcore.calibrate(session, terms=lagged, window_c=None).save(stateful)
    for time_cell, said in (
        ("", "not a finite number"),
        ("0.05", "time is not strictly increasing"),
    ):
        bad = rows[:120]
        bad[100] = time_cell + "," + bad[100].split(",", 1)[1]
        log = tmp_path / "bad_time.csv"
        log.write_text("\n".join([*bad[:51], "", *bad[51:]]) + "\n")  # a blank line too
        status, _, err = run_main("compensate", stateful, log, "-o", tmp_path / "t.csv")
        assert status == 1 and f"{log}:102:1: column 'time_s': {said}" in err, err
    # A Parquet time column of timestamps: was a traceback (cannot cast to float64).
    frame = pd.read_csv(plain)
    frame["time_s"] = pd.to_datetime(frame["time_s"], unit="s")
    stamped = tmp_path / "stamped.parquet"
    frame.to_parquet(stamped)
    status, _, err = run_main("compensate", cal_file, stamped, "-o", tmp_path / "s.csv")
    assert status == 1 and "column 'time_s' is timestamp" in err and "not numeric" in err, err


# ---------------------------------------------------------------------- simulate
def test_simulate_writes_a_session(tmp_path: Path) -> None:
    folder = tmp_path / "s"
    target = tmp_path / "sim.json"
    status, out, err = run_main(
        "simulate", folder, "--sensor", "mpu9255", "--seed", "4", "--duration-h", "0.05",
        "--soak-min", "1", "--orientations", "OZ+", "OZ-", "--serial", "M-2", "--json", target,
    )  # fmt: skip
    assert status == 0, err
    assert "wrote" in out and "MPU-9255" in out
    session = accelcore.load_session(folder)
    assert session.orientations == ("OZ+", "OZ-") and session.serial == "M-2"
    doc = strict_json(target)
    assert doc["schema"] == "accelcore-cli/1" and doc["command"] == "simulate"
    assert doc["result"]["units"] == "LSB" and len(doc["result"]["runs"]) == 2
    # Refuses to write into a non-empty folder: a data error naming it.
    status, _, err = run_main("simulate", folder, "--duration-h", "0.05", "--soak-min", "1")
    assert status == 1 and str(folder) in err
    # Unknown sensor, bad duration: usage errors.
    assert run_main("simulate", tmp_path / "t", "--sensor", "BMI088")[0] == 2
    assert run_main("simulate", tmp_path / "t", "--duration-h", "-1")[0] == 2


# ---------------------------------------------------------------------- diagnose, bench
@pytest.mark.skipif(not HAVE_DIAGNOSIS, reason="accelcore.diagnosis is not written yet")
def test_diagnose(sim: simulate.SimulatedSession, tmp_path: Path) -> None:
    target = tmp_path / "d.json"
    status, out, err = run_main("diagnose", sim.path, "--json", target)
    assert status == 0, err
    assert out.strip()
    doc = strict_json(target)
    assert doc["schema"] == "accelcore-cli/1" and doc["command"] == "diagnose"
    assert set(doc["result"]) == {"session", "diagnosis", "quality"}


def test_diagnose_without_the_module_exits_2(
    sim: simulate.SimulatedSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "accelcore.diagnosis", None)
    status, _, err = run_main("diagnose", sim.path)
    assert status == 2 and "diagnosis is not available" in err


class _FakeDiagnosis:
    """Stands in for accelcore.diagnosis.Diagnosis to test the command's plumbing."""

    def __init__(self, session: accelcore.Session, calibration: object) -> None:
        self.session, self.calibration = session, calibration

    def text(self) -> str:
        return f"fake diagnosis of {len(self.session.runs)} runs"

    def to_dict(self) -> dict[str, Any]:
        return {"effects": ["curvature"], "rms_mg": [float("nan"), 0.5]}


def _fake_diagnosis_module(calls: list[object]) -> types.ModuleType:
    def diagnose(
        session: accelcore.Session, calibration: object = None, quality: object = None
    ) -> _FakeDiagnosis:
        calls.append(calibration)
        return _FakeDiagnosis(session, calibration)

    module = types.ModuleType("accelcore.diagnosis")
    module.diagnose = diagnose  # type: ignore[attr-defined]
    return module


def test_diagnose_plumbing_with_a_stand_in_module(
    sim: simulate.SimulatedSession, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[object] = []
    fake = _fake_diagnosis_module(calls)
    monkeypatch.setitem(sys.modules, "accelcore.diagnosis", fake)
    monkeypatch.setattr(accelcore, "diagnosis", fake, raising=False)
    target = tmp_path / "d.json"
    status, out, err = run_main("diagnose", sim.path, "--json", target)
    assert status == 0, err
    assert out.strip() == "fake diagnosis of 6 runs"
    doc = strict_json(target)
    assert doc["command"] == "diagnose"
    assert doc["result"] == {
        "session": str(sim.path),
        "diagnosis": {"effects": ["curvature"], "rms_mg": [None, 0.5]},
        "quality": [],
    }
    # The demo ends with the diagnosis table, reusing its joint calibration.
    status, out, err = run_main("demo", "--dir", tmp_path / "demo")
    assert status == 0, err
    assert out.rstrip().endswith("fake diagnosis of 6 runs")
    assert isinstance(calls[-1], accelcore.Calibration) and calls[-1].method == "joint"


def test_bench_forwards_its_arguments(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[list[str] | None] = []

    def fake_main(argv: list[str] | None = None) -> int:
        seen.append(argv)
        return 3

    fake = types.ModuleType("accelcore.apps.bench")
    fake.main = fake_main  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "accelcore.apps.bench", fake)
    monkeypatch.setattr(accelcore, "bench", fake, raising=False)
    assert run_main("bench", "--quick", "--help")[0] == 3
    assert seen == [["--quick", "--help"]]


def test_bench_without_the_module_exits_2(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "accelcore.apps.bench", None)
    status, out, err = run_main("bench")
    assert status == 2 and out == ""
    assert "benchmarks are not available" in err


# ---------------------------------------------------------------------- demo
def test_demo_generates_once_and_prints_the_tables(tmp_path: Path) -> None:
    folder = tmp_path / "demo"
    status, out, err = run_main("demo", "--dir", folder)
    assert status == 0, err
    assert err == ""
    assert "generated in" in out
    for heading in (
        "Calibration (joint) of ADXL335",
        "Datasheet comparison, ADXL335",
        "at T_ref:",
        "temperature coefficients:",
        "recovered vs true",
    ):
        assert heading in out
    if not HAVE_DIAGNOSIS:
        assert "diagnosis not available" in out
        assert len(out.splitlines()) <= 60
    # The recovered coefficients sit next to the truth: Z offset TC -3.602 mg/°C.
    z_row = next(line for line in out.splitlines() if "z    offset TC" in line)
    true, joint = z_row.split()[4], z_row.split()[5]
    assert float(true) == -3.602 and abs(float(joint) - -3.602) < 0.05
    files = sorted(p.name for p in folder.iterdir())
    assert "session.toml" in files and "demo.json" in files
    mtime = (folder / "session.toml").stat().st_mtime_ns
    # Second run: reused, identical tables.
    status, again, _ = run_main("demo", "--dir", folder)
    assert status == 0 and "reused" in again
    assert (folder / "session.toml").stat().st_mtime_ns == mtime
    assert again.split("\n", 2)[2] == out.split("\n", 2)[2]
    # --regenerate writes the same files again (fixed seed).
    before = (folder / "z_pos.csv").read_bytes()
    assert run_main("demo", "--dir", folder, "--regenerate")[0] == 0
    assert (folder / "z_pos.csv").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]


def test_demo_default_folder() -> None:
    from accelcore.apps import demo

    root = Path(demo.__file__).resolve().parents[2]
    folder = demo.default_directory()
    if (root / "pyproject.toml").is_file() and os.access(root, os.W_OK):
        assert folder == root / "examples" / "adxl335-demo" / "generated"
    else:
        assert folder.parts[-2:] == ("accelcore", "adxl335-demo")


def test_demo_refuses_a_foreign_folder(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("mine")
    status, _, err = run_main("demo", "--dir", tmp_path)
    assert status == 1 and str(tmp_path) in err and "not an accelcore demo session" in err
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_demo_through_python_dash_m(tmp_path: Path) -> None:
    proc = run_subprocess("demo", "--dir", tmp_path / "d")
    assert proc.returncode == 0, proc.stderr
    assert "Datasheet comparison, ADXL335" in proc.stdout


def test_console_script_is_installed(sim: simulate.SimulatedSession) -> None:
    script = Path(sys.executable).parent / "accelcore"
    if not script.exists():
        pytest.skip(f"no console script next to {sys.executable}")
    proc = subprocess.run(
        [str(script), "calibrate", str(sim.path), "--json", "-"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["command"] == "calibrate"
