"""Which run files are one record: what session.toml says (``continues``), then the clock.

The same samples cut into files must give the same records (and so the same
diagnosis): a logger that starts a new file with its clock restarted is joined when
``session.toml`` says the file continues the run before it; two power-ons whose files
interleave in time are joined each to its own; ``continues = false`` keeps a new
power-on apart even where its clock follows on.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from accelcore import simulate
from accelcore.errors import SessionFormatError
from accelcore.input.records import records
from accelcore.input.session import load_session

RATE_HZ = 20.0


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, pd.DataFrame]:
    """Two power-ons of OZ- (each timed from 0, 6 min at 20 Hz, different seeds) and one OX+."""
    out = {}
    for name, seed, orient in (("a", 1, "OZ-"), ("b", 2, "OZ-"), ("c", 3, "OX+")):
        sim = simulate.arrays(
            "ADXL335", seed=seed, duration_h=0.1, soak_min=1.0, orientations=(orient,)
        )
        out[name] = pd.DataFrame(sim.runs[0].columns)
    return out


def _write(folder: Path, pieces: Sequence[tuple[str, pd.DataFrame, str, bool | None]]) -> Path:
    """Write each (file, rows, orientation, continues) and a session.toml listing them."""
    folder.mkdir()
    toml = ['format = "accelcore-session/1"', 'sensor = "ADXL335"', 'units = "V"']
    toml.append(f"rate_hz = {RATE_HZ}")
    for file, rows, orient, cont in pieces:
        rows.to_csv(folder / file, index=False, float_format="%.9g")
        toml += ["", "[[run]]", f'file = "{file}"', f'orientation = "{orient}"']
        if cont is not None:
            toml.append(f"continues = {'true' if cont else 'false'}")
    (folder / "session.toml").write_text("\n".join(toml) + "\n")
    return folder


def _cut(frame: pd.DataFrame, at: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    # Cut at a multiple of the decimation (10 rows at 20 Hz): the blocks are the same.
    return frame.iloc[:at], frame.iloc[at:]


def _same(a: object, b: object, shift_s: float = 0.0) -> None:
    np.testing.assert_array_equal(a.output, b.output)  # type: ignore[attr-defined]
    np.testing.assert_array_equal(a.temperature_c, b.temperature_c)  # type: ignore[attr-defined]
    np.testing.assert_allclose(a.time_s, b.time_s + shift_s, rtol=0, atol=1e-9)  # type: ignore[attr-defined]


def test_two_power_ons_cut_with_their_clocks_are_joined_each_to_its_own(
    logs: dict[str, pd.DataFrame], tmp_path: Path
) -> None:
    """Both timed from 0: every piece of one could follow the other's by the clock."""
    whole = records(
        load_session(
            _write(
                tmp_path / "whole",
                [("a.csv", logs["a"], "OZ-", None), ("b.csv", logs["b"], "OZ-", None)],
            ),
            cache=False,
        )
    )
    a1, a2 = _cut(logs["a"], 2400)
    b1, b2 = _cut(logs["b"], 3000)
    listed = {
        "in order": [("a1", a1), ("a2", a2), ("b1", b1), ("b2", b2)],
        "interleaved": [("a1", a1), ("b1", b1), ("b2", b2), ("a2", a2)],
        "backwards": [("b2", b2), ("a2", a2), ("b1", b1), ("a1", a1)],
    }
    for how, pieces in listed.items():
        folder = _write(
            tmp_path / how.replace(" ", "_"), [(f"{n}.csv", f, "OZ-", None) for n, f in pieces]
        )
        got = records(load_session(folder, cache=False))
        assert len(got) == 2, how
        by_start = sorted(got, key=lambda r: float(r.output[0, 2]))
        want = sorted(whole, key=lambda r: float(r.output[0, 2]))
        for g, w in zip(by_start, want, strict=True):
            _same(g, w)


def test_a_restarted_clock_declared_to_continue_is_one_record(
    logs: dict[str, pd.DataFrame], tmp_path: Path
) -> None:
    one = records(
        load_session(_write(tmp_path / "one", [("a.csv", logs["a"], "OZ-", None)]), cache=False)
    )
    first, second = _cut(logs["a"], 4000)
    second = second.assign(time_s=second["time_s"] - second["time_s"].iloc[0])  # clock from 0
    # Not declared: two records (the clock says a new run).
    apart = [("a1.csv", first, "OZ-", None), ("a2.csv", second, "OZ-", None)]
    assert len(records(load_session(_write(tmp_path / "apart", apart), cache=False))) == 2
    joined = [("a1.csv", first, "OZ-", None), ("a2.csv", second, "OZ-", True)]
    got = records(load_session(_write(tmp_path / "joined", joined), cache=False))
    assert len(got) == 1
    # The second file's blocks follow on one block interval (0.5 s) after the first's:
    # exactly where they were in the one file.
    _same(got[0], one[0])
    assert got[0].stats.n_rows == one[0].stats.n_rows


def test_continues_false_keeps_a_new_power_on_apart(
    logs: dict[str, pd.DataFrame], tmp_path: Path
) -> None:
    """A second power-on whose clock runs on (a wall clock) is its own record when said so."""
    first, second = _cut(logs["a"], 4000)
    guessed = [("a1.csv", first, "OZ-", None), ("a2.csv", second, "OZ-", None)]
    assert len(records(load_session(_write(tmp_path / "guessed", guessed), cache=False))) == 1
    said = [("a1.csv", first, "OZ-", None), ("a2.csv", second, "OZ-", False)]
    got = records(load_session(_write(tmp_path / "said", said), cache=False))
    assert [len(r) for r in got] == [400, len(second) // 10]


@pytest.mark.parametrize(
    ("pieces", "message"),
    [
        (
            [("a.csv", "OZ-", True)],
            r"\[\[run\]\] #1 \(OZ-\) says continues = true, but no \[\[run\]\]",
        ),
        (
            [("c.csv", "OX+", None), ("a.csv", "OZ-", True)],
            r"#2 \(OZ-\) says continues = true, but \[\[run\]\] #1 \(OX\+\)",
        ),
        ([("a.csv", "OZ-", "yes")], "continues must be true or false, got 'yes'"),
    ],
)
def test_a_continuation_that_cannot_be_is_refused(
    logs: dict[str, pd.DataFrame],
    tmp_path: Path,
    pieces: list[tuple[str, str, object]],
    message: str,
) -> None:
    folder = tmp_path / "s"
    folder.mkdir()
    toml = ['format = "accelcore-session/1"', 'units = "V"', f"rate_hz = {RATE_HZ}"]
    for file, orient, cont in pieces:
        logs[file[0]].to_csv(folder / file, index=False)
        toml += ["[[run]]", f'file = "{file}"', f'orientation = "{orient}"']
        if cont is not None:
            toml.append(
                f"continues = {'true' if cont is True else repr(cont).replace(chr(39), chr(34))}"
            )
    (folder / "session.toml").write_text("\n".join(toml) + "\n")
    with pytest.raises(SessionFormatError, match=message):
        load_session(folder, cache=False)
