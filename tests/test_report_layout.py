"""The HTML report as a reader sees it: tables that fit the page, plain headers, the lab
record, date and version, a print stylesheet, one residual panel per axis, no line for a
term that was not identified, and a fleet page that names every part's pass or fail."""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

matplotlib = pytest.importorskip("matplotlib", reason="matplotlib is the [plot] extra")
matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

import accelcore  # noqa: E402
from accelcore import simulate  # noqa: E402
from accelcore.apps import bulk  # noqa: E402
from accelcore.outputs import plots, report  # noqa: E402
from accelcore.outputs.diagnosis_plot import plot_residuals_per_axis  # noqa: E402
from accelcore.outputs.report.fleet import FLEET_COLUMNS  # noqa: E402

LAB = {
    "date": "2024-05-14",
    "operator": "A. Tester",
    "chamber": "Votsch VT 4002 slot 3",
    "reference_probe": "PT100 class A #17",
    "notes": "Board on the aluminium cube; the chamber door was opened once at 40 °C "
    "for a visual check of the harness, which is a long note that has to wrap in its cell.",
}
EPOCH = 1_700_000_000  # 2023-11-14 22:13 UTC
STAMP = "Report written 2023-11-14 22:13 UTC by accelcore"
A4_CONTENT_PX = 703  # 210 mm less 2 x 12 mm margins, at 96 px per inch


def _with_lab(folder: Path, lab: dict[str, str]) -> None:
    body = "".join(f"{k} = {json.dumps(v)}\n" for k, v in lab.items())
    with (folder / "session.toml").open("a", encoding="utf-8") as fh:
        fh.write(f"\n[lab]\n{body}")


@pytest.fixture(scope="module")
def session_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("layout") / "part-with-lab"
    simulate.session(folder, "ADXL335", seed=12, duration_h=0.5, soak_min=2.0, serial="SN-42")
    _with_lab(folder, LAB)
    return folder


@pytest.fixture(scope="module")
def session_page(
    session_dir: Path, tmp_path_factory: pytest.TempPathFactory, monkeypatch_module: Any
) -> Path:
    monkeypatch_module.setenv("SOURCE_DATE_EPOCH", str(EPOCH))
    return report.session_report(session_dir, tmp_path_factory.mktemp("layout-session"))


@pytest.fixture(scope="module")
def monkeypatch_module() -> Any:
    mp = pytest.MonkeyPatch()
    yield mp
    mp.undo()


@pytest.fixture(scope="module")
def bulk_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("layout-fleet")
    archive = root / "archive"
    for i in range(3):
        folder = archive / "lot2" / f"part{i}"
        simulate.session(folder, "ADXL335", seed=30 + i, duration_h=0.3, serial=f"SN-{100 + i}")
        if i < 2:  # the third session has no [lab] table
            _with_lab(folder, {**LAB, "operator": f"operator {i}"})
    broken = archive / "lot2" / "broken"
    broken.mkdir(parents=True)
    (broken / "session.toml").write_text("this is not = [valid toml\n")
    bulk.bulk(archive, root / "out", jobs=1, progress=False)
    return root / "out"


@pytest.fixture(scope="module")
def fleet_page(bulk_out: Path, monkeypatch_module: Any) -> Path:
    monkeypatch_module.setenv("SOURCE_DATE_EPOCH", str(EPOCH))
    return report.fleet_report(bulk_out)


def _section(text: str, sid: str) -> str:
    start = text.index(f'<section id="{sid}">')
    return text[start : text.index("</section>", start)]


def _rows(part: str) -> list[list[str]]:
    """The body rows of the first table in ``part``, cells as plain text."""
    body = part[part.index("<tbody>") : part.index("</tbody>")]
    return [
        [_plain(c) for c in re.findall(r"<td[^>]*>(.*?)</td>", row, re.S)]
        for row in re.findall(r"<tr>(.*?)</tr>", body, re.S)
    ]


def _plain(cell: str) -> str:
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", cell)).split())


# ---------------------------------------------------------------------- page text
@pytest.mark.parametrize("which", ["session", "fleet"])
def test_headers_are_plain_words(which: str, request: pytest.FixtureRequest) -> None:
    text = request.getfixturevalue(f"{which}_page").read_text(encoding="utf-8")
    headers = [html.unescape(h) for h in re.findall(r"<th[^>]*>(.*?)</th>", text, re.S)]
    assert len(headers) > 20
    assert [h for h in headers if "_" in h] == []


@pytest.mark.parametrize("which", ["session", "fleet"])
def test_date_version_and_print_stylesheet(which: str, request: pytest.FixtureRequest) -> None:
    text = request.getfixturevalue(f"{which}_page").read_text(encoding="utf-8")
    head = text[: text.index("<nav>")]
    foot = text[text.index("<footer") :]
    for part in (head, foot):
        assert f"{STAMP} {accelcore.__version__}" in part
    css = text[text.index("<style>") : text.index("</style>")]
    printed = css[css.index("@media print") :]
    assert "size: A4" in printed
    assert re.search(r"nav\s*\{\s*display:\s*none", printed)
    assert re.search(r"(table|figure)[^{]*\{[^}]*break-inside:\s*avoid", printed)


def test_session_page_shows_the_lab_record(session_page: Path) -> None:
    part = _section(session_page.read_text(encoding="utf-8"), "lab")
    cells = dict((r[0], r[1]) for r in re.findall(r"<th>(.*?)</th><td[^>]*>(.*?)</td>", part))
    shown = {k: html.unescape(v) for k, v in cells.items()}
    assert shown == {
        "Date": LAB["date"],
        "Operator": LAB["operator"],
        "Chamber": LAB["chamber"],
        "Reference probe": LAB["reference_probe"],
        "Notes": LAB["notes"],
    }


def test_fleet_table_and_page_carry_the_lab_fields(bulk_out: Path, fleet_page: Path) -> None:
    fleet = pd.read_csv(bulk_out / "fleet.csv", dtype=str, keep_default_na=False)
    lab_columns = [c for c in FLEET_COLUMNS if c.startswith("lab_")]
    assert lab_columns == [f"lab_{k}" for k in LAB]
    by_session = fleet.groupby("session").first()
    assert by_session.loc["lot2/part0", "lab_operator"] == "operator 0"
    assert by_session.loc["lot2/part1", "lab_chamber"] == LAB["chamber"]
    assert (by_session.loc["lot2/part2", lab_columns] == "").all()  # no [lab] table
    rows = _rows(_section(fleet_page.read_text(encoding="utf-8"), "lab"))
    assert [r[:4] for r in rows] == [
        ["SN-100", "lot2/part0", LAB["date"], "operator 0"],
        ["SN-101", "lot2/part1", LAB["date"], "operator 1"],
        ["SN-102", "lot2/part2", "", ""],
    ]


def test_fleet_page_lists_every_part_with_pass_or_fail(bulk_out: Path, fleet_page: Path) -> None:
    fleet = pd.read_csv(bulk_out / "fleet.csv", dtype=str, keep_default_na=False)
    rows = _rows(_section(fleet_page.read_text(encoding="utf-8"), "parts"))
    by_session = {r[1]: r for r in rows}
    assert set(by_session) == {"lot2/part0", "lot2/part1", "lot2/part2", "lot2/broken"}
    for session, part in fleet.groupby("session"):
        serial, _, sensor, result, failed = by_session[str(session)][:5]
        assert serial == part["serial"].iloc[0] and sensor == "ADXL335"
        out = [
            f"{a} {name}"
            for a, flags in zip(part["axis"], part.to_dict(orient="records"), strict=True)
            for col, name in (
                ("zero_g_offset_in_spec", "zero-g offset"),
                ("sensitivity_in_spec", "sensitivity"),
                ("offset_tc_in_spec", "offset TC"),
                ("sensitivity_tc_in_spec", "sensitivity TC"),
            )
            if flags[col] == "False"
        ]
        # The simulated ADXL335 has the paper's out-of-spec z temperature coefficients.
        assert out == ["z offset TC", "z sensitivity TC"]
        assert result == "fail" and failed == ", ".join(out)
    assert by_session["lot2/broken"][3] == "not calibrated"
    assert "load" in by_session["lot2/broken"][4]


def test_small_fleet_gets_points_a_large_one_histograms(fleet_page: Path, tmp_path: Path) -> None:
    text = fleet_page.read_text(encoding="utf-8")
    assert text.count("each part with its standard error") == 2 and "histogram" not in text
    # A fleet of 25 parts (made-up values) gets histograms instead.
    rng = np.random.default_rng(1)
    rows = [
        {
            "session": f"lot/p{i}",
            "serial": f"S{i}",
            "sensor": "ADXL335",
            "axis": a,
            "offset_tc_mg_per_c": rng.normal(0.2, 0.1),
            "sensitivity_tc_pct_per_c": rng.normal(0.004, 0.001),
        }
        for i in range(25)
        for a in "xyz"
    ]
    pd.DataFrame(rows).to_csv(tmp_path / "fleet.csv", index=False)
    big = report.fleet_report(tmp_path).read_text(encoding="utf-8")
    assert big.count("histogram;") == 2 and "each part with its standard error" not in big


# ---------------------------------------------------------------------- figures
@pytest.fixture(scope="module")
def one_orientation(tmp_path_factory: pytest.TempPathFactory) -> accelcore.Session:
    folder = tmp_path_factory.mktemp("one") / "oz"
    simulate.session(folder, "ADXL335", seed=3, duration_h=0.3, soak_min=1.0, orientations=["OZ+"])
    return accelcore.load_session(folder)


def _fit_lines(axes: list[Any]) -> list[str]:
    return [
        str(line.get_label())
        for ax in axes
        for line in ax.get_lines()
        if "fit" in str(line.get_label())
    ]


def test_no_fitted_line_for_a_term_not_identified(
    one_orientation: accelcore.Session, session_dir: Path
) -> None:
    cal = accelcore.calibrate(one_orientation)
    assert "z:sensitivity" in cal.not_identified
    axes = plots.plot_sensitivity_vs_temperature(one_orientation, cal)
    assert _fit_lines(axes) == []
    for ax, a in zip(axes, "xyz", strict=True):
        said = " ".join(t.get_text() for t in ax.texts)
        assert "not identified" in said and f"{a}:sensitivity" in said
    offset = plots.plot_offset_vs_temperature(one_orientation, cal)
    # x and y offsets are identified (no gravity on them); z's only combined with the gain.
    assert [ax.get_lines() != [] for ax in offset] == [True, True, False]
    plt.close("all")
    full = accelcore.load_session(session_dir)  # six orientations: every line is drawn
    assert (
        len(_fit_lines(plots.plot_sensitivity_vs_temperature(full, accelcore.calibrate(full)))) == 3
    )
    plt.close("all")


def test_residuals_one_panel_per_axis_with_a_binned_trend(session_dir: Path) -> None:
    session = accelcore.load_session(session_dir)
    diag = accelcore.diagnose(session, max_steps=1)
    fig = plot_residuals_per_axis(diag, "elapsed_s")
    try:
        assert len(fig.axes) == 6  # x, y, z rows by temperature and elapsed time
        grid = np.array(fig.axes).reshape(3, 2)
        assert [ax.get_ylabel() for ax in grid[:, 0]] == [
            "x error (mg)",
            "y error (mg)",
            "z error (mg)",
        ]
        for col in range(2):
            column = grid[:, col]
            assert all(column[0].get_shared_x_axes().joined(column[0], ax) for ax in column)
            for ax in column:
                points = ax.get_lines()[0]
                assert np.asarray(points.get_xdata()).size <= plots.MAX_POINTS
                trend = [
                    ln for ln in ax.get_lines() if ln.get_label() in ("binned mean", "diagnosed")
                ]
                assert len(trend) == 1 and 5 < np.asarray(trend[0].get_xdata()).size < 200
        assert grid[2, 0].get_xlabel() == "temperature (°C)"
        assert grid[2, 1].get_xlabel() == "elapsed time (s)"
    finally:
        plt.close(fig)


def test_figure4_thins_points_and_shows_averaging(session_dir: Path) -> None:
    session = accelcore.load_session(session_dir)
    cal = accelcore.calibrate(session)
    fig, (top, bottom) = plt.subplots(2, 1)
    plots.plot_raw_vs_decimated(session, ax=top, calibration=cal, max_raw_points=plots.MAX_POINTS)
    plots.plot_averaging(session, ax=bottom, calibration=cal)
    try:
        for ax in (top, bottom):
            assert all(np.asarray(ln.get_xdata()).size <= plots.MAX_POINTS for ln in ax.get_lines())
        raw, averaged = (str(ln.get_label()) for ln in bottom.get_lines()[:2])
        sigma = [float(re.search(r"σ ([0-9.e+-]+) mg", s).group(1)) for s in (raw, averaged)]  # type: ignore[union-attr]
        assert raw.startswith("raw, 20 Hz") and averaged.startswith("2 Hz averages")
        assert sigma[1] < 0.6 * sigma[0]  # averaging 10 samples narrows the scatter
    finally:
        plt.close(fig)


def test_stride_is_deterministic_and_bounded() -> None:
    assert plots.stride(100) == 1 and plots.stride(5000) == 1 and plots.stride(5001) == 2
    assert all(len(range(0, n, plots.stride(n, 700))) <= 700 for n in (1, 699, 700, 701, 10**6))


# ---------------------------------------------------------------------- headless browser
_BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
# After load: every table's right edge against the body's content box, and the page's width.
_MEASURE = """<script>
window.addEventListener("load", function () {
  var body = document.body, cs = getComputedStyle(body);
  var right = body.getBoundingClientRect().right - parseFloat(cs.paddingRight);
  var tables = Array.prototype.map.call(document.querySelectorAll("table"), function (t) {
    var box = t.parentElement;
    return {name: (t.className || "") + ":" + (t.querySelector("th") || {}).textContent,
            right: t.getBoundingClientRect().right, limit: right,
            scroll: box.scrollWidth, client: box.clientWidth};
  });
  var p = document.createElement("pre");
  p.id = "measure";
  p.textContent = JSON.stringify({tables: tables, page: document.documentElement.scrollWidth,
                                  window: window.innerWidth,
                                  nav: getComputedStyle(document.querySelector("nav")).display});
  body.appendChild(p);
});
</script>"""


def _browser() -> str:
    for name in _BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    pytest.skip(f"no headless browser on PATH (looked for {', '.join(_BROWSERS)})")


def _measure(page: Path, tmp_path: Path, width: int, *, printed: bool) -> dict[str, Any]:
    text = page.read_text(encoding="utf-8")
    if printed:  # lay the page out with its print rules, at A4's printable width
        text = text.replace("@media print", "@media all")
    probe = tmp_path / f"measure-{width}-{printed}.html"
    probe.write_text(text.replace("</body>", _MEASURE + "</body>", 1), encoding="utf-8")
    cmd = [
        _browser(),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--hide-scrollbars",
        f"--user-data-dir={tmp_path / f'profile-{width}-{printed}'}",
        f"--window-size={width},2000",
        "--virtual-time-budget=10000",
        "--dump-dom",
        probe.as_uri(),
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    match = re.search(r'<pre id="measure">(.*?)</pre>', done.stdout, re.S)
    assert match, done.stdout[-2000:]
    return dict(json.loads(html.unescape(match.group(1))))


@pytest.mark.parametrize(("which", "n_tables"), [("session", 7), ("fleet", 5)])
@pytest.mark.parametrize(("width", "printed"), [(1280, False), (A4_CONTENT_PX, True)])
def test_every_table_fits_the_page_in_headless_chromium(
    which: str,
    n_tables: int,
    width: int,
    printed: bool,
    request: pytest.FixtureRequest,
    tmp_path: Path,
) -> None:
    page: Path = request.getfixturevalue(f"{which}_page")
    got = _measure(page, tmp_path, width, printed=printed)
    assert len(got["tables"]) >= n_tables
    over = [
        t for t in got["tables"] if t["right"] > t["limit"] + 1 or t["scroll"] > t["client"] + 1
    ]
    assert over == [], f"tables running off a {width} px page: {over}"
    assert got["page"] <= got["window"]
    assert got["nav"] == ("none" if printed else "block")
