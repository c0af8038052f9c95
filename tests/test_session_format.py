"""SessionFormat: session.toml read once, kept on the Session, and what it says."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

import accelcore
from accelcore import load_session
from accelcore.input.format import SessionFormat
from accelcore.input.session import Session

TOML = """format = "accelcore-session/1"
sensor = "adxl327"
serial = ""
units = "LSB"
rate_hz = 50
delimiter = "tab"
time_unit = "ms"

[columns]
time = "t_ms"
x = "ax"

[[run]]
file = "a.tsv"
orientation = " oz+ "

[[run]]
file = "b.tsv"
orientation = "OX-"
"""


def write(folder: Path, toml: str = TOML) -> Path:
    folder.mkdir()
    (folder / "session.toml").write_text(toml, encoding="utf-8")
    for name in ("a.tsv", "b.tsv"):
        rows = ["t_ms\ttemp_c\tax\ty\tz"]
        rows += [f"{20 * i}\t{25 + 0.01 * i}\t{i % 3}\t1\t2" for i in range(40)]
        (folder / name).write_text("\n".join(rows) + "\n", encoding="utf-8")
    return folder


def test_every_key_is_read(tmp_path: Path) -> None:
    folder = write(tmp_path / "s")
    fmt = SessionFormat.read(folder)
    assert fmt.version == "accelcore-session/1"
    assert (fmt.units, fmt.rate_hz, fmt.sensor, fmt.serial) == ("LSB", 50.0, "adxl327", None)
    assert (fmt.delimiter, fmt.separator) == ("tab", "\t")
    assert (fmt.time_unit, fmt.time_scale_to_s) == ("ms", 1e-3)
    assert dict(fmt.columns) == {
        "time": "t_ms",
        "temperature": "temp_c",
        "x": "ax",
        "y": "y",
        "z": "z",
    }
    assert fmt.channel_columns == ("ax", "y", "z")
    assert [(r.file, r.orientation) for r in fmt.runs] == [("a.tsv", "OZ+"), ("b.tsv", "OX-")]
    assert fmt.run_files == (folder / "a.tsv", folder / "b.tsv")
    np.testing.assert_array_equal(fmt.runs[1].gravity_g, [-1.0, 0.0, 0.0])
    assert fmt.toml_path == folder / "session.toml"
    assert fmt.sha256 == hashlib.sha256((folder / "session.toml").read_bytes()).hexdigest()
    with pytest.raises(AttributeError):
        fmt.units = "V"  # type: ignore[misc]
    with pytest.raises(TypeError):
        fmt.columns["x"] = "other"  # type: ignore[index]


def test_the_session_keeps_what_it_read(tmp_path: Path) -> None:
    folder = write(tmp_path / "s")
    session = load_session(folder, decimation_factor=5, cache=False, digest="sha256")
    assert session.format == SessionFormat.read(folder)
    assert session.file_sha256["session.toml"] == session.format.sha256
    assert session.units == "LSB" and session.rate_hz == 50.0
    assert session.orientations == ("OZ+", "OX-")
    assert session.runs[0].time_s[0] == pytest.approx(0.04)  # ms -> s
    memory = Session.from_arrays(
        [
            (
                "OZ+",
                {"time_s": [0.0, 0.1], "temp_c": [1.0, 1.0], "x": [0, 0], "y": [0, 0], "z": [1, 1]},
            )
        ],
        units="g",
        rate_hz=10.0,
        decimation_factor=1,
    )
    assert memory.format is None


def test_run_files_are_checked_unless_asked_not_to(tmp_path: Path) -> None:
    folder = write(tmp_path / "s")
    (folder / "b.tsv").unlink()
    with pytest.raises(accelcore.AccelcoreIOError, match=r"b\.tsv: run file does not exist"):
        SessionFormat.read(folder)
    fmt = SessionFormat.read(folder, check_files=False)
    assert fmt.run_files[1] == folder / "b.tsv"


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('units = "LSB"', 'units = "volts"', "units must be one of"),
        ("rate_hz = 50", "rate_hz = -1", "rate_hz must be a positive number"),
        ('delimiter = "tab"', 'delimiter = "|"', "delimiter must be"),
        ('x = "ax"', "x = 3", r"\[columns\] values must be strings"),
        ('x = "ax"', 'w = "ax"', r"unknown key\(s\) in \[columns\]: w"),
        ('orientation = "OX-"', 'orientation = "up"', r"\[\[run\]\] #2: unknown orientation"),
        # A NUL in a file name was a traceback (ValueError: embedded null byte).
        ('file = "b.tsv"', 'file = "b.tsv\\u0000.txt"', r"\[\[run\]\] #2: file .* holds a NUL"),
        ("rate_hz = 50", "rate_hz = true", "rate_hz must be a positive number"),
    ],
)
def test_invalid_keys_are_named(tmp_path: Path, old: str, new: str, message: str) -> None:
    folder = write(tmp_path / "s", TOML.replace(old, new))
    with pytest.raises(accelcore.SessionFormatError, match=message):
        SessionFormat.read(folder)


@pytest.mark.parametrize(
    ("typo", "message"),
    [
        ('serail = "A-1"\n', "unknown key 'serail'; did you mean 'serial'?"),
        ("rate = 20\n", "unknown key 'rate'; did you mean 'rate_hz'?"),
        ('chamber = "B"\n', "unknown key 'chamber'; known keys: format, sensor"),
    ],
)
def test_an_unknown_key_is_named_with_the_nearest_known_one(
    tmp_path: Path, typo: str, message: str
) -> None:
    folder = write(tmp_path / "s", typo + TOML)
    with pytest.raises(accelcore.SessionFormatError, match=message.replace("?", r"\?")):
        SessionFormat.read(folder)


def test_an_unknown_run_key_is_named_with_its_run(tmp_path: Path) -> None:
    toml = TOML.replace('file = "b.tsv"\n', 'file = "b.tsv"\norientaton = "OX-"\n')
    folder = write(tmp_path / "s", toml)
    with pytest.raises(
        accelcore.SessionFormatError,
        match=r"unknown key 'orientaton' in \[\[run\]\] #2; did you mean 'orientation'\?",
    ):
        SessionFormat.read(folder)


def test_the_lab_record_reaches_the_calibration(tmp_path: Path) -> None:
    from accelcore import simulate

    folder = tmp_path / "s"
    simulate.session(folder, "ADXL335", seed=2, duration_h=0.3)
    toml = folder / "session.toml"
    lab = '\n[lab]\ndate = "2026-11-23"\noperator = "A. Ng"\nchamber = "Vötsch VT 4002"\n'
    toml.write_text(toml.read_text().replace("\n[columns]", lab + "\n[columns]", 1))
    session = load_session(folder, cache=False)
    assert dict(session.format.lab) == {  # type: ignore[union-attr]
        "date": "2026-11-23",
        "operator": "A. Ng",
        "chamber": "Vötsch VT 4002",
    }
    cal = accelcore.calibrate(session)
    assert cal.provenance["lab"]["operator"] == "A. Ng"
    toml.write_text(toml.read_text().replace("operator", "operater"))
    with pytest.raises(accelcore.SessionFormatError, match=r"in \[lab\]; did you mean 'operator'"):
        SessionFormat.read(folder)
