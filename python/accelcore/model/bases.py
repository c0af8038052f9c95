"""The bases of the model: observables (:class:`Features`) and named functions of them.

One basis per design column (:class:`Basis` and its kinds). The grammar of their
names is in :mod:`accelcore.model`.
"""

from __future__ import annotations

import math
import re
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import first_order_lag
from accelcore.constants import AXES, DTDT_SMOOTHING_S
from accelcore.errors import ParameterError

__all__ = [
    "Basis",
    "Constant",
    "Decay",
    "Elapsed",
    "Extra",
    "Features",
    "Hinge",
    "LaggedTemperaturePower",
    "RunRate",
    "RunStep",
    "SquaredGravity",
    "TemperaturePower",
    "TemperatureRate",
]

FloatArray = NDArray[np.float64]


@dataclass
class Features:
    """Observables of a stretch of contiguous samples, the inputs of every basis.

    Parameters
    ----------
    temperature_c : ndarray
        Logged temperature, °C.
    time_s : ndarray or None
        Time since the stretch's start, s (needed by time-dependent bases).
    extras : mapping of str to ndarray
        Extra logged columns.
    t_ref_c : float
        Reference temperature of ``dT``.
    """

    temperature_c: FloatArray
    time_s: FloatArray | None
    extras: Mapping[str, FloatArray]
    t_ref_c: float
    _lag_cache: dict[tuple[float, float | None], FloatArray] = field(
        default_factory=dict, repr=False
    )
    #: Label of the run (record) the samples come from, for session-event bases.
    run: str | None = None
    #: Specific force on the axes, g, shape (n, 3) or (3,), for bases of the force
    #: (:class:`SquaredGravity`); None when it is not known (a compensation solves for it).
    gravity_g: FloatArray | None = None

    def __len__(self) -> int:
        return int(self.temperature_c.shape[0])

    def _need_time(self, basis: str) -> FloatArray:
        if self.time_s is None:
            raise ParameterError(f"the model term basis {basis!r} needs time_s")
        return self.time_s

    def lagged_temperature_c(self, tau_s: float, cool_tau_s: float | None = None) -> FloatArray:
        """Temperature through a first-order lag of ``tau_s`` seconds (cached).

        With ``cool_tau_s``, ``tau_s`` while heating and ``cool_tau_s`` while cooling.
        """
        key = (tau_s, cool_tau_s)
        if key not in self._lag_cache:
            time_s = self._need_time(f"lag({tau_s})")
            self._lag_cache[key] = first_order_lag(
                time_s, self.temperature_c, tau_s, tau_cool_s=cool_tau_s
            )
        return self._lag_cache[key]


# ---------------------------------------------------------------------- bases
class Basis(ABC):
    """A named function of a sample's observables; one column of the design per term.

    Bases are small immutable values: equal when they mean the same function,
    hashable, written to files as their :attr:`name` (the grammar in the module
    docs) and read back with :meth:`parse`. Code asks a basis what it is
    (:attr:`temperature_order`, :attr:`lag_s`, :attr:`stateful`, ...) instead of
    splitting its name.
    """

    #: True when the value at a sample depends on earlier samples or on the run's
    #: start (lag filters, dT/dt, elapsed time): compensation then carries state.
    stateful: ClassVar[bool] = False

    #: True when the value depends on the specific force itself (known from the
    #: orientation when fitting; solved for with it when compensating).
    needs_gravity: ClassVar[bool] = False

    @property
    @abstractmethod
    def name(self) -> str:
        """The basis' name in the model grammar (what files store)."""

    @abstractmethod
    def evaluate(
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        """Value at every sample of ``features`` (float64, one per sample)."""

    def at_gravity(self, gravity_g: FloatArray, n: int) -> FloatArray:
        """Value at ``n`` samples of specific force ``gravity_g`` (g, (3,) or (n, 3)).

        Only for a basis of the force (:attr:`needs_gravity`); fitting reads it from
        the orientation, compensation from its estimate of the force.
        """
        raise ParameterError(f"the basis {self.name!r} does not depend on the force")

    @property
    def temperature_order(self) -> int | None:
        """``k`` of a ``(T - t_ref)^k`` basis (lagged or not), else None."""
        return None

    @property
    def lag_s(self) -> float | None:
        """Time constant of the temperature lag, s (None when the basis has none).

        Of a lag whose time constant differs between heating and cooling, the heating one.
        """
        return None

    @property
    def lag_key(self) -> tuple[float, ...] | None:
        """Every time constant of the temperature lag, s: ``(tau,)`` or ``(heating, cooling)``."""
        return None

    @property
    def column(self) -> str | None:
        """Name of the extra logged column the basis reads, else None."""
        return None

    def without_lag(self) -> Basis:
        """Return the same basis on the logged temperature (itself when it has no lag)."""
        return self

    def __str__(self) -> str:
        return self.name

    @staticmethod
    def parse(text: str | Basis) -> Basis:
        """Read a basis from its name (module docs); a Basis is returned as it is.

        Raises
        ------
        ParameterError
            The name is not in the grammar.
        """
        if isinstance(text, Basis):
            return text
        if not isinstance(text, str):
            raise ParameterError(f"a model basis is a name, got {type(text).__name__}")
        if text == "1":
            return Constant()
        m = _POLY.match(text)
        if m:
            return TemperaturePower(int(m.group(1)))
        m = _LAG.match(text)
        if m:
            cool = None if m.group(2) is None else float(m.group(2))
            return LaggedTemperaturePower(float(m.group(1)), int(m.group(3)), cool)
        if text == "dTdt":
            return TemperatureRate()
        if text == "elapsed_h":
            return Elapsed()
        m = _DECAY.match(text)
        if m:
            return Decay(float(m.group(1)))
        m = _STEP.match(text)
        if m:
            return RunStep(m.group(2), float(m.group(3)), before=m.group(1) == "until")
        m = _RUN_RATE.match(text)
        if m:
            return RunRate(m.group(1))
        m = _HINGE.match(text)
        if m:
            return Hinge(float(m.group(1)), Basis.parse(m.group(2)))
        m = _SQUARE.match(text)
        if m:
            return SquaredGravity(m.group(1))
        if text.startswith("extra:") and len(text) > len("extra:"):
            return Extra(text[len("extra:") :])
        raise ParameterError(f"unknown basis {text!r}")


_POLY = re.compile(r"^dT\^([1-9])$")
_LAG = re.compile(r"^lag\(([0-9.eE+-]+)(?:,([0-9.eE+-]+))?\):dT\^([1-9])$")
_HINGE = re.compile(r"^hinge\(([0-9.eE+-]+)\):(.+)$")
_DECAY = re.compile(r"^decay\(([0-9.eE+-]+)\)$")
_STEP = re.compile(r"^(step|until)\((.+)@([0-9.eE+-]+)\)$")
_RUN_RATE = re.compile(r"^rate\((.+)\)$")
_SQUARE = re.compile(r"^g_([xyz])\^2$")


@dataclass(frozen=True)
class Constant(Basis):
    """``1``: the constant (offset at T_ref, or sensitivity with a gain term)."""

    @property
    def name(self) -> str:  # noqa: D102
        return "1"

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        return np.ones(len(features))


@dataclass(frozen=True)
class TemperaturePower(Basis):
    """``dT^k``: ``(T - t_ref_c)^k`` in °C^k (k = 1 linear tempco, k >= 2 curvature)."""

    order: int

    def __post_init__(self) -> None:
        if not 1 <= self.order <= 9:
            raise ParameterError(f"temperature order must be 1..9, got {self.order}")

    @property
    def name(self) -> str:  # noqa: D102
        return f"dT^{self.order}"

    @property
    def temperature_order(self) -> int:  # noqa: D102
        return self.order

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        return np.asarray((features.temperature_c - features.t_ref_c) ** self.order)


@dataclass(frozen=True)
class LaggedTemperaturePower(Basis):
    """``lag(tau):dT^k``: ``dT^k`` of the temperature through a first-order lag of tau s.

    With ``cool_tau_s``, ``lag(tau,cool):dT^k``: the lag's time constant is ``tau_s``
    while the logged temperature is above the lagged one (the die heating) and
    ``cool_tau_s`` while it is below (cooling); equal to ``tau_s``, it is the plain lag.
    """

    tau_s: float
    order: int
    cool_tau_s: float | None = None

    stateful: ClassVar[bool] = True

    def __post_init__(self) -> None:
        # The basis is what its name says: tau to the 6 significant digits files keep,
        # so a model evaluates the same before and after a save and load.
        for tau in (self.tau_s, self.tau_s if self.cool_tau_s is None else self.cool_tau_s):
            if not (math.isfinite(tau) and tau > 0.0):
                raise ParameterError(f"a lag time constant must be positive, s; got {tau}")
        object.__setattr__(self, "tau_s", float(f"{self.tau_s:.6g}"))
        if self.cool_tau_s is not None:
            cool = float(f"{self.cool_tau_s:.6g}")
            object.__setattr__(self, "cool_tau_s", None if cool == self.tau_s else cool)
        if not 1 <= self.order <= 9:
            raise ParameterError(f"temperature order must be 1..9, got {self.order}")

    @property
    def name(self) -> str:  # noqa: D102
        cool = "" if self.cool_tau_s is None else f",{self.cool_tau_s:.6g}"
        return f"lag({self.tau_s:.6g}{cool}):dT^{self.order}"

    @property
    def lag_key(self) -> tuple[float, ...]:  # noqa: D102
        return (self.tau_s,) if self.cool_tau_s is None else (self.tau_s, self.cool_tau_s)

    @property
    def temperature_order(self) -> int:  # noqa: D102
        return self.order

    @property
    def lag_s(self) -> float:  # noqa: D102
        return self.tau_s

    def without_lag(self) -> Basis:  # noqa: D102
        return TemperaturePower(self.order)

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        lagged = features.lagged_temperature_c(self.tau_s, self.cool_tau_s)
        return np.asarray((lagged - features.t_ref_c) ** self.order)


@dataclass(frozen=True)
class TemperatureRate(Basis):
    """``dTdt``: rate of change of temperature, °C/min (causal, smoothed over 60 s)."""

    stateful: ClassVar[bool] = True

    @property
    def name(self) -> str:  # noqa: D102
        return "dTdt"

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        lagged = features.lagged_temperature_c(DTDT_SMOOTHING_S)
        return np.asarray((features.temperature_c - lagged) / DTDT_SMOOTHING_S * 60.0)


@dataclass(frozen=True)
class Elapsed(Basis):
    """``elapsed_h``: time since the start of the run, hours (drift)."""

    stateful: ClassVar[bool] = True

    @property
    def name(self) -> str:  # noqa: D102
        return "elapsed_h"

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        return features._need_time(self.name) / 3600.0


@dataclass(frozen=True)
class Extra(Basis):
    """``extra:NAME``: an extra logged column minus its reference value (kept in the model)."""

    column_name: str

    @property
    def name(self) -> str:  # noqa: D102
        return f"extra:{self.column_name}"

    @property
    def column(self) -> str:  # noqa: D102
        return self.column_name

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        if self.column_name not in features.extras:
            name = self.column_name
            raise ParameterError(
                f"the model uses the extra column {name!r}, which the data does not have"
            )
        ref = (references or {}).get(self.name, 0.0)
        return np.asarray(features.extras[self.column_name], dtype=np.float64) - ref


@dataclass(frozen=True)
class Hinge(Basis):
    """``hinge(k):B``: ``max(B - k, 0)``, a linear-spline piece of an observable.

    ``B`` is one of ``dT^1`` (°C from T_ref), ``dTdt`` (°C/min), ``elapsed_h`` (h) or
    ``extra:NAME`` (the column minus its reference); ``k`` is in ``B``'s units (kept
    to 6 significant digits, as files store it). The line ``B`` and hinges at a few
    knots make a continuous piecewise-linear function of the observable.
    """

    knot: float
    inner: Basis

    stateful: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not math.isfinite(self.knot):
            raise ParameterError(f"a hinge knot must be finite, got {self.knot}")
        object.__setattr__(self, "knot", float(f"{self.knot:.6g}"))
        ok = isinstance(self.inner, (TemperatureRate, Elapsed, Extra)) or (
            isinstance(self.inner, TemperaturePower) and self.inner.order == 1
        )
        if not ok:
            raise ParameterError(
                f"a hinge acts on dT^1, dTdt, elapsed_h or extra:NAME, not {self.inner.name!r}"
            )

    @property
    def name(self) -> str:  # noqa: D102
        return f"hinge({self.knot:.6g}):{self.inner.name}"

    @property
    def column(self) -> str | None:  # noqa: D102
        return self.inner.column

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        return np.maximum(self.inner.evaluate(features, references) - self.knot, 0.0)


@dataclass(frozen=True)
class Decay(Basis):
    """``decay(tau)``: ``exp(-t / tau)``, t the time since the run's start, s (warm-up)."""

    tau_s: float

    stateful: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.tau_s) and self.tau_s > 0.0):
            raise ParameterError(f"a decay time constant must be positive, s; got {self.tau_s}")
        object.__setattr__(self, "tau_s", float(f"{self.tau_s:.6g}"))

    @property
    def name(self) -> str:  # noqa: D102
        return f"decay({self.tau_s:.6g})"

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        return np.exp(-features._need_time(self.name) / self.tau_s)


@dataclass(frozen=True)
class RunStep(Basis):
    """``step(RUN@t0)``: 1 in run ``RUN`` from ``t0`` s after its start on, else 0.

    With ``before``, ``until(RUN@t0)``: 1 in run ``RUN`` before ``t0`` s, else 0 (the
    same step, with the level after it the part's: an offset that went away).
    """

    run: str
    at_s: float
    before: bool = False

    stateful: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if not math.isfinite(self.at_s):
            raise ParameterError(f"a step time must be finite, got {self.at_s}")
        object.__setattr__(self, "at_s", float(f"{self.at_s:.6g}"))

    @property
    def name(self) -> str:  # noqa: D102
        return f"{'until' if self.before else 'step'}({self.run}@{self.at_s:.6g})"

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        if features.run != self.run:
            return np.zeros(len(features))
        after = features._need_time(self.name) >= self.at_s
        return (~after if self.before else after).astype(np.float64)


@dataclass(frozen=True)
class RunRate(Basis):
    """``rate(RUN)``: the temperature's rate of change (``dTdt``, °C/min) in run ``RUN``, else 0.

    A session event: a run whose logged temperature trails (or leads) the part's, a
    probe that lagged in that run only, reads off by about its lag times the rate.
    """

    run: str

    stateful: ClassVar[bool] = True

    @property
    def name(self) -> str:  # noqa: D102
        return f"rate({self.run})"

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        if features.run != self.run:
            return np.zeros(len(features))
        return TemperatureRate().evaluate(features, references)


@dataclass(frozen=True)
class SquaredGravity(Basis):
    """``g_b^2``: the square of the specific force on axis ``b``, g².

    As an offset term of axis ``a`` it is the output's second-order nonlinearity in
    the force (``b == a``: IEEE Std 1293's ``K2``, a scale factor that differs
    between +1 g and -1 g) or its response to the square of the force across
    (``b != a``). Six orientations see ``g_b`` at -1, 0 and +1 g, so the offset,
    the gain and ``g_b^2`` are told apart. Fitting reads the force from the run's
    orientation (:func:`design_columns`); :meth:`evaluate` reads
    :attr:`Features.gravity_g`, which compensation fills with its estimate of the
    force and refines (:class:`accelcore.result.compensator.Compensator`).
    """

    axis: str

    needs_gravity: ClassVar[bool] = True

    def __post_init__(self) -> None:
        if self.axis not in AXES:
            raise ParameterError(f"g_b^2 needs an axis x, y or z, got {self.axis!r}")

    @property
    def name(self) -> str:  # noqa: D102
        return f"g_{self.axis}^2"

    def at_gravity(self, gravity_g: FloatArray, n: int) -> FloatArray:  # noqa: D102
        g = np.asarray(gravity_g, dtype=np.float64)[..., AXES.index(self.axis)]
        return np.broadcast_to(g * g, (n,)).astype(np.float64)

    def evaluate(  # noqa: D102
        self, features: Features, references: Mapping[str, float] | None = None
    ) -> FloatArray:
        if features.gravity_g is None:
            raise ParameterError(
                f"the model term basis {self.name!r} needs the specific force (gravity_g)"
            )
        return self.at_gravity(features.gravity_g, len(features))
