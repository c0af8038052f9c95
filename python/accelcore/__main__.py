"""``python -m accelcore``: the command line (see :mod:`accelcore.apps.cli`)."""

from __future__ import annotations

import sys

from accelcore.apps.cli import main

if __name__ == "__main__":
    sys.exit(main())
