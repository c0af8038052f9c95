"""Facts every room shares, each defined once: axes, orientations, units, delimiters, gravity.

Foundation: imports nothing of accelcore.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Final

__all__ = [
    "ARDUPILOT_SCALE",
    "ARDUPILOT_T_REF_C",
    "AXES",
    "DEFAULT_COLUMNS",
    "DELIMITERS",
    "DTDT_SMOOTHING_S",
    "MIN_TEMPERATURE_SPAN_C",
    "ORIENTATIONS",
    "SAMPLE_TIME_UNIT",
    "SESSION_FORMAT",
    "STANDARD_GRAVITY",
    "TIME_UNITS",
    "UNITS",
    "UNITS_PER_G",
]

AXES: Final = ("x", "y", "z")
"""The sensor axes, in order."""

ORIENTATIONS: Final[Mapping[str, tuple[float, float, float]]] = MappingProxyType(
    {
        "OX+": (1.0, 0.0, 0.0),
        "OX-": (-1.0, 0.0, 0.0),
        "OY+": (0.0, 1.0, 0.0),
        "OY-": (0.0, -1.0, 0.0),
        "OZ+": (0.0, 0.0, 1.0),
        "OZ-": (0.0, 0.0, -1.0),
    }
)
"""Gravity in g seen by each axis in each orientation of the paper (``OZ+``: Z up, +1 g on Z)."""

UNITS: Final = ("V", "LSB", "g", "mg", "m/s2")
"""Output units a session (and a part's datasheet) may have."""

UNITS_PER_G: Final[Mapping[str, float]] = MappingProxyType({"g": 1.0, "mg": 1000.0})
"""Output per g of the units that are already acceleration (``m/s2``: the local gravity)."""

TIME_UNITS: Final[Mapping[str, float]] = MappingProxyType(
    {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
)
"""Seconds per unit of a log's time column."""

SAMPLE_TIME_UNIT: Final = "sample"
"""``time_unit`` of a time column that counts samples: seconds are ``index / rate_hz``."""

DELIMITERS: Final[Mapping[str, str]] = MappingProxyType(
    {",": ",", "\t": "\t", ";": ";", "\\t": "\t", "tab": "\t"}
)
"""Field delimiters a session may name, and the character each stands for."""

DEFAULT_COLUMNS: Final[Mapping[str, str]] = MappingProxyType(
    {"time": "time_s", "temperature": "temp_c", "x": "x", "y": "y", "z": "z"}
)
"""Log column of each channel when ``session.toml`` has no ``[columns]`` table."""

SESSION_FORMAT: Final = "accelcore-session/1"
"""Value of ``format`` in ``session.toml``."""

STANDARD_GRAVITY: Final = 9.80665
"""Standard gravity, m/s² per g: a session in m/s2 without ``gravity_m_s2`` assumes it."""

ARDUPILOT_T_REF_C: Final = 35.0
"""ArduPilot's fixed reference temperature of its ``INS_TCAL`` polynomial, °C."""

ARDUPILOT_SCALE: Final = 1.0e6
"""ArduPilot's ``INS_TCAL<n>_ACC<k>_*`` parameters hold their coefficients times this."""

MIN_TEMPERATURE_SPAN_C: Final = 1.0
"""Below this temperature span (5th to 95th percentile, °C) the temperature does not
move: two of the paper's 0.5 °C bins. A default calibration then fits no temperature
term, and the diagnosis tries no temperature-driven effect."""

DTDT_SMOOTHING_S: Final = 60.0
"""Time constant of the causal smoothing behind the ``dTdt`` model basis, s."""
