"""Applications room: the command line, bulk processing of archives, the demo, the bench harness.

``cli/`` (a package: entry point, options, one function per command, the ``--json``
documents), ``bulk.py`` (its fleet-table rows built in ``fleet_rows.py``), ``demo.py``
and ``bench.py`` (the measuring harness the repository's ``benches/`` cases import;
it never imports them by itself).
These compose the rooms upstream into jobs; nothing in the library imports them.

May import: every other room.
"""
