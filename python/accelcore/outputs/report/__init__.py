"""Self-contained HTML reports: one session, or a whole bulk output (a fleet).

:func:`session_report` (:mod:`~accelcore.outputs.report.session`) writes one
session's page; :func:`fleet_report` (:mod:`~accelcore.outputs.report.fleet`)
the page of a folder written by ``accelcore bulk``; :mod:`~accelcore.outputs.report.html`
holds the pieces both are made of.

Pages are single files: figures are PNG embedded as ``data:`` URIs, styles are
inline, there is no script and nothing is fetched. Every piece of text from
data (names, notes, reasons) is HTML-escaped. matplotlib (the ``[plot]``
extra) draws the figures; without it both functions raise :class:`ImportError`.
Pages are written with :func:`accelcore.files.atomic_write`.

Part of the outputs room: may import everything upstream, never the applications.
"""

from __future__ import annotations

from accelcore.outputs.report.fleet import (
    FAILURE_COLUMNS,
    FLEET_COLUMNS,
    FLEET_PARAMETERS,
    fleet_report,
    is_bulk_output,
)
from accelcore.outputs.report.session import session_report

__all__ = [
    "FAILURE_COLUMNS",
    "FLEET_COLUMNS",
    "FLEET_PARAMETERS",
    "fleet_report",
    "is_bulk_output",
    "session_report",
]
