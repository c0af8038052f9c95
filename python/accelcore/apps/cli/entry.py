"""The command line's entry point: :func:`main` parses, dispatches and sets the exit status.

Errors become one line on stderr (``accelcore COMMAND: error: ...``) and
warnings are printed once each (``accelcore COMMAND: warning: ...``).
Part of the applications room.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import TextIO

from accelcore.apps.cli.commands import CliDataError, UsageError, cmd_bench
from accelcore.apps.cli.parser import build_parser
from accelcore.errors import AccelcoreError, OutputConflictError

__all__ = ["main"]


def _one_line(exc: BaseException, path: str | None, named: Sequence[str] = ()) -> str:
    """One line naming the file at fault: the error's own path, else the command's data path.

    ``named`` are every path of the command; a message naming one of them (the
    calibration file, an output) is not prefixed with the data path.
    """
    text = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, OSError) and not isinstance(exc, AccelcoreError) and exc.filename:
        # The OS named the file at fault (an output folder, say): never blame the input.
        return f"{exc.filename}: {exc.strerror or text}"
    if path and not getattr(exc, "path", None) and not any(p in text for p in (path, *named)):
        text = f"{path}: {text}"
    return text


def _show_warnings(caught: Sequence[warnings.WarningMessage], command: str) -> None:
    seen: set[str] = set()
    for w in caught:
        text = " ".join(str(w.message).split())
        if text not in seen:
            seen.add(text)
            print(f"accelcore {command}: warning: {text}", file=sys.stderr)


def main(argv: Sequence[str] | None = None, *, stdout: TextIO | None = None) -> int:
    """Run the command line.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).
    stdout : text stream, optional
        Where results go (default ``sys.stdout``); errors and warnings go to stderr.

    Returns
    -------
    int
        Exit status: 0 success, 1 data error, 2 usage error.
    """
    args_list = list(sys.argv[1:] if argv is None else argv)
    out = stdout or sys.stdout
    if args_list[:1] == ["bench"]:  # everything after 'bench' belongs to the bench runner
        ns = argparse.Namespace(command="bench", bench_args=args_list[1:], data_path=None)
        handler: Callable[[argparse.Namespace, TextIO], int] = cmd_bench
    else:
        parser = build_parser()
        try:
            ns = parser.parse_args(args_list)
        except SystemExit as exc:
            return int(exc.code) if isinstance(exc.code, int) else 2
        handler = ns.func
    path = getattr(ns, ns.data_path) if ns.data_path else None
    named = [
        str(v)
        for k in ("calibration", "input", "output", "session", "path", "archive", "json", "save")
        if (v := getattr(ns, k, None)) is not None and str(v) not in ("", "-")
    ]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            status = handler(ns, out)
        except BrokenPipeError:  # the reader went away (e.g. `accelcore demo | head`)
            if out is sys.stdout:
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
            status = 1
        except (UsageError, OutputConflictError, ImportError) as exc:
            # An ImportError is an optional dependency missing (its message names the extra).
            # An output that would overwrite an input is a usage error, found before any read.
            print(f"accelcore {ns.command}: error: {' '.join(str(exc).split())}", file=sys.stderr)
            status = 2
        except (AccelcoreError, OSError, CliDataError) as exc:
            print(f"accelcore {ns.command}: error: {_one_line(exc, path, named)}", file=sys.stderr)
            status = 1
        finally:
            _show_warnings(caught, ns.command)
    return status
