"""A temperature no thermometer reads is refused at its position, never averaged in.

A flight log's garbage message (DataFlash has no checksum) decoded as -4e21 °C, and a
CSV cell of 1e30, made ``calibrate`` end in a traceback (a histogram of 1e30 bins);
averaged into a block, such a value would move every fit in silence. Every reader
refuses it where it is: file, line and column (or message, or run and row).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import accelcore
from accelcore import simulate
from accelcore.input.readers.orientation_log import read_orientation_log
from accelcore.input.session import Session, load_session


def _columns(seed: int = 1) -> dict[str, np.ndarray]:
    sim = simulate.arrays(
        "ADXL335", seed=seed, duration_h=0.05, soak_min=0.5, orientations=("OZ+",)
    )
    return {k: v.copy() for k, v in sim.runs[0].columns.items()}


@pytest.mark.parametrize("value", [1e30, -300.0, -6.08e26])
def test_from_arrays_names_run_column_and_row(value: float) -> None:
    cols = _columns()
    cols["temp_c"][123] = value
    with pytest.raises(
        accelcore.ParameterError,
        match=r"run 1 \(OZ\+\): column 'temp_c', row 123: "
        r"temperature .* is not one in °C",
    ):
        Session.from_arrays([("OZ+", cols)], units="V", rate_hz=20.0)


def test_a_session_file_names_file_line_and_column(tmp_path: Path) -> None:
    sim = simulate.session(tmp_path / "s", "ADXL335", seed=2, duration_h=0.05, soak_min=0.5)
    path = sim.path / "x_pos.csv"
    lines = path.read_text().splitlines()
    cells = lines[500].split(",")
    cells[1] = "1e30"
    lines[500] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(accelcore.ParseError) as info:
        load_session(sim.path, cache=False)
    assert (info.value.line, info.value.column) == (501, 2)
    assert "column 'temp_c': 1e30 is not a temperature in °C" in str(info.value)


def test_a_one_log_session_names_line_and_column(tmp_path: Path) -> None:
    cols = _columns(3)
    n = cols["time_s"].size
    cols["temp_c"][40] = -1e9
    lines = ["time_s,temp_c,x,y,z,orientation"]
    lines += [
        f"{cols['time_s'][i]:.3f},{cols['temp_c'][i]:g},{cols['x'][i]},{cols['y'][i]},"
        f"{cols['z'][i]},OZ+"
        for i in range(n)
    ]
    log = tmp_path / "chamber.csv"
    log.write_text("\n".join(lines) + "\n")
    with pytest.raises(accelcore.ParseError) as info:
        read_orientation_log(log, units="V", rate_hz=20.0)
    assert (info.value.line, info.value.column) == (42, 2), str(info.value)
    assert "temperature -1.000000e+09 is not one in °C" in str(info.value)
