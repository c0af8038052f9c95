"""The arguments of a simulation checked and resolved into one :class:`Config`.

:func:`configure` validates what :func:`~accelcore.simulate.session` and
:func:`~accelcore.simulate.arrays` are given, fills in the defaults from the
part's datasheet (units, noise, word length, supply) and the paper's measured
truth, and orders the effect chain by stage.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np

from accelcore import datasheets
from accelcore.constants import ORIENTATIONS
from accelcore.simulate.chain import STAGES, Effect, LinearTempco, ProbeNoise, WhiteNoise
from accelcore.simulate.truth import SensorTruth, axis3

__all__ = [
    "DEFAULT_ORIENTATIONS",
    "EXTRA_COLUMNS",
    "EXTRA_DECIMALS",
    "TEMP_DECIMALS",
    "Config",
    "configure",
    "default_noise_g",
]

DEFAULT_ORIENTATIONS: Final = ("OX+", "OX-", "OY+", "OY-", "OZ+", "OZ-")
"""Orientations simulated by default: the paper's six, one run each."""

_FILE_STEMS: Final = {
    "OX+": "x_pos",
    "OX-": "x_neg",
    "OY+": "y_pos",
    "OY-": "y_neg",
    "OZ+": "z_pos",
    "OZ-": "z_neg",
}
_DEFAULT_NOISE_DENSITY_UG: Final = 200.0

EXTRA_COLUMNS: Final = ("supply_v", "die_temp_c")
"""Extra columns :func:`session` can add: supply voltage (V) and the true die temperature (°C)."""

EXTRA_DECIMALS: Final = {"supply_v": 5, "die_temp_c": 4}
"""Decimals each extra column is rounded and printed to."""

TEMP_DECIMALS: Final = 3
"""Decimals the logged temperature is rounded and printed to (1 m°C)."""


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
class Config:
    """The checked arguments of one simulation, with every default resolved."""

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


def configure(
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
) -> Config:
    """Check the arguments of a simulation and resolve their defaults.

    Parameters
    ----------
    sensor, seed, duration_h, rate_hz, t_start_c, t_end_c, soak_min, cool_back
        As in :func:`accelcore.simulate.session`.
    orientations, params, noise_g, bandwidth_hz, adc_bits, adc_full_scale_v
        As in :func:`accelcore.simulate.session`.
    probe_noise_c, serial, extra_columns, effects
        As in :func:`accelcore.simulate.session`.

    Returns
    -------
    Config
        The checked configuration; its effects are ordered by stage, the
        defaults first within each stage.

    Raises
    ------
    ValueError
        If a value is out of range or names an unknown orientation or column.
    TypeError
        If ``params`` is not a :class:`SensorTruth` or an effect is not an
        :class:`Effect`.
    """
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
        arr = axis3(np.asarray(noise_g, dtype=np.float64), "noise_g")
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
    return Config(
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
