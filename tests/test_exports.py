"""Exports to PX4, ArduPilot and imucal, each read back by the target's own reader.

- PX4's QGroundControl file: read by ``read_qgc`` below, written from QGroundControl's
  ``ParameterManager::readParametersFromStream`` (``#`` lines skipped, five tab-separated
  fields), then applied as PX4's ``calc_thermal_offsets_3D`` does.
- ArduPilot's ``.param``: read by pymavlink's ``MAVParmDict.load``, then applied as
  ``AP_InertialSensor_TCal::correct_sensor`` does.
- imucal: ``imucal.management.load_calibration_info`` and its ``calibrate``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from pathlib import Path
from typing import Any

import imucal  # type: ignore[import-untyped]
import imucal.management as imucal_management  # type: ignore[import-untyped]
import numpy as np
import pytest
from numpy.typing import NDArray
from pymavlink import mavparm  # type: ignore[import-untyped]

from accelcore.constants import STANDARD_GRAVITY as G0
from accelcore.errors import CalibrationFileError, ParameterError, TemperatureRangeWarning
from accelcore.model import Term
from accelcore.outputs.exports import export_ardupilot, export_imucal, export_px4
from accelcore.result.calibration import AxisModel, Calibration
from accelcore.result.foreign import read_imucal


def term(kind: str, basis: str, source: str | None = None) -> Term:
    return Term.from_dict({"kind": kind, "basis": basis, "source": source})


def axis_model(axis: str, terms: list[Term], coefficients: list[float]) -> AxisModel:
    n = len(terms)
    return AxisModel(
        axis, tuple(terms), np.array(coefficients), np.zeros((n, n)), np.ones(n, bool), 100, 0.0
    )


def calibration(axes: dict[str, AxisModel], units: str = "m/s2") -> Calibration:
    return Calibration("joint", units, 25.0, (0.0, 50.0), (0.0, 50.0), axes, sensor="test")


def cubic_cal(z_extra: list[tuple[Term, float]] | None = None) -> Calibration:
    """A model that is already a cubic offset, in m/s² with sensitivity exactly g0.

    x: offset 0.05 + 0.002·(T-25) m/s²;  y: offset 0.001·(T-25)² m/s²;  z: offset -0.1.
    """
    z_terms = [term("offset", "1"), term("gain", "1", "z")]
    z_coefs = [-0.1, G0]
    for t, c in z_extra or []:
        z_terms.append(t)
        z_coefs.append(c)
    return calibration(
        {
            "x": axis_model(
                "x",
                [term("offset", "1"), term("offset", "dT^1"), term("gain", "1", "x")],
                [0.05, 0.002, G0],
            ),
            "y": axis_model("y", [term("offset", "dT^2"), term("gain", "1", "y")], [0.001, G0]),
            "z": axis_model("z", z_terms, z_coefs),
        }
    )


# ----------------------------------------------------------------------------- PX4


def read_qgc(path: Path, system_id: int = 1) -> dict[str, tuple[int, float, int]]:
    """QGroundControl's reader: skip ``#`` lines, five tab-separated fields per line."""
    out: dict[str, tuple[int, float, int]] = {}
    for line in path.read_text().splitlines():
        if line.startswith("#"):
            continue
        fields = line.split("\t")
        assert len(fields) == 5, line
        vehicle, component, name, value, kind = fields
        assert int(vehicle) == system_id
        assert int(kind) in (6, 9)
        parsed = float(int(value)) if int(kind) == 6 else float(value)
        out[name] = (int(component), parsed, int(kind))
    return out


def px4_offset(p: dict[str, tuple[int, float, int]], i: int, temp: float) -> NDArray[np.float64]:
    """PX4's calc_thermal_offsets_3D: temperature clipped to [TMIN, TMAX], cubic about TREF."""
    tmin, tmax, tref = (p[f"TC_A{i}_{k}"][1] for k in ("TMIN", "TMAX", "TREF"))
    d = min(max(temp, tmin), tmax) - tref
    return np.array([sum(p[f"TC_A{i}_X{k}_{j}"][1] * d**k for k in range(4)) for j in range(3)])


def test_px4_signs_and_units_by_hand(tmp_path: Path) -> None:
    # Worked by hand: TREF is the middle of 0…50 °C, 25 °C. PX4's offset is
    # X0 + X1·d + X2·d² + X3·d³ (m/s²), d = T - TREF, and PX4 SUBTRACTS it. Our x offset is
    # 0.05 + 0.002·(T-25) m/s², so X1_0 = 0.002 and (relative, as PX4's own script) X0_0 = 0:
    # at 35 °C the zero-g reading is 0.05 + 0.02 = 0.07 m/s², PX4 subtracts 0.002·10 = 0.02,
    # and CAL_ACC0_XOFF (0.05, from PX4's accelerometer calibration at 25 °C) the rest: 0.
    # y: 0.001·(T-25)² gives X2_1 = 0.001. Sensitivity is exactly g0 (units m/s2), so no scaling.
    cal = cubic_cal()
    out = export_px4(cal, device_id=1310988)
    path = tmp_path / "tc.params"
    out.write(path)
    text = path.read_text()
    assert text.startswith("# Onboard parameters for Vehicle 1\n")
    assert "# Vehicle-Id Component-Id Name Value Type\n" in text
    p = read_qgc(path)
    assert p["TC_A0_ID"] == (1, 1310988.0, 6)
    assert p["TC_A_ENABLE"] == (1, 1.0, 6)
    assert p["TC_A0_TREF"][1:] == (25.0, 9)
    assert (p["TC_A0_TMIN"][1], p["TC_A0_TMAX"][1]) == (0.0, 50.0)
    assert p["TC_A0_X1_0"][1] == pytest.approx(0.002, rel=1e-6)
    assert p["TC_A0_X2_1"][1] == pytest.approx(0.001, rel=1e-6)
    for name in ("X0_0", "X0_1", "X0_2", "X2_0", "X3_0", "X1_1", "X3_1", "X1_2", "X2_2"):
        assert abs(p[f"TC_A0_{name}"][1]) < 1e-12, name
    assert out.fit.max_residual_mg < 1e-9
    assert out.fit.rms_residual_mg < 1e-9
    # Applied as PX4 does, with the constant from PX4's accelerometer calibration at TREF:
    cal_off = np.array(out.fit.offset_at_t_ref_m_s2)
    assert cal_off == pytest.approx([0.05, 0.0, -0.1])
    for temp in (0.0, 12.5, 35.0, 50.0):
        zero_g = cal.compensate(np.zeros((1, 3)), [temp])  # g seen at zero raw (session units)
        raw = -zero_g[0] * G0  # the raw reading at zero acceleration, m/s²
        corrected = raw - px4_offset(p, 0, temp) - cal_off
        assert np.max(np.abs(corrected)) < 1e-6
    assert "max residual" in out.text()


def test_px4_options_checked() -> None:
    cal = cubic_cal()
    with pytest.raises(ParameterError, match="TC_A0"):
        export_px4(cal, instance=4)
    full = export_px4(cal, relative=False, instance=2, t_ref_c=20.0, enable=False)
    assert "TC_A_ENABLE" not in full.params
    assert full.params["TC_A2_TREF"] == (20.0, 9)
    # Whole offset in X0: x at 20 °C is 0.05 - 0.01 = 0.04 m/s².
    assert full.params["TC_A2_X0_0"][0] == pytest.approx(0.04, rel=1e-9)


# ----------------------------------------------------------------------------- ArduPilot


def test_ardupilot_signs_and_units_by_hand(tmp_path: Path) -> None:
    # Worked by hand: ArduPilot's polynomial is (ACC1·t + ACC2·t² + ACC3·t³)·1e-6 m/s² with
    # t = T - 35 °C and no constant; it subtracts P(T-35) - P(T_cal-35). Our y offset
    # 0.001·(T-25)² = 0.001·(t+10)² = 0.001·t² + 0.02·t + 0.1, so ACC1_Y = 0.02e6 = 20000,
    # ACC2_Y = 0.001e6 = 1000 (the 0.1 is dropped: INS_ACCOFFS holds the constant). x:
    # 0.002·(T-25) gives ACC1_X = 2000. At 45 °C with T_cal = 25 °C the x correction is
    # 2000e-6·(10 - (-10)) = 0.04 m/s²: the reading 0.05 + 0.04 less 0.04 is 0.05 = INS_ACCOFFS_X.
    cal = cubic_cal()
    out = export_ardupilot(cal)
    path = tmp_path / "tcal.param"
    out.write(path)
    parms = mavparm.MAVParmDict()
    assert parms.load(str(path))
    assert set(parms) == set(out.params)
    assert parms["INS_TCAL1_ENABLE"] == 1
    assert (parms["INS_TCAL1_TMIN"], parms["INS_TCAL1_TMAX"]) == (0.0, 50.0)
    assert parms["INS_TCAL1_ACC1_X"] == pytest.approx(2000.0, rel=1e-6)
    assert parms["INS_TCAL1_ACC1_Y"] == pytest.approx(20000.0, rel=1e-6)
    assert parms["INS_TCAL1_ACC2_Y"] == pytest.approx(1000.0, rel=1e-6)
    for name in ("ACC2_X", "ACC3_X", "ACC3_Y", "ACC1_Z", "ACC2_Z", "ACC3_Z"):
        assert abs(parms[f"INS_TCAL1_{name}"]) < 1e-6, name

    def poly(t: float, axis: str) -> float:
        return float(sum(parms[f"INS_TCAL1_ACC{k}_{axis}"] * t**k for k in (1, 2, 3)) * 1e-6)

    t_cal = 25.0
    offs = -cal.compensate(np.zeros((1, 3)), [t_cal])[0] * G0  # INS_ACCOFFS at T_cal
    for temp in (0.0, 17.0, 45.0, 50.0):
        raw = -cal.compensate(np.zeros((1, 3)), [temp])[0] * G0
        for j, axis in enumerate("XYZ"):
            corrected = raw[j] - (poly(temp - 35.0, axis) - poly(t_cal - 35.0, axis)) - offs[j]
            assert abs(corrected) < 1e-6
    assert out.fit.max_residual_mg < 1e-9
    with pytest.raises(ParameterError, match="INS_TCAL"):
        export_ardupilot(cal, imu=4)


# ----------------------------------------------------------------------------- residuals


def test_lagged_term_residual_reported() -> None:
    # z offset 0.003 m/s²/°C on a die lagging the probe by tau = 300 s. On a ramp at
    # r = 1 °C/min the die trails by r·tau = 5 °C: 0.015 m/s² = 1.53 mg of offset that no
    # polynomial of the logged temperature can give both up and down the ramp.
    lag = term("offset", "lag(300):dT^1")
    cal = cubic_cal([(lag, 0.003)])
    expected_mg = 0.003 * (1.0 / 60.0) * 300.0 / G0 * 1000.0
    px4 = export_px4(cal)
    ardu = export_ardupilot(cal)
    z = px4.fit.axes[2]
    assert z.max_residual_mg == pytest.approx(expected_mg, rel=0.02)
    assert 0.5 * z.max_residual_mg < z.rms_residual_mg <= z.max_residual_mg
    assert px4.fit.axes[0].max_residual_mg < 1e-9
    # The same cubic space either way: both formats lose the same.
    assert ardu.fit.axes[2].max_residual_mg == pytest.approx(z.max_residual_mg, rel=1e-9)
    assert f"{z.max_residual_mg:.4f} mg" in px4.text()
    assert f"max residual {px4.fit.max_residual_mg:.4f} mg" in px4.file_text()
    slow = export_px4(cal, ramp_c_per_min=0.5).fit.axes[2]
    assert slow.max_residual_mg == pytest.approx(expected_mg / 2, rel=0.03)


def test_sensitivity_drift_reported_and_folded() -> None:
    # z sensitivity g0·(1 + 1e-4·(T-25)): over 0…50 °C it moves by up to 1e-4·25 = 2.5 mg per g,
    # which an offset polynomial cannot carry. Folded in at gravity (0, 0, 1) g it becomes an
    # offset slope of g0·1e-4 m/s²/°C on z.
    cal = cubic_cal([(term("gain", "dT^1", "z"), G0 * 1e-4)])
    plain = export_px4(cal)
    assert plain.fit.axes[2].sensitivity_drift_mg_per_g == pytest.approx(2.5, rel=1e-9)
    assert plain.params["TC_A0_X1_2"][0] == pytest.approx(0.0, abs=1e-12)
    folded = export_px4(cal, gravity_g=(0, 0, 1))
    assert folded.params["TC_A0_X1_2"][0] == pytest.approx(G0 * 1e-4, rel=1e-9)


def test_offsets_scaled_by_sensitivity() -> None:
    # Session in volts, 0.3 V/g: an offset slope of 0.6 mV/°C is 2 mg/°C = 0.0196133 m/s²/°C.
    axes = {
        a: axis_model(
            a, [term("offset", "1"), term("offset", "dT^1"), term("gain", "1", a)], [1.5, 6e-4, 0.3]
        )
        for a in "xyz"
    }
    out = export_px4(calibration(axes, units="V"))
    assert out.params["TC_A0_X1_0"][0] == pytest.approx(2e-3 * G0, rel=1e-9)


def test_exports_use_the_sessions_local_gravity() -> None:
    """1 g of the calibration is the local gravity the part sat in (``gravity_m_s2``): the
    m/s² the exports write scale with it, exactly."""
    axes = {
        a: axis_model(
            a, [term("offset", "1"), term("offset", "dT^1"), term("gain", "1", a)], [1.5, 6e-4, 0.3]
        )
        for a in "xyz"
    }
    standard = calibration(axes, units="V")
    local = dataclasses.replace(standard, options={**standard.options, "gravity_m_s2": 9.78})
    ratio = 9.78 / G0
    for key in ("TC_A0_X1_0", "TC_A0_X1_2"):
        assert export_px4(local).params[key][0] == pytest.approx(
            export_px4(standard).params[key][0] * ratio, rel=1e-12
        )
    k_std = export_imucal(tilted_cal()).K_a
    k_loc = export_imucal(dataclasses.replace(tilted_cal(), options={"gravity_m_s2": 9.78})).K_a
    np.testing.assert_allclose(k_loc, k_std / ratio, rtol=1e-12)


# ----------------------------------------------------------------------------- imucal


def tilted_cal(units: str = "V") -> Calibration:
    """Volts, 0.3 V/g, misaligned, with a temperature-dependent offset and sensitivity."""
    cross = {"x": (0.3, 0.004, -0.002), "y": (0.003, 0.31, 0.001), "z": (-0.001, 0.002, 0.29)}
    axes = {}
    for a, row in cross.items():
        terms = [term("offset", "1"), term("offset", "dT^1"), term("gain", "dT^1", a)]
        coefs = [1.5 + 0.01 * "xyz".index(a), 2e-4, 3e-5]
        terms += [term("gain", "1", b) for b in "xyz"]
        coefs += list(row)
        axes[a] = axis_model(a, terms, coefs)
    return calibration(axes, units=units)


RAW = np.array([[1.5, 1.5, 1.8], [1.8, 1.52, 1.52], [1.2, 1.2, 1.2], [1.51, 1.83, 1.49]])


@pytest.mark.parametrize("temperature_c", [None, 40.0])
def test_imucal_reads_our_json_and_calibrates_like_us(
    tmp_path: Path, temperature_c: float | None
) -> None:
    cal = tilted_cal()
    out = export_imucal(cal, temperature_c=temperature_c)
    path = tmp_path / "cal.json"
    out.write(path)
    info = imucal_management.load_calibration_info(path)
    assert isinstance(info, imucal.FerrarisCalibrationInfo)
    assert "placeholders" in (info.comment or "")
    gyr = np.zeros_like(RAW)
    acc, gyr_out = info.calibrate(RAW, gyr, acc_unit="V", gyr_unit="deg/s")
    temp = cal.t_ref_c if temperature_c is None else temperature_c
    ours = cal.compensate(RAW, np.full(len(RAW), temp))
    np.testing.assert_allclose(acc, ours * G0, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(gyr_out, gyr)
    # imucal's conventions: K_a diagonal, R_a rows of unit length.
    assert np.count_nonzero(info.K_a - np.diag(np.diag(info.K_a))) == 0
    np.testing.assert_allclose(np.linalg.norm(info.R_a, axis=1), 1.0, rtol=1e-14)
    assert out.offset_change_mg > 0 and "lost over the calibrated range" in out.text()


def test_imucal_takes_m_s2_in_its_own_spelling(tmp_path: Path) -> None:
    """A calibration of a flight log (m/s²) is for imucal's ``acc_unit="m/s^2"``."""
    cal = tilted_cal(units="m/s2")
    path = tmp_path / "cal.json"
    export_imucal(cal).write(path)
    info = imucal_management.load_calibration_info(path)
    assert info.from_acc_unit == "m/s^2"
    acc, _ = info.calibrate(RAW, np.zeros_like(RAW), acc_unit="m/s^2", gyr_unit="deg/s")
    ours = cal.compensate(RAW, np.full(len(RAW), cal.t_ref_c))
    np.testing.assert_allclose(acc, ours * G0, rtol=1e-12, atol=1e-12)
    back = read_imucal(path)
    assert back.units == "m/s2"  # read back in ours


def test_imucal_round_trip(tmp_path: Path) -> None:
    cal = tilted_cal()
    path = tmp_path / "cal.json"
    export_imucal(cal, temperature_c=30.0).write(path)
    back = read_imucal(path)
    assert back.method == "imucal" and back.units == "V"
    assert back.provenance["source"] == "imucal" and back.provenance["file"] == str(path)
    temps = np.array([-10.0, 30.0, 90.0, 30.0])  # no temperature terms: no warning anywhere
    np.testing.assert_allclose(
        back.compensate(RAW, temps), cal.compensate(RAW, np.full(4, 30.0)), rtol=1e-12, atol=1e-13
    )
    again = export_imucal(back)
    np.testing.assert_allclose(again.K_a, export_imucal(cal, temperature_c=30.0).K_a, rtol=1e-13)
    # The one-temperature calibration saves and loads as any other.
    back.save(tmp_path / "back.json")
    loaded = Calibration.load(tmp_path / "back.json")
    assert loaded.temperature_range_c == (-math.inf, math.inf)
    with pytest.raises(ParameterError, match="not a finite interval"):
        export_px4(back)


def test_read_imucal_file_written_by_imucal(tmp_path: Path) -> None:
    k_a = np.diag([100.0, 102.0, 98.0])
    r_a = np.array([[1.0, 0.01, 0.0], [0.0, 1.0, -0.02], [0.005, 0.0, 1.0]])
    r_a /= np.linalg.norm(r_a, axis=1)[:, None]
    info = imucal.FerrarisCalibrationInfo(
        from_acc_unit="a.u.",
        from_gyr_unit="a.u.",
        K_a=k_a,
        R_a=r_a,
        b_a=np.array([3.0, -2.0, 5.0]),
        K_g=np.eye(3),
        R_g=np.eye(3),
        K_ga=np.zeros((3, 3)),
        b_g=np.zeros(3),
    )
    path = tmp_path / "theirs.json"
    info.to_json_file(path)
    cal = read_imucal(path)
    raw = np.array([[3.0, -2.0, 985.0], [984.0, -2.0, 5.0], [50.0, 60.0, -900.0]])
    theirs, _ = info.calibrate(raw, np.zeros_like(raw), acc_unit="a.u.", gyr_unit="a.u.")
    ours = cal.compensate(raw, np.full(3, 25.0))
    np.testing.assert_allclose(ours * G0, theirs, rtol=1e-12, atol=1e-12)


def write_json(path: Path, doc: Any) -> Path:
    path.write_text(json.dumps(doc))
    return path


def test_read_imucal_errors(tmp_path: Path) -> None:
    good = export_imucal(tilted_cal()).to_dict()
    bad_json = tmp_path / "bad.json"
    bad_json.write_text('{\n  "cal_type": "Ferraris",\n  oops\n}')
    with pytest.raises(CalibrationFileError, match=r"bad\.json:3:3"):
        read_imucal(bad_json)
    with pytest.raises(CalibrationFileError, match="cal_type"):
        read_imucal(write_json(tmp_path / "t.json", {**good, "cal_type": "Magic"}))
    with pytest.raises(CalibrationFileError, match="format version"):
        read_imucal(write_json(tmp_path / "v.json", {**good, "_format_version": "1.0.0"}))
    with pytest.raises(CalibrationFileError, match="K_a has shape"):
        read_imucal(write_json(tmp_path / "k.json", {**good, "K_a": [1, 2, 3]}))
    singular = {**good, "R_a": [[1, 0, 0], [1, 0, 0], [0, 0, 1]]}
    with pytest.raises(CalibrationFileError, match="singular"):
        read_imucal(write_json(tmp_path / "s.json", singular))


def test_imucal_export_outside_the_calibrated_range_warns() -> None:
    """Held at 500 °C of a -2…65 °C calibration: said, not written in silence."""
    cal = dataclasses.replace(tilted_cal(), temperature_range_c=(-2.0, 65.0))
    with pytest.warns(TemperatureRangeWarning, match=r"500 °C, outside the calibrated range"):
        export_imucal(cal, temperature_c=500.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", TemperatureRangeWarning)
        export_imucal(cal, temperature_c=40.0)
    with pytest.raises(ParameterError, match="finite"):
        export_imucal(cal, temperature_c=math.nan)
