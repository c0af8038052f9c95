"""The session simulator: file format, truth, determinism, quantisation, profile, effects."""

from __future__ import annotations

import os
import sys
import tomllib
import types
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import numpy as np
import pytest

try:  # the package __init__ needs the compiled extension ...
    import accelcore  # noqa: F401
except ImportError:  # ... but the modules under test are pure Python: load them without it
    _stub = types.ModuleType("accelcore")
    _stub.__path__ = [str(Path(__file__).resolve().parents[1] / "python" / "accelcore")]
    sys.modules["accelcore"] = _stub

from accelcore import datasheets, paper, simulate
from accelcore.simulate import RunState, SensorTruth, Stage

FloatArray = np.ndarray[tuple[int, ...], np.dtype[np.float64]]


class Short(TypedDict):
    duration_h: float
    soak_min: float


SHORT: Short = {"duration_h": 0.1, "soak_min": 1.0}  # 7200 rows per run at 20 Hz
NI9220_LSB_V = 20.0 / 65536.0


def read_log(path: Path) -> tuple[list[str], FloatArray]:
    with path.open(encoding="ascii") as fh:
        header = fh.readline().rstrip("\n").split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64)
    return header, data


# --------------------------------------------------------------------------- format


def test_session_folder_follows_the_format(tmp_path: Path) -> None:
    sim = simulate.session(tmp_path / "s", "ADXL335", serial="A-0017", **SHORT)
    meta = tomllib.loads((tmp_path / "s" / "session.toml").read_text(encoding="utf-8"))
    assert meta["format"] == "accelcore-session/1"
    assert meta["sensor"] == "ADXL335"
    assert meta["serial"] == "A-0017"
    assert meta["units"] == "V"
    assert meta["rate_hz"] == 20.0
    assert meta["delimiter"] == ","
    assert meta["time_unit"] == "s"
    assert meta["columns"] == {
        "time": "time_s",
        "temperature": "temp_c",
        "x": "x",
        "y": "y",
        "z": "z",
    }
    runs = meta["run"]
    assert [r["orientation"] for r in runs] == ["OX+", "OX-", "OY+", "OY-", "OZ+", "OZ-"]
    assert [r["file"] for r in runs] == [r.file for r in sim.runs]
    assert set(meta) <= {
        "format",
        "sensor",
        "serial",
        "units",
        "rate_hz",
        "delimiter",
        "time_unit",
        "columns",
        "run",
    }
    for run in runs:
        header, data = read_log(tmp_path / "s" / run["file"])
        assert header == ["time_s", "temp_c", "x", "y", "z"]
        assert data.shape == (7200, 5)
        assert np.all(np.isfinite(data))
        np.testing.assert_allclose(data[:, 0], np.arange(7200) * 0.05, atol=1e-9)
    assert sim.path == tmp_path / "s"
    assert all(r.n_samples == 7200 for r in sim.runs)


def test_first_rows_look_like_the_format_example(tmp_path: Path) -> None:
    simulate.session(tmp_path, "ADXL335", orientations=("OZ+",), **SHORT)
    lines = (tmp_path / "z_pos.csv").read_text(encoding="ascii").splitlines()
    assert lines[0] == "time_s,temp_c,x,y,z"
    time_s, temp_c, *xyz = lines[1].split(",")
    assert time_s == "0.00"
    assert len(temp_c.split(".")[1]) == 3
    assert all(len(v.split(".")[1]) == 6 for v in xyz)


def test_mpu_session_writes_integer_counts(tmp_path: Path) -> None:
    sim = simulate.session(tmp_path, "mpu9255", orientations=("OZ+", "OZ-"), **SHORT)
    meta = tomllib.loads((tmp_path / "session.toml").read_text(encoding="utf-8"))
    assert meta["units"] == "LSB"
    assert meta["sensor"] == "MPU-9255"
    assert "serial" not in meta
    for run in sim.runs:
        text = (tmp_path / run.file).read_text(encoding="ascii").splitlines()[1]
        assert all("." not in v for v in text.split(",")[2:])
        _, data = read_log(tmp_path / run.file)
        assert np.array_equal(data[:, 2:], np.rint(data[:, 2:]))
        assert data[:, 2:].min() >= -32768
        assert data[:, 2:].max() <= 32767
    assert sim.quantum == 1.0


def test_truth_file_is_written_beside_the_session(tmp_path: Path) -> None:
    sim = simulate.session(tmp_path, "ADXL327", seed=7, **SHORT)
    truth = tomllib.loads((tmp_path / "truth.toml").read_text(encoding="utf-8"))
    assert truth["seed"] == 7
    assert truth["sensitivity_per_g"] == list(sim.truth.sensitivity_per_g)
    assert truth["offset_tc_mg_per_c"] == [-0.344, 0.463, -2.164]
    assert truth["effects"] == ["probe_noise", "linear_tempco", "white_noise"]
    simulate.session(tmp_path / "no_truth", "ADXL327", write_truth=False, **SHORT)
    assert not (tmp_path / "no_truth" / "truth.toml").exists()


def test_extra_columns_and_repeated_orientations(tmp_path: Path) -> None:
    sim = simulate.session(
        tmp_path,
        "LIS344ALH",
        orientations=("OZ+", "OZ+", "OZ-"),
        extra_columns=("supply_v", "die_temp_c"),
        **SHORT,
    )
    assert [r.file for r in sim.runs] == ["z_pos.csv", "z_pos_2.csv", "z_neg.csv"]
    header, data = read_log(tmp_path / "z_pos_2.csv")
    assert header == ["time_s", "temp_c", "x", "y", "z", "supply_v", "die_temp_c"]
    assert abs(data[:, 5].mean() - 3.0) < 1e-3
    assert np.all(np.abs(data[:, 6] - data[:, 1]) < 0.2)  # die vs probe: probe noise only
    _, first = read_log(tmp_path / "z_pos.csv")
    assert not np.array_equal(first[:, 2:5], data[:, 2:5])  # repeats get their own noise


# --------------------------------------------------------------------------- truth


@pytest.mark.parametrize("sensor", ["ADXL335", "ADXL327", "LIS344ALH", "MPU-9255"])
def test_default_truth_is_the_papers_measured_part(sensor: str) -> None:
    ref = datasheets.measured(sensor)
    truth = simulate.arrays(sensor, orientations=("OZ+",), duration_h=0.01, soak_min=0).truth
    assert truth.units == ref.units
    assert truth.reference_temperature_c == 25.0
    assert tuple(truth.zero_g_offset) == ref.zero_g_offset.as_tuple()
    assert tuple(truth.sensitivity_per_g) == ref.sensitivity.as_tuple()
    assert tuple(truth.offset_tc_mg_per_c) == ref.offset_tc_mg_per_c.as_tuple()
    assert tuple(truth.sensitivity_tc_pct_per_c) == ref.sensitivity_tc_pct_per_c.as_tuple()


def test_truth_model_in_output_units() -> None:
    truth = SensorTruth.from_paper("MPU-9255")
    # Table 6 X: 0.783 mg/°C at 16313 LSB/g = 12.773 LSB/°C.
    assert truth.offset_tc_per_c[0] == pytest.approx(0.783e-3 * 16313.0)
    t = np.array([25.0, 60.0])
    off = truth.zero_g_offset_at(t)
    sens = truth.sensitivity_at(t)
    assert off.shape == sens.shape == (2, 3)
    np.testing.assert_allclose(off[0], [-220.0, 89.0, 128.0])
    np.testing.assert_allclose(sens[1], [16313.0, 16365.0 * (1 - 0.004e-2 * 35), 16592.0 * 0.9958])
    with pytest.raises(ValueError, match="read-only"):
        truth.zero_g_offset[0] = 0.0


def test_sensor_truth_validation() -> None:
    ok = SensorTruth("V", 1.5, 0.3, 0.0, 0.0)
    np.testing.assert_array_equal(ok.sensitivity_per_g, [0.3, 0.3, 0.3])
    with pytest.raises(ValueError, match="units"):
        SensorTruth("mV", 1.5, 0.3, 0.0, 0.0)
    with pytest.raises(ValueError, match="one value per axis"):
        SensorTruth("V", [1.5, 1.5], 0.3, 0.0, 0.0)
    with pytest.raises(ValueError, match="non-zero"):
        SensorTruth("V", 1.5, [0.3, 0.0, 0.3], 0.0, 0.0)
    with pytest.raises(ValueError, match="finite"):
        SensorTruth("V", 1.5, 0.3, float("nan"), 0.0)


def test_noiseless_output_is_the_linear_model_on_the_adc_grid() -> None:
    sim = simulate.arrays("ADXL335", orientations=("OZ-",), noise_g=0.0, probe_noise_c=0.0, **SHORT)
    run = sim.runs[0]
    t = run.die_temp_c
    np.testing.assert_allclose(run.columns["temp_c"], t, rtol=0, atol=0.5e-3)  # 1 m°C print
    truth = sim.truth
    expected = truth.zero_g_offset_at(t) + truth.sensitivity_at(t) * np.array([0.0, 0.0, -1.0])
    for i, axis in enumerate("xyz"):
        assert np.max(np.abs(run.columns[axis] - expected[:, i])) <= NI9220_LSB_V / 2 + 1e-15
    # ADXL335 Z at -1 g: V(T) = 1.541 - 0.305 = 1.236 V at 25 °C, and drifts by
    # (-3.602 mg/°C * 0.305 V/g) - 0.305 * (-0.012 %/°C) per °C.
    z25 = paper.zero_g_offset_at(25.0, 1.541, -3.602, 0.305) - paper.sensitivity_at(
        25.0, 0.305, -0.012
    )
    assert z25 == pytest.approx(1.236)


def test_paper_method_recovers_the_truth_from_the_simulated_runs() -> None:
    # Eq. (8)/(10) per sample on the OZ+/OZ- pair, then a line against the logged
    # temperature, as the paper does: the tempcos come back as Tables 5 and 6.
    sim = simulate.arrays("ADXL335", orientations=("OZ+", "OZ-"), duration_h=1.0, seed=3)
    pos, neg = sim.runs
    t = 0.5 * (pos.columns["temp_c"] + neg.columns["temp_c"])
    s = paper.sensitivity_from_pair(pos.columns["z"], neg.columns["z"])
    v0 = paper.zero_g_offset_from_pair(pos.columns["z"], neg.columns["z"])
    s_slope, s_25 = np.polyfit(t - 25.0, s, 1)
    v0_slope, v0_25 = np.polyfit(t - 25.0, v0, 1)
    assert s_25 == pytest.approx(0.305, abs=2e-5)
    assert v0_25 == pytest.approx(1.541, abs=2e-5)
    assert paper.offset_tc_to_mg_per_c(v0_slope, s_25) == pytest.approx(-3.602, abs=0.01)
    assert paper.sensitivity_tc_to_pct_per_c(s_slope, s_25) == pytest.approx(-0.012, abs=0.001)


def test_custom_params_and_clipping() -> None:
    truth = SensorTruth("LSB", [40000.0, 0.0, -40000.0], 16384.0, 0.0, 0.0)
    sim = simulate.arrays(
        "MPU-9255", orientations=("OY+",), params=truth, noise_g=0.0, probe_noise_c=0.0, **SHORT
    )
    cols = sim.runs[0].columns
    assert np.all(cols["x"] == 32767.0)
    assert np.all(cols["y"] == 16384.0)
    assert np.all(cols["z"] == -32768.0)
    assert sim.truth is truth
    with pytest.raises(ValueError, match="params are in V"):
        simulate.arrays("MPU-9255", params=SensorTruth("V", 1.5, 0.3, 0.0, 0.0), **SHORT)


# --------------------------------------------------------------------------- noise, quantisation


def test_default_noise_from_the_noise_density() -> None:
    x, y, z = simulate.default_noise_g("ADXL335")
    assert x == y == pytest.approx(150e-6 * np.sqrt(1.6 * 50.0))  # 1.34 mg
    assert z == pytest.approx(300e-6 * np.sqrt(1.6 * 50.0))
    assert simulate.default_noise_g("LIS344ALH")[0] == pytest.approx(50e-6 * np.sqrt(80.0))
    assert simulate.default_noise_g("MPU-9255", bandwidth_hz=20.0)[2] == pytest.approx(
        300e-6 * np.sqrt(32.0)
    )


def test_noise_level_in_the_output() -> None:
    sim = simulate.arrays("ADXL335", orientations=("OZ+",), t_start_c=25.0, t_end_c=25.0, **SHORT)
    z_mg = (sim.runs[0].columns["z"] - 1.541 - 0.305) / 0.305 * 1000.0
    expected = np.hypot(sim.noise_g[2] * 1000.0, NI9220_LSB_V / np.sqrt(12) / 0.305 * 1000.0)
    assert z_mg.std() == pytest.approx(expected, rel=0.05)


def test_analog_values_are_on_the_ni9220_grid(tmp_path: Path) -> None:
    sim = simulate.session(tmp_path, "ADXL327", orientations=("OX+",), **SHORT)
    assert sim.quantum == NI9220_LSB_V
    _, data = read_log(tmp_path / "x_pos.csv")
    codes = data[:, 2:5] / NI9220_LSB_V
    # %.6f rounds by at most 5e-7 V = 0.0016 LSB: printing never hides the grid.
    assert np.max(np.abs(codes - np.rint(codes))) < 0.002
    coarse = simulate.arrays("ADXL327", orientations=("OX+",), adc_bits=12, **SHORT)
    step = 20.0 / 4096.0
    x = coarse.runs[0].columns["x"] / step
    np.testing.assert_allclose(x, np.rint(x), atol=1e-9)


# --------------------------------------------------------------------------- temperature profile


def test_temperature_profile_soaks_then_ramps() -> None:
    sim = simulate.arrays("ADXL335", orientations=("OZ+",), duration_h=1.0, soak_min=10.0)
    run = sim.runs[0]
    t, temp = run.columns["time_s"], run.columns["temp_c"]
    soak = t < 600.0
    assert temp[soak].mean() == pytest.approx(-2.0, abs=0.005)
    assert temp[soak].std() == pytest.approx(0.02, rel=0.1)  # probe noise
    ramp = t >= 600.0
    slope, intercept = np.polyfit(t[ramp], temp[ramp], 1)
    assert slope == pytest.approx(67.0 / (t[-1] - 600.0), rel=1e-3)
    assert intercept + slope * 600.0 == pytest.approx(-2.0, abs=0.01)
    assert run.die_temp_c[-1] == pytest.approx(65.0)
    assert np.all(np.diff(run.die_temp_c) >= 0.0)


def test_temperature_profile_cool_back() -> None:
    time_s = np.arange(0.0, 3600.0, 0.5)
    temp = simulate.temperature_profile(
        time_s, t_start_c=0.0, t_end_c=60.0, soak_s=600.0, cool_back=True
    )
    peak = int(np.argmax(temp))
    assert temp[peak] == pytest.approx(60.0, abs=0.05)
    assert time_s[peak] == pytest.approx(600.0 + (time_s[-1] - 600.0) / 2, abs=0.5)
    assert temp[-1] == pytest.approx(0.0)
    assert np.all(temp[time_s <= 600.0] == 0.0)
    assert np.all(np.diff(temp[peak:]) <= 0.0)


# --------------------------------------------------------------------------- determinism


def test_same_seed_same_files_other_seed_other_files(tmp_path: Path) -> None:
    a = simulate.session(tmp_path / "a", "ADXL335", seed=11, **SHORT)
    b = simulate.session(tmp_path / "b", "ADXL335", seed=11, **SHORT)
    c = simulate.session(tmp_path / "c", "ADXL335", seed=12, **SHORT)
    for ra, rb, rc in zip(a.runs, b.runs, c.runs, strict=True):
        text_a = (a.path / ra.file).read_bytes()
        assert text_a == (b.path / rb.file).read_bytes()
        assert text_a != (c.path / rc.file).read_bytes()


def test_arrays_hold_what_session_writes(tmp_path: Path) -> None:
    orientations, extra = ("OY-", "OZ+"), ("supply_v",)
    written = simulate.session(
        tmp_path, "ADXL335", seed=5, orientations=orientations, extra_columns=extra, **SHORT
    )
    memory = simulate.arrays(
        "ADXL335", seed=5, orientations=orientations, extra_columns=extra, **SHORT
    )
    assert written.effects == memory.effects == ("probe_noise", "linear_tempco", "white_noise")
    for run_file, run in zip(written.runs, memory.runs, strict=True):
        assert run_file.file == run.file
        header, data = read_log(tmp_path / run.file)
        assert header == list(run.columns)
        for i, name in enumerate(header):
            np.testing.assert_allclose(data[:, i], run.columns[name], rtol=0, atol=5.1e-7)


# --------------------------------------------------------------------------- effects hook


@dataclass(frozen=True)
class DieOffset:
    """Test effect: the die runs warmer than the chamber by a constant."""

    delta_c: float

    @property
    def name(self) -> str:
        return "die_offset"

    @property
    def stage(self) -> Stage:
        return "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        state.die_temp_c = state.die_temp_c + self.delta_c


@dataclass(frozen=True)
class Step:
    """Test effect: a constant step on the output."""

    volts: float

    @property
    def name(self) -> str:
        return "step"

    @property
    def stage(self) -> Stage:
        return "output"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        state.output = state.output + self.volts


def test_effects_run_in_stage_order_and_are_recorded() -> None:
    base = simulate.arrays(
        "ADXL335", orientations=("OZ+",), noise_g=0.0, probe_noise_c=0.0, **SHORT
    )
    shifted = simulate.arrays(
        "ADXL335",
        orientations=("OZ+",),
        noise_g=0.0,
        probe_noise_c=0.0,
        effects=(Step(0.01), DieOffset(10.0)),
        **SHORT,
    )
    assert shifted.effects == ("probe_noise", "die_offset", "linear_tempco", "white_noise", "step")
    b, s = base.runs[0], shifted.runs[0]
    np.testing.assert_array_equal(s.columns["temp_c"], b.columns["temp_c"])  # probe unchanged
    np.testing.assert_allclose(s.die_temp_c, b.die_temp_c + 10.0)
    # The die offset acts through the linear model before the step is added.
    truth = shifted.truth
    expected_z = (
        truth.zero_g_offset_at(s.die_temp_c)[:, 2] + truth.sensitivity_at(s.die_temp_c)[:, 2]
    )
    np.testing.assert_allclose(s.columns["z"], expected_z + 0.01, atol=NI9220_LSB_V / 2 + 1e-12)


def test_not_an_effect_is_rejected() -> None:
    with pytest.raises(TypeError, match="not an Effect"):
        simulate.arrays("ADXL335", effects=(object(),), **SHORT)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- arguments


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"orientations": ("OZ",)}, "unknown orientation"),
        ({"orientations": ()}, "at least one orientation"),
        ({"soak_min": 6.0}, "soak_min"),
        ({"rate_hz": 0.0}, "rate_hz"),
        ({"duration_h": float("nan")}, "duration_h"),
        ({"noise_g": -1e-3}, "noise_g"),
        ({"noise_g": (1e-3, 1e-3)}, "one value per axis"),
        ({"adc_bits": 40}, "adc_bits"),
        ({"extra_columns": ("humidity",)}, "unknown extra column"),
        ({"seed": -1}, "seed"),
    ],
)
def test_bad_arguments(kwargs: dict[str, object], message: str) -> None:
    args: dict[str, object] = {"duration_h": 0.1, "soak_min": 1.0, **kwargs}
    with pytest.raises(ValueError, match=message):
        simulate.arrays("ADXL335", **args)  # type: ignore[arg-type]


def test_unknown_sensor_and_non_empty_folder(tmp_path: Path) -> None:
    with pytest.raises(datasheets.DatasheetError, match="unknown sensor"):
        simulate.arrays("ADXL999", **SHORT)
    simulate.session(tmp_path, "ADXL335", orientations=("OZ+",), **SHORT)
    with pytest.raises(FileExistsError, match="not empty"):
        simulate.session(tmp_path, "ADXL335", orientations=("OZ+",), **SHORT)
    again = simulate.session(tmp_path, "ADXL335", orientations=("OZ-",), overwrite=True, **SHORT)
    assert [r.file for r in again.runs] == ["z_neg.csv"]


# --------------------------------------------------------------------------- size and speed


def test_full_size_session(tmp_path: Path) -> None:
    # The default: 6 runs of 2 h at 20 Hz = 144,000 rows each.
    sim = simulate.session(tmp_path, "ADXL335")
    assert [r.n_samples for r in sim.runs] == [144_000] * 6
    with (tmp_path / "z_neg.csv").open(encoding="ascii") as fh:
        assert sum(1 for _ in fh) == 144_001


def test_overwrite_never_writes_through_a_link(tmp_path: Path) -> None:
    """--overwrite into a folder whose files link elsewhere: the links go, not their targets."""
    folder = tmp_path / "s"
    simulate.session(folder, "ADXL335", seed=1, duration_h=0.02, soak_min=0.2)
    outside = tmp_path / "precious.csv"
    outside.write_text("keep me\n")
    hard = tmp_path / "hard.toml"
    hard.write_text("keep me too\n")
    (folder / "x_pos.csv").unlink()
    (folder / "x_pos.csv").symlink_to(outside)
    (folder / "session.toml").unlink()
    os.link(hard, folder / "session.toml")
    simulate.session(folder, "ADXL335", seed=2, duration_h=0.02, soak_min=0.2, overwrite=True)
    assert outside.read_text() == "keep me\n" and hard.read_text() == "keep me too\n"
    assert not (folder / "x_pos.csv").is_symlink()
    assert (folder / "session.toml").stat().st_nlink == 1
