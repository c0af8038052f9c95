"""Spikes are found once per channel content: a changed output is looked at again.

The quality check and the weights of every fit of a run share their spike search
(:func:`accelcore.input.quality._spikes`), keyed by the digest of the channel's
values, so a run whose output is changed in place is never judged by its old values.
"""

from __future__ import annotations

import numpy as np

from accelcore.input.quality import check_session, excluded_blocks
from accelcore.input.session import Session


def _session(seed: int) -> Session:
    rng = np.random.default_rng(seed)
    n = 4000
    t = np.arange(n) / 2.0
    runs = []
    for orientation, z in (("OZ+", 1.0), ("OZ-", -1.0)):
        runs.append(
            (
                orientation,
                {
                    "time": t,
                    "temperature": 20.0 + 0.01 * t,
                    "x": 1e-3 * rng.normal(size=n),
                    "y": 1e-3 * rng.normal(size=n),
                    "z": z + 1e-3 * rng.normal(size=n),
                },
            )
        )
    return Session.from_arrays(runs, units="g", rate_hz=2.0, decimation_factor=1)


def _outliers(session: Session) -> list[tuple[str | None, int | None]]:
    return [
        (i.channel, i.count) for i in check_session(session, warn=False) if i.kind == "outliers"
    ]


def test_a_spike_written_after_a_check_is_found() -> None:
    session = _session(3)
    run = session.runs[0]
    assert _outliers(session) == []
    assert not excluded_blocks(run)[0].any()
    run.output[1234, 1] += 1.0  # 1000 sigma: a spike on y
    assert _outliers(session) == [("y", 1)]
    mask, n_spikes, _ = excluded_blocks(run)
    assert np.flatnonzero(mask).tolist() == [1234] and n_spikes == 1
    run.output[1234, 1] -= 1.0
    assert _outliers(session) == []
    assert not excluded_blocks(run)[0].any()
