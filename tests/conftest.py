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
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

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
