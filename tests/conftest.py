"""Pytest configuration: hypothesis profiles and an importable ``tests/`` folder.

Hypothesis profiles, chosen by the environment variable
``ACCELCORE_HYPOTHESIS_PROFILE`` (default ``dev``):

``dev``
    ~50 examples per property, hypothesis' default deadline; quick local runs.
``ci``
    300 examples, no deadline (shared 2-core runners have noisy timing), and
    derandomised so that a CI failure reproduces exactly on any machine.
``thorough``
    2000 examples, no deadline, random; for occasional long hunts.

The run cache of ``load_session`` (``accelcore.input.cache``) points at a temporary
folder for the whole test session, so no test reads or writes the user's
``~/.cache/accelcore/runs``.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest
from hypothesis import HealthCheck, settings

# The shared helpers (``strategies``, ``helpers``) are plain modules next to
# the tests; make them importable whatever pytest's import mode is.
_TESTS_DIR = str(Path(__file__).resolve().parent)
if _TESTS_DIR not in sys.path:
    sys.path.insert(0, _TESTS_DIR)

# Composite strategies build whole streams; generating them can trip the
# "too slow" health check on a loaded 2-core machine without being a problem.
_SUPPRESSED = [HealthCheck.too_slow]

settings.register_profile("dev", max_examples=50, suppress_health_check=_SUPPRESSED)
settings.register_profile(
    "ci",
    max_examples=300,
    deadline=None,
    derandomize=True,
    print_blob=True,
    suppress_health_check=_SUPPRESSED,
)
settings.register_profile(
    "thorough",
    max_examples=2000,
    deadline=None,
    print_blob=True,
    suppress_health_check=_SUPPRESSED,
)
settings.load_profile(os.environ.get("ACCELCORE_HYPOTHESIS_PROFILE", "dev"))


_CACHE_ENV = ("ACCELCORE_CACHE_DIR", "ACCELCORE_CACHE", "ACCELCORE_CACHE_MAX_MB")


@pytest.fixture(autouse=True, scope="session")
def _private_run_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Point the default run cache at a temporary folder; the defaults otherwise.

    Set in ``os.environ`` (not monkeypatch, which is per test) so that CLI
    subprocesses, bulk worker processes and Dask workers inherit it.
    """
    saved = {k: os.environ.get(k) for k in _CACHE_ENV}
    folder = tmp_path_factory.mktemp("run-cache")
    for k in _CACHE_ENV:
        os.environ.pop(k, None)
    os.environ["ACCELCORE_CACHE_DIR"] = str(folder)
    try:
        yield folder
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@pytest.fixture(scope="session")
def bench() -> ModuleType:
    """``benches/validation.py`` (the validation cases and their scoring), imported under
    a private name: the tests do not put the checkout's ``benches`` package on the path."""
    path = Path(__file__).resolve().parents[1] / "benches" / "validation.py"
    spec = importlib.util.spec_from_file_location("_validation_bench", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[spec.name]
        raise
    return module
