"""Effects to inject into :mod:`accelcore.simulate`, for testing the diagnosis.

Each class implements the simulator's :class:`~accelcore.simulate.Effect`
protocol (a ``name``, a ``stage`` and ``apply(state, rng)``) and is passed in
``effects=`` of :func:`accelcore.simulate.arrays` or :func:`~accelcore.simulate.session`.
Sizes are per axis (x, y, z), in the units a datasheet uses (mg, %, degrees).

Effects of the diagnosis' catalogue:

- :class:`OffsetCurvature`: zero-g offset quadratic/cubic in die temperature;
- :class:`SensitivityCurvature`: sensitivity quadratic in die temperature;
- :class:`ThermalLag`: the die trails the chamber by a first-order lag;
- :class:`Misalignment`: small-angle 3x3 misalignment / cross-axis sensitivity;
- :class:`Nonlinearity`: output quadratic in the specific force along the axis
  (IEEE Std 1293's ``K2``: the +1 g and -1 g readings differ beyond the offset);
- :class:`Drift`: offset drifting linearly with time since the run's start;
- :class:`SupplySensitivity`: offset proportional to the supply voltage's
  deviation (its ``supply_v`` column is added by :func:`attach_extra_columns`).

Effects outside the catalogue (the diagnosis must report them as unexplained
structure, naming the observable):

- :class:`TemperatureStep`: a step of the offset at one temperature (solder or
  package stress relaxing, a mode switch of the part's internal trim);
- :class:`CompressorCycle`: a periodic disturbance from the chamber's
  compressor cycling (a small tilt of the fixture), period about 15 min.

Session events (one session's, not the part's; defined in
:mod:`accelcore.simulate.events` and re-exported here): :class:`RunTilt`,
:class:`GravityDrift`, :class:`OutputStep`, :class:`WarmUp`, :class:`TurnOnBias`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
import numpy.typing as npt

from accelcore._accelcore import first_order_lag
from accelcore.simulate.chain import RunState, Stage
from accelcore.simulate.events import (
    GravityDrift,
    OutputStep,
    ProbeLag,
    RunTilt,
    TurnOnBias,
    WarmUp,
)
from accelcore.simulate.runs import SimulatedArrays

__all__ = [
    "CompressorCycle",
    "Drift",
    "GravityDrift",
    "Misalignment",
    "Nonlinearity",
    "OffsetCurvature",
    "OutputStep",
    "ProbeLag",
    "RunTilt",
    "SensitivityCurvature",
    "SupplySensitivity",
    "TemperatureStep",
    "ThermalLag",
    "TurnOnBias",
    "WarmUp",
    "attach_extra_columns",
]

FloatArray = npt.NDArray[np.float64]
_T_REF_C: Final = 25.0


def _vec3(value: float | Sequence[float]) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(3, float(arr))
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"expected a finite scalar or one value per axis (3), got {value!r}")
    return arr


def _mg_to_units(state: RunState, mg: FloatArray) -> FloatArray:
    """Acceleration in mg (any shape ending in 3) to output units via the reference sensitivity."""
    return mg / 1000.0 * state.truth.sensitivity_per_g


@dataclass(frozen=True)
class OffsetCurvature:
    """Zero-g offset curvature: ``c2 (T-25)^2 + c3 (T-25)^3`` mg, ``T`` the die temperature.

    Parameters
    ----------
    mg_per_c2 : float or 3 floats
        Quadratic coefficient per axis, mg/°C² (0.005 bows the offset by 3-8 mg
        over -2…65 °C).
    mg_per_c3 : float or 3 floats, default 0
        Cubic coefficient per axis, mg/°C³.
    """

    mg_per_c2: float | tuple[float, float, float] = (0.004, 0.004, 0.008)
    mg_per_c3: float | tuple[float, float, float] = 0.0

    @property
    def name(self) -> str:
        """``"offset_curvature"``."""
        return "offset_curvature"

    @property
    def stage(self) -> Stage:
        """``"response"``."""
        return "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the curvature to ``state.output``."""
        dt = (state.die_temp_c - _T_REF_C)[:, None]
        mg = _vec3(self.mg_per_c2) * dt**2 + _vec3(self.mg_per_c3) * dt**3
        state.output = state.output + _mg_to_units(state, mg)


@dataclass(frozen=True)
class SensitivityCurvature:
    """Sensitivity curvature: ``S(T) *= 1 + k2/100 (T-25)^2``, ``T`` the die temperature.

    Parameters
    ----------
    pct_per_c2 : float or 3 floats
        Quadratic coefficient per axis, %/°C² (2e-4 changes the 1 g reading by
        about 3 mg at 65 °C).
    """

    pct_per_c2: float | tuple[float, float, float] = 2.5e-4

    @property
    def name(self) -> str:
        """``"sensitivity_curvature"``."""
        return "sensitivity_curvature"

    @property
    def stage(self) -> Stage:
        """``"response"``."""
        return "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add ``S_25 k2/100 (T-25)^2 g`` to ``state.output``."""
        dt = (state.die_temp_c - _T_REF_C)[:, None]
        rel = _vec3(self.pct_per_c2) / 100.0 * dt**2
        state.output = state.output + rel * state.truth.sensitivity_per_g * state.specific_force_g


@dataclass(frozen=True)
class ThermalLag:
    """The die trails the chamber: ``die = first_order_lag(chamber, tau_s)``.

    Parameters
    ----------
    tau_s : float
        Time constant, s (a part in a small package on a board: 30-300 s).
    tau_cool_s : float, optional
        The time constant while the chamber is colder than the die (cooling), when it
        differs from the one while heating (``tau_s``): a board a heater blows on, in a
        chamber that cools through its walls. Default: ``tau_s`` both ways.
    """

    tau_s: float = 60.0
    tau_cool_s: float | None = None

    @property
    def name(self) -> str:
        """``"thermal_lag"``."""
        return "thermal_lag"

    @property
    def stage(self) -> Stage:
        """``"temperature"``."""
        return "temperature"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Replace ``state.die_temp_c`` by the lagged chamber temperature."""
        for name, tau in (("tau_s", self.tau_s), ("tau_cool_s", self.tau_cool_s)):
            if tau is not None and not tau >= 0:
                raise ValueError(f"{name} must be >= 0, got {tau}")
        cool = None if self.tau_cool_s is None else float(self.tau_cool_s)
        state.die_temp_c = first_order_lag(
            state.time_s, state.chamber_temp_c, float(self.tau_s), tau_cool_s=cool
        )


@dataclass(frozen=True)
class Misalignment:
    """Small-angle misalignment and cross-axis sensitivity.

    The specific force along the sensing axes becomes ``M @ f`` with ``M = I +
    A``, ``A[i, j]`` (i != j) the angle in radians by which axis ``i`` leans
    towards axis ``j`` (non-orthogonal axes, so ``A`` need not be skew).

    Parameters
    ----------
    angles_deg : 3x3 nested tuple
        Off-diagonal angles, degrees (the diagonal is ignored); 0.5-1° is
        typical of a part soldered on a board.
    """

    angles_deg: tuple[tuple[float, float, float], ...] = (
        (0.0, 0.6, -0.8),
        (0.5, 0.0, 0.7),
        (-0.9, 0.6, 0.0),
    )

    @property
    def name(self) -> str:
        """``"misalignment"``."""
        return "misalignment"

    @property
    def stage(self) -> Stage:
        """``"stimulus"``."""
        return "stimulus"

    def matrix(self) -> FloatArray:
        """``M = I + A`` (A in radians, zero diagonal)."""
        a = np.radians(np.asarray(self.angles_deg, dtype=np.float64))
        if a.shape != (3, 3):
            raise ValueError(f"angles_deg must be 3x3, got {a.shape}")
        np.fill_diagonal(a, 0.0)
        return np.eye(3) + a

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Rotate ``state.specific_force_g`` into the misaligned sensing axes."""
        state.specific_force_g = state.specific_force_g @ self.matrix().T


@dataclass(frozen=True)
class Nonlinearity:
    """Second-order nonlinearity: ``K2 g_a^2`` mg on each axis ``a``, ``g_a`` its specific force.

    A scale factor that differs between +1 g and -1 g (IEEE Std 1293's ``K2``);
    datasheets bound the nonlinearity at 0.2-0.5 % of full scale.

    Parameters
    ----------
    mg_per_g2 : float or 3 floats
        ``K2`` per axis, mg/g².
    """

    mg_per_g2: float | tuple[float, float, float] = (4.0, -3.0, 5.0)

    @property
    def name(self) -> str:
        """``"nonlinearity"``."""
        return "nonlinearity"

    @property
    def stage(self) -> Stage:
        """``"response"``."""
        return "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add ``K2 g_a^2`` to ``state.output``."""
        mg = _vec3(self.mg_per_g2) * state.specific_force_g**2
        state.output = state.output + _mg_to_units(state, mg)


@dataclass(frozen=True)
class Drift:
    """Offset drift linear in the time since the run's start.

    Parameters
    ----------
    mg_per_h : float or 3 floats
        Drift rate per axis, mg/h.
    """

    mg_per_h: float | tuple[float, float, float] = (2.0, -2.0, 3.0)

    @property
    def name(self) -> str:
        """``"drift"``."""
        return "drift"

    @property
    def stage(self) -> Stage:
        """``"output"``."""
        return "output"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the drift to ``state.output``."""
        hours = ((state.time_s - state.time_s[0]) / 3600.0)[:, None]
        state.output = state.output + _mg_to_units(state, _vec3(self.mg_per_h) * hours)


@dataclass(frozen=True)
class SupplySensitivity:
    """Offset proportional to the deviation of the supply voltage from nominal.

    The supply wanders (slow regulator wander and load steps, independent of
    temperature): ``nominal_v + wander_v * sin(2π t / period_s + φ) + steps``,
    deterministic in ``seed`` and the run's orientation so that
    :func:`attach_extra_columns` can write the same waveform as the
    ``supply_v`` column.

    Parameters
    ----------
    mg_per_v : float or 3 floats
        Offset change per volt of supply, mg/V (a ratiometric analog part
        without trim: hundreds of mg/V).
    nominal_v : float
        Nominal supply, V.
    wander_v : float
        Amplitude of the slow wander, V.
    period_s : float
        Period of the wander, s.
    step_v : float
        Size of the load steps, V (a step up, later a step down).
    seed : int
        Seed of the per-run phases and step times.
    """

    mg_per_v: float | tuple[float, float, float] = (300.0, -250.0, 400.0)
    nominal_v: float = 3.0
    wander_v: float = 0.004
    period_s: float = 1300.0
    step_v: float = 0.003
    seed: int = 7

    @property
    def name(self) -> str:
        """``"supply_sensitivity"``."""
        return "supply_sensitivity"

    @property
    def stage(self) -> Stage:
        """``"output"``."""
        return "output"

    def supply_v(self, time_s: npt.ArrayLike, orientation: str) -> FloatArray:
        """Return the supply voltage of a run, V."""
        t = np.asarray(time_s, dtype=np.float64)
        t = t - t[0]
        key = sum((i + 1) * ord(c) for i, c in enumerate(orientation))
        rng = np.random.default_rng([self.seed, key])
        phase = rng.uniform(0.0, 2.0 * math.pi)
        span = float(t[-1]) if t.size else 0.0
        t_up, t_down = np.sort(rng.uniform(0.1 * span, 0.9 * span, 2))
        steps = self.step_v * ((t >= t_up) & (t < t_down))
        wander = self.wander_v * np.sin(2.0 * math.pi * t / self.period_s + phase)
        return np.asarray(self.nominal_v + wander + steps, dtype=np.float64)

    def extra_columns(self, time_s: FloatArray, orientation: str) -> dict[str, FloatArray]:
        """Return the logged columns this effect implies: ``{"supply_v": ...}``."""
        return {"supply_v": np.round(self.supply_v(time_s, orientation), 5)}

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add ``mg_per_v * (supply - nominal)`` to ``state.output``."""
        dv = (self.supply_v(state.time_s, state.orientation) - self.nominal_v)[:, None]
        state.output = state.output + _mg_to_units(state, _vec3(self.mg_per_v) * dv)


@dataclass(frozen=True)
class TemperatureStep:
    """Out of the catalogue: a smooth step of the offset at one die temperature.

    ``offset += step_mg * (1 + tanh((T - at_c) / width_c)) / 2``: a package
    stress that relaxes above a temperature, or a mode switch of the part's trim.

    Parameters
    ----------
    at_c : float
        Temperature of the step, °C.
    step_mg : float or 3 floats
        Size per axis, mg.
    width_c : float
        Width of the transition, °C.
    """

    at_c: float = 38.0
    step_mg: float | tuple[float, float, float] = (0.0, 0.0, 4.0)
    width_c: float = 0.5

    @property
    def name(self) -> str:
        """``"temperature_step"``."""
        return "temperature_step"

    @property
    def stage(self) -> Stage:
        """``"response"``."""
        return "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the step to ``state.output``."""
        s = 0.5 * (1.0 + np.tanh((state.die_temp_c - self.at_c) / self.width_c))[:, None]
        state.output = state.output + _mg_to_units(state, _vec3(self.step_mg) * s)


@dataclass(frozen=True)
class CompressorCycle:
    """Out of the catalogue: the chamber's compressor cycling tilts the fixture.

    A periodic specific-force disturbance ``amplitude_mg * sin(2π t / period_s
    + φ)`` with a random phase per run (the compressor does not start with the run).

    Parameters
    ----------
    period_s : float
        Compressor cycle, s (about 15 min).
    amplitude_mg : float or 3 floats
        Amplitude per axis, mg.
    """

    period_s: float = 900.0
    amplitude_mg: float | tuple[float, float, float] = (0.0, 0.0, 2.0)

    @property
    def name(self) -> str:
        """``"compressor_cycle"``."""
        return "compressor_cycle"

    @property
    def stage(self) -> Stage:
        """``"output"``."""
        return "output"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        """Add the disturbance to ``state.output``."""
        phase = rng.uniform(0.0, 2.0 * math.pi)
        wave = np.sin(2.0 * math.pi * state.time_s / self.period_s + phase)[:, None]
        state.output = state.output + _mg_to_units(state, _vec3(self.amplitude_mg) * wave)


def attach_extra_columns(sim: SimulatedArrays, effects: Iterable[object]) -> SimulatedArrays:
    """Write the logged columns that effects imply (e.g. ``supply_v``) into ``sim``'s runs.

    The simulator writes its own ``supply_v`` (nominal plus noise) before it
    knows of injected effects; an effect with an ``extra_columns(time_s,
    orientation)`` method defines the column it implies, and this puts it in
    every run (replacing a column of the same name).

    Parameters
    ----------
    sim : SimulatedArrays
        From :func:`accelcore.simulate.arrays`, with the same ``effects``.
    effects : iterable
        The injected effects.

    Returns
    -------
    SimulatedArrays
        ``sim`` itself, its run columns updated in place.
    """
    for eff in effects:
        maker = getattr(eff, "extra_columns", None)
        if maker is None:
            continue
        for run in sim.runs:
            cols: Mapping[str, FloatArray] = maker(run.columns["time_s"], run.orientation)
            run.columns.update(cols)
    return sim
