"""Records: contiguous pieces of one log are one run for everything with a history."""

from __future__ import annotations

import numpy as np
import pytest

from accelcore import Session, calibrate
from accelcore.input.records import records
from accelcore.model import Term, base_terms


def _log(t0: float, n: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = t0 + np.arange(n) * 0.5
    temp = 25.0 + 20.0 * np.sin(t / 900.0)
    return {
        "time_s": t,
        "temp_c": temp,
        "x": 0.001 * (temp - 25.0) + 0.001 * rng.standard_normal(n),
        "y": 0.002 * (temp - 25.0) + 0.001 * rng.standard_normal(n),
        "z": 1.0 + 0.001 * rng.standard_normal(n),
    }


def _cut(log: dict[str, np.ndarray], k: int) -> list[dict[str, np.ndarray]]:
    return [{c: v[:k] for c, v in log.items()}, {c: v[k:] for c, v in log.items()}]


def _session(parts: list[tuple[str, dict[str, np.ndarray]]]) -> Session:
    return Session.from_arrays(parts, units="g", rate_hz=2.0, decimation_factor=1)


def test_contiguous_pieces_join_into_the_whole_log() -> None:
    log = _log(1000.0, 4000, 1)
    log["x"] = np.clip(log["x"], -0.01, 0.01)  # a rail, reached in both pieces
    whole = _session([("OZ+", log)])
    cut = _session([("OZ+", p) for p in _cut(log, 1234)])
    (joined,) = records(cut)
    np.testing.assert_array_equal(joined.time_s, whole.runs[0].time_s)
    np.testing.assert_array_equal(joined.output, whole.runs[0].output)
    np.testing.assert_array_equal(joined.count, whole.runs[0].count)
    assert joined.stats.n_rows == whole.runs[0].stats.n_rows
    np.testing.assert_array_equal(joined.stats.channel_max, whole.runs[0].stats.channel_max)
    np.testing.assert_array_equal(joined.stats.channel_min, whole.runs[0].stats.channel_min)
    np.testing.assert_array_equal(joined.stats.n_at_max, whole.runs[0].stats.n_at_max)
    np.testing.assert_array_equal(joined.stats.n_at_min, whole.runs[0].stats.n_at_min)


@pytest.mark.parametrize(
    ("first", "second", "why"),
    [
        ("OZ+", "OZ-", "another orientation"),
        ("OZ+", "OZ+", "a clock that restarts"),
        ("OZ+", "OZ+", "a pause of an hour"),
    ],
)
def test_pieces_that_are_not_one_log_stay_apart(first: str, second: str, why: str) -> None:
    a = _log(1000.0, 2000, 2)
    # A clock that restarts: the second file's times run over the first's (0-1249.5 s
    # against 1000-1999.5 s), whichever is listed first.
    t0 = {"a clock that restarts": 0.0, "a pause of an hour": 1000.0 + 1000.0 + 3600.0}
    b = _log(t0.get(why, 1000.0 + 1000.0), 2500, 3)
    runs = records(_session([(first, a), (second, b)]))
    assert len(runs) == 2, why


def test_pieces_listed_out_of_time_order_join_in_time_order() -> None:
    """The session's order of the files is not the log's: pieces listed last-first, or
    shuffled among other runs, are joined in time order (they were records of their own,
    and a lag's state, the legs and the folds restarted at every file)."""
    log = _log(1000.0, 4000, 5)
    whole = _session([("OZ+", log)])
    pieces = [{c: v[s:e] for c, v in log.items()} for s, e in ((0, 900), (900, 2500), (2500, 4000))]
    other = _log(1000.0, 500, 6)
    cut = _session([("OZ+", pieces[2]), ("OX+", other), ("OZ+", pieces[0]), ("OZ+", pieces[1])])
    joined = records(cut)
    assert [r.orientation for r in joined] == ["OZ+", "OX+"]  # first-listed piece first
    np.testing.assert_array_equal(joined[0].time_s, whole.runs[0].time_s)
    np.testing.assert_array_equal(joined[0].output, whole.runs[0].output)


def test_a_piece_of_one_block_joins_its_neighbours() -> None:
    """One block has no spacing of its own: the session's decides (it was 0: no join)."""
    log = _log(1000.0, 3000, 7)
    pieces = [{c: v[s:e] for c, v in log.items()} for s, e in ((0, 1), (1, 2), (2, 3000))]
    (joined,) = records(_session([("OZ+", p) for p in pieces]))
    np.testing.assert_array_equal(joined.time_s, _session([("OZ+", log)]).runs[0].time_s)


def test_a_lagged_model_is_the_same_whichever_way_the_log_was_cut() -> None:
    # A lag filter carries state; cut into files, its history must not restart.
    log = _log(1000.0, 6000, 4)
    terms = {a: (*base_terms(a), Term("offset", "lag(300):dT^1")) for a in "xyz"}
    whole = calibrate(_session([("OZ+", log)]), terms=terms, t_ref_c=25.0)
    cut = calibrate(_session([("OZ+", p) for p in _cut(log, 2500)]), terms=terms, t_ref_c=25.0)
    for a in "xy":
        # Same rows, same design: equal to the rounding of two QR passes.
        np.testing.assert_allclose(
            cut.axes[a].coefficients, whole.axes[a].coefficients, rtol=1e-9, atol=1e-12
        )
