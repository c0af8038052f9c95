"""Bulk workers take their share of the cores: BLAS on one thread, logs read and time
constants searched with cores // jobs.

On a machine with two cores or more, NumPy's BLAS starts with more than one thread;
the checks below fail if bulk leaves it so (its idle threads spin and take CPU
from the other worker).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from threadpoolctl import threadpool_info

from accelcore.apps import bulk as bulk_mod
from accelcore.diagnosis import search as diagnosis_search
from accelcore.input import session as session_reader


def _blas_threads() -> list[int]:
    return [int(i["num_threads"]) for i in threadpool_info() if i["user_api"] == "blas"]


def test_a_worker_runs_blas_on_one_thread_and_reads_with_its_share() -> None:
    code = (
        "import os, threadpoolctl\n"
        "from accelcore.apps import bulk\n"
        "from accelcore.input import session\n"
        "from accelcore.diagnosis import search\n"
        "assert search.search_threads is None\n"
        "bulk._start_worker(os.getpid(), 3)\n"
        "info = threadpoolctl.threadpool_info()\n"
        "n = [i['num_threads'] for i in info if i['user_api'] == 'blas']\n"
        "print(session.read_threads, search.search_threads, n)\n"
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    ).stdout.split(maxsplit=2)
    assert out[:2] == ["3", "3"]
    assert out[2].strip() in ("[1]", "[]")  # [] only where NumPy has no BLAS library


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: BLAS has one thread anyway")
def test_one_job_runs_the_sessions_with_blas_on_one_thread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[list[int]] = []

    def fake(archive: Any, rel: str, out: Any, **options: Any) -> str:
        seen.append(_blas_threads())
        return rel

    before = _blas_threads()
    monkeypatch.setattr(bulk_mod, "process_session", fake)
    done: list[Any] = []
    bulk_mod._run_local(tmp_path, ["a", "b"], tmp_path / "out", 1, {}, done.append)
    assert done == ["a", "b"]
    assert all(s in ([1], []) for s in seen), seen
    assert _blas_threads() == before  # restored after the batch
    assert session_reader.read_threads is None  # the parent's reads keep every core
    assert diagnosis_search.search_threads is None  # and so do its searches
