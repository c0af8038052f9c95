"""Defaults that fit real logs, and inputs without temperature, in mg, at local gravity, by index.

Issue 16, items 3 and 4: the decimation factor follows ``rate_hz``; the default
temperature window is the logged range; a session may log no temperature (then
the calibration is at one temperature and says so); units ``mg``; a local
gravity; a time column that counts samples. Sessions are simulated, and the
tofupilot thermal cycle is read from ``../shared/realdata`` when it is there.
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

import accelcore
from accelcore import simulate
from accelcore.apps.cli import main
from accelcore.constants import STANDARD_GRAVITY
from accelcore.errors import TemperatureRangeWarning
from accelcore.input.format import gravity_of
from accelcore.input.session import default_decimation_factor
from accelcore.model import full_gain_terms
from accelcore.outputs.exports import export_imucal, export_px4

FloatArray = NDArray[np.float64]


def _arrays_session(
    sim: simulate.SimulatedArrays,
    *,
    drop: tuple[str, ...] = (),
    scale: float = 1.0,
    units: str | None = None,
    **options: object,
) -> accelcore.Session:
    """Session.from_arrays of a simulated session, some columns left out, outputs scaled."""
    runs = []
    for r in sim.runs:
        cols = {k: v for k, v in r.columns.items() if k not in drop}
        for a in ("x", "y", "z"):
            cols[a] = np.asarray(r.columns[a]) * scale
        runs.append((r.orientation, cols))
    return accelcore.Session.from_arrays(
        runs,
        units=units or sim.units,
        rate_hz=sim.rate_hz,
        sensor=sim.sensor,
        **options,  # type: ignore[arg-type]
    )


def _raw(sim: simulate.SimulatedArrays, i: int) -> FloatArray:
    return np.column_stack([np.asarray(sim.runs[i].columns[a]) for a in ("x", "y", "z")])


# ------------------------------------------------------------------ decimation follows the rate


@pytest.mark.parametrize(
    ("rate_hz", "factor"), [(20.0, 10), (1.98, 1), (2.0, 1), (0.5, 1), (100.0, 50), (7.0, 4)]
)
def test_default_factor_gives_blocks_of_half_a_second(rate_hz: float, factor: int) -> None:
    assert default_decimation_factor(rate_hz) == factor


def test_a_rate_beyond_any_logger_is_refused() -> None:
    with pytest.raises(accelcore.ParameterError, match=r"rate_hz .*samples per block") as info:
        default_decimation_factor(1.8e19)
    assert info.value.parameter == "rate_hz"


def test_from_arrays_decimates_by_the_rate_unless_told(tmp_path: Path) -> None:
    sim = simulate.arrays(
        "ADXL335", seed=7, duration_h=0.05, soak_min=1.0, orientations=("OZ+",), rate_hz=4.0
    )
    s = _arrays_session(sim)
    assert s.decimation_factor == 2
    n_raw = len(sim.runs[0].columns["x"])
    assert len(s.runs[0]) == pytest.approx(n_raw / 2, abs=1)
    assert _arrays_session(sim, decimation_factor=1).decimation_factor == 1


def test_load_session_decimates_by_the_rate(tmp_path: Path) -> None:
    folder = tmp_path / "slow"
    simulate.session(folder, seed=8, duration_h=0.05, soak_min=0.5, rate_hz=2.0)
    s = accelcore.load_session(folder, cache=False)
    assert s.decimation_factor == 1
    assert accelcore.load_session(folder, cache=False, decimation_factor=2).decimation_factor == 2
    with pytest.raises(accelcore.ParameterError, match="min_count"):
        accelcore.load_session(folder, cache=False, min_count=2)  # > the default factor 1


# ------------------------------------------------------------------ window = the logged range


@pytest.fixture(scope="module")
def cold() -> simulate.SimulatedArrays:
    """A cold-chamber sweep, -40 → -10 °C: nothing of it in the seed paper's 0–60 °C."""
    return simulate.arrays("ADXL335", seed=21, duration_h=0.3, t_start_c=-40.0, t_end_c=-10.0)


@pytest.mark.parametrize("method", ["joint", "paper"])
def test_a_cold_chamber_log_calibrates_by_default(
    cold: simulate.SimulatedArrays, method: str
) -> None:
    s = _arrays_session(cold)
    cal = accelcore.calibrate(s, method)  # type: ignore[arg-type]
    lo, hi = cal.temperature_range_c
    assert -40.5 <= lo < -38.0 and -12.0 < hi <= -9.5
    assert cal.window_c == (-math.inf, math.inf)
    assert any("outside the fitted range" in n for n in cal.notes)  # T_ref 25 °C, 35 °C away
    with pytest.raises(accelcore.InsufficientDataError, match="no decimated sample"):
        accelcore.calibrate(s, window_c=(0.0, 60.0))
    within = accelcore.calibrate(s, t_ref_c=-25.0)
    assert not any("outside the fitted range" in n for n in within.notes)


def test_quality_checks_the_logged_range_by_default(cold: simulate.SimulatedArrays) -> None:
    from accelcore.input.quality import check_session

    s = _arrays_session(cold)
    assert [i.kind for i in check_session(s, warn=False)] == []
    coverage = [i for i in check_session(s, warn=False, window_c=(0.0, 60.0))]
    assert [i.kind for i in coverage][:1] == ["temperature"]


# ------------------------------------------------------------------ no temperature logged


@pytest.fixture(scope="module")
def flat() -> simulate.SimulatedArrays:
    """Six positions at room temperature (imucal's job), the temperature not logged."""
    return simulate.arrays(
        "ADXL335", seed=31, duration_h=0.1, soak_min=1.0, t_start_c=25.0, t_end_c=25.0
    )


def test_no_temperature_calibrates_at_one_temperature(flat: simulate.SimulatedArrays) -> None:
    s = _arrays_session(flat, drop=("temp_c",))
    assert not s.has_temperature
    assert all(np.isnan(r.temperature_c).all() for r in s.runs)
    cal = accelcore.calibrate(s)
    assert not cal.has_temperature
    assert all(math.isnan(v) for v in cal.temperature_range_c)
    assert cal.notes[0].startswith("no temperature logged: calibration at one temperature")
    for a in ("x", "y", "z"):
        assert f"{a}:offset_tc" in cal.not_identified
        assert f"{a}:sensitivity_tc" in cal.not_identified
        assert all(t.basis.temperature_order is None for t in cal.axes[a].terms)
        assert math.isnan(cal.axis(a).offset_tc_mg_per_c)
    truth = flat.truth
    for i, a in enumerate(("x", "y", "z")):
        assert cal.axis(a).sensitivity == pytest.approx(truth.sensitivity_per_g[i], rel=2e-3)
    for i, run in enumerate(flat.runs):
        g = cal.compensate(_raw(flat, i), None)
        expected = gravity_of(run.orientation)
        assert np.allclose(np.nanmean(g, axis=0), expected, atol=3e-3)
    with pytest.raises(accelcore.InsufficientDataError, match="no temperature logged"):
        accelcore.calibrate(s, "paper")
    with pytest.raises(accelcore.ParameterError, match="window_c"):
        accelcore.calibrate(s, window_c=(0.0, 60.0))


def test_compensate_without_temperature_needs_a_model_without_temperature_terms(
    flat: simulate.SimulatedArrays,
) -> None:
    # A steady 25 °C: the default fits no temperature term, so they are asked for.
    with_temp = accelcore.calibrate(
        _arrays_session(flat), terms={a: full_gain_terms(a) for a in "xyz"}
    )
    with pytest.raises(accelcore.ParameterError, match=r"temp_c is None.*dT\^1") as info:
        with_temp.compensate(_raw(flat, 0), None)
    assert info.value.parameter == "temp_c"


def test_a_temperature_that_does_not_move_gets_no_temperature_term(
    flat: simulate.SimulatedArrays,
) -> None:
    """Below 1 °C of span (5th-95th percentile) the default calibration is at one
    temperature: no offset or sensitivity tempco, said in the notes. Here the z-up
    hold is logged twice, re-placed 0.3 °C warmer with 50 mg more on x (a re-seat);
    fitted anyway, x's offset tempco takes the re-seat for temperature (50 mg over
    0.3 °C: ~170 mg/°C, the size a real two-placement MPU6050 log gave; another
    session 5 °C away would be off by most of a g)."""
    runs = []
    for r in flat.runs:
        cols = dict(r.columns)
        runs.append((r.orientation, cols))
        if r.orientation == "OZ+":
            again = {k: np.asarray(v).copy() for k, v in cols.items()}
            again["temp_c"] = again["temp_c"] + 0.3
            again["x"] = again["x"] + 0.050 * flat.truth.sensitivity_per_g[0]
            runs.append(("OZ+", again))
    session = accelcore.Session.from_arrays(runs, units=flat.units, rate_hz=flat.rate_hz)
    cal = accelcore.calibrate(session)
    assert not any(t.basis.temperature_order for m in cal.axes.values() for t in m.terms)
    assert {"x:offset_tc", "x:sensitivity_tc"} <= set(cal.not_identified)
    assert any("less than 1 °C: calibration at one temperature" in n for n in cal.notes)
    # Nothing in this model reads the temperature: compensating 10 °C away extrapolates
    # nothing and is not warned of (the real log's own samples were: 13107 of 45544
    # lay past the block means' range, by the thermometer's 0.094 °C steps).
    raw = _raw(flat, 0)
    temp = np.asarray(flat.runs[0].columns["temp_c"]) + 10.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", TemperatureRangeWarning)
        cal.compensate(raw, temp)
    forced = accelcore.calibrate(session, terms={a: full_gain_terms(a) for a in "xyz"})
    with pytest.warns(TemperatureRangeWarning, match="outside the calibrated range"):
        forced.compensate(raw, temp)
    tc = float(np.asarray(forced.summary()["offset_tc_mg_per_c"], dtype=float)[0])  # x
    assert abs(tc) > 100.0, tc  # 50 mg / 0.3 °C, less what the other runs pull back


def test_a_cross_gain_held_for_want_of_the_opposite_run_is_said(
    flat: simulate.SimulatedArrays,
) -> None:
    """One orientation per axis (OZ+, OX-, OY+; a real MPU6050 log, real22): z's offset,
    sensitivity and two cross gains are four unknowns for three runs. The gain held at
    0 is not identified, and the note says that z's offset then takes what z reads in
    that gain's run (a 4° tilt there moved z's sensitivity by 7 %, 80 standard errors,
    with nothing said)."""
    runs = [
        (r.orientation, dict(r.columns))
        for r in flat.runs
        if r.orientation in ("OZ+", "OX-", "OY+")
    ]
    cal = accelcore.calibrate(
        accelcore.Session.from_arrays(runs, units=flat.units, rate_hz=flat.rate_hz)
    )
    held = [n for n in cal.not_identified if n.startswith("z:gain[")]
    assert len(held) == 1, cal.not_identified
    source = held[0][len("z:gain[")]
    said = [n for n in cal.notes if n.startswith(f"z: gain[{source}]·1 held at 0")]
    assert len(said) == 1 and f"log O{source.upper()}+ and O{source.upper()}-" in said[0], cal.notes
    # No temperature term (a steady 25 °C): no word of T_ref outside the range.
    assert not any("T_ref" in n for n in cal.notes), cal.notes


def test_no_temperature_round_trips_through_the_file(
    flat: simulate.SimulatedArrays, tmp_path: Path
) -> None:
    cal = accelcore.calibrate(_arrays_session(flat, drop=("temp_c",)))
    cal.save(tmp_path / "cal.json")
    loaded = accelcore.Calibration.load(tmp_path / "cal.json")
    assert not loaded.has_temperature and loaded.not_identified == cal.not_identified
    raw = _raw(flat, 2)
    assert np.array_equal(loaded.compensate(raw, None), cal.compensate(raw, None))
    # imucal holds a calibration at one temperature: the natural export of this one.
    assert np.all(np.isfinite(export_imucal(loaded).b_a))


def test_runs_agree_on_whether_temperature_was_logged(flat: simulate.SimulatedArrays) -> None:
    runs = [(r.orientation, dict(r.columns)) for r in flat.runs[:2]]
    del runs[1][1]["temp_c"]
    with pytest.raises(accelcore.SessionFormatError, match=r"run 2 .*not logged here"):
        accelcore.Session.from_arrays(runs, units="V", rate_hz=flat.rate_hz)


def _rewrite_toml(folder: Path, old: str, new: str) -> None:
    toml = folder / "session.toml"
    text = toml.read_text()
    assert old in text
    toml.write_text(text.replace(old, new))


def test_session_toml_without_temperature(tmp_path: Path) -> None:
    folder = tmp_path / "no_temp"
    simulate.session(folder, seed=32, duration_h=0.05, soak_min=0.5, t_start_c=25, t_end_c=25)
    _rewrite_toml(folder, 'temperature = "temp_c"', 'temperature = ""')
    s = accelcore.load_session(folder, cache=False)
    assert not s.has_temperature and s.format is not None and not s.format.has_temperature
    assert all(np.isnan(r.temperature_c).all() for r in s.runs)
    assert "temp_c" in s.extra_columns  # the unused column is kept as an observable
    cal = accelcore.calibrate(s)
    assert "z:offset_tc" in cal.not_identified


# ------------------------------------------------------------------ mg, local gravity


def test_units_mg(flat: simulate.SimulatedArrays) -> None:
    in_g = accelcore.calibrate(_arrays_session(flat), window_c=(0.0, 60.0))
    # The same part read as acceleration: a session in g and one in mg.
    sens = np.array([in_g.axis(a).sensitivity for a in ("x", "y", "z")])
    offs = np.array([in_g.axis(a).zero_g_offset for a in ("x", "y", "z")])
    runs_g, runs_mg = [], []
    for r in flat.runs:
        cols = dict(r.columns)
        raw = np.column_stack([cols[a] for a in ("x", "y", "z")])
        acc = (raw - offs) / sens
        runs_g.append((r.orientation, {**cols, **dict(zip("xyz", acc.T, strict=True))}))
        runs_mg.append((r.orientation, {**cols, **dict(zip("xyz", 1000.0 * acc.T, strict=True))}))
    cal_g = accelcore.calibrate(accelcore.Session.from_arrays(runs_g, units="g", rate_hz=20.0))
    session_mg = accelcore.Session.from_arrays(runs_mg, units="mg", rate_hz=20.0)
    cal_mg = accelcore.calibrate(session_mg)
    assert cal_mg.units == "mg"
    for a in ("x", "y", "z"):
        assert cal_mg.axis(a).sensitivity == pytest.approx(1000.0 * cal_g.axis(a).sensitivity)
    raw_mg = np.column_stack([runs_mg[0][1][a] for a in ("x", "y", "z")])
    raw_g = raw_mg / 1000.0
    temp = np.clip(runs_mg[0][1]["temp_c"], *cal_mg.temperature_range_c)
    assert np.allclose(cal_mg.compensate(raw_mg, temp), cal_g.compensate(raw_g, temp), atol=1e-9)
    # Exports are in m/s²: the same numbers whatever the session's units.
    px4_g, px4_mg = export_px4(cal_g), export_px4(cal_mg)
    for name, (value, _) in px4_g.params.items():
        if "_X" in name:
            assert px4_mg.params[name][0] == pytest.approx(value, rel=1e-6, abs=1e-9), name
    assert np.allclose(export_imucal(cal_mg).b_a / 1000.0, export_imucal(cal_g).b_a)
    with pytest.raises(accelcore.SessionFormatError, match=r"mg per g.*units"):
        # Data in g declared as mg: 1000 times off.
        accelcore.calibrate(accelcore.Session.from_arrays(runs_g, units="mg", rate_hz=20.0))


def _one_orientation_m_s2(gravity: float) -> list[tuple[str, dict[str, FloatArray]]]:
    """A board lying still in m/s2 (the flight stacks' case): 1 g reads the local gravity."""
    n = 2000
    t = np.arange(n) / 20.0
    rng = np.random.default_rng(5)
    z = gravity + 0.05 + rng.normal(0, 0.01, n)
    xy = rng.normal(0, 0.01, (2, n))
    return [("OZ+", {"time_s": t, "temp_c": 25.0 + t / 100, "x": xy[0], "y": xy[1], "z": z})]


def test_local_gravity_sets_the_nominal_sensitivity_of_m_s2(tmp_path: Path) -> None:
    local = 9.8123
    runs = _one_orientation_m_s2(local)
    standard = accelcore.calibrate(accelcore.Session.from_arrays(runs, units="m/s2", rate_hz=20))
    at_local = accelcore.calibrate(
        accelcore.Session.from_arrays(runs, units="m/s2", rate_hz=20, gravity_m_s2=local)
    )
    assert "z:sensitivity" in at_local.not_identified
    assert at_local.axis("z").sensitivity == local
    assert standard.axis("z").sensitivity == STANDARD_GRAVITY
    assert at_local.options["gravity_m_s2"] == local
    # The offset is what is left over 1 g of the local gravity, not of the standard one.
    assert at_local.axis("z").zero_g_offset == pytest.approx(0.05, abs=2e-3)
    assert standard.axis("z").zero_g_offset == pytest.approx(
        0.05 + local - STANDARD_GRAVITY, abs=2e-3
    )
    raw = np.column_stack([runs[0][1][a] for a in ("x", "y", "z")])
    g = at_local.compensate(raw, np.clip(runs[0][1]["temp_c"], *at_local.temperature_range_c))
    assert float(np.mean(g[:, 2])) == pytest.approx(1.0, abs=1e-4)
    with pytest.raises(accelcore.ParameterError, match="gravity_m_s2"):
        accelcore.Session.from_arrays(runs, units="m/s2", rate_hz=20, gravity_m_s2=1.0)


def test_gravity_key_of_session_toml(tmp_path: Path) -> None:
    folder = tmp_path / "grav"
    simulate.session(folder, seed=33, duration_h=0.03, soak_min=0.5)
    _rewrite_toml(folder, "rate_hz", "gravity_m_s2 = 9.8123\nrate_hz")
    s = accelcore.load_session(folder, cache=False)
    assert s.gravity_m_s2 == 9.8123 and s.format is not None and s.format.gravity_m_s2 == 9.8123
    _rewrite_toml(folder, "gravity_m_s2 = 9.8123", "gravity_m_s2 = 98.123")
    with pytest.raises(accelcore.SessionFormatError, match="gravity_m_s2 must be the local"):
        accelcore.load_session(folder, cache=False)
    _rewrite_toml(folder, "gravity_m_s2 = 98.123", "gravity = 9.81")
    with pytest.raises(accelcore.SessionFormatError, match="did you mean 'gravity_m_s2'"):
        accelcore.load_session(folder, cache=False)


# ------------------------------------------------------------------ time as a sample index


def test_time_unit_sample(tmp_path: Path) -> None:
    folder = tmp_path / "index"
    simulate.session(folder, seed=34, duration_h=0.05, soak_min=0.5)
    reference = accelcore.load_session(folder, cache=False)
    for spec in reference.format.runs if reference.format else ():
        text = spec.path.read_text().splitlines()
        rows = [line.split(",") for line in text[1:]]
        index = [str(round(float(r[0]) * 20.0)) for r in rows]
        body = [",".join([i, *r[1:]]) for i, r in zip(index, rows, strict=True)]
        spec.path.write_text("\n".join([text[0], *body]) + "\n")
    _rewrite_toml(folder, 'time_unit = "s"', 'time_unit = "sample"')
    s = accelcore.load_session(folder, cache=False)
    for run, ref in zip(s.runs, reference.runs, strict=True):
        assert np.allclose(run.time_s, ref.time_s, atol=1e-9)
        assert np.array_equal(run.output, ref.output)


def test_from_arrays_without_time_takes_it_from_the_rate(flat: simulate.SimulatedArrays) -> None:
    with_time = _arrays_session(flat)
    without = _arrays_session(flat, drop=("time_s",))
    for run, ref in zip(without.runs, with_time.runs, strict=True):
        first = flat.runs[0].columns["time_s"][0]
        assert np.allclose(run.time_s + first, ref.time_s, atol=1e-6)
        assert np.allclose(run.output, ref.output)
    explicit = _arrays_session(flat, columns={"time": ""})
    assert np.array_equal(explicit.runs[0].time_s, without.runs[0].time_s)


# ------------------------------------------------------------------ the command line


def test_cli_calibrates_a_cold_chamber_log(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "cold"
    simulate.session(folder, seed=35, duration_h=0.1, soak_min=0.5, t_start_c=-40, t_end_c=-10)
    assert main(["calibrate", str(folder), "--no-cache"]) == 0
    out = capsys.readouterr().out
    assert "fitted over -4" in out
    assert main(["calibrate", str(folder), "--no-cache", "--window", "0", "60"]) == 1
    assert "no decimated sample" in capsys.readouterr().err


# ------------------------------------------------------------------ a measured log


def _realdata() -> Path:
    env = os.environ.get("ACCELCORE_REALDATA")
    name = "tofupilot_thermal_cycle"
    if env:
        p = Path(env)
        return p / name if (p / name).is_dir() else p
    return Path(__file__).resolve().parents[2] / "shared" / "realdata" / name


REAL = _realdata()


@pytest.mark.skipif(not (REAL / "session.toml").is_file(), reason=f"real data not found at {REAL}")
def test_tofupilot_log_gets_factor_one_and_its_logged_range(tmp_path: Path) -> None:
    session = accelcore.load_session(REAL, cache=False)
    assert session.rate_hz == pytest.approx(1.98) and session.decimation_factor == 1
    temps = np.concatenate([r.temperature_c for r in session.runs])
    cal = accelcore.calibrate(session)
    lo, hi = cal.temperature_range_c
    assert lo == pytest.approx(float(temps.min())) and hi == pytest.approx(float(temps.max()))
    assert cal.window_c == (-math.inf, math.inf)
    assert sum(m.n_samples for m in cal.axes.values()) == 3 * temps.size


def test_compensate_a_log_with_a_sample_index_and_no_temperature(tmp_path: Path) -> None:
    """`accelcore compensate --session`: a session whose time column is a sample index
    (`time_unit = "sample"`) and which logs no temperature (`temperature = ""`): the
    output keeps the index, has no temperature column, and each run compensates to its
    orientation's gravity within the noise of one 20 Hz sample (~5 mg at 3 sigma)."""
    import io

    import pandas as pd

    sim = simulate.arrays(
        "ADXL335", seed=4, duration_h=0.1, t_start_c=25.0, t_end_c=25.2, soak_min=0.0
    )
    folder = tmp_path / "s"
    folder.mkdir()
    toml = (
        'format = "accelcore-session/1"\nsensor = "ADXL335"\nunits = "V"\nrate_hz = 20.0\n'
        'time_unit = "sample"\n\n[columns]\ntime = "n"\ntemperature = ""\n\n'
    )
    for r in sim.runs:
        name = r.orientation.replace("+", "p").replace("-", "m") + ".csv"
        frame = {"n": np.arange(r.columns["x"].size)} | {a: r.columns[a] for a in "xyz"}
        pd.DataFrame(frame).to_csv(folder / name, index=False)
        toml += f'[[run]]\nfile = "{name}"\norientation = "{r.orientation}"\n\n'
    (folder / "session.toml").write_text(toml)
    cal = tmp_path / "cal.json"
    assert main(["calibrate", str(folder), "--save", str(cal)], stdout=io.StringIO()) == 0
    out = tmp_path / "out.csv"
    argv = ["compensate", str(cal), str(folder / "OXp.csv"), "--session", str(folder)]
    assert main([*argv, "-o", str(out)], stdout=io.StringIO()) == 0
    result = pd.read_csv(out)
    assert list(result.columns) == ["n", "x_g", "y_g", "z_g"]
    assert result["n"].iloc[-1] == len(result) - 1
    mean = result[["x_g", "y_g", "z_g"]].mean().to_numpy()
    np.testing.assert_allclose(mean, [1.0, 0.0, 0.0], atol=5e-3)
