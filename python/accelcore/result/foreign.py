"""Calibrations made by other tools, read into a :class:`Calibration`.

:func:`read_imucal` reads imucal's ``FerrarisCalibrationInfo`` (or ``Turntable``)
JSON: ``raw = K_a · R_a · a + b_a``, ``a`` in ``acc_unit``. It becomes a calibration at
one temperature: per axis a constant offset (``b_a``) and a constant 3×3 gain
(``K_a R_a`` times the value of 1 g in ``acc_unit``), no temperature terms. imucal
records no temperature, so the model applies as-is at every temperature and the
fitted range is unbounded. The gyroscope fields are not read.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from accelcore.constants import AXES, STANDARD_GRAVITY
from accelcore.errors import AccelcoreIOError, CalibrationFileError
from accelcore.model import Term
from accelcore.result.calibration import AxisModel, Calibration

__all__ = ["IMUCAL_CAL_TYPES", "read_imucal"]

#: imucal calibration types with the Ferraris model.
IMUCAL_CAL_TYPES = ("Ferraris", "Turntable")
#: Value of 1 g in the acceleration units imucal calibrates to.
_G_IN = {"m/s^2": STANDARD_GRAVITY, "m/s2": STANDARD_GRAVITY, "g": 1.0}


def read_imucal(path: str | Path, *, t_ref_c: float = 25.0) -> Calibration:
    """Read an imucal ``FerrarisCalibrationInfo`` JSON file as a one-temperature calibration.

    Parameters
    ----------
    path : str or Path
    t_ref_c : float
        Nominal temperature recorded as the calibration's T_ref (imucal stores none).

    Returns
    -------
    Calibration
        ``method = "imucal"``, ``units`` = the file's ``from_acc_unit``; compensation
        gives what imucal's ``calibrate`` gives, in g instead of ``acc_unit``.

    Raises
    ------
    accelcore.CalibrationFileError
        Not JSON (with line and column), another ``cal_type`` or format version, or
        matrices of the wrong shape, non-finite or singular.
    accelcore.AccelcoreIOError
        The file cannot be read.
    """
    where = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise AccelcoreIOError(f"{where}: cannot read imucal file: {exc.strerror}") from exc
    try:
        doc = json.loads(data.decode("utf-8"))
    except json.JSONDecodeError as exc:
        raise CalibrationFileError(
            f"{where}:{exc.lineno}:{exc.colno}: not an imucal JSON file: {exc.msg}"
        ) from exc
    except UnicodeDecodeError as exc:
        raise CalibrationFileError(f"{where}: not an imucal JSON file: {exc}") from exc
    if not isinstance(doc, dict):
        raise CalibrationFileError(f"{where}: not an imucal calibration (no JSON object)")
    cal_type = doc.get("cal_type")
    if cal_type not in IMUCAL_CAL_TYPES:
        raise CalibrationFileError(
            f"{where}: cal_type {cal_type!r} is not one of {', '.join(IMUCAL_CAL_TYPES)}"
        )
    version = doc.get("_format_version")
    if version is None or str(version).split(".")[0] != "2":
        raise CalibrationFileError(
            f"{where}: imucal format version {version!r} is not supported; expected 2.x"
        )
    acc_unit = doc.get("acc_unit")
    if acc_unit not in _G_IN:
        raise CalibrationFileError(
            f"{where}: acc_unit {acc_unit!r} is not one of {', '.join(_G_IN)}"
        )
    k_a = _matrix(doc, "K_a", (3, 3), where)
    r_a = _matrix(doc, "R_a", (3, 3), where)
    b_a = _matrix(doc, "b_a", (3,), where)
    gain = k_a @ r_a * _G_IN[acc_unit]
    if _rank_deficient(gain):
        raise CalibrationFileError(f"{where}: K_a · R_a is singular; it cannot be inverted")

    axes = {}
    for a_i, a in enumerate(AXES):
        terms = [Term.from_dict({"kind": "offset", "basis": "1", "effect": "imucal"})]
        terms += [
            Term.from_dict({"kind": "gain", "basis": "1", "source": b, "effect": "imucal"})
            for b in AXES
        ]
        coefficients = np.concatenate([[b_a[a_i]], gain[a_i]])
        axes[a] = AxisModel(
            axis=a,
            terms=tuple(terms),
            coefficients=coefficients,
            covariance=np.zeros((4, 4)),
            estimated=np.ones(4, dtype=bool),
            n_samples=0,
            rms_residual=math.nan,
        )
    from_unit = doc.get("from_acc_unit")
    unbounded = (-math.inf, math.inf)
    return Calibration(
        method="imucal",
        # imucal spells m/s² "m/s^2"; ours is "m/s2".
        units={"m/s^2": "m/s2"}.get(str(from_unit), str(from_unit))
        if from_unit is not None
        else "a.u.",
        t_ref_c=float(t_ref_c),
        window_c=unbounded,
        temperature_range_c=unbounded,
        axes=axes,
        notes=(
            f"read from imucal's {cal_type} calibration: offset and gain at one temperature, "
            "no temperature terms; imucal records no temperature, so the model is applied "
            "as-is at every temperature",
        ),
        provenance={
            "source": "imucal",
            "file": where,
            "sha256": hashlib.sha256(data).hexdigest(),
            "cal_type": cal_type,
            "format_version": str(version),
            "acc_unit": acc_unit,
            "from_acc_unit": from_unit,
            "comment": doc.get("comment"),
        },
    )


def _matrix(doc: dict[str, Any], key: str, shape: tuple[int, ...], where: str) -> NDArray[Any]:
    try:
        value = np.asarray(doc[key], dtype=np.float64)
    except KeyError as exc:
        raise CalibrationFileError(f"{where}: the imucal file has no {key!r}") from exc
    except (TypeError, ValueError) as exc:
        raise CalibrationFileError(f"{where}: {key} is not a numeric array: {exc}") from exc
    if value.shape != shape:
        raise CalibrationFileError(f"{where}: {key} has shape {value.shape}, expected {shape}")
    if not np.all(np.isfinite(value)):
        raise CalibrationFileError(f"{where}: {key} has non-finite values")
    return value


def _rank_deficient(m: NDArray[np.float64]) -> bool:
    """Whether a 3×3 matrix is singular to working precision (scaled determinant)."""
    norms = np.sqrt(np.sum(m**2, axis=1))
    if not np.all(norms > 0):
        return True
    unit = m / norms[:, None]
    det = float(
        unit[0, 0] * (unit[1, 1] * unit[2, 2] - unit[1, 2] * unit[2, 1])
        - unit[0, 1] * (unit[1, 0] * unit[2, 2] - unit[1, 2] * unit[2, 0])
        + unit[0, 2] * (unit[1, 0] * unit[2, 1] - unit[1, 1] * unit[2, 0])
    )
    return abs(det) < 1e-9
