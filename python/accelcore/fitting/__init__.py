"""Fitting room: ``calibrate`` turns a session into a calibration.

Two methods: the paper's (bins and line fits) and the joint weighted least-squares
fit over every decimated sample, in the core's Givens QR (:class:`accelcore.core.LeastSquares`).

May import: the foundation, the input room (the session it fits), the model room
(terms and their evaluation) and the result room (the :class:`Calibration` it builds).
Never the diagnosis, outputs or applications.
"""
