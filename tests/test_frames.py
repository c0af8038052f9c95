"""DataFrames in: pandas, polars and pyarrow tables give one session; errors name run/column/row."""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import pandas as pd
import pytest

import accelcore
from accelcore import simulate
from accelcore.errors import ParseError, SessionFormatError
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
