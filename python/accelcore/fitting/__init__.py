"""Fitting room: ``calibrate`` turns a session into a calibration.

Two methods: the paper's (bins and line fits) and the joint weighted least-squares
fit over every decimated sample, in the core's QR (:class:`accelcore.core.LeastSquares`).
:mod:`.calibrate` holds both; :mod:`.stacking` lays a session out for the joint fit
(the samples in the window, their features and block weights); :mod:`.reduced` factors
each stretch's few functions of the samples once, for every axis and model over them.

May import: the foundation, the input room (the session it fits), the model room
(terms and their evaluation) and the result room (the :class:`Calibration` it builds).
Never the diagnosis, outputs or applications.
"""
