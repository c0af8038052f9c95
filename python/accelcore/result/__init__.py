"""Result room: what a calibration *is* — the :class:`Calibration`, the compensator, file I/O.

A calibration is a per-axis list of model terms and their fitted coefficients, with
the covariance, the fitted range, notes and provenance. It can compensate raw data
(in Rust, streaming), be compared with a datasheet, saved and loaded.

May import: the foundation, the model room (:mod:`accelcore.model`) and the
input room's checks of in-memory tables (:mod:`accelcore.input.frames`). Never the
fitting room that produces a calibration, nor the diagnosis, outputs or applications
that consume one.
"""
