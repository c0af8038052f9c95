"""Writing a simulated session folder: ``session.toml``, one CSV log per run, ``truth.toml``."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Final

import numpy as np

from accelcore.constants import SESSION_FORMAT
from accelcore.simulate.chain import Effect
from accelcore.simulate.config import (
    DEFAULT_ORIENTATIONS,
    EXTRA_DECIMALS,
    TEMP_DECIMALS,
    Config,
    configure,
)
from accelcore.simulate.runs import SimulatedRun, simulate_runs
from accelcore.simulate.truth import SensorTruth

__all__ = ["RunFile", "SimulatedSession", "session"]

_BASE_COLUMNS: Final = ("time_s", "temp_c", "x", "y", "z")
_ROWS_PER_CHUNK: Final = 100_000


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


def _time_decimals(rate_hz: float) -> int:
    period = 1.0 / rate_hz
    for decimals in range(2, 10):
        if abs(round(period, decimals) - period) <= 1e-12 * max(1.0, period):
            return decimals
    return 9


def _value_format(cfg: Config) -> str:
    if cfg.units == "LSB":
        return "%d"
    decimals = max(6, math.ceil(-math.log10(cfg.quantum)) + 2)
    return f"%.{decimals}f"


def _unlink(path: Path) -> None:
    """Remove what ``path`` names before it is written: a new file, never through a link.

    With ``overwrite``, an old file may be a symbolic or hard link to a file outside the
    folder; opening it for writing would write over that file.
    """
    path.unlink(missing_ok=True)


def _write_csv(path: Path, run: SimulatedRun, cfg: Config) -> None:
    names = list(run.columns)
    value_fmt = _value_format(cfg)
    formats = [f"%.{_time_decimals(cfg.rate_hz)}f", f"%.{TEMP_DECIMALS}f"]
    formats += [value_fmt] * 3 + [f"%.{EXTRA_DECIMALS[n]}f" for n in names[len(_BASE_COLUMNS) :]]
    row = ",".join(formats) + "\n"
    table = np.column_stack([run.columns[n] for n in names])
    _unlink(path)
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


def _session_toml(cfg: Config) -> str:
    lines = [f"format = {_toml_str(SESSION_FORMAT)}", f"sensor = {_toml_str(cfg.sensor)}"]
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


def _truth_toml(cfg: Config) -> str:
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
    folder = Path(path)
    if folder.exists():
        if not folder.is_dir():
            raise FileExistsError(f"{folder} exists and is not a directory")
        if not overwrite and any(folder.iterdir()):
            raise FileExistsError(f"{folder} is not empty; pass overwrite=True to write into it")
    folder.mkdir(parents=True, exist_ok=True)
    runs = []
    for run in simulate_runs(cfg):
        _write_csv(folder / run.file, run, cfg)
        runs.append(RunFile(run.orientation, run.file, cfg.n_samples))
    _unlink(folder / "session.toml")
    (folder / "session.toml").write_text(_session_toml(cfg), encoding="utf-8")
    if write_truth:
        _unlink(folder / "truth.toml")
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
