"""The cross-validation engine: samples cut into parts, blocks and folds; held-out fits per axis.

Each run's samples inside the calibration's window are cut into *parts* (run x leg of
the temperature cycle), parts into *blocks* of at most ``block_s`` seconds (the unit
of the paired test), and blocks into *folds* (whole runs, legs, or every third block of
each run). :meth:`Engine.cv` fits an axis model once per fold on the other folds and
once on everything, and scores each block under the fit without its fold.

The rows are pushed once per catalogue, not once per model. The *catalogue* holds
every column a candidate of the model space can use without a lag (offset bases, and
gain bases times each axis' gravity, up to ``max_order``; drift; the extra columns);
its rows go into one :class:`accelcore.core.BlockedLeastSquares`, the three axes as
responses, and its folds are fixed once. A model whose free columns are all in a
catalogue is a subset query (:meth:`accelcore.core.FoldedLeastSquares.cross_validate`):
no row is visited again. Once the selection keeps a lag (:meth:`Engine.keep_lags`),
a catalogue with that lag (every temperature basis lagged, or the rate term added)
serves the models of later steps the same way. A model with other columns (the lag
search's trial time constants, chosen from the data one at a time) pushes its own
rows once, into its own blocked factors. Results are kept (:attr:`Engine.memo_size`
models). A column some training data cannot identify is held at zero, the later of two
dependent ones (:meth:`accelcore.core.LeastSquares.solve_identifiable`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from accelcore._accelcore import first_order_lag
from accelcore.core import BlockedLeastSquares, FoldedLeastSquares, HeldOutFit
from accelcore.fitting.calibrate import Stacked
from accelcore.input.records import record_names, records
from accelcore.input.session import Session
from accelcore.model import (
    AXES,
    Basis,
    Constant,
    Elapsed,
    Extra,
    Hinge,
    LaggedTemperaturePower,
    TemperaturePower,
    Term,
    design_columns,
)
from accelcore.pools import shared_pool
from accelcore.result.calibration import AxisModel, Calibration

from .fits import CV, Fit, fold_coefficients
from .folds import choose_folds, cut_blocks, fold_spans
from .parts import axis_responses, cut_parts
from .windows import choose_windows, noise_floor

__all__ = ["CV", "Engine"]

FloatArray = NDArray[np.float64]
_T = TypeVar("_T")


class Engine:
    """Samples cut into parts (run x leg), blocks and folds; fast blocked CV per axis."""

    def __init__(
        self,
        session: Session,
        base: Calibration,
        *,
        folds: str,
        block_s: float,
        steady_c_per_min: float,
        max_order: int = 5,
        corrections: Sequence[FloatArray] | None = None,
        threads: int = 1,
    ) -> None:
        # ``corrections``: per part (in the order parts are cut), what to take off
        # the output first (session events fitted on an earlier pass), session units.
        self.session = session
        self._settings = (folds, block_s, steady_c_per_min, max_order)
        #: Threads of the catalogues' pushes (independent problems in the core).
        self.threads = max(1, int(threads))
        # Contiguous pieces of one log are one record: folds never follow file cuts.
        self.records = records(session)
        self.record_names = record_names(self.records)
        self.t_ref_c = base.t_ref_c
        self.references = dict(base.references)
        parts = cut_parts(
            self.records,
            self.record_names,
            base,
            steady_c_per_min=steady_c_per_min,
            corrections=corrections,
        )
        feats = parts.features
        self._wholes = parts.wholes
        self.data = Stacked(feats, parts.gravity, parts.output, parts.weight, parts.run)
        self._gather = np.concatenate(parts.gather)
        self.part_run = parts.run
        self.part_leg = parts.leg
        self.leg_s = parts.leg_s
        self.leg_kinds = parts.leg_kinds
        sizes = [len(f) for f in feats]
        self.n = int(sum(sizes))
        self.part_start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        self.w = np.concatenate(parts.weight)
        self.gravity = np.vstack(
            [np.broadcast_to(g, (s, 3)) for g, s in zip(parts.gravity, sizes, strict=True)]
        )
        self.output = np.vstack(parts.output)
        #: Distinct gravity values each axis sees (2 or more: offset and gain told apart).
        self.gravity_values = tuple(int(np.unique(self.gravity[:, i]).size) for i in range(3))
        #: Axes whose gravity a cross-axis gain can be told on (:meth:`.Parts.gain_sources`).
        self.gain_sources = parts.gain_sources()
        self.temperature = np.concatenate([f.temperature_c for f in feats])
        self.elapsed_s = np.concatenate([np.asarray(f.time_s) for f in feats])
        self.rate = np.concatenate(parts.rate_c_per_min)
        self.sample_part = np.repeat(np.arange(len(feats)), sizes)
        self.sample_run = np.repeat(np.asarray(parts.run), sizes)
        self.extras = {
            name: np.concatenate([np.asarray(f.extras[name]) for f in feats])
            for name in session.extra_columns
        }
        self._basis_cache: dict[Basis, FloatArray] = {}
        starts, block_part = cut_blocks(
            [np.asarray(f.time_s) for f in feats], self.part_start, block_s
        )
        self.block_start = np.asarray(starts, dtype=np.int64)
        self.block_part = np.asarray(block_part, dtype=np.int64)
        self.block_stop = np.append(self.block_start[1:], self.n)
        self.sample_block = np.repeat(
            np.arange(self.block_start.size), self.block_stop - self.block_start
        )
        self.scheme, self.fold_names, self.block_fold = choose_folds(
            folds,
            parts.run,
            parts.leg,
            parts.gravity,
            self.record_names,  # not the files': folds do not follow file cuts, nor names
            parts.leg_kinds,
            self.block_part,
            self.elapsed_s[self.block_start],
            [(float(np.min(f.temperature_c)), float(np.max(f.temperature_c))) for f in feats],
        )
        self.n_folds = len(self.fold_names)
        self.sample_fold = self.block_fold[self.sample_block]
        self.fold_rows = [np.flatnonzero(self.sample_fold == k) for k in range(self.n_folds)]
        #: Each fold as contiguous stretches of samples (neighbouring blocks joined).
        self.fold_spans = fold_spans(
            self.block_fold, self.block_start, self.block_stop, self.n_folds
        )
        # Scale per axis (units per g) for mg conversion, fixed terms, centring.
        self.base = base
        self.scale, self.fixed, self.y = axis_responses(
            base, session, self.output, self.gravity, self.column
        )
        self.windows = choose_windows(
            self.w,
            self.block_start,
            self.block_stop,
            [self.temperature, self.rate, self.elapsed_s, *self.extras.values()],
            [self.y[a] for a in AXES],
        )
        self.sample_window = self.windows.sample_window
        self.n_windows = self.windows.n
        self.window_start = self.windows.start
        self.window_weight = self.windows.weight
        self.window_block = self.windows.block
        self.window_gravity = np.column_stack([self.compress(self.gravity[:, i]) for i in range(3)])
        self._cbasis_cache: dict[Basis, FloatArray] = {}
        # Each axis' response as window means, and what the means leave out: the weighted
        # square of each sample about its window's mean, per block (in every model's SSE).
        self._yc: dict[str, FloatArray] = {}
        self._within: dict[str, FloatArray] = {}
        for a in AXES:
            yc = self.compress(self.y[a])
            self._yc[a] = yc
            dev = self.y[a] - yc[self.sample_window]
            self._within[a] = np.bincount(
                self.sample_block, weights=self.w * dev * dev, minlength=self.block_start.size
            ).astype(np.float64)
        self._within_total = {a: float(self._within[a].sum()) for a in AXES}
        self._wsum = float(self.w.sum())
        # The least held-out squared error any model leaves, its noise (:func:`noise_floor`).
        self.noise_floor = {
            a: noise_floor(self.y[a], self.w, self.sample_block, self._within_total[a])
            for a in AXES
        }
        self._memo: dict[tuple[str, tuple[_Key, ...]], HeldOutFit] = {}
        self._fixed_keys = {a: {_loose_key(t) for t, _ in self.fixed[a]} for a in AXES}
        self._free: dict[tuple[str, tuple[Term, ...]], tuple[Term, ...]] = {}
        #: Full fits of axis models on every sample (:func:`.parameters.fit_models`).
        self.fitted: dict[tuple[str, tuple[Term, ...]], tuple[AxisModel, list[str], list[str]]] = {}
        self.max_order = max_order
        #: Extra columns that are finite and vary (candidates of the model space).
        self.varying_extras = [
            name
            for name, values in self.extras.items()
            if np.all(np.isfinite(values)) and float(np.std(values)) > 0
        ]
        #: Knots of each observable of the generic family (filled by that family).
        self.knot_cache: dict[tuple[Basis, tuple[float, ...]], tuple[float, ...]] = {}
        #: The weighted samples of each observable and their 5–95 % span (for its knots).
        self.span_cache: dict[Basis, tuple[FloatArray, tuple[float, float] | None]] = {}
        self._attempted: set[tuple[str, str]] = set()
        self._model_keys: tuple[_Key, ...] = ()
        # Catalogues of columns, their rows pushed once: (column index, folds) per lag,
        # or per observable of the generic family (("generic", name)).
        self._wide: dict[_CatalogueName, tuple[dict[_Key, int], FoldedLeastSquares]] = {}
        self._push_catalogues([(None, self._catalogue(None))])
        #: Records whose level is off by a session event (free in :mod:`.between`'s tests).
        self.event_runs: frozenset[str] = frozenset()

    def less(self, corrections: Sequence[FloatArray], event_runs: Sequence[str] = ()) -> Engine:
        """Return this session's engine on the output less ``corrections`` (:attr:`event_runs`)."""
        folds, block_s, steady, order = self._settings
        found = Engine(
            self.session,
            self.base,
            folds=folds,
            block_s=block_s,
            steady_c_per_min=steady,
            max_order=order,
            corrections=corrections,
            threads=self.threads,
        )
        found.event_runs = frozenset(event_runs)
        return found

    def compress(self, values: FloatArray) -> FloatArray:
        """Return the weighted mean of ``values`` (one per sample) in every window."""
        return self.windows.compress(values)

    # -------------------------------------------------------------- columns
    def basis(self, basis: Basis | str) -> FloatArray:
        """Return the column of a basis (e.g. ``dT^2``, ``lag(60):dT^1``) over every sample."""
        key = Basis.parse(basis)
        if key not in self._basis_cache and isinstance(
            key, (TemperaturePower, LaggedTemperaturePower)
        ):
            if isinstance(key, LaggedTemperaturePower) and key.order == 1:
                # One filter pass per record, as a part's features would run it.
                lagged = np.concatenate(
                    [
                        first_order_lag(t, temp, key.tau_s, tau_cool_s=key.cool_tau_s)
                        for t, temp in self._wholes
                    ]
                )
                self._basis_cache[key] = lagged[self._gather] - self.t_ref_c
            elif key.order > 1:
                # dT^k = dT^(k-1) * dT: one filter pass per lag, one product per order.
                lower = replace(key, order=key.order - 1)
                first = replace(key, order=1)
                self._basis_cache[key] = self.basis(lower) * self.basis(first)
        if key not in self._basis_cache and isinstance(key, Hinge):
            # max(B - k, 0) of the observable's column: the same floats as per part.
            self._basis_cache[key] = np.maximum(self.basis(key.inner) - key.knot, 0.0)
        if key not in self._basis_cache:
            one = Term("offset", key)
            self._basis_cache[key] = np.concatenate(
                [
                    design_columns((one,), f, g, self.references)[:, 0]
                    for f, g in zip(self.data.features, self.data.gravity, strict=True)
                ]
            )
        return self._basis_cache[key]

    def drop_lag_cache(self, keep: Sequence[float | tuple[float, float]]) -> None:
        """Forget the cached lagged bases except those of the time constants ``keep``.

        Each a time constant or a (heating, cooling) pair.
        """
        keep_s = {_lag_text(k) for k in keep}
        for key in list(self._basis_cache):
            if key.lag_key is not None and _lag_text(key.lag_key) not in keep_s:
                del self._basis_cache[key]

    def column(self, term: Term) -> FloatArray:
        """Return the design column of a term (a gain term's basis times its gravity)."""
        return self._key_column(_key(term))

    def free_terms(self, axis: str, terms: Sequence[Term]) -> tuple[Term, ...]:
        """Terms minus those the base held fixed (matched ignoring lag)."""
        memo_key = (axis, tuple(terms))
        found = self._free.get(memo_key)
        if found is None:
            fixed = self._fixed_keys[axis]
            found = tuple(t for t in terms if _loose_key(t) not in fixed)
            if len(self._free) >= 4 * self.memo_size:
                self._free.clear()
            self._free[memo_key] = found
        return found

    def design(self, axis: str, terms: Sequence[Term]) -> FloatArray:
        """Return the design of the free terms of an axis model, one row per sample."""
        free = self.free_terms(axis, terms)
        if not free:
            return np.zeros((self.n, 0))
        return np.column_stack([self.column(t) for t in free])

    # -------------------------------------------------------------- fitting
    def _catalogue(
        self,
        lag: _CatalogueName,
        extra_keys: Sequence[_Key] = (),
        only: bool = False,
    ) -> tuple[list[_Key], FloatArray] | None:
        """Return the columns of a catalogue and their window design (None: not finite).

        ``lag`` None: the catalogue without a lag. ``("die", tau)``: every temperature
        basis lagged by ``tau`` (``("die", (heating, cooling))``: by a lag of each
        direction, :class:`~accelcore.model.LaggedTemperaturePower`). ``("rate", tau)``:
        the one without a lag plus the rate term ``lag(tau):dT^1``. ``extra_keys`` are
        further columns; ``only``: they are the whole catalogue.
        """
        plain: list[Basis] = [TemperaturePower(k) for k in range(1, self.max_order + 1)]
        temps: list[Basis] = plain
        if lag is not None and lag[0] == "die":
            tau, cool = _lag_pair(lag[1])
            temps = [LaggedTemperaturePower(tau, k, cool) for k in range(1, self.max_order + 1)]
        offsets: list[Basis] = [Constant(), *temps, Elapsed()]
        offsets += [Extra(name) for name in self.varying_extras]
        if lag is not None and lag[0] == "rate":
            offsets.append(LaggedTemperaturePower(_lag_pair(lag[1])[0], 1))
        gains: list[Basis] = [Constant(), *temps]
        keys: list[_Key] = [(b, None) for b in offsets] + [(b, a) for a in AXES for b in gains]
        keys = list(extra_keys) if only else keys + [k for k in extra_keys if k not in keys]
        keys = keys[:_MAX_COLUMNS]
        design = np.empty((self.n_windows, len(keys)))
        for i, key in enumerate(keys):
            design[:, i] = self._window_column(key)
        if not np.all(np.isfinite(design)):
            return None
        return keys, design

    def _push_catalogues(
        self, catalogues: Sequence[tuple[_CatalogueName, tuple[list[_Key], FloatArray] | None]]
    ) -> None:
        """Push the rows of catalogues (three responses) and fix their folds, at once.

        Each is its own problem in the core: they run on up to :attr:`threads` threads.
        """
        todo = [(name, found) for name, found in catalogues if found is not None]
        responses = np.column_stack([self._yc[a] for a in AXES])

        def push(design: FloatArray) -> FoldedLeastSquares:
            wide = BlockedLeastSquares(
                design.shape[1], int(self.block_start.size), n_responses=len(AXES)
            )
            wide.push(design, responses, self.window_block, self.window_weight)
            return wide.folds(self.block_fold)

        designs = [found[1] for _, found in todo]
        if self.threads > 1 and len(designs) > 1:
            folded = list(shared_pool("accelcore-engine", self.threads).map(push, designs))
        else:
            folded = [push(d) for d in designs]
        for (name, (keys, _)), f in zip(todo, folded, strict=True):
            self._wide[name] = ({k: i for i, k in enumerate(keys)}, f)

    def set_models(self, terms: Mapping[str, Sequence[Term]]) -> None:
        """Note the current model of every axis (the columns of :meth:`ensure_catalogues`)."""
        keys: list[_Key] = []
        for a, ts in terms.items():
            keys += [k for k in self._keys(a, ts) if k not in keys]
        self._model_keys = tuple(keys)

    def ensure_catalogues(
        self, catalogues: Sequence[tuple[str, Sequence[tuple[Basis, str | None]]]]
    ) -> None:
        """Push, once, for each (name, columns), the current models' columns plus ``columns``.

        ``columns`` are (basis, source) pairs. The generic family keeps one per
        observable and set of current models, so that its candidates (a model plus
        some of ``columns``) are subset queries. New ones are pushed together
        (:meth:`_push_catalogues`).
        """
        todo: list[tuple[_CatalogueName, tuple[list[_Key], FloatArray] | None]] = []
        for name, columns in catalogues:
            cols = [*self._model_keys, *(c for c in columns if c not in self._model_keys)]
            key = ("generic", f"{name}|{hash(tuple(cols))}")
            if key in self._attempted:
                continue
            self._attempted.add(key)
            for old in [k for k in self._wide if k is not None and k[0] == "generic"]:
                if str(old[1]).split("|")[0] == name:
                    del self._wide[old]  # the models moved on: its columns are stale
            todo.append((key, self._catalogue(None, cols, only=True)))
        self._push_catalogues(todo)

    def cv_coarse(self, axis: str, terms: Sequence[Term]) -> float:
        """Held-out weighted SSE of an axis model on every :attr:`coarse_stride`-th row.

        For searches over a nonlinear parameter (a lag's time constant): each trial
        pushes a fraction of the rows; the value found is then scored on every row.
        Same blocks and folds as :meth:`cv`.
        """
        keys = self._keys(axis, terms)
        rows = slice(None, None, self.coarse_stride)
        y, w = self._yc[axis][rows], self.window_weight[rows]
        if not keys:
            return float((w * y * y).sum())
        x = np.column_stack([self._window_column(k)[rows] for k in keys])
        own = BlockedLeastSquares(x.shape[1], int(self.block_start.size))
        own.push(x, y, self.window_block[rows], w)
        fit = own.cross_validate(self.block_fold)
        return float(np.sum(fit.heldout_rss_per_block))

    @property
    def coarse_stride(self) -> int:
        """Window stride of :meth:`cv_coarse`: about :data:`COARSE_ROWS` windows, at least all."""
        return max(1, self.n_windows // COARSE_ROWS)

    def keep_lags(self, die: Sequence[float | tuple[float, float]], rate: Sequence[float]) -> None:
        """Keep a catalogue (rows pushed once) for each lag the models now hold; drop the rest.

        ``die`` and ``rate`` are the time constants of the models' die lags (each one,
        or a (heating, cooling) pair) and rate terms. Lagged bases of other time
        constants are forgotten too.
        """
        wanted: set[_CatalogueName] = {None}
        wanted |= {("die", t) for t in die} | {("rate", float(t)) for t in rate}
        for lag in list(self._wide):
            if lag not in wanted and (lag is None or lag[0] != "generic"):
                del self._wide[lag]
        self.drop_lag_cache([*die, *rate])
        missing = sorted((lag for lag in wanted if lag not in self._wide), key=str)
        self._push_catalogues([(lag, self._catalogue(lag)) for lag in missing])

    def _window_column(self, key: _Key) -> FloatArray:
        """Return the column of a key as window means (a gain's gravity is constant in one)."""
        basis, source = key
        col = self._cbasis_cache.get(basis)
        if col is None:
            col = self.compress(self.basis(basis))
            if len(self._cbasis_cache) > 4 * _MAX_COLUMNS:
                self._cbasis_cache.clear()
            self._cbasis_cache[basis] = col
        if source is None:
            return col
        return col * self.window_gravity[:, AXES.index(source)]

    def _key_column(self, key: _Key) -> FloatArray:
        basis, source = key
        col = self.basis(basis)
        return col if source is None else col * self.gravity[:, AXES.index(source)]

    def _keys(self, axis: str, terms: Sequence[Term]) -> tuple[_Key, ...]:
        """Column keys of the free terms of an axis model, in term order."""
        return tuple(_key(t) for t in self.free_terms(axis, terms))

    def _heldout_of(self, axis: str, terms: Sequence[Term]) -> HeldOutFit | None:
        """:meth:`_heldout` of an axis model's free columns, kept by its terms.

        Terms keep their hash; a model's column keys (bases) would be hashed anew at
        every lookup, and the selection asks for the same models many times.
        """
        return self.kept(
            "_by_terms", (axis, tuple(terms)), lambda: self._heldout(axis, self._keys(axis, terms))
        )

    def _heldout(self, axis: str, keys: tuple[_Key, ...]) -> HeldOutFit | None:
        """Held-out fit of the columns ``keys`` for ``axis`` (None: no free column)."""
        if not keys:
            return None
        memo_key = (axis, keys)
        fit = self._memo.get(memo_key)
        if fit is not None:
            return fit
        wide = next((w for w in self._wide.values() if all(k in w[0] for k in keys)), None)
        if wide is not None:
            columns = [wide[0][k] for k in keys]
            fit = wide[1].cross_validate(columns, response=AXES.index(axis))
        else:
            x = np.column_stack([self._window_column(k) for k in keys])
            own = BlockedLeastSquares(x.shape[1], int(self.block_start.size))
            own.push(x, self._yc[axis], self.window_block, self.window_weight)
            fit = own.cross_validate(self.block_fold)
        if len(self._memo) >= self.memo_size:
            self._memo.clear()
        self._memo[memo_key] = fit
        return fit

    #: Held-out fits kept (models asked for again are not fitted again).
    memo_size = 256

    def kept(self, name: str, memo: object, make: Callable[[], _T], limit: int = 0) -> _T:
        """``make()``, kept in this engine's cache ``name`` under ``memo`` (a full one cleared)."""
        cache: dict[object, _T] = self.__dict__.setdefault(name, {})
        if memo not in cache:
            if len(cache) >= (limit or self.memo_size):
                cache.clear()
            cache[memo] = make()
        return cache[memo]

    def fit(self, axis: str, terms: Sequence[Term]) -> Fit:
        """Fit the free terms of ``terms`` on every fold's training data and on all data."""
        keys = self._keys(axis, terms)
        columns = tuple(self._key_column(k) for k in keys)
        held = self._heldout(axis, keys)
        if held is None:
            y, w = self.y[axis], self.w
            return Fit(columns, np.zeros(0), np.zeros((self.n_folds, 0)), float((w * y * y).sum()))
        beta_in, beta_fold = fold_coefficients(held, self.n_folds)
        within = self._within_total[axis]
        return Fit(columns, beta_in, beta_fold, float(held.in_sample_rss) + within)

    def heldout_residuals(self, y: FloatArray, fit: Fit) -> FloatArray:
        """Residual of every sample under the fit that held its fold out, mg."""
        if not fit.columns:
            return y.copy()
        r_out = np.empty(self.n)
        for k, spans in enumerate(self.fold_spans):
            for s, e in spans:
                r_out[s:e] = y[s:e] - fit.fitted(fit.beta_fold[k], s, e)
        return r_out

    def cv(self, axis: str, terms: Sequence[Term]) -> CV:
        """Held-out error per block and in-sample error of an axis model."""
        held = self._heldout_of(axis, terms)
        if held is None:
            y2 = self.w * self.y[axis] ** 2
            sse_blocks = np.bincount(
                self.sample_block, weights=y2, minlength=self.block_start.size
            ).astype(np.float64)
            sse_in = float(y2.sum())
        else:
            within = self._within[axis]
            sse_blocks = np.array(held.heldout_rss_per_block, dtype=np.float64) + within
            sse_in = max(float(held.in_sample_rss), 0.0) + self._within_total[axis]
        wsum = self._wsum
        return CV(
            tuple(terms),
            sse_blocks.astype(np.float64),
            sse_in,
            math.sqrt(float(sse_blocks.sum()) / wsum),
            math.sqrt(sse_in / wsum),
        )

    def residuals(self, axis: str, terms: Sequence[Term]) -> tuple[FloatArray, FloatArray]:
        """In-sample and held-out residual per sample, mg (read-only arrays, kept)."""

        def make() -> tuple[FloatArray, FloatArray]:
            fit = self.fit(axis, terms)
            y = self.y[axis]
            r_in = y - fit.fitted(fit.beta_in) if fit.columns else y.copy()
            found = (r_in, self.heldout_residuals(y, fit))
            for r in found:
                r.flags.writeable = False
            return found

        # The models asked for last: each step, the events and the end ask for the same.
        return self.kept("_residuals", (axis, self._keys(axis, terms)), make, 4 * len(AXES))


#: A design column: a basis, alone (offset, ``None``) or times an axis' gravity (gain).
_Key = tuple[Basis, str | None]

#: A catalogue: None (no lag), ``("die"|"rate", tau)``, ``("die", (heating, cooling))``
#: or ``("generic", name)``.
_CatalogueName = tuple[str, float | tuple[float, float] | str] | None

#: Rows a coarse search trial (:meth:`Engine.cv_coarse`) aims at.
COARSE_ROWS = 4_000

#: Most columns of one least-squares problem in the core.
_MAX_COLUMNS = 64


def _loose_key(term: Term) -> tuple[str, Basis, str | None]:
    """Return what matches a term to a fixed one: kind, basis without its lag, gain source."""
    return term.kind, term.basis.without_lag(), term.source if term.kind == "gain" else None


def _key(term: Term) -> _Key:
    """Return the design column of a term."""
    return (term.basis, (term.source or "x") if term.kind == "gain" else None)


def _lag_pair(lag: float | tuple[float, float] | str) -> tuple[float, float | None]:
    """Return a catalogue's lag as (time constant, cooling one or None)."""
    if isinstance(lag, tuple):
        return float(lag[0]), float(lag[1])
    return float(lag), None


def _lag_text(lag: float | tuple[float, ...]) -> str:
    """Return a lag's time constants as the 6 digits a basis keeps, for matching."""
    taus = lag if isinstance(lag, tuple) else (lag,)
    return ",".join(f"{t:.6g}" for t in taus)
