"""Simulated thermal-chamber sessions with a known truth.

:func:`session` writes a session folder in the accelcore session format
(``session.toml`` and one CSV log per run, see ``session-format.md``);
:func:`arrays` returns the same data in memory. Both are deterministic for a
given ``seed``.

The truth model
---------------
A run holds the sensor still in one orientation (``"OZ+"``: +1 g on Z) while the
chamber follows :func:`temperature_profile`: a soak at ``t_start_c``, then a
linear ramp to ``t_end_c`` (or half the remaining time heating and half cooling
back, with ``cool_back=True``). Per axis, at die temperature ``T``::

    offset(T)      = offset_25 + offset_tc_mg_per_c / 1000 * S_25 * (T - 25)
    sensitivity(T) = S_25 * (1 + sensitivity_tc_pct_per_c / 100 * (T - 25))
    output         = offset(T) + sensitivity(T) * g_axis + noise

then the output is quantised by the acquisition: an ADC of ``adc_bits`` over
±``adc_full_scale_v`` for analog parts (the paper's NI 9220 is 16-bit, ±10 V,
so one LSB is 20/65536 V), integer counts clipped to the two's complement word
for digital parts. The default truth (:meth:`SensorTruth.from_paper`) is the
paper's measured Tables 3-6.

The model is a sequence of named :class:`Effect` objects, each with a ``stage``
(``"temperature"``, ``"stimulus"``, ``"response"``, ``"output"``) and an
``apply(state, rng)`` hook that edits the :class:`RunState` of a run in place.
The default chain is ``ProbeNoise`` (temperature), ``LinearTempco`` (response)
and ``WhiteNoise`` (output); effects passed in ``effects=`` run after the
defaults of their stage. Thermal lag (a temperature effect on ``die_temp_c``),
misalignment (a stimulus effect), curvature or drift (response/output effects)
plug in there without changing this module.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Final, Literal, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from accelcore import datasheets, paper
from accelcore.constants import ORIENTATIONS

__all__ = [
    "DEFAULT_ORIENTATIONS",
    "EXTRA_COLUMNS",
    "ORIENTATIONS",
    "STAGES",
    "Effect",
    "LinearTempco",
    "ProbeNoise",
    "RunFile",
    "RunState",
    "SensorTruth",
    "SimulatedArrays",
    "SimulatedRun",
    "SimulatedSession",
    "Stage",
    "WhiteNoise",
    "arrays",
    "default_noise_g",
    "session",
    "temperature_profile",
]

FloatArray = npt.NDArray[np.float64]
Stage = Literal["temperature", "stimulus", "response", "output"]

STAGES: Final[tuple[Stage, ...]] = ("temperature", "stimulus", "response", "output")
"""Order in which effect stages run."""


DEFAULT_ORIENTATIONS: Final = ("OX+", "OX-", "OY+", "OY-", "OZ+", "OZ-")

_FILE_STEMS: Final = {
    "OX+": "x_pos",
    "OX-": "x_neg",
    "OY+": "y_pos",
    "OY-": "y_neg",
    "OZ+": "z_pos",
    "OZ-": "z_neg",
}
_BASE_COLUMNS: Final = ("time_s", "temp_c", "x", "y", "z")
_SESSION_FORMAT: Final = "accelcore-session/1"
_DEFAULT_NOISE_DENSITY_UG: Final = 200.0
_ROWS_PER_CHUNK: Final = 100_000


def _axis3(value: npt.ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(3, float(arr))
    if arr.shape != (3,):
        raise ValueError(f"{name} must be a scalar or have one value per axis (3), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr}")
    arr = arr.copy()
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False, init=False)
class SensorTruth:
    """The true linear thermal model of one sensor, per axis (x, y, z).

    Parameters
    ----------
    units : str
        Output units, ``"V"`` or ``"LSB"``.
    zero_g_offset : array_like, shape (3,)
        Output at 0 g at the reference temperature, in ``units``.
    sensitivity_per_g : array_like, shape (3,)
        Sensitivity at the reference temperature, ``units`` per g.
    offset_tc_mg_per_c : array_like, shape (3,)
        Zero-g offset change vs temperature, mg/°C (scaled to ``units`` with the
        sensitivity at the reference temperature, as the paper does).
    sensitivity_tc_pct_per_c : array_like, shape (3,)
        Sensitivity change vs temperature, %/°C of the reference sensitivity.
    reference_temperature_c : float, optional
        Temperature of the reference values, °C; default 25.

    Notes
    -----
    Scalars are broadcast to the three axes; arrays are stored read-only.
    """

    units: str
    zero_g_offset: FloatArray
    sensitivity_per_g: FloatArray
    offset_tc_mg_per_c: FloatArray
    sensitivity_tc_pct_per_c: FloatArray
    reference_temperature_c: float

    def __init__(
        self,
        units: str,
        zero_g_offset: npt.ArrayLike,
        sensitivity_per_g: npt.ArrayLike,
        offset_tc_mg_per_c: npt.ArrayLike,
        sensitivity_tc_pct_per_c: npt.ArrayLike,
        reference_temperature_c: float = paper.REFERENCE_TEMPERATURE_C,
    ) -> None:
        if units not in ("V", "LSB"):
            raise ValueError(f"units must be 'V' or 'LSB', got {units!r}")
        object.__setattr__(self, "units", units)
        for name, value in (
            ("zero_g_offset", zero_g_offset),
            ("sensitivity_per_g", sensitivity_per_g),
            ("offset_tc_mg_per_c", offset_tc_mg_per_c),
            ("sensitivity_tc_pct_per_c", sensitivity_tc_pct_per_c),
        ):
            object.__setattr__(self, name, _axis3(value, name))
        if np.any(self.sensitivity_per_g == 0.0):
            raise ValueError("sensitivity_per_g must be non-zero on every axis")
        t_ref = float(reference_temperature_c)
        if not math.isfinite(t_ref):
            raise ValueError("reference_temperature_c must be finite")
        object.__setattr__(self, "reference_temperature_c", t_ref)

    @classmethod
    def from_paper(cls, sensor: str) -> SensorTruth:
        """Return the paper's measured part (Tables 3-6) as the truth.

        Parameters
        ----------
        sensor : str
            ``"ADXL335"``, ``"ADXL327"``, ``"LIS344ALH"`` or ``"MPU-9255"``.

        Returns
        -------
        SensorTruth
            Offset and sensitivity at 25 °C from Table 3 (or 4), sensitivity
            tempco from Table 5, offset tempco from Table 6.
        """
        ref = datasheets.measured(sensor)
        return cls(
            units=ref.units,
            zero_g_offset=np.array(ref.zero_g_offset.as_tuple()),
            sensitivity_per_g=np.array(ref.sensitivity.as_tuple()),
            offset_tc_mg_per_c=np.array(ref.offset_tc_mg_per_c.as_tuple()),
            sensitivity_tc_pct_per_c=np.array(ref.sensitivity_tc_pct_per_c.as_tuple()),
            reference_temperature_c=ref.reference_temperature_c,
        )

    @property
    def offset_tc_per_c(self) -> FloatArray:
        """Zero-g offset slope, ``units`` per °C."""
        return paper.offset_tc_from_mg_per_c(self.offset_tc_mg_per_c, self.sensitivity_per_g)

    @property
    def sensitivity_tc_per_c(self) -> FloatArray:
        """Sensitivity slope, ``units`` per g per °C."""
        return paper.sensitivity_tc_from_pct_per_c(
            self.sensitivity_tc_pct_per_c, self.sensitivity_per_g
        )

    def zero_g_offset_at(self, temperature_c: npt.ArrayLike) -> FloatArray:
        """Zero-g offset at each temperature, shape ``(n, 3)``, ``units``."""
        t = np.asarray(temperature_c, dtype=np.float64).reshape(-1, 1)
        return paper.zero_g_offset_at(
            t,
            self.zero_g_offset,
            self.offset_tc_mg_per_c,
            self.sensitivity_per_g,
            self.reference_temperature_c,
        )

    def sensitivity_at(self, temperature_c: npt.ArrayLike) -> FloatArray:
        """Sensitivity at each temperature, shape ``(n, 3)``, ``units`` per g."""
        t = np.asarray(temperature_c, dtype=np.float64).reshape(-1, 1)
        return paper.sensitivity_at(
            t, self.sensitivity_per_g, self.sensitivity_tc_pct_per_c, self.reference_temperature_c
        )


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


def _supply_column(state: RunState, rng: np.random.Generator, supply_v: float) -> FloatArray:
    return supply_v + rng.normal(0.0, 0.0005, state.time_s.shape)


EXTRA_COLUMNS: Final = ("supply_v", "die_temp_c")
"""Extra columns :func:`session` can add: supply voltage (V) and the true die temperature (°C)."""

_EXTRA_DECIMALS: Final = {"supply_v": 5, "die_temp_c": 4}
_TEMP_DECIMALS: Final = 3


@dataclass(frozen=True)
class RunFile:
    """One written run.

    Parameters
    ----------
    orientation : str
        Orientation label.
    file : str
        Log file name, relative to the session folder.
    n_samples : int
        Number of rows.
    """

    orientation: str
    file: str
    n_samples: int


@dataclass(frozen=True, eq=False)
class SimulatedRun:
    """One run in memory.

    Parameters
    ----------
    orientation : str
        Orientation label.
    file : str
        The file name :func:`session` would give it.
    columns : dict of str to ndarray
        ``time_s``, ``temp_c``, ``x``, ``y``, ``z`` and any extra columns: the
        values :func:`session` writes. Temperatures (1 m°C) and extra columns
        are rounded to their printed decimals; ``x``, ``y``, ``z`` are the exact
        quantised values, which the files print to a small fraction of an LSB.
    die_temp_c : ndarray
        True die temperature, °C.
    """

    orientation: str
    file: str
    columns: dict[str, FloatArray]
    die_temp_c: FloatArray


@dataclass(frozen=True, eq=False)
class SimulatedSession:
    """A session written by :func:`session`.

    Parameters
    ----------
    path : pathlib.Path
        The session folder.
    sensor : str
        Canonical part name.
    serial : str or None
        Serial written to ``session.toml``.
    units : str
        ``"V"`` or ``"LSB"``.
    rate_hz : float
        Sample rate, Hz.
    seed : int
        Seed of the random generator.
    truth : SensorTruth
        The true model (offset and sensitivity at 25 °C, tempcos).
    noise_g : tuple of float
        Output noise per axis, g rms.
    quantum : float
        Quantisation step of the outputs, ``units`` (1 for LSB).
    effects : tuple of str
        Names of the effects applied, in order.
    runs : tuple of RunFile
        The runs, in ``session.toml`` order.
    """

    path: Path
    sensor: str
    serial: str | None
    units: str
    rate_hz: float
    seed: int
    truth: SensorTruth
    noise_g: tuple[float, float, float]
    quantum: float
    effects: tuple[str, ...]
    runs: tuple[RunFile, ...]


@dataclass(frozen=True, eq=False)
class SimulatedArrays:
    """A session simulated in memory by :func:`arrays`.

    Parameters
    ----------
    sensor : str
        Canonical part name.
    serial : str or None
        Serial.
    units : str
        ``"V"`` or ``"LSB"``.
    rate_hz : float
        Sample rate, Hz.
    seed : int
        Seed of the random generator.
    truth : SensorTruth
        The true model.
    noise_g : tuple of float
        Output noise per axis, g rms.
    quantum : float
        Quantisation step of the outputs, ``units``.
    effects : tuple of str
        Names of the effects applied, in order.
    runs : tuple of SimulatedRun
        The runs with their arrays.
    """

    sensor: str
    serial: str | None
    units: str
    rate_hz: float
    seed: int
    truth: SensorTruth
    noise_g: tuple[float, float, float]
    quantum: float
    effects: tuple[str, ...]
    runs: tuple[SimulatedRun, ...]


def temperature_profile(
    time_s: npt.ArrayLike,
    *,
    t_start_c: float,
    t_end_c: float,
    soak_s: float,
    cool_back: bool = False,
) -> FloatArray:
    """Chamber temperature: a soak, then a linear ramp (and optionally back).

    Parameters
    ----------
    time_s : array_like
        Increasing sample times, s; the profile ends at the last one.
    t_start_c, t_end_c : float
        Soak temperature and ramp end temperature, °C.
    soak_s : float
        Soak duration at ``t_start_c``, s.
    cool_back : bool, optional
        If true, the time after the soak is split in half: ramp to ``t_end_c``,
        then back to ``t_start_c``.

    Returns
    -------
    ndarray
        Temperature at each time, °C.
    """
    t = np.asarray(time_s, dtype=np.float64)
    t0 = float(t[0]) + soak_s
    t1 = float(t[-1])
    span = t1 - t0
    if span <= 0.0:
        raise ValueError("the soak must end before the last sample")
    if cool_back:
        frac = np.clip((t - t0) / (span / 2.0), 0.0, 2.0)
        frac = np.where(frac <= 1.0, frac, 2.0 - frac)
    else:
        frac = np.clip((t - t0) / span, 0.0, 1.0)
    return t_start_c + (t_end_c - t_start_c) * frac


def default_noise_g(sensor: str, bandwidth_hz: float = 50.0) -> tuple[float, float, float]:
    """Output noise per axis from the datasheet noise density.

    Parameters
    ----------
    sensor : str
        Part name.
    bandwidth_hz : float, optional
        Single-pole -3 dB bandwidth of the output filter, Hz (default 50).

    Returns
    -------
    tuple of float
        ``density * sqrt(1.6 * bandwidth_hz)`` per axis, g rms (150 µg/√Hz at
        50 Hz gives 1.34 mg). Parts without a noise density use 200 µg/√Hz.
    """
    if not bandwidth_hz > 0.0:
        raise ValueError(f"bandwidth_hz must be > 0, got {bandwidth_hz}")
    ds = datasheets.load(sensor)
    typ = ds.typical("noise_density_ug_per_sqrt_hz")
    factor = math.sqrt(1.6 * bandwidth_hz) * 1e-6
    x, y, z = (_DEFAULT_NOISE_DENSITY_UG if v is None else v for v in typ)
    return (x * factor, y * factor, z * factor)


@dataclass(frozen=True)
class _Config:
    sensor: str
    units: str
    serial: str | None
    seed: int
    n_samples: int
    rate_hz: float
    t_start_c: float
    t_end_c: float
    soak_s: float
    cool_back: bool
    orientations: tuple[str, ...]
    files: tuple[str, ...]
    truth: SensorTruth
    noise_g: tuple[float, float, float]
    adc_bits: int
    quantum: float
    effects: tuple[Effect, ...]
    extra_columns: tuple[str, ...]
    supply_v: float


def _file_names(orientations: Sequence[str]) -> tuple[str, ...]:
    seen: dict[str, int] = {}
    out = []
    for o in orientations:
        stem = _FILE_STEMS[o]
        seen[stem] = seen.get(stem, 0) + 1
        out.append(f"{stem}.csv" if seen[stem] == 1 else f"{stem}_{seen[stem]}.csv")
    return tuple(out)


def _configure(
    sensor: str,
    *,
    seed: int,
    duration_h: float,
    rate_hz: float,
    t_start_c: float,
    t_end_c: float,
    soak_min: float,
    cool_back: bool,
    orientations: Sequence[str],
    params: SensorTruth | None,
    noise_g: float | Sequence[float] | None,
    bandwidth_hz: float,
    adc_bits: int | None,
    adc_full_scale_v: float,
    probe_noise_c: float,
    serial: str | None,
    extra_columns: Sequence[str],
    effects: Sequence[Effect],
) -> _Config:
    ds = datasheets.load(sensor)
    if ds.units not in ("V", "LSB"):
        raise ValueError(f"can only simulate parts with V or LSB outputs, {ds.name} has {ds.units}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    for name, value in (
        ("duration_h", duration_h),
        ("rate_hz", rate_hz),
        ("bandwidth_hz", bandwidth_hz),
        ("adc_full_scale_v", adc_full_scale_v),
    ):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    for name, value in (("t_start_c", t_start_c), ("t_end_c", t_end_c)):
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value!r}")
    if not (math.isfinite(soak_min) and soak_min >= 0.0):
        raise ValueError(f"soak_min must be finite and >= 0, got {soak_min!r}")
    if not (math.isfinite(probe_noise_c) and probe_noise_c >= 0.0):
        raise ValueError(f"probe_noise_c must be finite and >= 0, got {probe_noise_c!r}")
    n_samples = round(duration_h * 3600.0 * rate_hz)
    if n_samples < 2:
        raise ValueError("duration_h * rate_hz gives fewer than 2 samples")
    soak_s = soak_min * 60.0
    if soak_s >= (n_samples - 1) / rate_hz:
        raise ValueError(f"soak_min ({soak_min}) must be shorter than the run ({duration_h} h)")
    orients = tuple(orientations)
    if not orients:
        raise ValueError("at least one orientation is needed")
    bad = [o for o in orients if o not in ORIENTATIONS]
    if bad:
        raise ValueError(f"unknown orientation(s) {bad}; expected some of {list(ORIENTATIONS)}")
    truth = SensorTruth.from_paper(ds.name) if params is None else params
    if not isinstance(truth, SensorTruth):
        raise TypeError(f"params must be a SensorTruth, got {type(truth).__name__}")
    if truth.units != ds.units:
        raise ValueError(f"params are in {truth.units} but {ds.name} outputs {ds.units}")
    if noise_g is None:
        noise = default_noise_g(ds.name, bandwidth_hz)
    else:
        arr = _axis3(np.asarray(noise_g, dtype=np.float64), "noise_g")
        if np.any(arr < 0.0):
            raise ValueError(f"noise_g must be >= 0, got {arr}")
        noise = (float(arr[0]), float(arr[1]), float(arr[2]))
    bits = adc_bits if adc_bits is not None else (ds.adc_bits or 16)
    if isinstance(bits, bool) or not isinstance(bits, int) or not 2 <= bits <= 32:
        raise ValueError(f"adc_bits must be an integer in 2..32, got {bits!r}")
    quantum = 1.0 if ds.units == "LSB" else 2.0 * adc_full_scale_v / 2.0**bits
    extras = tuple(extra_columns)
    unknown = [c for c in extras if c not in EXTRA_COLUMNS]
    if unknown:
        raise ValueError(f"unknown extra column(s) {unknown}; available: {list(EXTRA_COLUMNS)}")
    if len(set(extras)) != len(extras):
        raise ValueError(f"extra_columns repeats a name: {list(extras)}")
    user_effects = tuple(effects)
    for eff in user_effects:
        if not isinstance(eff, Effect) or eff.stage not in STAGES:
            raise TypeError(f"{eff!r} is not an Effect with a stage in {STAGES}")
    chain: tuple[Effect, ...] = (
        ProbeNoise(probe_noise_c),
        LinearTempco(),
        WhiteNoise(noise),
        *user_effects,
    )
    chain = tuple(sorted(chain, key=lambda e: STAGES.index(e.stage)))
    return _Config(
        sensor=ds.name,
        units=ds.units,
        serial=serial,
        seed=int(seed),
        n_samples=n_samples,
        rate_hz=float(rate_hz),
        t_start_c=float(t_start_c),
        t_end_c=float(t_end_c),
        soak_s=soak_s,
        cool_back=bool(cool_back),
        orientations=orients,
        files=_file_names(orients),
        truth=truth,
        noise_g=noise,
        adc_bits=bits,
        quantum=quantum,
        effects=chain,
        extra_columns=extras,
        supply_v=ds.supply_v if ds.supply_v is not None else 3.0,
    )


def _quantise(output: FloatArray, cfg: _Config) -> FloatArray:
    lo, hi = -(2.0 ** (cfg.adc_bits - 1)), 2.0 ** (cfg.adc_bits - 1) - 1.0
    codes = np.clip(np.rint(output / cfg.quantum), lo, hi)
    return codes * cfg.quantum if cfg.units == "V" else codes


def _runs(cfg: _Config) -> Iterator[SimulatedRun]:
    """Simulate the runs one at a time (each from its own child generator)."""
    time_s = np.arange(cfg.n_samples, dtype=np.float64) / cfg.rate_hz
    chamber = temperature_profile(
        time_s,
        t_start_c=cfg.t_start_c,
        t_end_c=cfg.t_end_c,
        soak_s=cfg.soak_s,
        cool_back=cfg.cool_back,
    )
    seeds = np.random.SeedSequence(cfg.seed).spawn(len(cfg.orientations))
    extra_makers: dict[str, Callable[[RunState, np.random.Generator], FloatArray]] = {
        "supply_v": lambda st, rng: _supply_column(st, rng, cfg.supply_v),
        "die_temp_c": lambda st, rng: st.die_temp_c.copy(),
    }
    for orientation, file, child in zip(cfg.orientations, cfg.files, seeds, strict=True):
        rng = np.random.default_rng(child)
        state = RunState(
            orientation=orientation,
            truth=cfg.truth,
            rate_hz=cfg.rate_hz,
            time_s=time_s,
            chamber_temp_c=chamber,
            logged_temp_c=chamber.copy(),
            die_temp_c=chamber.copy(),
            specific_force_g=np.broadcast_to(
                np.asarray(ORIENTATIONS[orientation], dtype=np.float64), (cfg.n_samples, 3)
            ).copy(),
            output=np.zeros((cfg.n_samples, 3)),
        )
        for effect in cfg.effects:
            effect.apply(state, rng)
        out = _quantise(state.output, cfg)
        columns: dict[str, FloatArray] = {
            "time_s": time_s,
            "temp_c": np.round(state.logged_temp_c, _TEMP_DECIMALS),
            "x": out[:, 0].copy(),
            "y": out[:, 1].copy(),
            "z": out[:, 2].copy(),
        }
        for name in cfg.extra_columns:
            columns[name] = np.round(extra_makers[name](state, rng), _EXTRA_DECIMALS[name])
        yield SimulatedRun(
            orientation=orientation, file=file, columns=columns, die_temp_c=state.die_temp_c
        )


def _time_decimals(rate_hz: float) -> int:
    period = 1.0 / rate_hz
    for decimals in range(2, 10):
        if abs(round(period, decimals) - period) <= 1e-12 * max(1.0, period):
            return decimals
    return 9


def _value_format(cfg: _Config) -> str:
    if cfg.units == "LSB":
        return "%d"
    decimals = max(6, math.ceil(-math.log10(cfg.quantum)) + 2)
    return f"%.{decimals}f"


def _write_csv(path: Path, run: SimulatedRun, cfg: _Config) -> None:
    names = list(run.columns)
    value_fmt = _value_format(cfg)
    formats = [f"%.{_time_decimals(cfg.rate_hz)}f", f"%.{_TEMP_DECIMALS}f"]
    formats += [value_fmt] * 3 + [f"%.{_EXTRA_DECIMALS[n]}f" for n in names[len(_BASE_COLUMNS) :]]
    row = ",".join(formats) + "\n"
    table = np.column_stack([run.columns[n] for n in names])
    with path.open("w", encoding="ascii", newline="\n") as fh:
        fh.write(",".join(names) + "\n")
        for start in range(0, table.shape[0], _ROWS_PER_CHUNK):
            chunk = table[start : start + _ROWS_PER_CHUNK]
            fh.write((row * chunk.shape[0]) % tuple(chunk.ravel().tolist()))


def _toml_str(value: str) -> str:
    escaped = value.replace("\\", "\\\\").replace('"', '\\"')
    escaped = "".join(c if c >= " " and c != "\x7f" else f"\\u{ord(c):04x}" for c in escaped)
    return f'"{escaped}"'


def _toml_floats(values: Sequence[float]) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def _session_toml(cfg: _Config) -> str:
    lines = [f"format = {_toml_str(_SESSION_FORMAT)}", f"sensor = {_toml_str(cfg.sensor)}"]
    if cfg.serial is not None:
        lines.append(f"serial = {_toml_str(cfg.serial)}")
    lines += [
        f"units = {_toml_str(cfg.units)}",
        f"rate_hz = {cfg.rate_hz!r}",
        'delimiter = ","',
        'time_unit = "s"',
        "",
        "[columns]",
        'time = "time_s"',
        'temperature = "temp_c"',
        'x = "x"',
        'y = "y"',
        'z = "z"',
    ]
    for orientation, file in zip(cfg.orientations, cfg.files, strict=True):
        lines += [
            "",
            "[[run]]",
            f"file = {_toml_str(file)}",
            f"orientation = {_toml_str(orientation)}",
        ]
    return "\n".join(lines) + "\n"


def _truth_toml(cfg: _Config) -> str:
    t = cfg.truth
    lines = [
        "# Truth of a session simulated by accelcore.simulate (not part of the session format).",
        'generator = "accelcore.simulate"',
        f"sensor = {_toml_str(cfg.sensor)}",
        f"seed = {cfg.seed}",
        f"units = {_toml_str(cfg.units)}",
        f"reference_temperature_c = {t.reference_temperature_c!r}",
        f"zero_g_offset = {_toml_floats(t.zero_g_offset.tolist())}",
        f"sensitivity_per_g = {_toml_floats(t.sensitivity_per_g.tolist())}",
        f"offset_tc_mg_per_c = {_toml_floats(t.offset_tc_mg_per_c.tolist())}",
        f"sensitivity_tc_pct_per_c = {_toml_floats(t.sensitivity_tc_pct_per_c.tolist())}",
        f"noise_g = {_toml_floats(cfg.noise_g)}",
        f"quantum = {cfg.quantum!r}",
        "effects = [" + ", ".join(_toml_str(e.name) for e in cfg.effects) + "]",
    ]
    return "\n".join(lines) + "\n"


def session(
    path: str | os.PathLike[str],
    sensor: str = "ADXL335",
    *,
    seed: int = 0,
    duration_h: float = 2.0,
    rate_hz: float = 20.0,
    t_start_c: float = -2.0,
    t_end_c: float = 65.0,
    soak_min: float = 10.0,
    cool_back: bool = False,
    orientations: Sequence[str] = DEFAULT_ORIENTATIONS,
    params: SensorTruth | None = None,
    noise_g: float | Sequence[float] | None = None,
    bandwidth_hz: float = 50.0,
    adc_bits: int | None = None,
    adc_full_scale_v: float = 10.0,
    probe_noise_c: float = 0.02,
    serial: str | None = None,
    extra_columns: Sequence[str] = (),
    effects: Sequence[Effect] = (),
    write_truth: bool = True,
    overwrite: bool = False,
) -> SimulatedSession:
    """Write a simulated session folder (``session.toml`` and one CSV per run).

    Parameters
    ----------
    path : str or path-like
        Folder to create. It must be empty or absent unless ``overwrite``.
    sensor : str, optional
        Datasheet name (default ``"ADXL335"``); sets the units (V or LSB), the
        default noise and the default truth.
    seed : int, optional
        Seed; the same arguments and seed give identical files.
    duration_h : float, optional
        Length of each run, hours (default 2).
    rate_hz : float, optional
        Sample rate, Hz (default 20, as in the paper).
    t_start_c, t_end_c : float, optional
        Chamber soak temperature and ramp end, °C (default -2 and 65, the paper's).
    soak_min : float, optional
        Soak at ``t_start_c`` before the ramp, minutes (default 10).
    cool_back : bool, optional
        Heat during the first half of the ramp time and cool back in the second.
    orientations : sequence of str, optional
        One run per entry (``"OX+"`` ... ``"OZ-"``; repeats allowed).
    params : SensorTruth, optional
        The true sensor; default :meth:`SensorTruth.from_paper` of ``sensor``.
    noise_g : float or sequence of 3 floats, optional
        Output noise, g rms per axis; default :func:`default_noise_g`.
    bandwidth_hz : float, optional
        Output filter bandwidth for the default noise, Hz (default 50).
    adc_bits : int, optional
        ADC resolution (analog, default 16) or output word length (digital,
        default the datasheet's, 16).
    adc_full_scale_v : float, optional
        ADC input range ± volts for analog parts (default 10: one LSB = 20/2^16 V).
    probe_noise_c : float, optional
        Noise of the logged temperature, °C rms (default 0.02).
    serial : str, optional
        Serial written to ``session.toml``.
    extra_columns : sequence of str, optional
        Further log columns from :data:`EXTRA_COLUMNS`.
    effects : sequence of Effect, optional
        Further truth-model effects, run after the defaults of their stage.
    write_truth : bool, optional
        Also write ``truth.toml`` (outside the session format) with the truth.
    overwrite : bool, optional
        Allow writing into a non-empty folder.

    Returns
    -------
    SimulatedSession
        The folder, the truth and the run files.
    """
    cfg = _configure(
        sensor,
        seed=seed,
        duration_h=duration_h,
        rate_hz=rate_hz,
        t_start_c=t_start_c,
        t_end_c=t_end_c,
        soak_min=soak_min,
        cool_back=cool_back,
        orientations=orientations,
        params=params,
        noise_g=noise_g,
        bandwidth_hz=bandwidth_hz,
        adc_bits=adc_bits,
        adc_full_scale_v=adc_full_scale_v,
        probe_noise_c=probe_noise_c,
        serial=serial,
        extra_columns=extra_columns,
        effects=effects,
    )
    folder = Path(path)
    if folder.exists():
        if not folder.is_dir():
            raise FileExistsError(f"{folder} exists and is not a directory")
        if not overwrite and any(folder.iterdir()):
            raise FileExistsError(f"{folder} is not empty; pass overwrite=True to write into it")
    folder.mkdir(parents=True, exist_ok=True)
    runs = []
    for run in _runs(cfg):
        _write_csv(folder / run.file, run, cfg)
        runs.append(RunFile(run.orientation, run.file, cfg.n_samples))
    (folder / "session.toml").write_text(_session_toml(cfg), encoding="utf-8")
    if write_truth:
        (folder / "truth.toml").write_text(_truth_toml(cfg), encoding="utf-8")
    return SimulatedSession(
        path=folder,
        sensor=cfg.sensor,
        serial=cfg.serial,
        units=cfg.units,
        rate_hz=cfg.rate_hz,
        seed=cfg.seed,
        truth=cfg.truth,
        noise_g=cfg.noise_g,
        quantum=cfg.quantum,
        effects=tuple(e.name for e in cfg.effects),
        runs=tuple(runs),
    )


def arrays(
    sensor: str = "ADXL335",
    *,
    seed: int = 0,
    duration_h: float = 2.0,
    rate_hz: float = 20.0,
    t_start_c: float = -2.0,
    t_end_c: float = 65.0,
    soak_min: float = 10.0,
    cool_back: bool = False,
    orientations: Sequence[str] = DEFAULT_ORIENTATIONS,
    params: SensorTruth | None = None,
    noise_g: float | Sequence[float] | None = None,
    bandwidth_hz: float = 50.0,
    adc_bits: int | None = None,
    adc_full_scale_v: float = 10.0,
    probe_noise_c: float = 0.02,
    serial: str | None = None,
    extra_columns: Sequence[str] = (),
    effects: Sequence[Effect] = (),
) -> SimulatedArrays:
    """Simulate a session in memory; the arguments are those of :func:`session`.

    Parameters
    ----------
    sensor, seed, duration_h, rate_hz, t_start_c, t_end_c, soak_min, cool_back
        As in :func:`session`.
    orientations, params, noise_g, bandwidth_hz, adc_bits, adc_full_scale_v
        As in :func:`session`.
    probe_noise_c, serial, extra_columns, effects
        As in :func:`session`.

    Returns
    -------
    SimulatedArrays
        The truth and, per run, a dict of column name to array holding the
        values :func:`session` writes with the same arguments.
    """
    cfg = _configure(
        sensor,
        seed=seed,
        duration_h=duration_h,
        rate_hz=rate_hz,
        t_start_c=t_start_c,
        t_end_c=t_end_c,
        soak_min=soak_min,
        cool_back=cool_back,
        orientations=orientations,
        params=params,
        noise_g=noise_g,
        bandwidth_hz=bandwidth_hz,
        adc_bits=adc_bits,
        adc_full_scale_v=adc_full_scale_v,
        probe_noise_c=probe_noise_c,
        serial=serial,
        extra_columns=extra_columns,
        effects=effects,
    )
    return SimulatedArrays(
        sensor=cfg.sensor,
        serial=cfg.serial,
        units=cfg.units,
        rate_hz=cfg.rate_hz,
        seed=cfg.seed,
        truth=cfg.truth,
        noise_g=cfg.noise_g,
        quantum=cfg.quantum,
        effects=tuple(e.name for e in cfg.effects),
        runs=tuple(_runs(cfg)),
    )
