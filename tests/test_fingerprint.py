"""Cache keys of arrays: the core's 128-bit fingerprint, and the spike screen it keys.

The spike screen keeps what it found per channel content (its fingerprint), so a run
whose output is edited in place is screened again, never served a stale answer.
"""

from __future__ import annotations

import numpy as np

from accelcore import Session, simulate
from accelcore._accelcore import fingerprint
from accelcore.fitting.stacking import block_weights


def test_equal_arrays_equal_keys_any_bit_differs() -> None:
    y = np.linspace(-1.0, 1.0, 5000)
    count = np.full(5000, 10)
    key = fingerprint(y, count)
    assert key == fingerprint(y.copy(), count.copy())
    assert key == fingerprint(y[::-1][::-1], count)  # a strided view of the same values
    assert 0 <= key < 2**128
    for other_y, other_count in [
        (np.where(np.arange(5000) == 2500, -0.0, y), count),  # y[2500] is +0.0 there
        (y, np.where(np.arange(5000) == 4999, 9, count)),
        (y[:-1], count),
        (np.nextafter(y, 2.0), count),
    ]:
        assert fingerprint(other_y, other_count) != key


def test_an_output_edited_in_place_is_screened_again() -> None:
    sim = simulate.arrays("ADXL335", seed=4, duration_h=0.2, orientations=("OZ+", "OZ-"))
    session = Session.from_arrays(
        [(r.orientation, dict(r.columns)) for r in sim.runs], units="V", rate_hz=20.0
    )
    run = session.runs[0]
    assert block_weights(run)[0][100] > 0  # no spike there
    run.output[100, 0] += 0.5  # a 0.5 V spike, ~1.7 g: far beyond 8 robust sigma
    assert block_weights(run)[0][100] == 0
