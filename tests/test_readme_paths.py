"""The README's three user paths (PX4, ArduPilot, imucal), run exactly as written.

Each fenced block after a ``<!-- user path: NAME -->`` marker in README.md is a list
of ``accelcore`` commands; they run in a folder that holds what the commands name:
a synthetic PX4 ULog and ArduPilot DataFlash log of a thermal sweep
(``test_flight_logs``) and a folder of six simulated position logs without a
``session.toml``. Every command must exit 0 and the files they write must be what
their readers read.
"""

from __future__ import annotations

import io
import json
import os
import re
import shlex
from collections.abc import Iterator
from pathlib import Path

import pytest

from accelcore import simulate
from accelcore.apps.cli import main
from test_flight_logs import _sweep, _write_dataflash, _write_ulog

README = Path(__file__).resolve().parents[1] / "README.md"


def user_paths() -> dict[str, list[list[str]]]:
    """The commands of each user path of the README, as argument lists."""
    text = README.read_text(encoding="utf-8")
    out: dict[str, list[list[str]]] = {}
    for m in re.finditer(r"<!-- user path: (\w+) -->\s*```\n(.*?)```", text, re.S):
        commands = [shlex.split(line, comments=True) for line in m.group(2).splitlines()]
        out[m.group(1)] = [c for c in commands if c]
    return out


@pytest.fixture
def folder(tmp_path: Path) -> Iterator[Path]:
    _write_ulog(tmp_path / "thermal.ulg", {"sensor_accel": {0: _sweep(0)}})
    _write_dataflash(tmp_path / "thermal.bin", {0: _sweep(0)})
    simulate.session(tmp_path / "positions", "ADXL335", seed=8, duration_h=0.25)
    (tmp_path / "positions" / "session.toml").unlink()
    (tmp_path / "positions" / "truth.json").unlink(missing_ok=True)
    cwd = Path.cwd()
    os.chdir(tmp_path)
    try:
        yield tmp_path
    finally:
        os.chdir(cwd)


def test_the_readme_has_the_three_user_paths() -> None:
    paths = user_paths()
    assert set(paths) == {"px4", "ardupilot", "imucal"}
    for commands in paths.values():
        assert commands and all(c[0] == "accelcore" for c in commands)


@pytest.mark.parametrize("name", ["px4", "ardupilot", "imucal"])
def test_a_user_path_runs_as_written(name: str, folder: Path) -> None:
    for argv in user_paths()[name]:
        code = main(argv[1:], stdout=io.StringIO())
        assert code == 0, argv
    cal = json.loads((folder / "cal.json").read_text())
    assert cal["body"]["format"].startswith("accelcore-calibration/")
    if name == "px4":
        diagnosed = json.loads((folder / "diagnosed.json").read_text())
        assert diagnosed["body"]["method"] == "diagnosed"
        lines = (folder / "tc_params.txt").read_text().splitlines()
        assert any("TC_A0_X0_2" in line for line in lines)
    elif name == "ardupilot":
        text = (folder / "tcal.parm").read_text()
        assert "INS_TCAL1_ENABLE" in text
    else:
        management = pytest.importorskip("imucal.management")
        info = management.load_calibration_info(folder / "imucal_cal.json")
        assert info.K_a.shape == (3, 3)
