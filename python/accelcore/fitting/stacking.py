"""Stacking a session for the joint fit: the samples in the window, their features and weights.

:func:`stack_session` lays every record of a session (a run, or the pieces of
one log joined) out as features, gravity, output and least-squares weights of
the decimated samples inside the temperature window; :func:`block_weights`
weighs each block by its count and leaves out spikes and clipped blocks.
:func:`accelcore.fitting.calibrate.calibrate` and the diagnosis fit on it.

May import: the foundation, the input room and the model room.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from accelcore.errors import InsufficientDataError
from accelcore.input.quality import excluded_blocks
from accelcore.input.records import records
from accelcore.input.session import Run, Session
from accelcore.model import Features

__all__ = ["CutFeatures", "Stacked", "block_weights", "stack_session"]


@dataclass
class Stacked:
    """Decimated samples of every run inside the window, with per-run features."""

    features: list[Features]
    gravity: list[NDArray[np.float64]]
    output: list[NDArray[np.float64]]
    weight: list[NDArray[np.float64]]
    run_index: list[int]
    notes: list[str] = field(default_factory=list)

    @property
    def temperature_range_c(self) -> tuple[float, float]:
        """Lowest and highest temperature of the stacked samples, °C."""
        temps = np.concatenate([f.temperature_c for f in self.features])
        return float(temps.min()), float(temps.max())


def block_weights(run: Run, robust: bool = True) -> tuple[NDArray[np.float64], str | None]:
    """Least-squares weight of each decimated block of a run, and a note on what was left out.

    A block mean of ``count`` samples has variance ``sigma² / count``, so its
    weight is its count. With ``robust``, spikes and blocks clipped at a rail
    (:func:`accelcore.input.quality.excluded_blocks`) get weight 0.
    """
    weight = run.count.astype(np.float64)
    if not robust:
        return weight, None

    mask, n_spikes, n_clipped = excluded_blocks(run)
    if not mask.any():
        return weight, None
    weight[mask] = 0.0
    parts = [f"{n} spike block(s)" for n in (n_spikes,) if n] + [
        f"{n} clipped block(s)" for n in (n_clipped,) if n
    ]
    return weight, f"{run.label}: left out {' and '.join(parts)} of {len(run)}"


def stack_session(
    session: Session,
    t_ref_c: float,
    window_c: tuple[float, float] | None,
    runs: Sequence[int] | None = None,
    robust: bool = True,
) -> Stacked:
    """Per record: features, gravity, output and weights of the samples inside the window.

    A record is a run, or the contiguous pieces of one log joined
    (:func:`accelcore.input.records.records`; ``runs`` indexes the records), so a
    log's history does not restart where its files were cut.

    Features (elapsed time, lagged temperature) are computed on the whole run
    first and then cut to the window, so a lag filter sees the run's history.
    With ``robust``, spikes and clipped blocks get weight 0 (see :func:`block_weights`).
    """
    feats: list[Features] = []
    grav, out, wts, idx = [], [], [], []
    notes: list[str] = []
    for i, run in enumerate(records(session)):
        if runs is not None and i not in runs:
            continue
        time_s = run.time_s - run.time_s[0] if len(run) else run.time_s
        whole = Features(run.temperature_c, time_s, run.extras, t_ref_c)
        if window_c is None:
            keep = np.ones(len(run), dtype=bool)
        else:
            keep = (run.temperature_c >= window_c[0]) & (run.temperature_c <= window_c[1])
        if not keep.any():
            continue
        weight, note = block_weights(run, robust)
        if note:
            notes.append(note)
        feats.append(CutFeatures.cut(whole, keep))
        grav.append(run.gravity_g)
        if keep.all():  # the whole run (the usual case): no copy
            out.append(run.output)
            wts.append(weight)
        else:
            out.append(run.output[keep])
            wts.append(weight[keep])
        idx.append(i)
    if not feats:
        lo, hi = window_c if window_c else (-math.inf, math.inf)
        raise InsufficientDataError(
            f"no decimated sample lies in the window {lo}…{hi} °C; widen window_c or log a "
            "sweep that covers it"
        )
    return Stacked(feats, grav, out, wts, idx, notes)


class CutFeatures(Features):
    """Features of a run restricted to a mask, lag computed on the whole run."""

    @classmethod
    def cut(cls, whole: Features, keep: NDArray[np.bool_]) -> CutFeatures:
        """Restrict ``whole`` to the samples where ``keep`` is true."""
        obj = cls(
            whole.temperature_c[keep],
            None if whole.time_s is None else whole.time_s[keep],
            {k: v[keep] for k, v in whole.extras.items()},
            whole.t_ref_c,
            run=whole.run,
        )
        obj._whole = whole
        obj._keep = keep
        return obj

    _whole: Features
    _keep: NDArray[np.bool_]

    def lagged_temperature_c(
        self, tau_s: float, cool_tau_s: float | None = None
    ) -> NDArray[np.float64]:
        """Lagged temperature of the whole run (lag state unbroken), then cut."""
        return self._whole.lagged_temperature_c(tau_s, cool_tau_s)[self._keep]
