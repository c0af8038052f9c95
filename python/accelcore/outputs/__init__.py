"""Outputs room: what people read — text tables, plots, the HTML report.

Every output is a function that takes a calibration (and the session or diagnosis it
came from); the result never imports its consumers.

May import: everything upstream (foundation, input, model, result, fitting,
diagnosis). Never the applications.
"""
