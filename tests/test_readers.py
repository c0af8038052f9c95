"""The single-log, Parquet and TDMS readers map onto the same Session as a session folder.

Every reader is tested on a small file written here from ``simulate.arrays`` and
compared with the folder that ``simulate.session`` writes with the same seed:
same runs, same blocks, same calibration.

Tolerance of the comparison
---------------------------
The folder's logs print x, y, z to ``u`` (1e-6 V here, read off the file), so a
printed value is within ``u/2`` of the exact one; time (k/20 printed to 0.01 s)
and temperature (rounded to 1 m°C before printing) parse back to the very same
doubles. A file that holds the exact values (Parquet, TDMS) therefore differs by
``|δ| <= u/2`` per sample, hence per block mean. The joint fit is a weighted
least-squares solve ``β = (AᵀWA)⁻¹AᵀW y`` on identical ``A`` and ``W`` (same
temperatures, same counts), so ``|Δβ_i| <= u/2 · Σ_k w_k |c_k|`` with
``c = A(AᵀWA)⁻¹e_i``, and by Cauchy-Schwarz ``Σ_k w_k |c_k| <= sqrt(Σw) ·
sqrt((AᵀWA)⁻¹_ii)``. The calibration reports ``cov = σ²(AᵀWA)⁻¹`` with ``σ² =
RSS/dof`` and ``rms = sqrt(RSS/Σw)``, so that product is ``se_i · sqrt(dof) / rms``
(``dof <= n_samples``): the bound is ``u/2 · sqrt(n) · se_i / rms`` per coefficient,
about half a standard error here, plus 1e-10 relative for the two solves' own
rounding (scaled condition numbers are far below 1e4, eps · 1e4 ≈ 2e-12).
The single CSV log prints the same digits as the folder, so there the blocks and
the calibration must be identical.
"""

from __future__ import annotations

import dataclasses
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import accelcore
from accelcore import simulate
from accelcore.errors import DataQualityWarning, ParameterError
from accelcore.input import readers
from accelcore.input.session import AXES, Session
from accelcore.result.calibration import Calibration

KW: dict[str, Any] = {"sensor": "ADXL335", "seed": 7, "duration_h": 0.5, "soak_min": 5.0}
RATE = 20.0
LOG_HEADER = "time_s,temp_c,x,y,z,orientation\n"


@dataclasses.dataclass(frozen=True)
class Reference:
    sim: simulate.SimulatedArrays
    folder: Path
    session: Session
    calibration: Calibration
    formats: tuple[str, ...]  # printf formats of time, temp, x, y, z as in the folder's logs
    print_unit: float  # last printed digit of x, y, z


@pytest.fixture(scope="module")
def ref(tmp_path_factory: pytest.TempPathFactory) -> Reference:
    folder = tmp_path_factory.mktemp("readers") / "folder"
    simulate.session(folder, **KW)
    session = accelcore.load_session(folder)
    first = (folder / "x_pos.csv").read_text().splitlines()[1].split(",")
    decimals = [len(f.partition(".")[2]) for f in first]
    return Reference(
        sim=simulate.arrays(**KW),
        folder=folder,
        session=session,
        calibration=accelcore.calibrate(session),
        formats=tuple(f"%.{d}f" for d in decimals),
        print_unit=10.0 ** -decimals[2],
    )


def _table(run: simulate.SimulatedRun, time_offset: float = 0.0) -> np.ndarray:
    c = run.columns
    return np.column_stack([c["time_s"] + time_offset, c["temp_c"], c["x"], c["y"], c["z"]])


def _write_log(path: Path, ref: Reference, runs: list[tuple[str, np.ndarray]]) -> Path:
    """A single log with an orientation column, printed like the folder's logs."""
    with path.open("w", newline="\n") as fh:
        fh.write(LOG_HEADER)
        for label, table in runs:
            row = ",".join(ref.formats) + f",{label}\n"
            fh.write((row * table.shape[0]) % tuple(table.ravel().tolist()))
    return path


def _continuous_log(path: Path, ref: Reference) -> Path:
    """The six runs one after the other, time running on as the positioner turns."""
    n = ref.sim.runs[0].columns["time_s"].shape[0]
    return _write_log(
        path,
        ref,
        [(r.orientation, _table(r, j * n / RATE)) for j, r in enumerate(ref.sim.runs)],
    )


def assert_same_blocks(a: Session, b: Session, output_atol: float = 0.0) -> None:
    assert a.orientations == b.orientations
    for ra, rb in zip(a.runs, b.runs, strict=True):
        np.testing.assert_array_equal(ra.count, rb.count)
        np.testing.assert_array_equal(ra.temperature_c, rb.temperature_c)
        np.testing.assert_allclose(ra.time_s - ra.time_s[0], rb.time_s - rb.time_s[0], atol=1e-9)
        np.testing.assert_allclose(ra.output, rb.output, rtol=0, atol=output_atol)


def assert_same_calibration(a: Calibration, b: Calibration, print_unit: float) -> None:
    """Equal within the bound derived in the module docstring (0 print unit: identical)."""
    assert a.not_identified == b.not_identified
    for axis in AXES:
        ma, mb = a.axes[axis], b.axes[axis]
        assert ma.terms == mb.terms and ma.n_samples == mb.n_samples
        np.testing.assert_array_equal(ma.estimated, mb.estimated)
        se = np.sqrt(np.diag(ma.covariance))
        bound = 0.5 * print_unit * np.sqrt(ma.n_samples) * se / ma.rms_residual
        tol = bound + 1e-10 * np.abs(ma.coefficients)
        diff = np.abs(ma.coefficients - mb.coefficients)
        assert np.all(diff <= tol), f"{axis}: {diff} > {tol}"
        if print_unit:
            assert np.all(bound < se), "the bound must stay below one standard error"


# --------------------------------------------------------------------------- orientation log


def test_orientation_log_gives_the_folder_session(ref: Reference, tmp_path: Path) -> None:
    log = _continuous_log(tmp_path / "log.csv", ref)
    session = readers.read_orientation_log(log, units="V", rate_hz=RATE, sensor="ADXL335")
    assert session.units == "V" and session.sensor == "ADXL335" and session.path is None
    # Same digits as the folder's files: identical doubles, blocks and fit.
    assert_same_blocks(session, ref.session)
    for ra, rb in zip(session.runs, ref.session.runs, strict=True):
        assert ra.stats.n_rows == rb.stats.n_rows and ra.stats.n_gaps == 0
        np.testing.assert_array_equal(ra.stats.channel_min, rb.stats.channel_min)
        np.testing.assert_array_equal(ra.stats.n_at_max, rb.stats.n_at_max)
    n = ref.sim.runs[0].columns["time_s"].shape[0]
    assert session.runs[1].source == f"{log}#L{n + 2}-{2 * n + 1}"
    assert_same_calibration(accelcore.calibrate(session), ref.calibration, 0.0)


def test_orientation_log_does_not_depend_on_the_chunk_size(
    ref: Reference, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = _continuous_log(tmp_path / "log.csv", ref)
    whole = readers.read_orientation_log(log, units="V", rate_hz=RATE)
    monkeypatch.setattr(readers.common, "CHUNK_ROWS", 997)  # runs change mid-chunk and at its edge
    chunked = readers.read_orientation_log(log, units="V", rate_hz=RATE)
    assert_same_blocks(chunked, whole)
    for ra, rb in zip(chunked.runs, whole.runs, strict=True):
        np.testing.assert_array_equal(ra.time_s, rb.time_s)
        assert ra.stats.max_interval_s == rb.stats.max_interval_s


def test_a_label_that_comes_back_is_another_run(ref: Reference, tmp_path: Path) -> None:
    z_up, z_down = ref.sim.runs[4], ref.sim.runs[5]
    n = z_up.columns["time_s"].shape[0]
    log = _write_log(
        tmp_path / "log.csv",
        ref,
        [("OZ+", _table(z_up)), ("oz-", _table(z_down, n / RATE)), (" OZ+", _table(z_up, n / 10))],
    )
    session = readers.read_orientation_log(log, units="V", rate_hz=RATE)
    assert session.orientations == ("OZ+", "OZ-", "OZ+")
    np.testing.assert_array_equal(session.runs[0].output, session.runs[2].output)


def test_settle_s_drops_the_positioner_moving(ref: Reference, tmp_path: Path) -> None:
    n = ref.sim.runs[0].columns["time_s"].shape[0]
    settle_rows = 60  # 3 s at 20 Hz
    span = (n + settle_rows) / RATE
    runs = []
    for j, r in enumerate(ref.sim.runs):
        moving = np.zeros((settle_rows, 5))
        moving[:, 0] = j * span + np.arange(settle_rows) / RATE
        moving[:, 1] = -2.0
        moving[:, 2:] = 1.65  # mid-way between orientations
        runs.append((r.orientation, np.vstack([moving, _table(r, j * span + settle_rows / RATE)])))
    log = _write_log(tmp_path / "log.csv", ref, runs)
    settled = readers.read_orientation_log(log, units="V", rate_hz=RATE, settle_s=3.0)
    assert_same_blocks(settled, ref.session)
    assert_same_calibration(accelcore.calibrate(settled), ref.calibration, 0.0)
    raw = readers.read_orientation_log(log, units="V", rate_hz=RATE)
    assert raw.runs[0].stats.n_rows == n + settle_rows
    assert not np.allclose(raw.runs[0].output[0], settled.runs[0].output[0])


def test_run_shorter_than_settle_is_dropped_with_a_warning(tmp_path: Path) -> None:
    rows = [f"{i / 20:.2f},20.0,1.5,1.5,1.8,OZ+\n" for i in range(400)]
    rows[200:210] = [f"{i / 20:.2f},20.0,1.5,1.5,1.8,OX+\n" for i in range(200, 210)]
    log = tmp_path / "log.csv"
    log.write_text(LOG_HEADER + "".join(rows))
    with pytest.warns(DataQualityWarning, match=r"run OX\+ \(lines 202-211\) dropped"):
        session = readers.read_orientation_log(log, units="V", rate_hz=RATE, settle_s=1.0)
    assert session.orientations == ("OZ+", "OZ+")


def _small_log(tmp_path: Path, body: list[str], header: str = LOG_HEADER) -> Path:
    log = tmp_path / "bad.csv"
    log.write_text(header + "".join(body))
    return log


def _rows(n: int, label: str = "OZ+", start: int = 0) -> list[str]:
    return [f"{i / 20:.2f},20.0,1.5,1.5,1.8,{label}\n" for i in range(start, start + n)]


def test_unknown_label_names_file_line_and_column(tmp_path: Path) -> None:
    body = _rows(30)
    body[12] = body[12].replace("OZ+", "OZ")
    body.insert(5, "\n")  # a blank line is skipped but still counts as a line
    log = _small_log(tmp_path, body)
    with pytest.raises(accelcore.SessionFormatError, match=r"unknown orientation 'OZ'") as info:
        readers.read_orientation_log(log, units="V", rate_hz=RATE)
    assert str(info.value).startswith(f"{log}:15:6: ")  # header line 1, row 12 -> line 15


def test_label_missing_on_a_row_with_data(tmp_path: Path) -> None:
    body = _rows(30)
    body[3] = body[3].replace("OZ+", "")
    with pytest.raises(accelcore.SessionFormatError, match=r":5:6: no orientation label"):
        readers.read_orientation_log(_small_log(tmp_path, body), units="V", rate_hz=RATE)


def test_missing_columns_name_the_file(tmp_path: Path) -> None:
    log = _small_log(tmp_path, _rows(5), header="time_s,temp_c,x,y,zz,orientation\n")
    with pytest.raises(accelcore.ParseError, match=r"missing column\(s\) 'z'; found .*'zz'") as e:
        readers.read_orientation_log(log, units="V", rate_hz=RATE)
    assert str(e.value).startswith(str(log)) and e.value.path == str(log)
    with pytest.raises(accelcore.ParseError, match=r"missing column\(s\) 'pose'"):
        readers.read_orientation_log(
            _small_log(tmp_path, _rows(5)), units="V", rate_hz=RATE, orientation_column="pose"
        )


def test_non_numeric_cell_and_time_going_back(tmp_path: Path) -> None:
    body = _rows(30)
    body[7] = body[7].replace("1.8,", "1.8B,")
    with pytest.raises(accelcore.ParseError, match=r"'1\.8B' is not a number") as info:
        readers.read_orientation_log(_small_log(tmp_path, body), units="V", rate_hz=RATE)
    assert (info.value.line, info.value.column) == (9, 5)
    body = _rows(30)
    body[20] = body[20].replace("1.00,", "0.50,", 1)
    with pytest.raises(accelcore.ParseError, match="not strictly increasing") as info:
        readers.read_orientation_log(_small_log(tmp_path, body), units="V", rate_hz=RATE)
    assert (info.value.line, info.value.column) == (22, 1)


def test_real_log_noise_is_handled_like_the_folder_reader(tmp_path: Path) -> None:
    body = _rows(40)
    body[3] = body[3].replace("1.5,1.8", "nan,1.8")
    body[4] = body[4].replace("1.8,", ",")  # empty cell
    body.insert(10, "\n")
    text = "\ufeff" + LOG_HEADER + "".join(body) + "2.00,20.0,1.5"  # cut off mid-write
    log = tmp_path / "noisy.csv"
    log.write_bytes(text.replace("\n", "\r\n").encode())
    run = readers.read_orientation_log(log, units="V", rate_hz=RATE).runs[0]
    assert (run.stats.n_rows, run.stats.n_skipped_nonfinite, run.stats.n_truncated_rows) == (
        40,
        2,
        1,
    )
    np.testing.assert_array_equal(run.count, [8, 10, 10, 10])
    body = _rows(20)
    body[8] = body[8].replace("OZ+", "1,OZ+")
    with pytest.raises(accelcore.ParseError, match="line 10") as info:
        readers.read_orientation_log(_small_log(tmp_path, body), units="V", rate_hz=RATE)
    assert info.value.line == 10


def test_other_layouts_and_bad_arguments(tmp_path: Path) -> None:
    log = tmp_path / "semi.csv"
    log.write_text(
        "t_ms;T;ax;ay;az;supply_v;pos\n"
        + "".join(f"{i * 50};20.0;1.5;1.5;1.8;3.0;OY-\n" for i in range(40))
    )
    session = readers.read_orientation_log(
        log,
        units="V",
        rate_hz=RATE,
        delimiter=";",
        time_unit="ms",
        orientation_column="pos",
        columns={"time": "t_ms", "temperature": "T", "x": "ax", "y": "ay", "z": "az"},
    )
    assert session.orientations == ("OY-",) and session.extra_columns == ("supply_v",)
    np.testing.assert_allclose(session.runs[0].time_s, [0.225, 0.725, 1.225, 1.725])
    with pytest.raises(accelcore.AccelcoreIOError):
        readers.read_orientation_log(tmp_path / "nope.csv", units="V", rate_hz=RATE)
    with pytest.raises(ParameterError, match="settle_s"):
        readers.read_orientation_log(log, units="V", rate_hz=RATE, settle_s=-1)
    with pytest.raises(accelcore.SessionFormatError, match="units"):
        readers.read_orientation_log(log, units="volts", rate_hz=RATE)


# --------------------------------------------------------------------------- Parquet


def _parquet(path: Path, tables: list[tuple[str, simulate.SimulatedRun]], **kw: Any) -> Path:
    pa = pytest.importorskip("pyarrow", reason="pyarrow not installed (accelcore[parquet])")
    pq = pytest.importorskip("pyarrow.parquet")
    n = tables[0][1].columns["time_s"].shape[0]
    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("time_s", "temp_c", "x", "y", "z")}
    labels: list[str] = []
    for j, (label, run) in enumerate(tables):
        for k in cols:  # exact simulated values, not the printed ones
            cols[k].append(run.columns[k] + (j * n / RATE if k == "time_s" else 0.0))
        labels += [label] * n
    data = {k: np.concatenate(v) for k, v in cols.items()}
    table = pa.table({**data, "orientation": pa.array(labels).dictionary_encode(), **kw})
    pq.write_table(table, path, row_group_size=5_000)
    return path


def test_parquet_orientation_column_gives_the_folder_calibration(
    ref: Reference, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _parquet(tmp_path / "s.parquet", [(r.orientation, r) for r in ref.sim.runs])
    monkeypatch.setattr(readers.common, "CHUNK_ROWS", 4_099)
    session = readers.read_parquet(
        path, units="V", rate_hz=RATE, orientation_column="orientation", sensor="ADXL335"
    )
    assert_same_blocks(session, ref.session, output_atol=ref.print_unit / 2)
    assert session.runs[0].source == f"{path}#rows=1-36000"
    assert_same_calibration(ref.calibration, accelcore.calibrate(session), ref.print_unit)


def test_parquet_one_orientation_per_file(ref: Reference, tmp_path: Path) -> None:
    runs: list[accelcore.Run] = []
    for j, r in enumerate(ref.sim.runs):
        path = _parquet(tmp_path / f"{j}.parquet", [("ignored", r)])
        one = readers.read_parquet(path, units="V", rate_hz=RATE, orientation=r.orientation)
        assert one.orientations == (r.orientation,)
        runs += one.runs
    session = Session(runs=tuple(runs), units="V", rate_hz=RATE, sensor="ADXL335")
    assert_same_calibration(ref.calibration, accelcore.calibrate(session), ref.print_unit)


def test_parquet_errors(ref: Reference, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pa = pytest.importorskip("pyarrow", reason="pyarrow not installed (accelcore[parquet])")
    pq = pytest.importorskip("pyarrow.parquet")
    run = ref.sim.runs[0]
    path = _parquet(tmp_path / "s.parquet", [("OX+", run)])
    with pytest.raises(ParameterError, match="exactly one of"):
        readers.read_parquet(path, units="V", rate_hz=RATE)
    with pytest.raises(ParameterError, match="exactly one of"):
        readers.read_parquet(
            path, units="V", rate_hz=RATE, orientation="OX+", orientation_column="orientation"
        )
    with pytest.raises(accelcore.ParseError, match=r"s\.parquet: missing column\(s\) 'pose'"):
        readers.read_parquet(path, units="V", rate_hz=RATE, orientation_column="pose")
    labels = ["OX+"] * 10 + ["OXX"] + ["OX+"] * 9
    bad = tmp_path / "bad.parquet"
    pq.write_table(
        pa.table(
            {k: run.columns[k][:20] for k in ("time_s", "temp_c", "x", "y", "z")}
        ).append_column("orientation", pa.array(labels)),
        bad,
    )
    with pytest.raises(accelcore.SessionFormatError, match=r"bad\.parquet:row 11: unknown .*'OXX'"):
        readers.read_parquet(bad, units="V", rate_hz=RATE, orientation_column="orientation")
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    with pytest.raises(ImportError, match=r"pip install accelcore\[parquet\]"):
        readers.read_parquet(path, units="V", rate_hz=RATE, orientation="OX+")


# --------------------------------------------------------------------------- TDMS


def _tdms(
    path: Path,
    ref: Reference,
    *,
    time_channel: bool = False,
    orientation_property: bool = True,
    waveform: bool = True,
    segment: int = 7_000,
) -> Path:
    """One group per run, as a LabVIEW acquisition VI streams it: many segments."""
    nptdms = pytest.importorskip("nptdms", reason="npTDMS not installed (accelcore[tdms])")
    start = np.datetime64("2024-05-06T09:00:00", "us")
    wf = {"wf_increment": 1.0 / RATE, "wf_start_offset": 0.0, "wf_samples": segment}
    with nptdms.TdmsWriter(str(path)) as writer:
        root = nptdms.RootObject({"sensor": "ADXL335", "serial": "A-0007"})
        n = ref.sim.runs[0].columns["time_s"].shape[0]
        for a in range(0, n, segment):
            objects: list[Any] = [root]
            for j, r in enumerate(ref.sim.runs):
                name = f"run{j + 1}"
                props = {"orientation": r.orientation} if orientation_property else {}
                objects.append(nptdms.GroupObject(name, properties=props))
                names = ["temp_c", "x", "y", "z"] + (["time_s"] if time_channel else [])
                for c in names:
                    cprops: dict[str, Any] = {"wf_start_time": start}
                    if waveform:
                        cprops |= wf
                    objects.append(
                        nptdms.ChannelObject(name, c, r.columns[c][a : a + segment], cprops)
                    )
            writer.write_segment(objects)
    return path


def test_tdms_waveform_groups_give_the_folder_calibration(ref: Reference, tmp_path: Path) -> None:
    path = _tdms(tmp_path / "s.tdms", ref)
    session = readers.read_tdms(path, units="V")
    assert session.rate_hz == RATE  # 1 / wf_increment
    assert (session.sensor, session.serial) == ("ADXL335", "A-0007")
    assert session.runs[2].source == f"{path}#run3"
    assert_same_blocks(session, ref.session, output_atol=ref.print_unit / 2)
    assert_same_calibration(ref.calibration, accelcore.calibrate(session), ref.print_unit)


def test_tdms_time_channel_and_orientation_argument(ref: Reference, tmp_path: Path) -> None:
    path = _tdms(tmp_path / "s.tdms", ref, time_channel=True, orientation_property=False)
    mapping = {f"run{j + 1}": r.orientation for j, r in enumerate(ref.sim.runs)}
    session = readers.read_tdms(path, units="V", orientation=mapping, serial="other")
    assert session.serial == "other"
    assert_same_calibration(ref.calibration, accelcore.calibrate(session), ref.print_unit)
    one = readers.read_tdms(path, units="V", rate_hz=RATE, group="run5", orientation="OZ+")
    assert one.orientations == ("OZ+",)
    assert_same_blocks(one, dataclasses.replace(ref.session, runs=ref.session.runs[4:5]), 5e-7)


def test_tdms_errors(ref: Reference, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = _tdms(tmp_path / "s.tdms", ref, orientation_property=False, segment=40_000)
    with pytest.raises(accelcore.SessionFormatError, match="run1: the group has no 'orientation'"):
        readers.read_tdms(path, units="V")
    with pytest.raises(accelcore.ParseError, match=r"s\.tdms#run1: missing column\(s\) 'ax'"):
        readers.read_tdms(path, units="V", group="run1", orientation="OX+", channel_map={"x": "ax"})
    with pytest.raises(accelcore.SessionFormatError, match="no group 'nope'"):
        readers.read_tdms(path, units="V", group="nope")
    with pytest.raises(accelcore.SessionFormatError, match=r"unknown orientation 'up'"):
        readers.read_tdms(path, units="V", group="run1", orientation="up")
    with pytest.raises(ParameterError, match="for 6 groups"):
        readers.read_tdms(path, units="V", orientation="OX+")
    bare = _tdms(tmp_path / "bare.tdms", ref, waveform=False, segment=40_000)
    with pytest.raises(accelcore.SessionFormatError, match="no wf_increment"):
        readers.read_tdms(bare, units="V")
    monkeypatch.setitem(sys.modules, "nptdms", None)
    with pytest.raises(ImportError, match=r"pip install accelcore\[tdms\]"):
        readers.read_tdms(path, units="V")


def test_tdms_unequal_channel_lengths_warn(ref: Reference, tmp_path: Path) -> None:
    nptdms = pytest.importorskip("nptdms", reason="npTDMS not installed (accelcore[tdms])")
    r = ref.sim.runs[0]
    path = tmp_path / "short.tdms"
    wf = {"wf_increment": 0.05}
    with nptdms.TdmsWriter(str(path)) as writer:
        writer.write_segment(
            [nptdms.GroupObject("g", properties={"orientation": "OX+"})]
            + [
                nptdms.ChannelObject("g", c, r.columns[c][: 400 if c == "z" else 420], wf)
                for c in ("temp_c", "x", "y", "z")
            ]
        )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        session = readers.read_tdms(path, units="V")
    assert any(issubclass(w.category, DataQualityWarning) for w in caught)
    assert session.runs[0].stats.n_rows == 400


def test_timestamp_time_columns(tmp_path: Path) -> None:
    nptdms = pytest.importorskip("nptdms", reason="npTDMS not installed (accelcore[tdms])")
    pa = pytest.importorskip("pyarrow", reason="pyarrow not installed (accelcore[parquet])")
    pq = pytest.importorskip("pyarrow.parquet")
    n = 400
    stamps = np.datetime64("2024-05-06T09:00:00", "us") + np.arange(n) * np.timedelta64(50, "ms")
    flat = {"temp_c": np.full(n, 20.0), "x": np.full(n, 1.5), "y": np.full(n, 1.5)}
    flat["z"] = np.full(n, 1.8)
    path = tmp_path / "stamps.tdms"
    with nptdms.TdmsWriter(str(path)) as writer:
        writer.write_segment(
            [nptdms.GroupObject("g", properties={"orientation": "OZ-"})]
            + [nptdms.ChannelObject("g", "time_s", stamps)]
            + [nptdms.ChannelObject("g", c, v) for c, v in flat.items()]
        )
    tdms = readers.read_tdms(path, units="V")  # rate from the time stamps
    assert tdms.rate_hz == RATE
    table = pa.table({"time_s": pa.array(stamps), **flat})
    pq.write_table(table, tmp_path / "stamps.parquet")
    parquet = readers.read_parquet(
        tmp_path / "stamps.parquet", units="V", rate_hz=RATE, orientation="OZ-"
    )
    for session in (tdms, parquet):
        np.testing.assert_array_equal(session.runs[0].count, [10] * 40)
        np.testing.assert_allclose(session.runs[0].time_s[:2], [0.225, 0.725], rtol=1e-12)
