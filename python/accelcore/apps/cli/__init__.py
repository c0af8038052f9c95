"""The ``accelcore`` command line (also ``python -m accelcore``).

Subcommands: ``calibrate``, ``compensate``, ``diagnose``, ``export``, ``report``,
``bulk``, ``init``, ``simulate``, ``bench`` and ``demo``; ``accelcore COMMAND --help``
shows each one's options and an example. Exit status: 0 on success, 1 on a data error (a one-line
reason naming the file goes to stderr), 2 on a usage error.

``--json OUT`` writes a machine-readable result in the versioned schema
``accelcore-cli/1`` (see ``docs/cli.md``)::

    {"schema": "accelcore-cli/1", "command": "calibrate",
     "accelcore_version": "0.1.0", "result": {...}}

The file is written atomically (:func:`accelcore.files.atomic_write`); ``--json -``
writes it to stdout instead of the human-readable output.

Modules: :mod:`~accelcore.apps.cli.entry` (:func:`main`: dispatch, exit status,
errors and warnings on stderr), :mod:`~accelcore.apps.cli.parser` (the options),
:mod:`~accelcore.apps.cli.commands` (one function per subcommand; ``compensate``
in :mod:`~accelcore.apps.cli.compensate`, ``init`` in :mod:`~accelcore.apps.cli.init`
and, for one log, :mod:`~accelcore.apps.cli.init_log`, their guesses in
:mod:`~accelcore.apps.cli.guesses`), :mod:`~accelcore.apps.cli.inputs` (session
folders, single logs or flight logs, output guards, missing extras) and
:mod:`~accelcore.apps.cli.documents` (the ``--json`` envelope and its writer).
"""

from __future__ import annotations

from accelcore.apps.cli.documents import JSON_SCHEMA, json_document, write_json
from accelcore.apps.cli.entry import main
from accelcore.apps.cli.parser import build_parser

__all__ = ["JSON_SCHEMA", "build_parser", "json_document", "main", "write_json"]
