"""Simulating the runs of a session in memory (:func:`arrays`)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from accelcore.constants import ORIENTATIONS
from accelcore.simulate.chain import Effect, RunState
from accelcore.simulate.config import (
    DEFAULT_ORIENTATIONS,
    EXTRA_DECIMALS,
    TEMP_DECIMALS,
    Config,
    configure,
)
from accelcore.simulate.profile import temperature_profile
from accelcore.simulate.truth import FloatArray, SensorTruth

__all__ = [
    "SimulatedArrays",
    "SimulatedRun",
    "arrays",
    "quantise",
    "simulate_runs",
    "supply_column",
]


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


def supply_column(state: RunState, rng: np.random.Generator, supply_v: float) -> FloatArray:
    """Return the ``supply_v`` column: ``supply_v`` plus 0.5 mV rms noise per row."""
    return supply_v + rng.normal(0.0, 0.0005, state.time_s.shape)


def quantise(output: FloatArray, cfg: Config) -> FloatArray:
    """Quantise the outputs as the acquisition does (ADC codes in V, or clipped integer counts)."""
    lo, hi = -(2.0 ** (cfg.adc_bits - 1)), 2.0 ** (cfg.adc_bits - 1) - 1.0
    codes = np.clip(np.rint(output / cfg.quantum), lo, hi)
    return codes * cfg.quantum if cfg.units == "V" else codes


def simulate_runs(cfg: Config) -> Iterator[SimulatedRun]:
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
        "supply_v": lambda st, rng: supply_column(st, rng, cfg.supply_v),
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
        out = quantise(state.output, cfg)
        columns: dict[str, FloatArray] = {
            "time_s": time_s,
            "temp_c": np.round(state.logged_temp_c, TEMP_DECIMALS),
            "x": out[:, 0].copy(),
            "y": out[:, 1].copy(),
            "z": out[:, 2].copy(),
        }
        for name in cfg.extra_columns:
            columns[name] = np.round(extra_makers[name](state, rng), EXTRA_DECIMALS[name])
        yield SimulatedRun(
            orientation=orientation, file=file, columns=columns, die_temp_c=state.die_temp_c
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
    cfg = configure(
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
        runs=tuple(simulate_runs(cfg)),
    )
