"""The residual plot of a diagnosis: base model and diagnosed, against two observables.

matplotlib is an optional extra, so it is imported when :func:`plot_diagnosis` is
called (not at module level); without it the function raises :class:`ImportError`
saying ``pip install accelcore[plot]``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from accelcore.constants import AXES
from accelcore.diagnosis import Diagnosis, residuals

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["plot_diagnosis"]


def plot_diagnosis(diagnosis: Diagnosis, observable: str | None = None) -> Figure:
    """Residual vs temperature and vs a chosen observable, base model and diagnosed.

    Parameters
    ----------
    diagnosis : Diagnosis
        A result of :func:`accelcore.diagnose` that still holds its data.
    observable : str, optional
        Column of :func:`accelcore.diagnosis.residuals` for the second row; default
        :attr:`Diagnosis.default_observable` (the observable of the strongest
        unexplained structure, else the one the last added effect depends on).

    Returns
    -------
    matplotlib.figure.Figure
        Two rows (temperature, ``observable``) by two columns (base, diagnosed).

    Raises
    ------
    ImportError
        Without matplotlib.
    accelcore.ParameterError
        If the diagnosis was restored without its data.
    """
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - optional dependency
        raise ImportError(
            "plot_diagnosis needs matplotlib, an optional extra: pip install accelcore[plot]"
        ) from exc
    session = diagnosis.session
    before = residuals(diagnosis.base, session)
    after = residuals(diagnosis.calibration, session)
    obs = observable or diagnosis.default_observable
    fig, axs = plt.subplots(2, 2, figsize=(11, 7), sharey="row", squeeze=False)
    for col, (title, df) in enumerate((("base model", before), ("diagnosed", after))):
        for row, x in enumerate(("temperature_c", obs)):
            ax = axs[row][col]
            for a in AXES:
                ax.plot(df[x], df[f"err_{a}_mg"], ".", ms=1.5, label=a, alpha=0.6)
            ax.set_xlabel(x)
            ax.set_ylabel("error, mg")
            ax.set_title(title)
            ax.grid(True, alpha=0.3)
    axs[0][0].legend(markerscale=6)
    fig.tight_layout()
    return fig
