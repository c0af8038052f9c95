"""Input room: from files (or arrays) on disk to decimated runs.

Holds the session format (:mod:`.format`, the one reader of ``session.toml``; the keys
of a session that names one log in :mod:`.log_format`), the sessions and the Rust CSV
reader (:mod:`.session`), the other readers (:mod:`.readers`: single-log, Parquet, TDMS
and flight logs), the sessions of one log and :func:`accelcore.load_session`
(:mod:`.single_log`), the persistent run cache (:mod:`.cache`, its
entry file in :mod:`.cache_entry`), the data-quality screening of runs
(:mod:`.quality`), the checks of in-memory runs (:mod:`.frames`) and of header
names (:mod:`.headers`), and the consistency of a session's labels, units and
rate with its data, checked before any fit (:mod:`.consistency`), and the
defaults that fit a log (:mod:`.defaults`: decimation by rate, time or temperature
not logged, local gravity). Run
statistics come from the core's ``RunTally`` everywhere.
Everything downstream receives a :class:`~accelcore.input.session.Session`.

May import: the foundation (:mod:`accelcore.errors`, :mod:`accelcore.core`, the Rust
extension, :mod:`accelcore.datasheets`). Never the model, fitting, result,
diagnosis, outputs or applications rooms.
"""
