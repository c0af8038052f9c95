"""Compensation (raw output to g) and calibration files (save/load)."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

import accelcore
from accelcore import calibrate, simulate
from accelcore._accelcore import first_order_lag
from accelcore.errors import TemperatureRangeWarning
from accelcore.input.session import Session
from accelcore.model import Basis, Term, base_terms
from accelcore.result.calibration import Calibration
from accelcore.result.compensator import continued_beyond_range
from accelcore.simulate import effects as se

FloatArray = NDArray[np.float64]
AXES = ("x", "y", "z")
PROBE_NOISE_C = 0.02  # simulate's default probe_noise_c
#: Per-check threshold in standard deviations. The noisiest test below makes
#: ~220 checks, so a correct model fails one with probability < 220 * 5.7e-7 < 1e-3.
Z_MAX = 5.0


def session_of(sim: simulate.SimulatedArrays) -> Session:
    return Session.from_arrays(
        [(r.orientation, r.columns) for r in sim.runs],
        units=sim.units,
        rate_hz=sim.rate_hz,
        sensor=sim.sensor,
        serial=sim.serial,
    )


@pytest.fixture(scope="module")
def fitted() -> tuple[simulate.SimulatedArrays, Calibration]:
    sim = simulate.arrays("ADXL335", seed=301, duration_h=2.0, serial="A-0017")
    # The seed paper's model (offset and sensitivity linear in T), whose formula and
    # uncertainty these tests write out; the default full gain is tested below.
    return sim, calibrate(session_of(sim), terms={a: base_terms(a) for a in AXES})


@pytest.fixture(scope="module")
def other() -> simulate.SimulatedArrays:
    """An independent session of the same part (same truth, new noise) to compensate."""
    return simulate.arrays("ADXL335", seed=302, duration_h=2.0)


def raw_of(run: simulate.SimulatedRun) -> tuple[FloatArray, FloatArray, FloatArray]:
    c = run.columns
    return np.column_stack([c["x"], c["y"], c["z"]]), c["temp_c"], c["time_s"]


def in_range(cal: Calibration, temp: FloatArray) -> NDArray[np.bool_]:
    lo, hi = cal.temperature_range_c
    return (temp >= lo) & (temp <= hi)


def sample_sigma_g(sim: simulate.SimulatedArrays, axis: int, gravity: float) -> float:
    """Standard deviation of one compensated 20 Hz sample, g.

    White output noise (``noise_g``), the ADC's quantisation (step q in volts,
    variance q²/12, divided by the sensitivity; the noise is > q/2, so the
    error is uniform and independent of the signal), and the probe's
    temperature noise acting through the slope of the output vs temperature.
    """
    t = sim.truth
    q_g = sim.quantum / t.sensitivity_per_g[axis]
    slope_g_per_c = (
        t.offset_tc_mg_per_c[axis] / 1000.0 + gravity * t.sensitivity_tc_pct_per_c[axis] / 100.0
    )
    return math.sqrt(sim.noise_g[axis] ** 2 + q_g**2 / 12.0 + (slope_g_per_c * PROBE_NOISE_C) ** 2)


def calibration_sigma_g(cal: Calibration, axis: str, gravity: float, dt: float) -> float:
    """Standard error of the compensated value due to the fitted coefficients, g.

    a = (v - o(T)) / s(T) with o, s linear in dT: to first order
    δa = -(δo0 + δo1 dT + a (δs0 + δs1 dT)) / s(T), i.e. the fit's design row
    x = (1, dT, a, a dT) against the coefficient covariance C: var = x'Cx / s(T)².
    """
    m = cal.axes[axis]
    x = np.array([1.0, dt, gravity, gravity * dt])
    s = m.coefficients[2] + m.coefficients[3] * dt
    return float(math.sqrt(x @ m.covariance @ x) / abs(s))


# --------------------------------------------------------------------------- accuracy


def test_compensation_returns_the_orientations_gravity(
    fitted: tuple[simulate.SimulatedArrays, Calibration], other: simulate.SimulatedArrays
) -> None:
    """Over the whole calibrated range, in 5 °C bins, every run of an independent session
    compensates to its gravity (±1 g on the vertical axis, 0 g on the others)."""
    sim, cal = fitted
    lo, hi = cal.temperature_range_c
    edges = np.linspace(lo, hi, 13)  # 12 bins of 5 °C
    for run in other.runs:
        raw, temp, _ = raw_of(run)
        keep = in_range(cal, temp)
        acc = cal.compensate(raw[keep], temp[keep])
        t = temp[keep]
        gravity = np.asarray(simulate.ORIENTATIONS[run.orientation])
        which = np.digitize(t, edges[1:-1])
        for b in range(len(edges) - 1):
            sel = which == b
            n = int(sel.sum())
            assert n > 1000, f"bin {b} of {run.orientation} holds {n} samples"
            dt = float(t[sel].mean()) - cal.t_ref_c
            for i, a in enumerate(AXES):
                g = float(gravity[i])
                err = float(acc[sel, i].mean()) - g
                sigma = math.hypot(
                    sample_sigma_g(sim, i, g) / math.sqrt(n), calibration_sigma_g(cal, a, g, dt)
                )
                assert abs(err) <= Z_MAX * sigma, (
                    f"{run.orientation} {a} bin {edges[b]:.1f} °C: {err * 1e3:.4f} mg "
                    f"> {Z_MAX} x {sigma * 1e3:.4f} mg"
                )


def test_compensated_scatter_is_the_sensor_noise(
    fitted: tuple[simulate.SimulatedArrays, Calibration], other: simulate.SimulatedArrays
) -> None:
    """The RMS error of single samples is the noise model's, not more: no thermal trend is
    left. The sample standard deviation of n ~ 1.3e5 Gaussian samples has a relative
    standard deviation 1/sqrt(2n) ~ 0.2 %, so Z_MAX of those is the tolerance."""
    sim, cal = fitted
    for run in other.runs:
        raw, temp, _ = raw_of(run)
        keep = in_range(cal, temp)
        acc = cal.compensate(raw[keep], temp[keep])
        gravity = np.asarray(simulate.ORIENTATIONS[run.orientation])
        n = int(keep.sum())
        for i, a in enumerate(AXES):
            rms = float(np.sqrt(np.mean((acc[:, i] - gravity[i]) ** 2)))
            expected = sample_sigma_g(sim, i, float(gravity[i]))
            assert rms == pytest.approx(expected, rel=Z_MAX / math.sqrt(2 * n)), (
                f"{run.orientation} {a}"
            )


def test_compensation_matches_the_model_formula(
    fitted: tuple[simulate.SimulatedArrays, Calibration],
) -> None:
    """Base model: a = (v - o0 - o1 dT) / (s0 + s1 dT) per axis, also outside the range
    (its terms are linear: extrapolated). Same double operations up to order: 1e-12 relative."""
    _, cal = fitted
    temp = np.array([-20.0, 0.0, 25.0, 47.5, 60.0, 85.0])
    raw = np.array([[1.50, 1.48, 1.85]] * temp.size) + np.linspace(-0.3, 0.3, temp.size)[:, None]
    with pytest.warns(TemperatureRangeWarning):
        acc = cal.compensate(raw, temp)
    dt = temp - cal.t_ref_c
    for i, a in enumerate(AXES):
        o0, o1, s0, s1 = cal.axes[a].coefficients
        expected = (raw[:, i] - o0 - o1 * dt) / (s0 + s1 * dt)
        np.testing.assert_allclose(acc[:, i], expected, rtol=1e-12, atol=0)


def _continued(x: FloatArray, lo: float, hi: float, k: int) -> FloatArray:
    """``x^k`` inside ``lo…hi`` (``x`` from T_ref), its tangent at the nearer edge beyond."""
    edge = np.clip(x, lo, hi)
    return np.asarray(edge**k + k * edge ** (k - 1) * (x - edge))


def test_curvature_continues_along_its_tangent_beyond_the_range() -> None:
    """Beyond the fitted range, the powers of order 2 and more (a lag's too) go on as
    their tangent at the range's edge; the linear terms extrapolate; inside, nothing
    changes.

    Fitted over 15…35 °C (a narrow sweep, as a user might run); written out per axis as
    a = (v - o(T)) / s(T) with each curvature term continued from the edge. Same double
    operations up to order: 1e-12 relative.
    """
    sim = simulate.arrays(
        "ADXL335", seed=7, duration_h=1.0, t_start_c=15.0, t_end_c=35.0, cool_back=True
    )
    terms = {
        a: (
            *base_terms(a),
            Term("offset", "dT^2"),
            Term("offset", "dT^3"),
            Term("gain", "dT^2", source=a),
            Term("offset", "lag(60):dT^2"),
        )
        for a in AXES
    }
    cal = calibrate(session_of(sim), terms=terms)
    lo, hi = cal.temperature_range_c
    assert 14.0 < lo < 16.0 and 34.0 < hi < 36.0  # the narrow sweep
    time_s = np.arange(40.0) * 100.0  # 100 s apart: the lag of 60 s mostly settles
    temp = np.concatenate([np.linspace(lo, hi, 10), np.linspace(-10.0, 60.0, 30)])
    raw = np.tile([1.50, 1.48, 1.85], (temp.size, 1)) + 0.01 * np.sin(np.arange(temp.size))[:, None]
    with pytest.warns(TemperatureRangeWarning, match="along its tangent at the range's edge"):
        acc = cal.compensate(raw, temp, time_s)
    t0 = cal.t_ref_c
    lagged = first_order_lag(time_s, temp, 60.0) - t0
    dt, lo0, hi0 = temp - t0, lo - t0, hi - t0
    for i, a in enumerate(AXES):
        m = cal.axes[a]
        offset = m.value("offset", "1")[0] + m.value("offset", "dT^1")[0] * dt
        offset += m.value("offset", "dT^2")[0] * _continued(dt, lo0, hi0, 2)
        offset += m.value("offset", "dT^3")[0] * _continued(dt, lo0, hi0, 3)
        offset += m.value("offset", "lag(60):dT^2")[0] * _continued(lagged, lo0, hi0, 2)
        gain = m.value("gain", "1", a)[0] + m.value("gain", "dT^1", a)[0] * dt
        gain += m.value("gain", "dT^2", a)[0] * _continued(dt, lo0, hi0, 2)
        np.testing.assert_allclose(acc[:, i], (raw[:, i] - offset) / gain, rtol=1e-12, atol=0)
    assert continued_beyond_range(Basis.parse("dT^2"))
    assert continued_beyond_range(Basis.parse("lag(60):dT^3"))
    assert not any(
        map(continued_beyond_range, map(Basis.parse, ["dT^1", "lag(60):dT^1", "hinge(5):dT^1"]))
    )


# --------------------------------------------------------------------------- range warnings


@pytest.mark.parametrize("temps", [[25.0, 70.0], [-5.0, 25.0], [-40.0, 90.0]])
def test_out_of_range_temperature_warns_with_the_range(
    temps: list[float], fitted: tuple[simulate.SimulatedArrays, Calibration]
) -> None:
    _, cal = fitted
    lo, hi = cal.temperature_range_c
    raw = np.tile([1.5, 1.5, 1.8], (len(temps), 1))
    pattern = re.escape(f"{lo:.2f}…{hi:.2f} °C")
    with pytest.warns(TemperatureRangeWarning, match=pattern) as record:
        acc = cal.compensate(raw, np.array(temps))
    assert len(record) == 1
    assert record[0].filename == __file__  # attributed to the caller, not to accelcore
    assert np.all(np.isfinite(acc))
    n_out = sum(1 for t in temps if not lo <= t <= hi)
    assert f"{n_out} of {len(temps)} samples" in str(record[0].message)


def test_in_range_temperature_does_not_warn(
    fitted: tuple[simulate.SimulatedArrays, Calibration],
) -> None:
    """pytest turns warnings into errors here (filterwarnings = error)."""
    _, cal = fitted
    lo, hi = cal.temperature_range_c
    temps = np.array([lo, 0.5 * (lo + hi), hi])
    cal.compensate(np.tile([1.5, 1.5, 1.8], (3, 1)), temps)


def test_non_finite_rows_give_nan_rows_only(
    fitted: tuple[simulate.SimulatedArrays, Calibration],
) -> None:
    _, cal = fitted
    raw = np.tile([1.5, 1.5, 1.8], (4, 1))
    raw[1, 2] = np.nan
    temps = np.array([20.0, 20.0, np.nan, 30.0])
    acc = cal.compensate(raw, temps)
    assert np.all(np.isnan(acc[1])) and np.all(np.isnan(acc[2]))
    assert np.all(np.isfinite(acc[[0, 3]]))


# --------------------------------------------------------------------------- streaming


def test_chunked_compensation_equals_one_call(
    fitted: tuple[simulate.SimulatedArrays, Calibration], other: simulate.SimulatedArrays
) -> None:
    """compensate works row by row, so any split of a log (e.g. a file read in chunks)
    gives bit-identical results to one call."""
    _, cal = fitted
    raw, temp, time_s = raw_of(other.runs[4])
    keep = in_range(cal, temp)
    raw, temp, time_s = raw[keep], temp[keep], time_s[keep]
    whole = cal.compensate(raw, temp, time_s=time_s)
    rng = np.random.default_rng(5)
    cuts = np.sort(rng.choice(np.arange(1, temp.size), size=20, replace=False))
    parts = [
        cal.compensate(r, t, time_s=s)
        for r, t, s in zip(
            np.split(raw, cuts), np.split(temp, cuts), np.split(time_s, cuts), strict=True
        )
    ]
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    one_row = cal.compensate(raw[:1], temp[:1])
    np.testing.assert_array_equal(one_row, whole[:1])


# --------------------------------------------------------------------------- save / load


def assert_same_calibration(a: Calibration, b: Calibration) -> None:
    """Every field equal; every float bit for bit (NaN included)."""
    assert a.to_dict().keys() == b.to_dict().keys()
    for name in ("method", "units", "sensor", "serial", "not_identified", "notes", "options"):
        assert getattr(a, name) == getattr(b, name), name
    for name in ("t_ref_c", "window_c", "temperature_range_c"):
        np.testing.assert_array_equal(
            np.asarray(getattr(a, name), dtype=np.float64).view(np.uint64),
            np.asarray(getattr(b, name), dtype=np.float64).view(np.uint64),
            err_msg=name,
        )
    assert a.references == b.references
    assert a.axes.keys() == b.axes.keys()
    for axis, ma in a.axes.items():
        mb = b.axes[axis]
        assert ma.terms == mb.terms
        for field in ("coefficients", "covariance"):
            np.testing.assert_array_equal(
                getattr(ma, field).view(np.uint64), getattr(mb, field).view(np.uint64), field
            )
        np.testing.assert_array_equal(ma.estimated, mb.estimated)
        assert ma.n_samples == mb.n_samples
        assert np.float64(ma.rms_residual).view(np.uint64) == np.float64(mb.rms_residual).view(
            np.uint64
        )


@pytest.mark.parametrize(
    "variant", ["joint", "paper", "joint-no-window", "paper-partial", "joint-partial"]
)
def test_save_load_round_trips_exactly(
    variant: str, tmp_path: Path, fitted: tuple[simulate.SimulatedArrays, Calibration]
) -> None:
    sim, joint = fitted
    if variant == "joint":
        cal = joint
    elif variant == "paper":
        cal = calibrate(session_of(sim), method="paper")
    elif variant == "joint-no-window":
        cal = calibrate(session_of(sim), window_c=None)  # window (-inf, inf) in the file
    else:
        part = simulate.arrays("ADXL335", seed=303, duration_h=0.5, orientations=("OZ+", "OZ-"))
        cal = calibrate(session_of(part), method=variant.split("-")[0])  # type: ignore[arg-type]
    path = tmp_path / "cal.json"
    cal.save(path)
    loaded = Calibration.load(path, sensor="adxl335")
    assert_same_calibration(cal, loaded)
    assert loaded.axis("z") == cal.axis("z") or math.isnan(cal.axis("z").sensitivity)
    raw, temp, time_s = raw_of(sim.runs[0])
    keep = in_range(cal, temp) & in_range(loaded, temp)
    if variant == "paper-partial":
        # x and y have no model at all (the paper's method needs both orientations):
        # compensation refuses rather than return NaN for every axis.
        for c in (cal, loaded):
            with pytest.raises(accelcore.InsufficientDataError, match="axis x is not calibrated"):
                c.compensate(raw[keep], temp[keep], time_s[keep])
    else:
        np.testing.assert_array_equal(
            loaded.compensate(raw[keep], temp[keep], time_s[keep]),
            cal.compensate(raw[keep], temp[keep], time_s[keep]),
        )
    # Saving again writes the same bytes.
    cal2 = tmp_path / "again.json"
    loaded.save(cal2)
    assert cal2.read_bytes() == path.read_bytes()


@pytest.fixture
def saved(tmp_path: Path, fitted: tuple[simulate.SimulatedArrays, Calibration]) -> Path:
    path = tmp_path / "cal.json"
    fitted[1].save(path)
    return path


def test_load_refuses_a_truncated_file(saved: Path) -> None:
    data = saved.read_bytes()
    saved.write_bytes(data[: len(data) // 2])
    with pytest.raises(accelcore.CalibrationFileError, match="truncated or corrupted"):
        Calibration.load(saved)


def test_load_refuses_a_corrupted_digit(saved: Path) -> None:
    """A changed digit keeps valid JSON; only the checksum can tell."""
    text = saved.read_text()
    at = text.index('"coefficients"')
    at += re.search(r"\d", text[at:]).start()  # type: ignore[union-attr]
    digit = text[at]
    saved.write_text(text[:at] + str((int(digit) + 1) % 10) + text[at + 1 :])
    with pytest.raises(accelcore.CalibrationFileError, match="checksum mismatch"):
        Calibration.load(saved)


def test_load_refuses_a_non_utf8_byte(saved: Path) -> None:
    data = bytearray(saved.read_bytes())
    data[len(data) // 3] = 0xFF
    saved.write_bytes(bytes(data))
    with pytest.raises(accelcore.CalibrationFileError, match="corrupted"):
        Calibration.load(saved)


def test_load_refuses_another_format_version(saved: Path) -> None:
    doc = json.loads(saved.read_text())
    doc["body"]["format"] = "accelcore-calibration/2"
    saved.write_text(json.dumps(doc))
    with pytest.raises(
        accelcore.CalibrationFileError,
        match=r"'accelcore-calibration/2' is not supported; expected 'accelcore-calibration/1'",
    ):
        Calibration.load(saved)


@pytest.mark.parametrize("content", ["[]", '{"body": {}}', "{}", "null"])
def test_load_refuses_other_json(saved: Path, content: str) -> None:
    saved.write_text(content)
    with pytest.raises(accelcore.CalibrationFileError):
        Calibration.load(saved)


def test_load_refuses_another_sensor_or_serial(saved: Path) -> None:
    with pytest.raises(
        accelcore.CalibrationFileError, match=r"for sensor 'ADXL335', not 'MPU-9255'"
    ):
        Calibration.load(saved, sensor="MPU-9255")
    with pytest.raises(accelcore.CalibrationFileError, match=r"serial 'A-0017', not 'B-1'"):
        Calibration.load(saved, serial="B-1")
    assert Calibration.load(saved, sensor="ADXL335", serial="A-0017").serial == "A-0017"


def test_missing_calibration_file_is_an_os_error(tmp_path: Path) -> None:
    with pytest.raises(accelcore.AccelcoreIOError, match="cannot read calibration file") as info:
        Calibration.load(tmp_path / "absent.json")
    assert isinstance(info.value, OSError)


def test_default_full_gain_compensation_inverts_the_3x3_gain() -> None:
    """Default model with six orientations: v = o(T) + S(T) a with S the full 3x3 gain
    (own-axis sensitivity linear in T, constant cross-axis terms). Compensation solves
    it for a; checked against numpy.linalg.solve, sample by sample (a 3x3 solve of a
    gain matrix with condition ~1: 1e-12 relative)."""
    sim = simulate.arrays("ADXL335", seed=311, duration_h=0.5, effects=(se.Misalignment(),))
    cal = calibrate(session_of(sim))
    assert not cal.not_identified
    for a in AXES:
        for b in AXES:
            if b != a:
                assert cal.axes[a].estimated[cal.axes[a].index("gain", "1", b)]
    temp = np.array([5.0, 25.0, 47.5, 55.0])
    raw = np.array([[1.50, 1.48, 1.85]] * temp.size) + np.linspace(-0.3, 0.3, temp.size)[:, None]
    acc = cal.compensate(raw, temp)
    dt = temp - cal.t_ref_c
    for k in range(temp.size):
        gain = np.zeros((3, 3))
        offset = np.zeros(3)
        for i, a in enumerate(AXES):
            m = cal.axes[a]
            offset[i] = m.value("offset", "1")[0] + m.value("offset", "dT^1")[0] * dt[k]
            for j, b in enumerate(AXES):
                gain[i, j] = m.value("gain", "1", b)[0]
            gain[i, i] += m.value("gain", "dT^1", a)[0] * dt[k]
        np.testing.assert_allclose(acc[k], np.linalg.solve(gain, raw[k] - offset), rtol=1e-12)
