"""``accelcore init``: a session.toml guessed from a folder of logs loads and calibrates.

The sessions are simulated (``accelcore.simulate`` writes a session.toml beside
the logs); the test removes it, lets ``init`` guess it again, and compares the
guess with the original and the calibrations of both.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import accelcore
from accelcore import simulate
from accelcore.apps.cli import main
from accelcore.apps.cli.init import guess_columns, orientation_from_means, orientation_from_name
from accelcore.input.format import SessionFormat

SIX = ["OX+", "OX-", "OY+", "OY-", "OZ+", "OZ-"]


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    out = io.StringIO()
    code = main(argv, stdout=out)
    return code, out.getvalue(), capsys.readouterr().err


@pytest.fixture(scope="module")
def original(tmp_path_factory: pytest.TempPathFactory) -> Path:
    sim = simulate.session(
        tmp_path_factory.mktemp("sim") / "s", "ADXL335", seed=3, duration_h=0.08, soak_min=0.5
    )
    return sim.path


def _copy_without_toml(
    src: Path,
    dst: Path,
    rename: dict[str, str] | None = None,
    edit: Callable[[str], str] | None = None,
) -> Path:
    """Copy the logs of ``src`` into ``dst``, renamed and their text edited as asked."""
    dst.mkdir()
    for f in src.glob("*.csv"):
        name = (rename or {}).get(f.name, f.name)
        (dst / name).write_text(f.read_text() if edit is None else edit(f.read_text()))
    return dst


def _orientations(folder: Path) -> dict[str, str]:
    fmt = SessionFormat.read(folder)
    return {Path(r.file).name: r.orientation for r in fmt.runs}


def test_guessed_session_loads_and_calibrates_like_the_original(
    original: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _copy_without_toml(original, tmp_path / "s")
    code, out, err = _run(["init", str(folder)], capsys)
    assert code == 0, err
    assert "6 runs" in out and "units V" in out and "rate 20 Hz" in out
    assert "x_pos.csv  OX+  (file name)" in out
    assert _orientations(folder) == _orientations(original)
    got = accelcore.calibrate(accelcore.load_session(folder, cache=False))
    want = accelcore.calibrate(accelcore.load_session(original, cache=False))
    pd.testing.assert_frame_equal(got.summary(), want.summary())


def test_orientation_from_gravity_when_names_say_nothing(
    original: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    truth = _orientations(original)
    rename = {name: f"run{i}.csv" for i, name in enumerate(sorted(truth))}
    folder = _copy_without_toml(original, tmp_path / "s", rename)
    code, out, err = _run(["init", str(folder)], capsys)
    assert code == 0, err
    assert "(mean output (gravity))" in out
    assert _orientations(folder) == {rename[k]: v for k, v in truth.items()}
    assert accelcore.load_session(folder, cache=False).runs


def test_refuses_an_existing_session_toml_unless_forced(
    original: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _copy_without_toml(original, tmp_path / "s")
    toml = folder / "session.toml"
    toml.write_text("# the lab's own\n")
    code, out, err = _run(["init", str(folder)], capsys)
    assert code == 2 and out == ""
    assert err.strip().count("\n") == 0 and "--force" in err
    assert toml.read_text() == "# the lab's own\n"
    code, _, err = _run(["init", str(folder), "--force", "--sensor", "ADXL335"], capsys)
    assert code == 0, err
    assert accelcore.load_session(folder, cache=False).sensor == "ADXL335"


def test_other_headers_delimiter_and_time_unit(
    original: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "tsv"
    folder.mkdir()
    names = {"x_pos.csv": "sweep_xp.tsv", "x_neg.csv": "sweep_xn.tsv", "z_neg.csv": "ZMINUS.tsv"}
    for src, dst in names.items():
        frame = pd.read_csv(original / src)
        frame = frame.rename(
            columns={"time_s": "t_ms", "temp_c": "Temperature", "x": "ax", "y": "ay", "z": "az"}
        )
        frame["t_ms"] = np.round(frame["t_ms"] * 1000.0)
        frame.to_csv(folder / dst, sep="\t", index=False)
    code, out, err = _run(["init", str(folder), "--units", "V"], capsys)
    assert code == 0, err
    assert "delimiter 'tab', time unit ms" in out
    assert "time=t_ms, temperature=Temperature, x=ax, y=ay, z=az" in out
    assert _orientations(folder) == {
        "sweep_xp.tsv": "OX+",
        "sweep_xn.tsv": "OX-",
        "ZMINUS.tsv": "OZ-",
    }
    session = accelcore.load_session(folder, cache=False)
    assert session.rate_hz == 20.0 and session.units == "V"


def test_a_flight_like_log_in_ms2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "log"
    folder.mkdir()
    n = 2000
    k = np.arange(n)
    frame = pd.DataFrame(
        {
            "timestamp_us": 1_000_000 + k * 4000,
            "imu_temp": 30.0 + 10.0 * k / n,
            "acc_x": 0.05 + np.zeros(n),
            "acc_y": -0.02 + np.zeros(n),
            "acc_z": -9.79 + 1e-3 * np.sin(k),
        }
    )
    frame.to_csv(folder / "bench.csv", index=False)
    code, out, err = _run(["init", str(folder)], capsys)
    assert code == 0, err
    assert "units m/s2" in out and "rate 250 Hz" in out and "time unit us" in out
    assert _orientations(folder) == {"bench.csv": "OZ-"}
    assert accelcore.load_session(folder, cache=False).runs[0].orientation == "OZ-"


@pytest.mark.parametrize(
    ("name", "orientation"),
    [
        ("x_pos.csv", "OX+"),
        ("OX+.csv", "OX+"),
        ("run3_ox-.csv", "OX-"),
        ("xp.csv", "OX+"),
        ("zminus.csv", "OZ-"),
        ("Y_NEG_2.csv", "OY-"),
        ("+z.csv", "OZ+"),
        ("sweep-yplus.tsv", "OY+"),
        ("pos_x.csv", "OX+"),
        ("z_up.dat", "OZ+"),
        ("experiment.csv", None),
        ("max_pos.csv", None),
        ("x_pos_then_z_neg.csv", None),
    ],
)
def test_orientation_from_name(name: str, orientation: str | None) -> None:
    assert orientation_from_name(name) == orientation


def test_guess_columns_and_gravity() -> None:
    assert guess_columns(["Time", "temp_c", "X", "Y", "Z", "supply_v"]) == {
        "time": "Time",
        "temperature": "temp_c",
        "x": "X",
        "y": "Y",
        "z": "Z",
    }
    assert guess_columns(["time_s", "die_temp", "accel_x", "accel_y", "accel_z"])["x"] == "accel_x"
    assert "temperature" not in guess_columns(["time", "x", "y", "z"])
    means = {"a": np.array([1.5, 1.5, 1.8]), "b": np.array([1.5, 1.5, 1.2])}
    assert orientation_from_means(means, "V") == {"a": "OZ+", "b": "OZ-"}
    assert orientation_from_means({"a": np.array([0.7, 0.7, 0.0])}, "g") == {}


def test_no_logs_or_no_time(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(["init", str(tmp_path)], capsys)
    assert code == 1 and "no log files" in err
    (tmp_path / "x_pos.csv").write_text("n,x,y,z\n0,0,0,1\n1,0,0,1\n")
    code, _, err = _run(["init", str(tmp_path)], capsys)
    assert code == 1 and "no column recognised as time" in err and "x_pos.csv" in err
    assert not (tmp_path / "session.toml").exists()


def test_logs_without_temperature_give_a_session_at_one_temperature(
    original: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """imucal's six positions log no temperature: init says so and writes temperature = ""."""
    folder = _copy_without_toml(
        original,
        tmp_path / "s",
        edit=lambda text: (
            pd.read_csv(io.StringIO(text)).drop(columns=["temp_c"]).to_csv(index=False)
        ),
    )
    code, out, err = _run(["init", str(folder)], capsys)
    assert code == 0, err
    assert 'no temperature column: temperature = ""' in out
    assert "temperature=" not in out  # the columns line lists the columns found
    assert not SessionFormat.read(folder).has_temperature
    session = accelcore.load_session(folder, cache=False)
    assert not session.has_temperature
    cal = accelcore.calibrate(session)
    assert any("no temperature logged" in n for n in cal.notes), cal.notes


def test_a_preamble_above_the_header_is_skipped_as_the_reader_skips_it(
    original: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A logger's settings lines above the header: found, and the session reads."""
    folder = _copy_without_toml(
        original, tmp_path / "s", edit=lambda text: "Fs,20\nLogging Type,1\n\n" + text
    )
    code, out, err = _run(["init", str(folder)], capsys)
    assert code == 0, err
    assert "columns: time=time_s, temperature=temp_c, x=x, y=y, z=z" in out
    assert "rate 20 Hz" in out
    got = accelcore.calibrate(accelcore.load_session(folder, cache=False))
    want = accelcore.calibrate(accelcore.load_session(original, cache=False))
    pd.testing.assert_frame_equal(got.summary(), want.summary())
