"""Reading sessions: load_session on simulated folders, [columns], delimiters, time units,
and Session.from_arrays from NumPy dicts and pandas DataFrames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.typing import NDArray

import accelcore
from accelcore import TimeOrderError, calibrate, load_session, simulate
from accelcore.input.session import Session

FloatArray = NDArray[np.float64]

PARTS = ("ADXL335", "ADXL327", "LIS344ALH", "MPU-9255")
SEEDS = {"ADXL335": 11, "ADXL327": 12, "LIS344ALH": 13, "MPU-9255": 14}
RATE_HZ = 20.0
FACTOR = 10  # load_session's default: 20 Hz -> 2 Hz, as in the paper
DURATION_H = 2.0
ROWS = round(DURATION_H * 3600 * RATE_HZ)  # 144000 rows per run
BLOCKS = ROWS // FACTOR  # 14400 decimated blocks per run
EPS = float(np.finfo(np.float64).eps)


def printing_half_unit(units: str, quantum: float) -> float:
    """Largest difference between a simulated value and its printed form in the log.

    The simulator prints LSB outputs as integers (exact) and volts with
    ``max(6, ceil(-log10(quantum)) + 2)`` decimals (see ``simulate.writer._value_format``),
    so a printed volt value is off by at most half a unit of its last decimal.
    A block mean of such values is off by at most the same amount.
    """
    if units == "LSB":
        return 0.0
    decimals = max(6, int(np.ceil(-np.log10(quantum))) + 2)
    return 0.5 * 10.0**-decimals


def block_means(values: FloatArray, factor: int = FACTOR) -> FloatArray:
    """Reference decimation of a gap-free stream: plain means of ``factor`` rows."""
    n = values.shape[0] // factor * factor
    return np.asarray(values[:n].reshape(-1, factor).mean(axis=1), dtype=np.float64)


@pytest.fixture(scope="module")
def sessions(
    tmp_path_factory: pytest.TempPathFactory,
) -> dict[str, tuple[simulate.SimulatedSession, Session]]:
    """One 2-hour, six-orientation session of every part, written and read back."""
    root = tmp_path_factory.mktemp("sessions")
    out = {}
    for part in PARTS:
        sim = simulate.session(
            root / part,
            part,
            seed=SEEDS[part],
            duration_h=DURATION_H,
            serial=f"{part}-S1",
            extra_columns=("supply_v",),
        )
        out[part] = (sim, load_session(sim.path))
    return out


# --------------------------------------------------------------------------- load_session


@pytest.mark.parametrize("part", PARTS)
def test_load_session_reads_every_run(
    part: str, sessions: dict[str, tuple[simulate.SimulatedSession, Session]]
) -> None:
    sim, s = sessions[part]
    assert s.sensor == sim.sensor
    assert s.serial == f"{part}-S1"
    assert s.units == sim.units == ("LSB" if part == "MPU-9255" else "V")
    assert s.rate_hz == RATE_HZ
    assert s.decimation_factor == FACTOR
    assert s.path == str(sim.path)
    assert s.orientations == simulate.DEFAULT_ORIENTATIONS
    assert len(s.runs) == 6
    assert s.extra_columns == ("supply_v",)
    for run, written in zip(s.runs, sim.runs, strict=True):
        np.testing.assert_array_equal(run.gravity_g, simulate.ORIENTATIONS[run.orientation])
        assert Path(run.source or "").name == written.file
        assert run.label == written.file
        # 2 h at 20 Hz = 144000 gap-free rows -> exactly 14400 full blocks of 10.
        assert len(run) == BLOCKS
        assert run.output.shape == (BLOCKS, 3)
        np.testing.assert_array_equal(run.count, np.full(BLOCKS, FACTOR))
        assert run.stats.n_rows == ROWS
        assert run.stats.n_skipped_nonfinite == 0
        assert run.stats.n_gaps == 0
        # Time is printed to 0.01 s, exact for multiples of 0.05 s up to rounding of the parse.
        assert run.stats.duration_s == pytest.approx((ROWS - 1) / RATE_HZ, rel=1e-12)
        assert run.extras["supply_v"].shape == (BLOCKS,)
    assert set(s.file_hashes()) == {"session.toml"} | {r.file for r in sim.runs}


@pytest.mark.parametrize("part", PARTS)
def test_loaded_blocks_are_the_means_of_the_written_rows(
    part: str, sessions: dict[str, tuple[simulate.SimulatedSession, Session]]
) -> None:
    """The streamed decimation equals a plain reshape-mean of what simulate.arrays holds.

    simulate.arrays with the same arguments holds exactly the values the files
    print, except that volts are printed to a finite number of decimals
    (:func:`printing_half_unit`). Temperatures and extras are already rounded to
    their printed decimals, so they differ only by the decimal parse (a few ulp
    of the value); 64 ulp of the column's magnitude covers the parse and the
    ten-term sum in another order.
    """
    sim, s = sessions[part]
    mem = simulate.arrays(
        part,
        seed=SEEDS[part],
        duration_h=DURATION_H,
        serial=f"{part}-S1",
        extra_columns=("supply_v",),
    )
    half = printing_half_unit(sim.units, sim.quantum)
    for run, ref in zip(s.runs, mem.runs, strict=True):
        cols = ref.columns
        for name, got in (
            ("time_s", run.time_s),
            ("temp_c", run.temperature_c),
            ("supply_v", run.extras["supply_v"]),
        ):
            scale = float(np.abs(cols[name]).max())
            np.testing.assert_allclose(got, block_means(cols[name]), rtol=0, atol=64 * EPS * scale)
        for i, axis in enumerate("xyz"):
            scale = float(np.abs(cols[axis]).max())
            np.testing.assert_allclose(
                run.output[:, i], block_means(cols[axis]), rtol=0, atol=half + 64 * EPS * scale
            )


def test_supply_column_is_kept_as_an_observable(
    sessions: dict[str, tuple[simulate.SimulatedSession, Session]],
) -> None:
    """supply_v is 3 V + 0.5 mV rms noise per row (simulate.runs.supply_column) for the ADXL335:
    its block means (86400 of them) must sit within 6 sigma of a 10-row mean (P(any beyond)
    ~ 86400 * 2e-9 < 1e-3) plus the 5-decimal print."""
    _, s = sessions["ADXL335"]
    tol = 6 * 0.0005 / np.sqrt(FACTOR) + 0.5e-5
    for run in s.runs:
        assert np.all(np.abs(run.extras["supply_v"] - 3.0) <= tol)


# --------------------------------------------------------------------------- [columns], ';', ms


def write_renamed_session(folder: Path, mem: simulate.SimulatedArrays) -> None:
    """A session with renamed, reordered columns, ';' separators and time in ms."""
    folder.mkdir()
    header = ["vdd", "az", "ay", "ax", "temperature", "t_ms"]
    source = ["supply_v", "z", "y", "x", "temp_c", "time_s"]
    formats = ["%.5f", "%.6f", "%.6f", "%.6f", "%.3f", "%.0f"]
    runs_toml = []
    for k, run in enumerate(mem.runs):
        table = np.column_stack(
            [run.columns[c] * (1000.0 if c == "time_s" else 1.0) for c in source]
        )
        name = f"run{k}.txt"
        np.savetxt(
            folder / name, table, fmt=formats, delimiter=";", header=";".join(header), comments=""
        )
        runs_toml.append(f'[[run]]\nfile = "{name}"\norientation = "{run.orientation}"\n')
    (folder / "session.toml").write_text(
        'format = "accelcore-session/1"\n'
        'sensor = "adxl327"\n'
        'units = "V"\n'
        "rate_hz = 20.0\n"
        'delimiter = ";"\n'
        'time_unit = "ms"\n'
        "\n[columns]\n"
        'time = "t_ms"\ntemperature = "temperature"\nx = "ax"\ny = "ay"\nz = "az"\n\n'
        + "\n".join(runs_toml),
        encoding="utf-8",
    )


def test_columns_delimiter_and_time_unit_are_honoured(tmp_path: Path) -> None:
    mem = simulate.arrays(
        "ADXL327",
        seed=3,
        duration_h=0.1,
        soak_min=1.0,
        orientations=("OY-", "OZ+"),
        extra_columns=("supply_v",),
    )
    write_renamed_session(tmp_path / "renamed", mem)
    s = load_session(tmp_path / "renamed")
    assert s.orientations == ("OY-", "OZ+")
    assert s.sensor == "adxl327"
    assert s.extra_columns == ("vdd",)
    half = printing_half_unit("V", mem.quantum)  # written with %.6f, like the simulator
    for run, ref in zip(s.runs, mem.runs, strict=True):
        cols = ref.columns
        assert len(run) == cols["time_s"].shape[0] // FACTOR
        # ms -> s: t_ms is an exact integer, times 1e-3 is within an ulp or two of time_s.
        np.testing.assert_allclose(
            run.time_s, block_means(cols["time_s"]), rtol=0, atol=64 * EPS * 360.0
        )
        assert run.stats.duration_s == pytest.approx(cols["time_s"][-1], rel=1e-12)
        np.testing.assert_allclose(
            run.temperature_c, block_means(cols["temp_c"]), rtol=0, atol=64 * EPS * 65.0
        )
        np.testing.assert_allclose(
            run.extras["vdd"], block_means(cols["supply_v"]), rtol=0, atol=64 * EPS * 3.0
        )
        # x, y, z come from the named columns, not from their positions in the header.
        for i, axis in enumerate("xyz"):
            np.testing.assert_allclose(
                run.output[:, i], block_means(cols[axis]), rtol=0, atol=half + 64 * EPS * 3.0
            )


def test_a_missing_renamed_column_is_named(tmp_path: Path) -> None:
    mem = simulate.arrays(
        "ADXL327",
        seed=3,
        duration_h=0.05,
        soak_min=1.0,
        orientations=("OZ+",),
        extra_columns=("supply_v",),
    )
    write_renamed_session(tmp_path / "s", mem)
    toml = tmp_path / "s" / "session.toml"
    toml.write_text(toml.read_text().replace('x = "ax"', 'x = "acc_x"'))
    with pytest.raises(accelcore.AccelcoreError, match="acc_x"):
        load_session(tmp_path / "s")


# --------------------------------------------------------------------------- from_arrays


def solution_operator(session: Session, axis: int, window_c: tuple[float, float]) -> FloatArray:
    """Rows of ``(X'WX)^-1 X'W`` of the default joint model of one axis (design as calibrate's).

    A perturbation ``d`` of the block outputs moves the coefficients by
    ``operator @ d``, hence by at most ``|operator|.sum(axis=1) * max|d|``.
    """
    rows, weights = [], []
    for run in session.runs:
        keep = (run.temperature_c >= window_c[0]) & (run.temperature_c <= window_c[1])
        dt = run.temperature_c[keep] - 25.0
        g = run.gravity_g[axis]
        # The default model: offset and sensitivity linear in T, then the gain on each
        # other axis' gravity (the full 3x3 gain), in calibrate's term order.
        cross = [run.gravity_g[b] * np.ones_like(dt) for b in range(3) if b != axis]
        rows.append(np.column_stack([np.ones_like(dt), dt, g * np.ones_like(dt), g * dt, *cross]))
        weights.append(run.count[keep].astype(np.float64))
    x, w = np.vstack(rows), np.concatenate(weights)
    return np.asarray(np.linalg.solve(x.T @ (w[:, None] * x), (x * w[:, None]).T))


@pytest.mark.parametrize("part", ["ADXL335", "MPU-9255"])
def test_from_arrays_calibrates_like_the_files(
    part: str, sessions: dict[str, tuple[simulate.SimulatedSession, Session]]
) -> None:
    """NumPy dicts and DataFrames give the file's calibration, within the printing precision.

    The dict and DataFrame sessions hold the same numbers, so they decimate and
    fit bit for bit alike. The files print volts to 1e-6 V, so each block output
    of the file session may differ by up to half a unit (0 for LSB counts); the
    fitted coefficients then differ by at most ``sum|operator row| * half_unit``
    (the fit is linear in the outputs), plus rounding of two different sums.
    """
    sim, from_files = sessions[part]
    mem = simulate.arrays(
        part, seed=SEEDS[part], duration_h=DURATION_H, extra_columns=("supply_v",)
    )
    as_dicts = Session.from_arrays(
        [(r.orientation, r.columns) for r in mem.runs],
        units=mem.units,
        rate_hz=mem.rate_hz,
        sensor=mem.sensor,
    )
    as_frames = Session.from_arrays(
        [(r.orientation, pd.DataFrame(r.columns)) for r in mem.runs],
        units=mem.units,
        rate_hz=mem.rate_hz,
        sensor=mem.sensor,
    )
    assert as_dicts.path is None and as_dicts.file_hashes() == {}
    assert as_dicts.extra_columns == as_frames.extra_columns == ("supply_v",)
    for a, b in zip(as_dicts.runs, as_frames.runs, strict=True):
        np.testing.assert_array_equal(a.output, b.output)
        np.testing.assert_array_equal(a.temperature_c, b.temperature_c)
        np.testing.assert_array_equal(a.extras["supply_v"], b.extras["supply_v"])
        assert a.stats.n_rows == ROWS

    window = (0.0, 60.0)
    cal_files = calibrate(from_files, window_c=window)
    cal_dicts = calibrate(as_dicts, window_c=window)
    cal_frames = calibrate(as_frames, window_c=window)
    half = printing_half_unit(sim.units, sim.quantum)
    for i, axis in enumerate("xyz"):
        np.testing.assert_array_equal(
            cal_dicts.axes[axis].coefficients, cal_frames.axes[axis].coefficients
        )
        coef = cal_dicts.axes[axis].coefficients
        bound = np.abs(solution_operator(as_dicts, i, window)).sum(axis=1) * half
        # Different summation order of ~70k terms: a relative 1e-9 of the coefficient
        # (n * eps with n ~ 1e5, times a conditioning margin of ~50) covers it.
        bound = bound + 1e-9 * np.abs(coef)
        diff = np.abs(cal_files.axes[axis].coefficients - coef)
        assert np.all(diff <= bound), f"{part} {axis}: {diff} > {bound}"


@pytest.mark.parametrize("where", ["restart", "repeat"])
def test_from_arrays_names_the_run_and_row_where_time_goes_back(where: str) -> None:
    sim = simulate.arrays("ADXL335", seed=1, duration_h=0.25, orientations=("OZ+", "OZ-", "OX+"))
    runs = [(r.orientation, {k: v.copy() for k, v in r.columns.items()}) for r in sim.runs]
    t = runs[2][1]["time_s"]
    if where == "restart":  # the logger restarted halfway: time from 0 again
        t[9000:] -= t[9000]
    else:  # one row repeated
        t[4000] = t[3999]
    row = 9000 if where == "restart" else 4000
    named = rf"^run 3 \(OX\+\): column 'time_s', row {row}: "
    with pytest.raises(TimeOrderError, match=named) as e:
        Session.from_arrays(runs, units="V", rate_hz=20.0, sensor="ADXL335")
    assert (e.value.index, e.value.previous_s, e.value.time_s) == (row, t[row - 1], t[row])
