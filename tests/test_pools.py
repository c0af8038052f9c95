"""The process' kept thread pools (:mod:`accelcore.pools`): reused, and fresh after fork."""

from __future__ import annotations

import multiprocessing
import os
import sys
from pathlib import Path

import pytest

import accelcore
from accelcore import simulate
from accelcore.pools import SIDE_TASK_SWITCH_S, beside, shared_pool


def test_one_pool_per_purpose_and_size() -> None:
    a = shared_pool("test-a", 2)
    assert shared_pool("test-a", 2) is a
    assert shared_pool("test-a", 1) is not a
    assert shared_pool("test-b", 2) is not a
    assert shared_pool("test-a", 0) is shared_pool("test-a", 1)  # at least one worker
    assert list(a.map(lambda v: v * v, range(5))) == [0, 1, 4, 9, 16]


def _load_in_child(path: str) -> int:
    return len(accelcore.load_session(path, cache=False).runs)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork is POSIX")
def test_a_forked_child_reads_with_its_own_pool(tmp_path: Path) -> None:
    # The parent's read pool exists (its threads do not in a child): the child's
    # load must not wait on it forever.
    example_session = tmp_path / "s"
    simulate.session(example_session, "ADXL335", duration_h=0.05, soak_min=0.5)
    runs = len(accelcore.load_session(example_session, cache=False).runs)
    assert runs == 6
    with multiprocessing.get_context("fork").Pool(1) as pool:
        assert pool.apply_async(_load_in_child, (str(example_session),)).get(timeout=60) == runs


def test_beside_restores_the_switch_interval() -> None:
    before = sys.getswitchinterval()
    with beside():
        assert sys.getswitchinterval() == pytest.approx(SIDE_TASK_SWITCH_S)
    assert sys.getswitchinterval() == before
    # Changed by someone else meanwhile: theirs is kept.
    try:
        with beside():
            sys.setswitchinterval(0.002)
        assert sys.getswitchinterval() == pytest.approx(0.002)
    finally:
        sys.setswitchinterval(before)
    # An error in the body: restored all the same.
    with pytest.raises(ZeroDivisionError), beside():
        _ = 1 / 0
    assert sys.getswitchinterval() == before
