"""HTML reports: one session and a bulk output, checked as text and in headless Chromium."""

from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

matplotlib = pytest.importorskip("matplotlib", reason="matplotlib is the [plot] extra")
matplotlib.use("Agg")

import accelcore  # noqa: E402
from accelcore import simulate  # noqa: E402
from accelcore.apps import bulk  # noqa: E402
from accelcore.apps.cli import main  # noqa: E402
from accelcore.outputs import report  # noqa: E402

SERIAL = 'SN<7>&"q"'  # HTML metacharacters: must come out escaped
SESSION_SECTIONS = ("summary", "datasheet", "figures", "diagnosis", "notes", "provenance")
FLEET_SECTIONS = ("fleet-plots", "spec-counts", "fleet-table", "failures", "provenance")
N_SESSION_IMAGES = 4  # Figures 4, 6, 7 and the residuals before/after
N_FLEET_IMAGES = 2  # one sensor type x two temperature coefficients
DATA_IMG = re.compile(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)"')


@pytest.fixture(scope="module")
def session_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("report") / "adxl335-part"
    simulate.session(folder, "ADXL335", seed=11, duration_h=0.5, soak_min=2.0, serial=SERIAL)
    return folder


@pytest.fixture(scope="module")
def session_page(session_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return report.session_report(session_dir, tmp_path_factory.mktemp("session-report"))


@pytest.fixture(scope="module")
def bulk_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("fleet")
    archive = root / "archive"
    for i in range(3):
        simulate.session(archive / "lot1" / f"part{i}", "ADXL335", seed=20 + i, duration_h=0.3)
    broken = archive / "lot1" / "broken"
    broken.mkdir(parents=True)
    (broken / "session.toml").write_text("this is not = [valid toml\n")
    result = bulk.bulk(archive, root / "out", jobs=1, progress=False)
    assert len(result.failures) == 1
    return root / "out"


@pytest.fixture(scope="module")
def fleet_page(bulk_out: Path) -> Path:
    return report.fleet_report(bulk_out)


def _self_contained(text: str) -> None:
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", text, re.I)
    assert "http://" not in text and "https://" not in text
    assert "<script" not in text.lower() and "<link" not in text.lower()
    assert "<iframe" not in text.lower() and "@import" not in text


def _images(text: str) -> list[bytes]:
    assert text.count("<img") == len(DATA_IMG.findall(text))  # every image is a data: URI
    return [base64.b64decode(m) for m in DATA_IMG.findall(text)]


# ---------------------------------------------------------------------- session report
def test_session_report_sections_and_figures(session_page: Path) -> None:
    assert session_page.name == "index.html"
    text = session_page.read_text(encoding="utf-8")
    for sid in SESSION_SECTIONS:
        assert f'<section id="{sid}">' in text
    for heading in (
        "Datasheet comparison",
        "Tables 3/4",
        "Tables 5/6",
        "Figure 4",
        "Figure 6",
        "Figure 7",
        "Diagnosis",
        "Residual",
        "Provenance",
    ):
        assert heading in text
    images = _images(text)
    assert len(images) == N_SESSION_IMAGES
    assert all(png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 5000 for png in images)
    _self_contained(text)
    assert 'class="note"' not in text  # every section rendered, none fell back to a note


def test_session_report_content(session_page: Path, session_dir: Path) -> None:
    text = session_page.read_text(encoding="utf-8")
    assert "ADXL335" in text and "adxl335-part" in text
    # The simulated ADXL335 has the paper's out-of-spec Z temperature coefficients.
    assert 'class="out"' in text and 'class="ok"' in text
    assert accelcore.__version__ in text
    for name in ("session.toml", "z_pos.csv"):
        assert name in text
    cal = accelcore.calibrate(accelcore.load_session(session_dir))
    for digest in cal.file_digests()[1].values():
        assert digest in text
    # Text from the data is escaped.
    assert SERIAL not in text
    assert "SN&lt;7&gt;&amp;&quot;q&quot;" in text


def test_session_report_from_objects(session_dir: Path, tmp_path: Path) -> None:
    session = accelcore.load_session(session_dir)
    cal = accelcore.calibrate(session)
    diag = accelcore.diagnose(session, cal, max_steps=1)
    page = report.session_report(session, tmp_path / "r", calibration=cal, diagnosis=diag)
    text = page.read_text(encoding="utf-8")
    assert len(_images(text)) == N_SESSION_IMAGES
    assert not list((tmp_path / "r").glob(".*tmp"))  # written atomically


def test_session_report_without_pairs_notes_instead_of_failing(tmp_path: Path) -> None:
    folder = tmp_path / "one"
    simulate.session(folder, "ADXL335", seed=3, duration_h=0.3, soak_min=1.0, orientations=["OZ+"])
    text = report.session_report(folder, tmp_path / "r").read_text(encoding="utf-8")
    for sid in SESSION_SECTIONS:
        assert f'<section id="{sid}">' in text
    assert "Not identified" in text
    _self_contained(text)


# ---------------------------------------------------------------------- fleet report
def test_fleet_report(fleet_page: Path, bulk_out: Path) -> None:
    assert fleet_page == bulk_out / "index.html"
    text = fleet_page.read_text(encoding="utf-8")
    for sid in FLEET_SECTIONS:
        assert f'<section id="{sid}">' in text
    assert len(_images(text)) == N_FLEET_IMAGES
    _self_contained(text)
    assert "datasheet limits dashed red" in text
    for i in range(3):
        assert f"lot1/part{i}" in text
    assert "lot1/broken" in text and "load" in text  # the failures.csv row
    assert text.count("<tr>") >= 1 + 9 + 1  # fleet header and 3 parts x 3 axes, failure row


def test_fleet_report_elsewhere_and_errors(bulk_out: Path, tmp_path: Path) -> None:
    page = report.fleet_report(bulk_out, tmp_path / "elsewhere")
    assert page == tmp_path / "elsewhere" / "index.html"
    assert report.is_bulk_output(bulk_out) and not report.is_bulk_output(tmp_path)
    with pytest.raises(FileNotFoundError, match=r"fleet\.csv"):
        report.fleet_report(tmp_path)
    (tmp_path / "fleet.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="missing column"):
        report.fleet_report(tmp_path)


# ---------------------------------------------------------------------- command line
def test_cli_report(
    session_dir: Path, bulk_out: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["report", str(session_dir), "-o", str(tmp_path / "s")]) == 0
    assert len(_images((tmp_path / "s" / "index.html").read_text(encoding="utf-8"))) == 4
    assert main(["report", str(bulk_out), "-o", str(tmp_path / "f")]) == 0
    assert (tmp_path / "f" / "index.html").is_file()
    capsys.readouterr()

    assert main(["report", str(session_dir)]) == 2  # a session needs -o
    assert "needs -o DIR" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "missing"), "-o", str(tmp_path / "x")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "missing" in err
    assert main(["report", str(tmp_path), "-o", str(tmp_path / "x")]) == 1
    assert "neither a session folder" in capsys.readouterr().err
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "session.toml").write_text('units = "V"\n')
    assert main(["report", str(bad), "-o", str(tmp_path / "x")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(bad) in err


def test_cli_report_help(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", "--help"]) == 0
    out = capsys.readouterr().out
    assert "example:" in out and "accelcore report" in out and "fleet.csv" in out


# ---------------------------------------------------------------------- headless browser
_BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

# Injected into a copy of the page: record errors (script errors and failed
# resource loads, by capture) and, after load, every image's natural size.
_PROBE_HEAD = """<script>
window.__errors = [];
window.addEventListener("error", function (e) {
  var t = e.target;
  window.__errors.push(e.message || ("failed to load " + (t && (t.src || t.href))));
}, true);
</script>"""
_PROBE_BODY = """<script>
window.addEventListener("load", function () {
  var imgs = Array.prototype.map.call(document.images, function (i) {
    return [i.naturalWidth, i.naturalHeight, i.complete];
  });
  var p = document.createElement("pre");
  p.id = "probe";
  p.textContent = JSON.stringify({images: imgs, errors: window.__errors});
  document.body.appendChild(p);
});
</script>"""


def _browser() -> str:
    for name in _BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    pytest.skip(
        f"no headless browser on PATH (looked for {', '.join(_BROWSERS)}); "
        "install Debian's chromium to run this test"
    )


def _run_browser(browser: str, profile: Path, *args: str) -> subprocess.CompletedProcess[str]:
    cmd = [
        browser,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
        "--hide-scrollbars",
        f"--user-data-dir={profile}",
        *args,
    ]
    try:
        return subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{browser} did not finish within 120 s: {' '.join(cmd)}")


def _probe(browser: str, page: Path, tmp_path: Path) -> tuple[str, dict[str, Any]]:
    text = page.read_text(encoding="utf-8")
    probed = page.with_name("probe.html")
    probed.write_text(
        text.replace("</title>", "</title>" + _PROBE_HEAD, 1).replace(
            "</body>", _PROBE_BODY + "</body>", 1
        ),
        encoding="utf-8",
    )
    done = _run_browser(
        browser,
        tmp_path / "profile-dom",
        "--virtual-time-budget=10000",
        "--dump-dom",
        probed.as_uri(),
    )
    assert done.returncode == 0, done.stderr[-2000:]
    match = re.search(r'<pre id="probe">(.*?)</pre>', done.stdout, re.S)
    assert match, f"the page did not finish loading:\n{done.stdout[-2000:]}"
    import html

    return done.stdout, json.loads(html.unescape(match.group(1)))


@pytest.mark.parametrize("which", ["session", "fleet"])
def test_renders_in_headless_chromium(
    which: str, request: pytest.FixtureRequest, tmp_path: Path
) -> None:
    browser = _browser()
    page: Path = request.getfixturevalue(f"{which}_page")
    copy = tmp_path / "page" / "index.html"
    copy.parent.mkdir()
    shutil.copy(page, copy)
    dom, probe = _probe(browser, copy, tmp_path)
    sections = SESSION_SECTIONS if which == "session" else FLEET_SECTIONS
    for sid in sections:
        assert f'<section id="{sid}">' in dom
    assert probe["errors"] == []
    expected = N_SESSION_IMAGES if which == "session" else N_FLEET_IMAGES
    assert len(probe["images"]) == expected
    for width, height, complete in probe["images"]:
        assert complete and width > 100 and height > 100

    shot = tmp_path / "shot.png"
    done = _run_browser(
        browser,
        tmp_path / "profile-shot",
        "--window-size=1280,2000",
        f"--screenshot={shot}",
        copy.as_uri(),
    )
    assert done.returncode == 0, done.stderr[-2000:]
    import matplotlib.image as mpimg
    import numpy as np

    pixels = np.asarray(mpimg.imread(shot))
    assert pixels.shape[:2] == (2000, 1280)
    assert float(pixels[..., :3].std()) > 0.05  # not a blank page
