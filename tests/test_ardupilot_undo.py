"""An ArduPilot log is read back to what the sensor measured, with the log's own parameters.

ArduPilot logs ``IMU`` after it corrects each sample in the sensor's frame (its
``INS_TCAL`` temperature polynomial, then ``INS_ACCOFFS``/``INS_ACCSCAL``) and rotates
it into the body frame (``AHRS_ORIENTATION``). The logs here are written through that
chain, forward, from a known sensor reading: the rotations as matrices written out
by hand and the polynomial as ArduPilot documents it, independently of the reader's
module, which must return the reading.

Tolerance: the log holds float32 values, so a logged sample of ~10 m/s² is rounded by
up to half an ulp, 4.8e-7 m/s²; undoing divides by a scale of 0.99 at the least.
Block means and the difference of two roundings stay within 2e-6 m/s²; 1e-5 m/s²
(1 µg) is asserted.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from accelcore.errors import DataQualityWarning, ParameterError
from accelcore.input.readers import read_dataflash
from test_flight_logs import G, N, _block_means, _sweep, _write_dataflash

pytest.importorskip("pymavlink")

ATOL = 1e-5  # m/s²: float32 logging (module docstring)

#: body = R · sensor, written out: ROLL_180 turns y and z over; YAW_90 takes x to y.
ROLL_180 = np.diag([1.0, -1.0, -1.0])
YAW_90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])

ACC = {1: (100.0, -50.0, 2000.0), 2: (3.0, 0.0, -10.0), 3: (0.1, 0.0, 0.2)}  # x 1e-6
TMIN, TMAX, CALTEMP = 25.0, 55.0, 40.0
OFFS = (0.1, -0.2, 0.3)
SCAL = (1.01, 0.99, 1.02)
LATER_OFFS_X = 0.15  # INS_ACCOFFS_X from sample N // 2 on


def _poly(t_c: np.ndarray) -> np.ndarray:
    """ArduPilot's P(t) = (ACC1 t + ACC2 t² + ACC3 t³) 1e-6 at t = T - 35, per axis."""
    t = np.asarray(t_c, dtype=np.float64)[:, None] - 35.0
    c = {k: np.asarray(v) * 1e-6 for k, v in ACC.items()}
    return np.asarray(c[1] * t + c[2] * t**2 + c[3] * t**3)


def _sensor_sweep(rotation: np.ndarray) -> dict[str, np.ndarray]:
    """The sensor's own reading of a level vehicle (body -1 g on z) on a board turned by
    ``rotation``: offsets 0.05/-0.03 m/s² on x/y, on z +2 mm/s² per °C."""
    s = _sweep(0)
    temp = s["temperature"].astype(np.float64)
    gravity = rotation.T @ np.array([0.0, 0.0, -G])
    raw = gravity + np.column_stack([np.full(N, 0.05), np.full(N, -0.03), 0.002 * (temp - 25.0)])
    return {"timestamp": s["timestamp"], "temperature": s["temperature"], "raw": raw}


def _logged(raw: np.ndarray, temp: np.ndarray, rotation: np.ndarray, tcal: bool) -> np.ndarray:
    """ArduPilot's chain: temperature correction, offsets, scale, board rotation."""
    a = raw.copy()
    if tcal:
        clip = np.clip(temp, TMIN, TMAX)
        a = a - (_poly(clip) - _poly(np.array([CALTEMP])))
    offs = np.tile(np.asarray(OFFS), (N, 1))
    offs[N // 2 :, 0] = LATER_OFFS_X
    a = (a - offs) * np.asarray(SCAL)
    return np.asarray(a @ rotation.T)


def _params(rotation_id: float, tcal: bool) -> tuple[dict[str, float], dict[int, dict[str, float]]]:
    """The dump: calibration first, then (after three samples, as real logs do) the rest."""
    first = {f"INS_ACCOFFS_{u}": OFFS[j] for j, u in enumerate("XYZ")}
    first |= {f"INS_ACCSCAL_{u}": SCAL[j] for j, u in enumerate("XYZ")}
    rest = {"INS_TCAL1_ENABLE": 1.0 if tcal else 0.0, "INS_TCAL1_TMIN": TMIN}
    rest |= {"INS_TCAL1_TMAX": TMAX, "INS_ACC1_CALTEMP": CALTEMP}
    rest |= {f"INS_TCAL1_ACC{k}_{u}": v[j] for k, v in ACC.items() for j, u in enumerate("XYZ")}
    rest["AHRS_ORIENTATION"] = rotation_id
    return first, {3: rest, N // 2: {"INS_ACCOFFS_X": LATER_OFFS_X}}


def _write(path: Path, rotation_id: float, rotation: np.ndarray, tcal: bool = True) -> np.ndarray:
    s = _sensor_sweep(rotation)
    temp = s["temperature"].astype(np.float64)
    body = _logged(s["raw"], temp, rotation, tcal)
    cols = {"timestamp": s["timestamp"], "temperature": s["temperature"]}
    cols |= {a: body[:, j].astype(np.float32) for j, a in enumerate("xyz")}
    first, later = _params(rotation_id, tcal)
    _write_dataflash(path, {0: cols}, first, later)
    return np.asarray(s["raw"])


@pytest.mark.parametrize(
    ("rotation_id", "rotation", "label"), [(8.0, ROLL_180, "OZ+"), (2.0, YAW_90, "OZ-")]
)
@pytest.mark.parametrize("tcal", [True, False])
def test_the_sensor_reading_comes_back(
    rotation_id: float, rotation: np.ndarray, label: str, tcal: bool, tmp_path: Path
) -> None:
    """Rotation, temperature correction, offsets and scale (one changed mid-log) undone:
    the block means are the sensor's own, and the level vehicle (body OZ-) is labelled
    in the sensor's frame: upside down (OZ+) on a board turned over, OZ- yawed."""
    path = tmp_path / "log.bin"
    raw = _write(path, rotation_id, rotation, tcal)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        run = read_dataflash(path, decimation_factor=10).runs[0]
    assert run.orientation == label
    for j in range(3):
        np.testing.assert_allclose(run.output[:, j], _block_means(raw[:, j]), rtol=0, atol=ATOL)


def test_the_export_is_in_the_frame_ardupilot_corrects(tmp_path: Path) -> None:
    """Fitted on the undone data, INS_TCAL1_ACC1_Z is the sensor's +2 mm/s²/°C (times
    1e6): the logged body z of a board turned over reads the opposite slope, and the
    logged correction (2000 in ACC1_Z over 25-55 °C) had taken most of it out."""
    from accelcore import calibrate
    from accelcore.outputs.exports import export_ardupilot

    path = tmp_path / "log.bin"
    _write(path, 8.0, ROLL_180)
    out = export_ardupilot(calibrate(read_dataflash(path)))
    assert out.imu == 1
    # A line of slope 2e-3 about 35 °C, so ACC1 = 2000 and the higher orders ~0; the
    # fit is exact up to the float32 rounding above (1e-5 over 40 °C: 0.3 in ACC1).
    assert out.params["INS_TCAL1_ACC1_Z"] == pytest.approx(2000.0, abs=1.0)
    assert abs(out.params["INS_TCAL1_ACC1_X"]) < 1.0


def test_only_the_instance_read_is_undone(tmp_path: Path) -> None:
    """INS_TCAL2 is the second IMU's: the first one's samples are read as logged."""
    path = tmp_path / "two.bin"
    _write_dataflash(path, {0: _sweep(0), 1: _sweep(1)}, {"INS_TCAL2_ENABLE": 1.0})
    truth = _sweep(0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataQualityWarning)
        run = read_dataflash(path, instance=0, decimation_factor=10).runs[0]
    np.testing.assert_allclose(run.output[:, 2], _block_means(truth["z"]), rtol=1e-12)


def test_a_board_turned_off_the_axes_stays_in_the_body_frame(tmp_path: Path) -> None:
    """PITCH_7 (41) takes the level vehicle's gravity off every sensor axis: the run
    cannot be labelled in the sensor's frame, so the data stay in the body frame with
    the corrections undone, and the export's frame is warned of."""
    m = pytest.importorskip("pymavlink.rotmat").rotations[41].r
    pitch_7 = np.array([[r.x, r.y, r.z] for r in (m.a, m.b, m.c)])
    np.testing.assert_allclose(
        pitch_7,
        [[np.cos(np.radians(7)), 0, np.sin(np.radians(7))], [0, 1, 0],
         [-np.sin(np.radians(7)), 0, np.cos(np.radians(7))]],
        atol=1e-7,
    )  # fmt: skip
    path = tmp_path / "pitch7.bin"
    raw = _write(path, 41.0, pitch_7)
    with pytest.warns(DataQualityWarning, match=r"AHRS_ORIENTATION = 41 in the log turns OZ-"):
        run = read_dataflash(path, decimation_factor=10).runs[0]
    assert run.orientation == "OZ-"
    body = raw @ pitch_7.T
    for j in range(3):
        np.testing.assert_allclose(run.output[:, j], _block_means(body[:, j]), rtol=0, atol=ATOL)


def test_a_rotation_that_cannot_be_undone_is_said_or_refused(tmp_path: Path) -> None:
    """A custom rotation (101) is not in pymavlink's table: the log is read as logged,
    nothing undone (its TCAL was applied in a frame out of reach), with a warning. A
    rotation that changes mid-log leaves the data in two frames: refused. Both name
    the file."""
    custom = tmp_path / "custom.bin"
    _write_dataflash(custom, {0: _sweep(0)}, {"AHRS_ORIENTATION": 101.0, "INS_ACCOFFS_Z": 0.5})
    with pytest.warns(DataQualityWarning, match=r"custom\.bin: AHRS_ORIENTATION = 101 .*as logged"):
        run = read_dataflash(custom, decimation_factor=10).runs[0]
    np.testing.assert_allclose(run.output[:, 2], _block_means(_sweep(0)["z"]), rtol=1e-12)
    moved = tmp_path / "moved.bin"
    _write_dataflash(
        moved, {0: _sweep(0)}, {"AHRS_ORIENTATION": 0.0}, {50: {"AHRS_ORIENTATION": 2.0}}
    )
    with pytest.raises(ParameterError, match=r"moved\.bin: AHRS_ORIENTATION changes during"):
        read_dataflash(moved)
