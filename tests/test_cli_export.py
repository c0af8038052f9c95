"""`accelcore export`: a saved calibration as PX4, ArduPilot or imucal parameters."""

from __future__ import annotations

import hashlib
import io
from pathlib import Path

import pytest

from accelcore import simulate
from accelcore.apps.cli import main
from accelcore.outputs.exports import (
    ArduPilotExport,
    ImucalExport,
    Px4Export,
    export_ardupilot,
    export_imucal,
    export_px4,
)
from accelcore.result.calibration import Calibration


@pytest.fixture(scope="module")
def cal_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("export")
    simulate.session(folder / "s", "ADXL335", seed=4, duration_h=0.5)
    cal = folder / "cal.json"
    assert main(["calibrate", str(folder / "s"), "--save", str(cal)], stdout=io.StringIO()) == 0
    return cal


def _run(*argv: str) -> tuple[int, str]:
    out = io.StringIO()
    return main(list(argv), stdout=out), out.getvalue()


@pytest.mark.parametrize(
    ("target", "name", "extra"),
    [
        ("px4", "tc.params", ["--device-id", "2621474", "--instance", "1"]),
        ("ardupilot", "tcal.param", ["--imu", "2"]),
        ("imucal", "cal.imucal.json", ["--temperature", "30"]),
    ],
)
def test_each_target_writes_what_the_library_writes(
    cal_file: Path, tmp_path: Path, target: str, name: str, extra: list[str]
) -> None:
    before = hashlib.sha256(cal_file.read_bytes()).hexdigest()
    out = tmp_path / name
    code, text = _run("export", str(cal_file), "--to", target, "-o", str(out), *extra)
    assert code == 0, text
    cal = Calibration.load(cal_file)
    want: Px4Export | ArduPilotExport | ImucalExport
    if target == "px4":
        want = export_px4(cal, instance=1, device_id=2621474)
        assert "TC_A1_ID" in out.read_text()
    elif target == "ardupilot":
        want = export_ardupilot(cal, imu=2)
        assert "INS_TCAL2_ENABLE" in out.read_text()
    else:
        want = export_imucal(cal, temperature_c=30.0)
    assert out.read_text() == want.file_text()
    assert want.text() in text  # the summary, residuals included, is printed
    assert hashlib.sha256(cal_file.read_bytes()).hexdigest() == before


def test_refuses_to_write_over_its_input(cal_file: Path) -> None:
    before = cal_file.read_bytes()
    code, _ = _run("export", str(cal_file), "--to", "px4", "-o", str(cal_file))
    assert code == 2
    assert cal_file.read_bytes() == before


def test_unknown_target_is_a_usage_error(cal_file: Path, tmp_path: Path) -> None:
    code, _ = _run("export", str(cal_file), "--to", "betaflight", "-o", str(tmp_path / "x"))
    assert code == 2
    assert not (tmp_path / "x").exists()
