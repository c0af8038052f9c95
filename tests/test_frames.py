"""DataFrames in: pandas, polars and pyarrow tables give one session; errors name run/column/row."""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import pandas as pd
import pytest

import accelcore
from accelcore import simulate
from accelcore.errors import DataQualityWarning, ParseError, SessionFormatError
from accelcore.input.session import Session

pl = pytest.importorskip("polars")
pytest.importorskip("narwhals")


@pytest.fixture(scope="module")
def sim() -> Any:
    return simulate.arrays("ADXL335", seed=5, duration_h=0.3)


def _session(sim: Any, wrap: Any) -> Session:
    return Session.from_arrays(
        [(r.orientation, wrap(dict(r.columns))) for r in sim.runs],
        units=sim.units,
        rate_hz=sim.rate_hz,
    )


def _assert_same_session(a: Session, b: Session) -> None:
    assert len(a.runs) == len(b.runs)
    for ra, rb in zip(a.runs, b.runs, strict=True):
        assert ra.orientation == rb.orientation
        for name in ("time_s", "temperature_c", "output", "count"):
            np.testing.assert_array_equal(getattr(ra, name), getattr(rb, name), strict=True)
        for key, value in vars(ra.stats).items():
            np.testing.assert_array_equal(value, getattr(rb.stats, key), strict=True)


def test_polars_and_pandas_frames_give_bit_identical_sessions_and_calibrations(sim: Any) -> None:
    by_dict = _session(sim, lambda d: d)
    by_pandas = _session(sim, pd.DataFrame)
    by_polars = _session(sim, pl.DataFrame)
    _assert_same_session(by_pandas, by_polars)
    _assert_same_session(by_dict, by_polars)
    for method in ("joint", "paper"):
        want = accelcore.calibrate(by_pandas, method).to_dict()
        got = accelcore.calibrate(by_polars, method).to_dict()
        assert got == want  # every coefficient to the last bit


def test_a_pyarrow_table_reads_like_a_pandas_frame(sim: Any) -> None:
    pa = pytest.importorskip("pyarrow")
    _assert_same_session(_session(sim, pd.DataFrame), _session(sim, pa.table))


def test_a_polars_datetime_time_column_is_seconds_from_its_first_stamp(sim: Any) -> None:
    run = dict(sim.runs[0].columns)
    stamps = np.datetime64("2024-05-01T08:00:00", "ns") + (run["time_s"] * 1e9).astype(
        "timedelta64[ns]"
    )
    frame = {**run, "time_s": stamps}
    a = Session.from_arrays([("OX+", pd.DataFrame(frame))], units=sim.units, rate_hz=sim.rate_hz)
    b = Session.from_arrays([("OX+", pl.DataFrame(frame))], units=sim.units, rate_hz=sim.rate_hz)
    _assert_same_session(a, b)
    assert a.runs[0].time_s[0] < 1.0  # seconds from the first stamp, not nanoseconds since 1970


def test_a_text_cell_in_a_polars_frame_names_run_column_and_row(sim: Any) -> None:
    frame = pl.DataFrame(dict(sim.runs[1].columns)).with_columns(pl.col("y").cast(pl.Utf8))
    frame[7, "y"] = "1.2.3"
    runs = [("OX+", pl.DataFrame(dict(sim.runs[0].columns))), ("OX-", frame)]
    with pytest.raises(ParseError) as info:
        Session.from_arrays(runs, units=sim.units, rate_hz=sim.rate_hz)
    err = info.value
    assert "run 2 (OX-)" in str(err) and "'y'" in str(err) and "row 7" in str(err)
    assert (err.path, err.line, err.column) == ("run 2 (OX-)", 8, 4)


def test_a_polars_null_is_a_missing_value_like_pandas_nan(sim: Any) -> None:
    run = dict(sim.runs[0].columns)
    x = run["x"].copy()
    x[[3, 50]] = np.nan
    pandas_frame = pd.DataFrame({**run, "x": x})
    polars_frame = pl.DataFrame({**run, "x": [None if np.isnan(v) else v for v in x]})
    a = Session.from_arrays([("OX+", pandas_frame)], units=sim.units, rate_hz=sim.rate_hz)
    b = Session.from_arrays([("OX+", polars_frame)], units=sim.units, rate_hz=sim.rate_hz)
    _assert_same_session(a, b)


def test_a_lazy_frame_is_refused_with_what_to_do(sim: Any) -> None:
    lazy = pl.DataFrame(dict(sim.runs[0].columns)).lazy()
    with pytest.raises(SessionFormatError, match=r"run 1 \(OX\+\): a lazy frame.*collect"):
        Session.from_arrays([("OX+", lazy)], units=sim.units, rate_hz=sim.rate_hz)


def test_something_that_is_not_a_table_is_refused(sim: Any) -> None:
    with pytest.raises(SessionFormatError, match=r"expected a mapping .* or a DataFrame"):
        Session.from_arrays([("OX+", 3.5)], units=sim.units, rate_hz=sim.rate_hz)


def test_a_repeated_column_name_in_an_arrow_table_is_named(sim: Any) -> None:
    pa = pytest.importorskip("pyarrow")
    run = dict(sim.runs[0].columns)
    table = pa.table([*run.values(), run["x"]], names=[*run, "x"])
    with pytest.raises(SessionFormatError, match="column name 'x' appears twice"):
        Session.from_arrays([("OX+", table)], units=sim.units, rate_hz=sim.rate_hz)


def test_without_narwhals_polars_is_one_line_naming_the_extra_and_pandas_still_works(
    sim: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    for name in [m for m in sys.modules if m == "narwhals" or m.startswith("narwhals.")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "narwhals", None)
    with pytest.raises(ImportError, match=r"polars DataFrame .*pip install accelcore\[frames\]"):
        _session(sim, pl.DataFrame)
    _assert_same_session(_session(sim, pd.DataFrame), _session(sim, lambda d: d))


# ---------------------------------------------------------------- a labelled frame out


@pytest.fixture(scope="module")
def cal(sim: Any) -> accelcore.Calibration:
    return accelcore.calibrate(_session(sim, lambda d: d))


def _in_range(sim: Any, i: int = 4) -> dict[str, Any]:
    """Run i's samples inside the calibrated range (no warning)."""
    run = dict(sim.runs[i].columns)
    keep = (run["temp_c"] > 5.0) & (run["temp_c"] < 55.0)
    return {k: np.asarray(v)[keep] for k, v in run.items()}


def test_compensate_frame_labels_the_same_numbers_as_compensate(
    sim: Any, cal: accelcore.Calibration
) -> None:
    run = _in_range(sim)
    frame = pd.DataFrame(run, index=pd.RangeIndex(100, 100 + len(run["x"]), name="sample"))
    frame["note"] = "chamber A"  # a text column the model does not read is left alone
    out = cal.compensate_frame(frame)
    assert list(out.columns) == ["time_s", "temp_c", "x_g", "y_g", "z_g"]
    assert out.index.equals(frame.index)
    raw = np.column_stack([run["x"], run["y"], run["z"]])
    want = cal.compensate(raw, run["temp_c"], run["time_s"])
    np.testing.assert_array_equal(out[["x_g", "y_g", "z_g"]].to_numpy(), want, strict=True)
    np.testing.assert_array_equal(out["temp_c"].to_numpy(), run["temp_c"])
    by_polars = cal.compensate_frame(pl.DataFrame(run))
    pd.testing.assert_frame_equal(by_polars, out.reset_index(drop=True), check_exact=True)


def test_compensate_frame_takes_role_names_and_keeps_date_times(
    sim: Any, cal: accelcore.Calibration
) -> None:
    run = _in_range(sim)
    stamps = np.datetime64("2024-05-01T08:00:00", "ns") + (run["time_s"] * 1e9).astype(
        "timedelta64[ns]"
    )
    frame = pl.DataFrame(
        {"stamp": stamps, "die_c": run["temp_c"], **{f"a{k}": run[k] for k in "xyz"}}
    )
    roles = {"time": "stamp", "temperature": "die_c", "x": "ax", "y": "ay", "z": "az"}
    out = cal.compensate_frame(frame, columns=roles)
    assert list(out.columns) == ["stamp", "die_c", "x_g", "y_g", "z_g"]
    assert out["stamp"].dtype.kind == "M" and out["stamp"].iloc[0] == pd.Timestamp(stamps[0])
    plain = cal.compensate_frame(run)
    np.testing.assert_array_equal(out[["x_g", "y_g", "z_g"]], plain[["x_g", "y_g", "z_g"]])


def test_compensate_frame_errors_name_the_column_and_the_row(
    sim: Any, cal: accelcore.Calibration
) -> None:
    run = _in_range(sim)
    with pytest.raises(SessionFormatError, match=r"frame: missing column.*temp_c"):
        cal.compensate_frame({k: v for k, v in run.items() if k != "temp_c"})
    frame = pd.DataFrame(run).astype({"z": object})
    frame.loc[12, "z"] = "n/a"
    with pytest.raises(ParseError, match=r"frame, column 'z' \(column 5\), row 12"):
        cal.compensate_frame(frame)


def test_compensate_frame_warns_outside_the_calibrated_range_at_the_callers_line(
    sim: Any, cal: accelcore.Calibration
) -> None:
    with pytest.warns(accelcore.errors.TemperatureRangeWarning) as record:
        cal.compensate_frame(dict(sim.runs[0].columns))
    assert record[0].filename == __file__


# ---------------------------------------------------------------- Parquet out of the CLI


def _cli(*argv: Any) -> tuple[int, str, str]:
    import io

    from accelcore.apps import cli

    out, err = io.StringIO(), io.StringIO()
    old, sys.stderr = sys.stderr, err
    try:
        status = cli.main([str(a) for a in argv], stdout=out)
    finally:
        sys.stderr = old
    return status, out.getvalue(), err.getvalue()


def test_compensate_writes_parquet_with_the_numbers_of_compensate_frame(
    sim: Any, cal: accelcore.Calibration, tmp_path: Any
) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    cal_path, source = tmp_path / "cal.json", tmp_path / "log.csv"
    cal.save(cal_path)
    run = _in_range(sim)
    pd.DataFrame(run).to_csv(source, index=False, float_format="%.17g")
    target = tmp_path / "out.parquet"
    status, out, err = _cli("compensate", cal_path, source, "-o", target, "--chunk-rows", "333")
    assert f"compensated {len(run['x'])} rows" in out
    assert status == 0, err
    table = pq.read_table(target)
    assert table.num_rows == len(run["x"]) and table.column_names == [
        "time_s",
        "temp_c",
        "x_g",
        "y_g",
        "z_g",
    ]
    got = table.to_pandas()
    want = accelcore.Calibration.load(cal_path).compensate_frame(run)
    pd.testing.assert_frame_equal(got, want, check_exact=True)
    status, _, err = _cli("compensate", cal_path, source, "-o", tmp_path / "out.csv")
    as_csv = pd.read_csv(tmp_path / "out.csv")
    np.testing.assert_allclose(as_csv.to_numpy(), got.to_numpy(), rtol=1e-9, atol=6e-8)


def test_parquet_output_without_pyarrow_is_one_line_naming_the_extra(
    sim: Any, cal: accelcore.Calibration, tmp_path: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    cal_path, source = tmp_path / "cal.json", tmp_path / "log.csv"
    cal.save(cal_path)
    pd.DataFrame(_in_range(sim)).to_csv(source, index=False)
    for name in [m for m in sys.modules if m == "pyarrow" or m.startswith("pyarrow.")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    status, out, err = _cli("compensate", cal_path, source, "-o", tmp_path / "out.parquet")
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and "pip install accelcore[parquet]" in err, err
    assert not (tmp_path / "out.parquet").exists()


def _with_aux(sim: Any, every: int) -> list[tuple[str, dict[str, Any]]]:
    """The runs with an extra column read on every ``every``-th row only (NaN between)."""
    runs = []
    for r in sim.runs:
        cols = dict(r.columns)
        aux = np.full(len(cols["x"]), np.nan)
        aux[::every] = 3.3
        runs.append((r.orientation, {**cols, "aux": aux}))
    return runs


def test_a_column_logged_more_slowly_says_what_it_takes_away(sim: Any) -> None:
    """Rows with a NaN in any column are skipped whole: say so, with the column's name."""
    runs = _with_aux(sim, 20)
    n = len(runs[0][1]["x"])
    skipped = n - len(range(0, n, 20))
    with pytest.warns(DataQualityWarning, match=r"run \d \(O[XYZ][+-]\): .*'aux'") as seen:
        Session.from_arrays(runs, units=sim.units, rate_hz=sim.rate_hz, sensor=sim.sensor)
    first = str(seen[0].message)
    assert first.startswith("run 1 (OX+)")
    assert f"{skipped} of {n} rows" in first and "with their x, y, z" in first
    # Every run is named, once.
    assert len([w for w in seen if "skipped whole" in str(w.message)]) == len(runs)


def test_a_column_never_logged_is_refused_by_name(sim: Any) -> None:
    runs = _with_aux(sim, 10**9)
    for _, cols in runs:
        cols["aux"][:] = np.nan
    with pytest.raises(accelcore.InsufficientDataError, match=r"run 1 \(OX\+\): no row.*'aux'"):
        Session.from_arrays(runs, units=sim.units, rate_hz=sim.rate_hz, sensor=sim.sensor)
