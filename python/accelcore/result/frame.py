"""A labelled frame out: compensated acceleration beside the time and temperature that came in.

:meth:`Calibration.compensate_frame` reads a table (a mapping of arrays, a pandas
or any DataFrame :func:`accelcore.input.frames.frame_columns` reads), checks it
cell by cell as :meth:`accelcore.Session.from_arrays` does, compensates it and
returns a pandas DataFrame.

Part of the result room; reads tables through :mod:`accelcore.input.frames`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from accelcore.constants import AXES
from accelcore.input.frames import column_roles, frame_columns, run_table
from accelcore.result.compensator import Compensator

__all__ = ["OUTPUT_SUFFIX", "compensated_frame"]

#: The unit suffix of the compensated columns (``x_g``, ``y_g``, ``z_g``).
OUTPUT_SUFFIX = "g"

_LABEL = "frame"


def compensated_frame(
    compensator: Compensator,
    data: Mapping[str, Any] | Any,
    columns: Mapping[str, str] | None,
    extras: Sequence[str],
) -> pd.DataFrame:
    """Compensate one table; see :meth:`Calibration.compensate_frame`.

    Parameters
    ----------
    compensator : Compensator
        A fresh compensator of the calibration.
    data : mapping or DataFrame
        The table.
    columns : mapping of str to str, optional
        Column names by role.
    extras : sequence of str
        The extra columns the model reads.

    Returns
    -------
    pandas.DataFrame
    """
    names = column_roles(columns)
    arrays, extra_names = run_table(data, _LABEL, columns, extras=extras)
    time_s, temp_c = arrays[0], arrays[1]
    g = compensator.push(
        np.column_stack(arrays[2:5]),
        temp_c,
        time_s,
        dict(zip(extra_names, arrays[5:], strict=True)),
    )
    shown, native = frame_columns(data, _LABEL)
    stamps = np.asarray(native[shown.index(names["time"])])
    out: dict[str, Any] = {
        names["time"]: stamps if stamps.dtype.kind in "Mm" else time_s,
        names["temperature"]: temp_c,
    }
    out.update({f"{a}_{OUTPUT_SUFFIX}": g[:, i] for i, a in enumerate(AXES)})
    index = data.index if isinstance(data, pd.DataFrame) else None
    return pd.DataFrame(out, index=index)
