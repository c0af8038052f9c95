"""The benchmark runner's bookkeeping (no timing is asserted: the clock is faked)."""

from __future__ import annotations

import gc

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
