"""Readers for logs that are not session folders, mapped onto the same :class:`Session`.

- :func:`read_orientation_log`: one delimited log with an orientation column, the
  positioner rotating during the run; every contiguous stretch of one label is a run.
- :func:`read_parquet`: a Parquet file (``pip install accelcore[parquet]``), one
  orientation for the whole file or an orientation column.
- :func:`read_tdms`: an NI TDMS file as LabVIEW writes it (``pip install
  accelcore[tdms]``), one run per group.
- :func:`read_ulog`: one ``sensor_accel`` instance of a PX4 ULog file (``pip install
  accelcore[px4]``), one run.
- :func:`read_dataflash`: one ``IMU`` instance of an ArduPilot DataFlash ``.bin`` log
  (``pip install accelcore[ardupilot]``), one run.

Every reader streams the file in chunks of at most ``common.CHUNK_ROWS`` rows into the
Rust :class:`accelcore.core.Decimator` (block means, ``decimation_factor`` raw
samples per block, the block grid starting at each run's first kept sample),
exactly as :func:`accelcore.load_session` does; only the decimated blocks are
kept. See ``docs/readers.md`` for the layouts each reader expects.

Rooms: :mod:`.common` (chunk size, checks, errors), :mod:`.segment` (chunks of
rows to runs), :mod:`.flightlog` (what the two flight-log readers share), one
module per kind of file. May import: the foundation and the
rest of the input room (:mod:`accelcore.input.format`, :mod:`accelcore.input.session`).
"""

from __future__ import annotations

from accelcore.input.readers import common
from accelcore.input.readers.common import CHUNK_ROWS
from accelcore.input.readers.dataflash import read_dataflash
from accelcore.input.readers.orientation_log import read_orientation_log
from accelcore.input.readers.parquet import read_parquet
from accelcore.input.readers.tdms import read_tdms
from accelcore.input.readers.ulog import read_ulog

__all__ = [
    "CHUNK_ROWS",
    "common",
    "read_dataflash",
    "read_orientation_log",
    "read_parquet",
    "read_tdms",
    "read_ulog",
]
