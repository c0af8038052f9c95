"""Progress on stderr: a bar on a terminal only, never with --quiet, never in the results."""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path

import pytest

from accelcore import simulate
from accelcore.apps import cli, progress
from accelcore.apps.progress import Progress


class Terminal(io.StringIO):
    """A text stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


# ---------------------------------------------------------------- the bar itself


def test_nothing_is_written_when_the_stream_is_not_a_terminal() -> None:
    stream = io.StringIO()
    with Progress(3, stream=stream, delay_s=0.0) as bar:
        bar.step("reading")
        bar.advance()
        bar.step("fitting")
    assert stream.getvalue() == ""


def test_nothing_is_written_when_disabled_even_on_a_terminal() -> None:
    stream = Terminal()
    with Progress(3, stream=stream, enabled=False, delay_s=0.0) as bar:
        bar.step("reading")
        bar.step("fitting")
    assert stream.getvalue() == ""


def test_a_terminal_gets_a_bar_that_is_erased_at_the_end() -> None:
    stream = Terminal()
    bar = Progress(4, stream=stream, delay_s=0.0)
    bar.step("reading")
    bar.step("fitting")
    text = stream.getvalue()
    assert "\r[" in text and "1/4, fitting" in text and "\n" not in text
    bar.close()
    after = stream.getvalue()
    assert after.endswith("\r" + " " * 79 + "\r")  # the line is left blank for the results
    bar.advance()
    assert stream.getvalue() == after  # nothing after close


def test_a_short_piece_of_work_shows_no_bar(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(progress, "DELAY_S", 3600.0)
    stream = Terminal()
    with Progress(2, stream=stream) as bar:
        bar.step("reading")
        bar.step("fitting")
    assert stream.getvalue() == ""


def test_a_count_without_total_shows_the_count() -> None:
    stream = Terminal()
    with Progress(None, what="rows", stream=stream, delay_s=0.0) as bar:
        bar.advance(1_500_000)
        assert "1.50M rows" in stream.getvalue()


def test_bulk_log_lines_when_not_a_terminal() -> None:
    stream = io.StringIO()
    with Progress(2, stream=stream, log_lines=True, rate=True, delay_s=0.0) as bar:
        bar.advance(item="part1", status="ok")
        bar.advance(item="part2", status="FAILED")
    lines = stream.getvalue().splitlines()
    assert [line.split(" (")[0] for line in lines] == ["1/2 part1: ok", "2/2 part2: FAILED"]


# ---------------------------------------------------------------- the commands


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("progress") / "s"
    simulate.session(path, "ADXL335", seed=2, duration_h=0.1, soak_min=1.0)
    return path


@pytest.fixture(scope="module")
def cal_file(folder: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cal") / "cal.json"
    assert cli.main(["calibrate", str(folder), "--save", str(path), "--quiet"]) == 0
    return path


def _commands(folder: Path, cal_file: Path, out: Path) -> dict[str, list[str]]:
    return {
        "calibrate": ["calibrate", str(folder), "--no-cache"],
        "diagnose": ["diagnose", str(folder), "--no-cache"],
        "report": ["report", str(folder), "-o", str(out / "report"), "--no-cache"],
        "compensate": [
            "compensate", str(cal_file), str(folder / "x_pos.csv"), "-o", str(out / "g.csv")
        ],
    }  # fmt: skip


def _run(argv: list[str], err: io.StringIO, monkeypatch: pytest.MonkeyPatch) -> tuple[int, str]:
    out = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    status = cli.main(argv, stdout=out)
    monkeypatch.undo()
    return status, out.getvalue()


@pytest.mark.parametrize("command", ["calibrate", "diagnose", "report", "compensate"])
def test_no_progress_when_stderr_is_not_a_terminal_or_with_quiet(
    command: str,
    folder: Path,
    cal_file: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    if command == "report":
        pytest.importorskip("matplotlib")
    argv = _commands(folder, cal_file, tmp_path)[command]
    monkeypatch.setattr(progress, "DELAY_S", 0.0)  # a bar would show at once
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert "\r" not in captured.err and "[#" not in captured.err and "\r" not in captured.out
    err = Terminal()
    status, out = _run([*argv, "--quiet"], err, monkeypatch)
    assert status == 0
    assert "\r" not in err.getvalue() and "\r" not in out


@pytest.mark.parametrize("command", ["calibrate", "compensate"])
def test_a_terminal_sees_a_bar_on_stderr_and_the_results_stay_clean(
    command: str, folder: Path, cal_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(progress, "DELAY_S", 0.0)
    argv = _commands(folder, cal_file, tmp_path)[command]
    if command == "calibrate":
        argv += ["--json", "-"]
    err = Terminal()
    status, out = _run(argv, err, monkeypatch)
    assert status == 0
    assert "\r" in err.getvalue() and "\r" not in out
    if command == "calibrate":
        assert "calibrating" in err.getvalue()
        assert json.loads(out)["command"] == "calibrate"
    else:
        assert "rows compensated" in err.getvalue()
