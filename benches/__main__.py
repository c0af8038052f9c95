"""``python -m benches`` (what ``make bench`` runs): every case, with the installed harness.

Run from the repository's root. Results go to ``benches/results/``; the options
are those of :func:`accelcore.apps.bench.build_parser` (``--help`` lists them).
"""

from __future__ import annotations

import sys
from pathlib import Path

from accelcore.apps.bench import build_parser, run
from benches.cases import CASES


def main() -> int:
    """Parse the command line and run the cases."""
    argv = sys.argv[1:]
    args = build_parser("python -m benches", benches_option=False).parse_args(argv)
    return run(CASES, args, folder=Path(__file__).resolve().parent, argv=argv)


if __name__ == "__main__":
    raise SystemExit(main())
