"""Input room: from files (or arrays) on disk to decimated runs.

Holds the session format (``session.toml``), the readers (the Rust CSV reader,
single-log, Parquet and TDMS files), the persistent run cache and the data-quality
screening of runs. Everything downstream receives a :class:`~accelcore.input.session.Session`.

May import: the foundation (:mod:`accelcore.errors`, :mod:`accelcore.core`, the Rust
extension, :mod:`accelcore.datasheets`). Never the model, fitting, result,
diagnosis, outputs or applications rooms.
"""
