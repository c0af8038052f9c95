"""The state of a run while it is simulated, the :class:`Effect` protocol and the default effects.

A run is built by a chain of effects, each editing the :class:`RunState` in place
at its :data:`STAGES` step: :class:`ProbeNoise` (temperature),
:class:`LinearTempco` (response) and :class:`WhiteNoise` (output) by default.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, Literal, Protocol, runtime_checkable

import numpy as np

from accelcore.simulate.truth import FloatArray, SensorTruth

__all__ = ["STAGES", "Effect", "LinearTempco", "ProbeNoise", "RunState", "Stage", "WhiteNoise"]

Stage = Literal["temperature", "stimulus", "response", "output"]

STAGES: Final[tuple[Stage, ...]] = ("temperature", "stimulus", "response", "output")
"""Order in which effect stages run."""


@dataclass(eq=False)
class RunState:
    """The arrays of one run while the effects build it (edited in place).

    Parameters
    ----------
    orientation : str
        Orientation label, e.g. ``"OZ+"``.
    truth : SensorTruth
        The sensor model.
    rate_hz : float
        Sample rate, Hz.
    time_s : ndarray, shape (n,)
        Sample times, s.
    chamber_temp_c : ndarray, shape (n,)
        True chamber temperature, °C.
    logged_temp_c : ndarray, shape (n,)
        Temperature the probe logs, °C (the ``temp_c`` column).
    die_temp_c : ndarray, shape (n,)
        Temperature of the sensor die, °C (drives the thermal model).
    specific_force_g : ndarray, shape (n, 3)
        True acceleration along the sensor axes, g.
    output : ndarray, shape (n, 3)
        Sensor output before the acquisition's quantisation, ``truth.units``.
    """

    orientation: str
    truth: SensorTruth
    rate_hz: float
    time_s: FloatArray
    chamber_temp_c: FloatArray
    logged_temp_c: FloatArray
    die_temp_c: FloatArray
    specific_force_g: FloatArray
    output: FloatArray


@runtime_checkable
class Effect(Protocol):
    """One named part of the truth model.

    An effect has a ``name``, a ``stage`` (one of :data:`STAGES`, the order they
    run in) and ``apply(state, rng)``, which edits the :class:`RunState` in
    place: a temperature effect edits ``die_temp_c`` or ``logged_temp_c``, a
    stimulus effect ``specific_force_g``, response and output effects ``output``.
    """

    @property
    def name(self) -> str:
        """Short identifier, recorded in the result."""
        ...

    @property
    def stage(self) -> Stage:
        """When the effect runs."""
        ...

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Edit ``state`` in place, drawing any randomness from ``rng``."""
        ...


@dataclass(frozen=True)
class ProbeNoise:
    """White noise of the chamber's temperature probe (logged temperature only).

    Parameters
    ----------
    sigma_c : float
        Standard deviation, °C.
    """

    sigma_c: float = 0.02

    @property
    def name(self) -> str:
        """``"probe_noise"``."""
        return "probe_noise"

    @property
    def stage(self) -> Stage:
        """``"temperature"``."""
        return "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the noise to ``state.logged_temp_c``."""
        if self.sigma_c > 0.0:
            state.logged_temp_c = state.logged_temp_c + rng.normal(
                0.0, self.sigma_c, state.logged_temp_c.shape
            )


@dataclass(frozen=True)
class LinearTempco:
    """The paper's model: offset and sensitivity linear in die temperature."""

    @property
    def name(self) -> str:
        """``"linear_tempco"``."""
        return "linear_tempco"

    @property
    def stage(self) -> Stage:
        """``"response"``."""
        return "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add ``offset(T_die) + sensitivity(T_die) * g`` to ``state.output``."""
        truth = state.truth
        state.output = (
            state.output
            + truth.zero_g_offset_at(state.die_temp_c)
            + truth.sensitivity_at(state.die_temp_c) * state.specific_force_g
        )


@dataclass(frozen=True)
class WhiteNoise:
    """White output noise, given in g rms per axis (scaled by the reference sensitivity).

    Parameters
    ----------
    noise_g : tuple of float
        Standard deviation per axis (x, y, z), g.
    """

    noise_g: tuple[float, float, float]

    @property
    def name(self) -> str:
        """``"white_noise"``."""
        return "white_noise"

    @property
    def stage(self) -> Stage:
        """``"output"``."""
        return "output"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the noise to ``state.output``."""
        sigma = np.abs(np.asarray(self.noise_g) * state.truth.sensitivity_per_g)
        state.output = state.output + rng.normal(0.0, 1.0, state.output.shape) * sigma
