"""Plots like the paper's Figures 4, 6 and 7, rendered with the Agg backend."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TypedDict

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib", reason="matplotlib is the [plot] extra")
matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

import accelcore  # noqa: E402
from accelcore import simulate  # noqa: E402
from accelcore.outputs import plots  # noqa: E402


class Short(TypedDict):
    duration_h: float
    soak_min: float


SHORT: Short = {"duration_h": 0.2, "soak_min": 1.0}


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> accelcore.Session:
    folder = tmp_path_factory.mktemp("plots") / "adxl335"
    simulate.session(folder, "ADXL335", seed=5, **SHORT)
    return accelcore.load_session(folder)


@pytest.fixture(scope="module")
def calibration(session: accelcore.Session) -> accelcore.Calibration:
    # The seed paper's window, which the figures' bins follow (asserted below).
    return accelcore.calibrate(session, window_c=(0.0, 60.0))


@pytest.fixture(autouse=True)
def _close_figures() -> None:
    plt.close("all")


def labels(ax: object) -> list[str]:
    return [line.get_label() for line in ax.get_lines()]  # type: ignore[attr-defined]


def save(ax: object, path: Path) -> None:
    ax.figure.savefig(path, dpi=60)  # type: ignore[attr-defined]
    assert path.is_file() and path.stat().st_size > 5000
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_raw_vs_decimated_like_figure_4(
    session: accelcore.Session, calibration: accelcore.Calibration, tmp_path: Path
) -> None:
    ax = plots.plot_raw_vs_decimated(session, calibration=calibration)
    save(ax, tmp_path / "fig4.png")
    assert ax.get_xlabel() == "temperature (°C)"
    assert ax.get_ylabel() == "z output (V)"  # default: the OZ+ run's vertical axis
    assert "OZ+" in ax.get_title()
    assert labels(ax) == [
        "raw (20 Hz)",
        "decimated (2 Hz)",
        "0.5 °C bin means",
        "calibration (joint)",
    ]
    raw, decimated, bins, model = ax.get_lines()
    run = next(r for r in session.runs if r.orientation == "OZ+")
    assert np.asarray(raw.get_xdata()).size == run.stats.n_rows
    assert np.asarray(decimated.get_xdata()).size == len(run)
    # The model line is offset + sensitivity at each temperature: at T_ref, +1 g output.
    t, y = np.asarray(model.get_xdata()), np.asarray(model.get_ydata())
    s = calibration.axis("z")
    assert np.interp(25.0, t, y) == pytest.approx(s.zero_g_offset + s.sensitivity, abs=1e-6)
    # Bin means lie on the model line within the noise.
    bx, by = np.asarray(bins.get_xdata()), np.asarray(bins.get_ydata())
    assert np.all(np.abs(by - np.interp(bx, t, y)) < 3e-3)


def test_raw_vs_decimated_choices(session: accelcore.Session, tmp_path: Path) -> None:
    ax = plots.plot_raw_vs_decimated(session, run="OX-", max_raw_points=500)
    save(ax, tmp_path / "fig4b.png")
    assert ax.get_ylabel() == "x output (V)"
    assert labels(ax)[0].startswith("raw (20 Hz, every")
    assert np.asarray(ax.get_lines()[0].get_xdata()).size <= 500
    assert labels(ax)[-1] == "linear fit of bins"
    _, own = plt.subplots()
    assert plots.plot_raw_vs_decimated(session, 1, "y", ax=own, raw=False) is own
    assert labels(own)[0] == "decimated (2 Hz)" and own.get_ylabel() == "y output (V)"
    with pytest.raises(ValueError, match="no run 'OQ\\+'"):
        plots.plot_raw_vs_decimated(session, run="OQ+")
    with pytest.raises(ValueError, match="axis must be"):
        plots.plot_raw_vs_decimated(session, axis="w")


def test_in_memory_session_has_no_raw_layer() -> None:
    sim = simulate.arrays("ADXL335", seed=2, orientations=("OZ+",), **SHORT)
    session = accelcore.Session.from_arrays(
        [(r.orientation, r.columns) for r in sim.runs], units="V", rate_hz=20.0
    )
    ax = plots.plot_raw_vs_decimated(session)
    assert labels(ax)[0] == "decimated (2 Hz)"


def test_sensitivity_vs_temperature_like_figure_6(
    session: accelcore.Session, calibration: accelcore.Calibration, tmp_path: Path
) -> None:
    axes = plots.plot_sensitivity_vs_temperature(session, calibration)
    save(axes[0], tmp_path / "fig6.png")
    assert len(axes) == 3 and len({id(a) for a in axes}) == 3
    for ax, name in zip(axes, "xyz", strict=True):
        assert ax.get_xlabel() == "temperature (°C)"
        assert ax.get_ylabel() == "sensitivity (V/g)"
        assert ax.get_title() == f"ADXL335 {name.upper()}"
        points, line = ax.get_lines()
        assert points.get_label() == "bins (V₊−V₋)/2"
        s = calibration.axis(name)
        assert line.get_label() == f"fit {s.sensitivity_tc_pct_per_c:+.4f} %/°C"
        t, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
        assert np.interp(25.0, t, y) == pytest.approx(s.sensitivity, rel=1e-9)
        bx, by = np.asarray(points.get_xdata()), np.asarray(points.get_ydata())
        assert bx.min() >= 0.0 and bx.max() < 60.0  # the calibration window
        assert np.median(np.abs(by - np.interp(bx, t, y))) < 5e-4


def test_offset_vs_temperature_like_figure_7(
    session: accelcore.Session, calibration: accelcore.Calibration, tmp_path: Path
) -> None:
    fig, ax = plt.subplots()
    axes = plots.plot_offset_vs_temperature(session, calibration, ax=ax)
    fig.savefig(tmp_path / "fig7.png", dpi=60)
    assert (tmp_path / "fig7.png").stat().st_size > 5000
    assert axes == [ax, ax, ax]
    assert ax.get_ylabel() == "zero-g offset (V)"
    names = labels(ax)
    assert names[0::2] == ["x: bins (V₊+V₋)/2", "y: bins (V₊+V₋)/2", "z: bins (V₊+V₋)/2"]
    assert names[5] == f"z: fit {calibration.axis('z').offset_tc_mg_per_c:+.3f} mg/°C"
    t, y = (np.asarray(v) for v in (ax.get_lines()[5].get_xdata(), ax.get_lines()[5].get_ydata()))
    assert np.interp(25.0, t, y) == pytest.approx(calibration.axis("z").zero_g_offset, rel=1e-9)
    # One panel per axis when given a sequence; a subset of axes.
    fig, panels = plt.subplots(1, 2)
    got = plots.plot_offset_vs_temperature(session, calibration, ax=panels, sensor_axes=["y", "z"])
    assert got == list(panels)
    with pytest.raises(ValueError, match="2 Axes for 3"):
        plots.plot_offset_vs_temperature(session, calibration, ax=panels)


def test_paired_plots_say_when_a_pair_is_missing(tmp_path: Path) -> None:
    folder = tmp_path / "z-only"
    simulate.session(folder, "ADXL335", seed=3, orientations=("OZ+", "OZ-", "OX+"), **SHORT)
    session = accelcore.load_session(folder)
    cal = accelcore.calibrate(session, "paper")  # x and y: not identified (NaN)
    axes = plots.plot_sensitivity_vs_temperature(session, cal)
    assert [len(a.get_lines()) for a in axes] == [0, 0, 2]
    assert "no OX+ / OX- pair" in axes[0].texts[0].get_text()
    save(axes[0], tmp_path / "partial.png")


def test_without_matplotlib_the_error_says_how_to_install(
    session: accelcore.Session, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match=r"pip install accelcore\[plot\]"):
        plots.plot_raw_vs_decimated(session)
