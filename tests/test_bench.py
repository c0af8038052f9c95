"""The benchmark runner's bookkeeping (no timing is asserted: the clock is faked)."""

from __future__ import annotations

import gc
import json
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from accelcore.apps import bench


class FakeClock:
    """``perf_counter`` that advances only when the measured function runs."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> FakeClock:
    fake = FakeClock()
    monkeypatch.setattr("accelcore.apps.bench.time.perf_counter", fake)
    return fake


def test_warm_up_runs_until_the_time_has_passed(clock: FakeClock) -> None:
    calls: list[float] = []

    def fn() -> None:
        calls.append(clock.now)
        clock.now += 0.1

    # 0.1 s per call: after 3 calls 0.3 s >= 0.25 s have passed.
    assert bench.warm_up(fn, 0.25) == 3
    assert calls == pytest.approx([0.0, 0.1, 0.2])


def test_warm_up_calls_at_least_once(clock: FakeClock) -> None:
    def slow() -> None:
        clock.now += 5.0

    assert bench.warm_up(slow, 0.25) == 1
    assert bench.warm_up(slow, 0.0) == 1


def test_measure_takes_memory_then_warms_up_then_times(
    clock: FakeClock, monkeypatch: pytest.MonkeyPatch
) -> None:
    order: list[str] = []
    phase = ["warm"]

    def fn() -> None:
        order.append(phase[0])
        clock.now += 0.2

    def peak(f: object) -> float:
        phase[0] = "memory"
        fn()
        phase[0] = "timed"
        return 1.5

    monkeypatch.setattr(bench, "peak_rss_growth_mb", peak)
    row = bench.measure("x", fn, n=10, repeat=3, warmup_s=0.3)
    # One untimed call, the memory call, two warm-up calls (0.4 s >= 0.3 s), 3 timed ones.
    assert order == ["warm", "memory", "timed", "timed", "timed", "timed", "timed"]
    assert row.peak_mb == 1.5
    assert row.wall_s == pytest.approx(0.2)
    assert row.rate == pytest.approx(10 / 0.2)


def test_measure_times_with_the_collector_disabled_and_restores_it(clock: FakeClock) -> None:
    seen: list[bool] = []

    def fn() -> None:
        seen.append(gc.isenabled())
        clock.now += 0.3

    assert gc.isenabled()
    bench.measure("x", fn, n=1, repeat=2, memory=False, warmup_s=0.0)
    # Without the memory call: the warm-up call and two timed calls, collector off.
    assert seen == [False, False, False]
    assert gc.isenabled()


def test_measure_restores_the_collector_when_the_call_raises(clock: FakeClock) -> None:
    calls = [0]

    def fn() -> None:
        calls[0] += 1
        if calls[0] > 1:
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        bench.measure("x", fn, n=1, repeat=2, memory=False, warmup_s=0.0)
    assert gc.isenabled()


# ---------------------------------------------------------------------- accelcore bench
_CASES = """
from accelcore.apps.bench import Context, Row, Table
from benches.helper import LABEL


def one(ctx: Context) -> list[Table]:
    return [Table(LABEL, rows=[Row("x", 4, 1.0, 1.0, "samples", 4.0)], notes=[str(ctx.quick)])]


CASES = {"one": one, "two": one}
"""


@pytest.fixture
def benches_folder(tmp_path: Path) -> Iterator[Path]:
    """A stand-in ``benches`` folder; the package it is imported as is forgotten afterwards."""
    folder = tmp_path / "checkout" / "benches"
    folder.mkdir(parents=True)
    (folder / "__init__.py").write_text('"""Stand-in cases."""\n')
    (folder / "helper.py").write_text('LABEL = "stand-in table"\n')
    (folder / "cases.py").write_text(textwrap.dedent(_CASES))
    saved = {k: v for k, v in sys.modules.items() if k == "benches" or k.startswith("benches.")}
    for k in saved:
        del sys.modules[k]
    yield folder
    for k in [k for k in sys.modules if k == "benches" or k.startswith("benches.")]:
        del sys.modules[k]
    sys.modules.update(saved)


def test_accelcore_bench_runs_the_cases_of_the_folder_it_is_given(
    benches_folder: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path_before = list(sys.path)
    assert bench.main(["--benches", str(benches_folder), "--quick", "--cases", "two"]) == 0
    assert sys.path == path_before  # the folder is imported by its path, sys.path untouched
    out = capsys.readouterr().out
    assert "== stand-in table" in out
    saved = list((benches_folder / "results").glob("*.json"))
    assert len(saved) == 1
    record = json.loads(saved[0].read_text())
    assert list(record["case_elapsed_s"]) == ["two"]
    assert [t["title"] for t in record["tables"]] == ["stand-in table"]
    assert record["tables"][0]["notes"] == ["True"]
    assert record["tables"][0]["rows"][0]["rate_per_s"] == 4.0
    assert not list(benches_folder.parent.glob("**/.*.tmp"))


def test_accelcore_bench_default_is_benches_in_the_current_directory(
    benches_folder: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(benches_folder.parent)
    assert bench.main(["--output", "-"]) == 0
    out = capsys.readouterr().out
    assert out.count("== stand-in table") == 2  # both cases, in order
    assert not (benches_folder / "results").exists()


def test_accelcore_bench_without_cases_exits_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert bench.main([]) == 2
    err = capsys.readouterr().err
    assert "not a benches folder" in err and "--benches DIR" in err
    assert "benches" not in sys.modules or sys.modules["benches"].__file__ != str(tmp_path)


def test_unknown_case_exits_2(benches_folder: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--benches", str(benches_folder), "--cases", "one,three"]) == 2
    assert "unknown case(s) ['three']" in capsys.readouterr().err
    assert not (benches_folder / "results").exists()


def test_the_package_never_names_the_source_tree() -> None:
    # The harness is installed; the cases import it, it does not import them.
    source = Path(bench.__file__).read_text()
    assert "sys.path" not in source.replace("``sys.path``", "")
    assert "parents[" not in source
