"""session.toml problems and swapped runs: each gets a clear error naming the file."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import accelcore
from accelcore import simulate


@pytest.fixture(scope="module")
def small_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("sess") / "s"
    simulate.session(path, "ADXL335", seed=3, duration_h=0.25, soak_min=1.0)
    return path


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def _edit_toml(path: Path, old: str, new: str) -> None:
    toml = path / "session.toml"
    text = toml.read_text()
    assert old in text, text
    toml.write_text(text.replace(old, new, 1))


def test_good_session_loads(small_session: Path) -> None:
    session = accelcore.load_session(small_session)
    assert len(session.runs) == 6
    assert session.sensor == "ADXL335"


def test_missing_session_toml(tmp_path: Path) -> None:
    tmp_path.joinpath("x.csv").write_text("time_s\n")
    with pytest.raises(accelcore.SessionFormatError, match=r"session\.toml: missing"):
        accelcore.load_session(tmp_path)


def test_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(accelcore.AccelcoreIOError, match="no such session folder"):
        accelcore.load_session(tmp_path / "absent")


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            'format = "accelcore-session/1"',
            'format = "accelcore-session/2"',
            "accelcore-session/2.*not supported",
        ),
        ('format = "accelcore-session/1"', "", "missing required key 'format'"),
        ('units = "V"', "", "missing required key 'units'"),
        ('units = "V"', 'units = "mV"', "units must be one of"),
        ('orientation = "OX+"', 'orientation = "OX"', r"\[\[run\]\] #1: unknown orientation 'OX'"),
    ],
)
def test_bad_session_toml(
    small_session: Path, tmp_path: Path, old: str, new: str, message: str
) -> None:
    path = _copy(small_session, tmp_path / "s")
    _edit_toml(path, old, new)
    with pytest.raises(accelcore.SessionFormatError, match=message) as info:
        accelcore.load_session(path)
    assert "session.toml" in str(info.value)


def test_run_file_that_does_not_exist(small_session: Path, tmp_path: Path) -> None:
    path = _copy(small_session, tmp_path / "s")
    first = next(iter(sorted(path.glob("*.csv"))))
    first.unlink()
    with pytest.raises(accelcore.AccelcoreIOError, match="run file does not exist"):
        accelcore.load_session(path)


def test_swapped_runs_are_an_error_not_a_negative_sensitivity(
    small_session: Path, tmp_path: Path
) -> None:
    path = _copy(small_session, tmp_path / "s")
    _edit_toml(path, 'orientation = "OZ+"', 'orientation = "OZ?"')
    _edit_toml(path, 'orientation = "OZ-"', 'orientation = "OZ+"')
    _edit_toml(path, 'orientation = "OZ?"', 'orientation = "OZ-"')
    session = accelcore.load_session(path)
    with pytest.raises(accelcore.SessionFormatError, match="look swapped") as info:
        accelcore.calibrate(session)
    assert "OZ+" in str(info.value) and "OZ-" in str(info.value)
