"""The streaming log reader: what each kind of bad input gets, and that good input is exact."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.typing import NDArray

import accelcore
from accelcore._accelcore import RunTally, read_run
from accelcore.reference import Decimator as RefDecimator
from strategies import DecimatorCase, chunks, decimator_cases

HEADER = "time_s,temp_c,x,y,z\n"


def _log(tmp_path: Path, text: str | bytes, name: str = "run.csv") -> str:
    path = tmp_path / name
    if isinstance(text, str):
        path.write_text(text, newline="")
    else:
        path.write_bytes(text)
    return str(path)


def _rows(n: int, rate_hz: float = 20.0) -> str:
    t = np.arange(n) / rate_hz
    lines = [
        f"{ti:.2f},{20 + 0.01 * i:.3f},{1.5 + 0.001 * i:.6f},1.48,1.84" for i, ti in enumerate(t)
    ]
    return "\n".join(lines) + "\n"


def test_good_log_matches_reference_decimation(tmp_path: Path) -> None:
    path = _log(tmp_path, HEADER + _rows(95))
    data = read_run(path)
    raw = np.loadtxt(path, delimiter=",", skiprows=1)
    ref = RefDecimator(factor=10, rate_hz=20.0, n_channels=3)
    ref.push(raw[:, 0], raw[:, 1], raw[:, 2:])
    expected = ref.finish()
    # Same parsed doubles, same block sums in the same order: equal to rounding of the mean.
    np.testing.assert_allclose(data.blocks.channels, expected.channels, rtol=1e-15)
    np.testing.assert_array_equal(data.blocks.count, expected.count)
    assert data.n_rows == 95
    assert data.channel_names == ["x", "y", "z"]


def test_extra_columns_are_kept_as_observables(tmp_path: Path) -> None:
    text = "time_s,temp_c,x,y,z,supply_v\n" + "".join(
        f"{i / 20:.2f},20.0,1.5,1.5,1.8,{3.0 + 0.001 * i}\n" for i in range(20)
    )
    data = read_run(_log(tmp_path, text))
    assert data.channel_names == ["x", "y", "z", "supply_v"]
    np.testing.assert_allclose(data.blocks.channels[:, 3], [3.0045, 3.0145], rtol=1e-12)


def test_crlf_and_byte_order_mark_are_accepted(tmp_path: Path) -> None:
    text = ("\ufeff" + HEADER + _rows(20)).replace("\n", "\r\n").encode("utf-8")
    data = read_run(_log(tmp_path, text))
    assert data.n_rows == 20
    assert data.header[0] == "time_s"


def test_non_numeric_cell_names_file_line_and_column(tmp_path: Path) -> None:
    rows = _rows(10).splitlines()
    rows[4] = rows[4].replace("1.48", "1.4B")
    path = _log(tmp_path, HEADER + "\n".join(rows) + "\n")
    with pytest.raises(accelcore.ParseError) as info:
        read_run(path)
    err = info.value
    assert (err.path, err.line, err.column) == (path, 6, 4)  # header is line 1
    assert "1.4B" in str(err) and "'y'" in str(err)
    assert isinstance(err, ValueError)


def test_a_preamble_above_the_header_is_skipped(tmp_path: Path) -> None:
    """A logger's settings lines above the header (an Arduino dump: Fs, range, ...)."""
    body = HEADER + _rows(40)
    plain = read_run(_log(tmp_path, body, "plain.csv"))
    path = _log(tmp_path, "Fs,20\nLogging Type,1\n\nrange;2g\n" + body, "dump.csv")
    data = read_run(path)
    np.testing.assert_array_equal(data.blocks.channels, plain.blocks.channels)
    assert data.n_rows == plain.n_rows and data.header == plain.header
    # Read in pieces (bulk's split of a long log) the same: a block cut by a piece
    # boundary is the count-weighted mean of two partial means, equal to a few ulps.
    from accelcore.apps.bulk import read_run_split

    split = read_run_split(path, pieces=3)
    np.testing.assert_allclose(split.blocks.channels, plain.blocks.channels, rtol=1e-14, atol=0)
    # Lines keep their numbers: the header is line 5, a bad cell of the 3rd row line 8.
    rows = body.splitlines()
    rows[3] = rows[3].replace("1.48", "1.4B")
    bad = _log(tmp_path, "Fs,20\nLogging Type,1\n\nrange;2g\n" + "\n".join(rows) + "\n", "bad.csv")
    with pytest.raises(accelcore.ParseError) as info:
        read_run(bad)
    assert (info.value.line, info.value.column) == (8, 4)


def test_missing_column_lists_what_was_found(tmp_path: Path) -> None:
    path = _log(tmp_path, "time_s,temp_c,x,y,zz\n0,1,2,3,4\n")
    with pytest.raises(accelcore.ParseError, match=r"missing column\(s\) 'z'.*'zz'") as info:
        read_run(path)
    assert info.value.line == 1


def test_other_delimiter_is_suggested(tmp_path: Path) -> None:
    path = _log(tmp_path, HEADER.replace(",", ";") + "0;1;2;3;4\n")
    with pytest.raises(accelcore.ParseError, match="is the delimiter ';'"):
        read_run(path)
    assert read_run(path, delimiter=";").n_rows == 1


@pytest.mark.parametrize("text", ["", "\n\n"])
def test_empty_file(tmp_path: Path, text: str) -> None:
    with pytest.raises(accelcore.ParseError, match="empty file"):
        read_run(_log(tmp_path, text))


def test_header_only(tmp_path: Path) -> None:
    with pytest.raises(accelcore.ParseError, match="no data rows"):
        read_run(_log(tmp_path, HEADER))


def test_truncated_last_line_is_dropped_and_counted(tmp_path: Path) -> None:
    data = read_run(_log(tmp_path, HEADER + _rows(20) + "1.00,20.2,1.5"))
    assert data.n_rows == 20
    assert data.n_truncated_rows == 1


def test_short_line_in_the_middle_is_an_error(tmp_path: Path) -> None:
    rows = _rows(10).splitlines()
    rows[2] = "0.10,20.0,1.5"
    with pytest.raises(accelcore.ParseError, match="3 fields where the header") as info:
        read_run(_log(tmp_path, HEADER + "\n".join(rows) + "\n"))
    assert info.value.line == 4


@pytest.mark.parametrize(("bad", "word"), [("0.10", "repeats"), ("0.01", "goes backwards")])
def test_time_going_backwards_or_repeating_names_the_line(
    tmp_path: Path, bad: str, word: str
) -> None:
    rows = _rows(10).splitlines()
    rows[3] = bad + rows[3][4:]
    with pytest.raises(accelcore.ParseError, match=word) as info:
        read_run(_log(tmp_path, HEADER + "\n".join(rows) + "\n"))
    assert (info.value.line, info.value.column) == (5, 1)


def test_nan_inf_and_empty_cells_are_skipped_and_counted(tmp_path: Path) -> None:
    rows = _rows(20).splitlines()
    rows[1] = rows[1].replace("1.48", "nan")
    rows[2] = rows[2].replace("1.48", "inf")
    rows[3] = rows[3].replace("1.48", "")
    data = read_run(_log(tmp_path, HEADER + "\n".join(rows) + "\n"))
    assert data.n_skipped_nonfinite == 3
    assert data.blocks.count.tolist() == [7, 10]


def test_gap_keeps_later_blocks_aligned_and_is_reported(tmp_path: Path) -> None:
    t = np.r_[np.arange(20), np.arange(20) + 53] / 20.0  # 1.65 s hole
    text = HEADER + "".join(f"{ti:.2f},20,1,1,1\n" for ti in t)
    data = read_run(_log(tmp_path, text))
    # Blocks are 0.5 s wide from t0 = 0: the samples after the hole start at 2.65 s -> block 5.
    assert data.blocks.block_index.tolist() == [0, 1, 5, 6, 7]
    assert data.n_gaps == 1
    assert data.max_interval_s == pytest.approx(1.7)


def test_clipping_counts_samples_at_the_rails(tmp_path: Path) -> None:
    text = HEADER + "".join(f"{i / 20:.2f},20,1.5,1.5,{min(2.0 + i, 3.3)}\n" for i in range(30))
    data = read_run(_log(tmp_path, text))
    assert data.channel_max[2] == 3.3
    assert data.n_at_max[2] == 28


def test_missing_file_is_an_os_error(tmp_path: Path) -> None:
    with pytest.raises(accelcore.AccelcoreIOError) as info:
        read_run(str(tmp_path / "nope.csv"))
    assert isinstance(info.value, OSError)
    assert info.value.path.endswith("nope.csv")


@pytest.mark.parametrize(
    "text",
    [
        HEADER + _rows(30),
        # CRLF line ends, a byte-order mark, and a last line cut off mid-write: the
        # digest covers every byte of the file, the dropped line included.
        ("\ufeff" + HEADER + _rows(30)).replace("\n", "\r\n") + "1.50,20.3,1.5",
        # Over 1 MB: several fills of the reader's buffer.
        HEADER + _rows(30_000),
    ],
    ids=["plain", "crlf-bom-cut", "multi-buffer"],
)
def test_sha256_is_that_of_the_bytes_read(tmp_path: Path, text: str) -> None:
    import hashlib

    path = _log(tmp_path, text)
    hashed = read_run(path, sha256=True)
    plain = read_run(path)
    assert hashed.sha256 == hashlib.sha256(Path(path).read_bytes()).hexdigest()
    assert plain.sha256 is None
    np.testing.assert_array_equal(hashed.blocks.channels, plain.blocks.channels)
    assert (hashed.n_rows, hashed.n_truncated_rows) == (plain.n_rows, plain.n_truncated_rows)


def test_session_hashes_are_sha256_of_the_files(tmp_path: Path) -> None:
    import hashlib

    folder = tmp_path / "s"
    from accelcore import simulate

    simulate.session(folder, duration_h=0.1, soak_min=1.0, seed=4)
    session = accelcore.load_session(folder, cache=False, digest="sha256")
    expected = {
        f.name: hashlib.sha256(f.read_bytes()).hexdigest()
        for f in folder.iterdir()
        if f.suffix in (".csv", ".toml") and f.name != "truth.toml"
    }
    assert session.file_hashes() == expected


# --------------------------------------------------------------------------- RunTally


def _plain_raw_stats(
    time_s: NDArray[np.float64],
    temperature_c: NDArray[np.float64],
    channels: NDArray[np.float64],
    rate_hz: float,
) -> dict[str, Any]:
    """RawStats computed the plainest NumPy way, from the whole arrays."""
    t = time_s[np.isfinite(time_s)]
    dt = np.diff(t)
    ok = np.isfinite(time_s) & np.isfinite(temperature_c) & np.isfinite(channels).all(axis=1)
    lo, hi, at_lo, at_hi = [], [], [], []
    for c in range(channels.shape[1]):
        col = channels[:, c][np.isfinite(channels[:, c])]
        lo.append(col.min() if col.size else np.inf)
        hi.append(col.max() if col.size else -np.inf)
        at_lo.append(np.count_nonzero(col == lo[-1]))
        at_hi.append(np.count_nonzero(col == hi[-1]))
    return {
        "n_rows": time_s.shape[0],
        "n_skipped_nonfinite": int(np.count_nonzero(~ok)),
        "first_time_s": t[0] if t.size else np.nan,
        "last_time_s": t[-1] if t.size else np.nan,
        "n_gaps": int(np.count_nonzero(dt > 1.5 * (1.0 / rate_hz))),
        "max_interval_s": float(dt.max()) if dt.size else 0.0,
        "channel_min": np.array(lo),
        "channel_max": np.array(hi),
        "n_at_min": np.array(at_lo, dtype=np.uint64),
        "n_at_max": np.array(at_hi, dtype=np.uint64),
    }


@given(case=decimator_cases(), clip=st.sampled_from([None, 40.0, 1.0]))
def test_run_tally_equals_plain_numpy_however_chunked(
    case: DecimatorCase, clip: float | None
) -> None:
    time_s, temperature_c, channels = case.stream.arrays()
    if clip is not None:  # many samples at the rails
        offset = np.nanmedian(channels) if np.isfinite(channels).any() else 0.0
        channels = np.clip(channels, offset - clip, offset + clip)
    rate_hz, n_channels = case.config["rate_hz"], case.config["n_channels"]
    chunked = RunTally(n_channels=n_channels, rate_hz=rate_hz)
    merged = RunTally(n_channels=n_channels, rate_hz=rate_hz)
    for t, temp, ch in chunks(case.bounds, time_s, temperature_c, channels):
        chunked.push(t, temp, ch)
        piece = RunTally(n_channels=n_channels, rate_hz=rate_hz)
        piece.push(t, temp, ch)
        merged.merge(piece)
    want = _plain_raw_stats(time_s, temperature_c, channels, rate_hz)
    for tally in (chunked, merged):
        got = tally.finish()
        for name, value in want.items():
            np.testing.assert_array_equal(getattr(got, name), value, err_msg=name)
        assert got.n_at_min.dtype == np.uint64


def test_run_tally_rejects_bad_input() -> None:
    with pytest.raises(accelcore.ParameterError):
        RunTally(n_channels=1, rate_hz=0.0)
    tally = RunTally(n_channels=2, rate_hz=20.0)
    with pytest.raises(accelcore.ShapeError):
        tally.push(np.zeros(3), np.zeros(3), np.zeros((3, 1)))
    assert tally.n_rows == 0
    with pytest.raises(accelcore.IncompatibleError):
        tally.merge(RunTally(n_channels=3, rate_hz=20.0))


def test_the_reader_statistics_are_a_tally_of_the_rows(tmp_path: Path) -> None:
    path = _log(tmp_path, HEADER + _rows(95) + "9.0,20.5,nan,1.48,1.84\n")
    data = read_run(path)
    raw = np.genfromtxt(path, delimiter=",", skip_header=1)
    tally = RunTally(n_channels=3, rate_hz=20.0)
    tally.push(raw[:, 0], raw[:, 1], raw[:, 2:])
    want = tally.finish()
    assert data.n_gaps == want.n_gaps == 1
    for name in ("n_rows", "n_skipped_nonfinite", "first_time_s", "last_time_s", "max_interval_s"):
        assert getattr(data, name) == getattr(want, name), name
    for name in ("channel_min", "channel_max", "n_at_min", "n_at_max"):
        np.testing.assert_array_equal(getattr(data, name), getattr(want, name), err_msg=name)
