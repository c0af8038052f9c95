"""Session events: what happens to one session, not to the part.

Each class implements the simulator's :class:`~accelcore.simulate.Effect`
protocol (a ``name``, a ``stage`` and ``apply(state, rng)``) and is passed in
``effects=`` of :func:`accelcore.simulate.arrays` or :func:`~accelcore.simulate.session`,
like the part's effects of :mod:`accelcore.simulate.effects` (which re-exports them).
Unlike those, an event belongs to one session: another session of the same part
is simulated without it (or with other events), so a calibration that carries an
event into the compensation of other data is wrong there.

- :class:`RunTilt`: the positioner left one run tilted: the gravity vector of
  that run is rotated by a small angle about a fixture axis;
- :class:`GravityDrift`: the fixture creeps: in every run the gravity vector
  turns about a fixture axis at a steady rate from the run's start;
- :class:`OutputStep`: the part was knocked: a step of the offset at a given
  time into one run;
- :class:`WarmUp`: after power-on at the start of a run, an offset that decays
  exponentially;
- :class:`TurnOnBias`: every run powers on with an offset of its own (the part's
  turn-on repeatability): a scatter over the runs, no run an outlier;
- :class:`ProbeLag`: one run's temperature probe out of its place (left on a shelf):
  the temperature logged in that run trails the chamber air.

A run is named by its orientation label (``"OZ+"``); a session that repeats an
orientation gets the event in every run of that orientation. None of the events
draws from the simulator's random generator (:class:`TurnOnBias` has its own seed),
so a session simulated with and without them (same seed) differs by the event alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
import numpy.typing as npt

from accelcore._accelcore import first_order_lag
from accelcore.simulate.chain import RunState, Stage

__all__ = [
    "GravityDrift",
    "OutputStep",
    "ProbeLag",
    "RunTilt",
    "TurnOnBias",
    "WarmUp",
    "rotation_matrix",
]

FloatArray = npt.NDArray[np.float64]

_AXES: Final = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def _vec3(value: float | Sequence[float], name: str) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(3, float(arr))
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(
            f"{name}: expected a finite scalar or one value per axis (3), got {value!r}"
        )
    return arr


def _mg_to_units(state: RunState, mg: FloatArray) -> FloatArray:
    """Acceleration in mg (any shape ending in 3) to output units via the reference sensitivity."""
    return mg / 1000.0 * state.truth.sensitivity_per_g


def _unit_axis(axis: str | Sequence[float]) -> FloatArray:
    """Return a rotation axis, by name (``"x"``, ``"y"``, ``"z"``) or as a vector, normalised."""
    if isinstance(axis, str):
        if axis not in _AXES:
            raise ValueError(f"axis must be 'x', 'y', 'z' or a 3-vector, got {axis!r}")
        return np.asarray(_AXES[axis], dtype=np.float64)
    vec = _vec3(axis, "axis")
    norm = float(np.linalg.norm(vec))
    if norm == 0.0:
        raise ValueError("axis must not be the zero vector")
    return vec / norm


def rotation_matrix(angle_deg: float, axis: str | Sequence[float]) -> FloatArray:
    """Rotation by ``angle_deg`` about ``axis`` (right hand), as a 3x3 matrix.

    Parameters
    ----------
    angle_deg : float
        Angle, degrees.
    axis : {"x", "y", "z"} or 3 floats
        Rotation axis, by name or as a (not necessarily unit) vector.

    Returns
    -------
    ndarray, shape (3, 3)
        ``R`` such that ``R @ v`` is ``v`` rotated (Rodrigues' formula).
    """
    if not math.isfinite(angle_deg):
        raise ValueError(f"angle_deg must be finite, got {angle_deg!r}")
    k = _unit_axis(axis)
    theta = math.radians(angle_deg)
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    rot: FloatArray = (
        np.eye(3) + math.sin(theta) * cross + (1.0 - math.cos(theta)) * (cross @ cross)
    )
    return rot


def _check_run(run: str) -> None:
    if not isinstance(run, str) or not run.strip():
        raise ValueError(f"run must be an orientation label such as 'OZ+', got {run!r}")


def _matches(run: str, state: RunState) -> bool:
    return run.strip().upper() == state.orientation.strip().upper()


@dataclass(frozen=True)
class RunTilt:
    """One run held tilted: its gravity vector rotated by ``angle_deg`` about ``axis``.

    The true specific force of the run (``state.specific_force_g``) is rotated,
    so everything downstream (misalignment listed after it, the part's gain and
    its temperature dependence) sees the tilted gravity. An ``"OZ+"`` run tilted
    by θ about ``x`` reads ``(0, -sin θ, cos θ)`` g.

    Parameters
    ----------
    run : str
        Orientation label of the run, e.g. ``"OZ+"``.
    angle_deg : float
        Tilt angle, degrees (a positioner off by 1-2°).
    axis : {"x", "y", "z"} or 3 floats, default "x"
        Rotation axis in the sensor frame.
    """

    run: str
    angle_deg: float
    axis: str | tuple[float, float, float] = "x"

    def __post_init__(self) -> None:
        _check_run(self.run)
        rotation_matrix(self.angle_deg, self.axis)

    @property
    def name(self) -> str:
        """``"run_tilt"``."""
        return "run_tilt"

    @property
    def stage(self) -> Stage:
        """``"stimulus"``."""
        return "stimulus"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Rotate ``state.specific_force_g`` when the run is the one named."""
        if _matches(self.run, state):
            rot = rotation_matrix(self.angle_deg, self.axis)
            state.specific_force_g = state.specific_force_g @ rot.T


@dataclass(frozen=True)
class GravityDrift:
    """The fixture creeps: in every run, gravity turns about ``axis`` at ``deg_per_h``.

    At ``t`` seconds after the run's first sample the run's specific force is rotated
    by ``deg_per_h · t / 3600`` degrees about ``axis`` (a fixture settling under the
    part's weight, a positioner's stage sagging): the run starts square and leaks a
    growing share of its gravity into a cross axis. An ``"OZ+"`` run turning about
    ``x`` reads ``(0, -sin θ(t), cos θ(t))`` g, an ``"OX+"`` run about ``x`` nothing.

    Parameters
    ----------
    deg_per_h : float
        Rate of the turn, degrees per hour.
    axis : {"x", "y", "z"} or 3 floats, default "x"
        Rotation axis in the sensor frame.
    """

    deg_per_h: float
    axis: str | tuple[float, float, float] = "x"

    def __post_init__(self) -> None:
        if not math.isfinite(self.deg_per_h):
            raise ValueError(f"deg_per_h must be finite, got {self.deg_per_h!r}")
        rotation_matrix(0.0, self.axis)

    @property
    def name(self) -> str:
        """``"gravity_drift"``."""
        return "gravity_drift"

    @property
    def stage(self) -> Stage:
        """``"stimulus"``."""
        return "stimulus"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Rotate each sample's ``state.specific_force_g`` by the angle reached at its time."""
        u = _unit_axis(self.axis)
        theta = np.radians(self.deg_per_h * (state.time_s - state.time_s[0]) / 3600.0)
        g = state.specific_force_g
        # Rodrigues' rotation of every row by its own angle about the unit axis u.
        cos, sin = np.cos(theta)[:, None], np.sin(theta)[:, None]
        along = (g @ u)[:, None] * u
        state.specific_force_g = g * cos + np.cross(u, g) * sin + along * (1.0 - cos)


@dataclass(frozen=True)
class OutputStep:
    """The part knocked: a step of the offset ``step_mg`` from ``at_s`` into one run on.

    Parameters
    ----------
    run : str
        Orientation label of the run, e.g. ``"OX+"``.
    at_s : float
        Time of the step, s after the run's first sample.
    step_mg : float or 3 floats
        Size per axis, mg (0 leaves an axis alone).
    before : bool, default False
        The offset holds before ``at_s`` instead, and is gone from it on (a shift
        annealed out, a disturbance that ended): the part after the step is the
        clean one.
    """

    run: str
    at_s: float
    step_mg: float | tuple[float, float, float] = (0.0, 0.0, 5.0)
    before: bool = False

    def __post_init__(self) -> None:
        _check_run(self.run)
        if not (math.isfinite(self.at_s) and self.at_s >= 0.0):
            raise ValueError(f"at_s must be finite and >= 0, got {self.at_s!r}")
        _vec3(self.step_mg, "step_mg")

    @property
    def name(self) -> str:
        """``"output_step"``."""
        return "output_step"

    @property
    def stage(self) -> Stage:
        """``"output"``."""
        return "output"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the step to ``state.output`` when the run is the one named."""
        if not _matches(self.run, state):
            return
        after = (state.time_s - state.time_s[0]) >= self.at_s
        held = (~after if self.before else after).astype(np.float64)[:, None]
        state.output = state.output + _mg_to_units(state, held * _vec3(self.step_mg, "step_mg"))


@dataclass(frozen=True)
class WarmUp:
    """After power-on at the start of a run, an offset ``amplitude_mg · exp(-t / tau_s)``.

    ``t`` is the time since the run's first sample (the part is powered on with
    the logging).

    Parameters
    ----------
    amplitude_mg : float or 3 floats
        Offset at power-on per axis, mg.
    tau_s : float
        Time constant, s.
    runs : tuple of str, optional
        Orientation labels of the runs that warm up; default every run.
    """

    amplitude_mg: float | tuple[float, float, float] = 5.0
    tau_s: float = 300.0
    runs: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        _vec3(self.amplitude_mg, "amplitude_mg")
        if not (math.isfinite(self.tau_s) and self.tau_s > 0.0):
            raise ValueError(f"tau_s must be finite and > 0, got {self.tau_s!r}")
        for run in self.runs or ():
            _check_run(run)

    @property
    def name(self) -> str:
        """``"warm_up"``."""
        return "warm_up"

    @property
    def stage(self) -> Stage:
        """``"output"``."""
        return "output"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the decaying offset to ``state.output`` (in the runs it applies to)."""
        if self.runs is not None and not any(_matches(r, state) for r in self.runs):
            return
        decay = np.exp(-(state.time_s - state.time_s[0]) / self.tau_s)[:, None]
        state.output = state.output + _mg_to_units(
            state, decay * _vec3(self.amplitude_mg, "amplitude_mg")
        )


@dataclass(frozen=True)
class TurnOnBias:
    """Every run powers on with its own offset: normal, ``mg_sd`` per axis, drawn per run.

    Datasheets give it as the bias' turn-on (run-to-run) repeatability. The offsets
    come from a generator of their own, seeded by ``seed`` and the run's orientation
    label, so the same session without the event differs by the offsets alone.

    Parameters
    ----------
    mg_sd : float or 3 floats
        Standard deviation of a run's offset per axis, mg.
    seed : int
        Seed of the offsets.
    """

    mg_sd: float | tuple[float, float, float] = 2.0
    seed: int = 0

    @property
    def name(self) -> str:
        """``"turn_on_bias"``."""
        return "turn_on_bias"

    @property
    def stage(self) -> Stage:
        """``"output"``."""
        return "output"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the run's offset to ``state.output``."""
        key = [self.seed, *(ord(c) for c in state.orientation)]
        offset = np.random.default_rng(key).normal(size=3) * _vec3(self.mg_sd, "mg_sd")
        state.output = state.output + _mg_to_units(state, offset)


@dataclass(frozen=True)
class ProbeLag:
    """One run's probe out of its place: the temperature logged in it trails the air.

    The chamber probe was left lying on a steel shelf after the part was turned (out of
    its clip in the air stream): it logs the shelf, a first-order lag ``tau_s`` behind
    the air, plus its own noise. The part follows the air as in every other run.

    Parameters
    ----------
    run : str
        Orientation label of the run, e.g. ``"OY-"``.
    tau_s : float, default 180
        Time constant of the lag, s (up to 8 °C behind on a 1.34 °C/min ramp).
    """

    run: str
    tau_s: float = 180.0

    def __post_init__(self) -> None:
        _check_run(self.run)
        if not (math.isfinite(self.tau_s) and self.tau_s > 0.0):
            raise ValueError(f"tau_s must be finite and > 0, got {self.tau_s!r}")

    @property
    def name(self) -> str:
        """``"probe_lag"``."""
        return "probe_lag"

    @property
    def stage(self) -> Stage:
        """``"temperature"``."""
        return "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Lag ``state.logged_temp_c`` behind the air, its noise kept, in the run named."""
        if not _matches(self.run, state):
            return
        noise = state.logged_temp_c - state.chamber_temp_c
        lagged = first_order_lag(state.time_s, state.chamber_temp_c, self.tau_s)
        state.logged_temp_c = lagged + noise
