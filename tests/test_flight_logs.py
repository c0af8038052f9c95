"""The PX4 ULog and ArduPilot DataFlash readers: real logs, thermal sweeps, errors.

The real logs are read where they lie (``../shared/realdata``, never copied; the
tests that need them skip without them). The thermal sweeps are written here:
the ULog one with pyulog's own writer (``ULog.write_ulog``; pyulog has no public
way to build a log from scratch, so the topic is declared through its message
classes), the DataFlash one byte by byte (pymavlink reads DataFlash but has no
writer): the header ``0xA3 0x95``, a message type, the packed fields, with FMT
messages describing FMT and IMU as ArduPilot writes them.

Values are float32 in both formats, so a block mean read back is compared with
the mean of the float32 values written, to 1e-12 relative (a sum of ten doubles).
"""

from __future__ import annotations

import struct
import sys
from pathlib import Path

import numpy as np
import pytest

from accelcore.errors import AccelcoreError, ParameterError, ParseError
from accelcore.input.readers import read_dataflash, read_ulog

pyulog = pytest.importorskip("pyulog")
pytest.importorskip("pymavlink")

REALDATA = Path(__file__).resolve().parents[2] / "shared" / "realdata"
if not REALDATA.is_dir():
    REALDATA = Path("/work/shared/realdata")
ULG = REALDATA / "px4_ulog_sample" / "sample_log_small.ulg"
BIN = REALDATA / "ardupilot_dataflash_sample" / "backend_log_80k.bin"
G = 9.80665
RATE = 50.0  # Hz of the synthetic sweeps
N = 4000  # samples per instance: 80 s, 400 blocks of 10


def _sweep(instance: int) -> dict[str, np.ndarray]:
    """A warm-up from 20 to 60 °C with an offset of 2 mm/s² per °C on z, per instance."""
    k = np.arange(N)
    # µs since boot, 50 Hz; every later sample half an interval off the grid that
    # starts at the first one, so no sample lies on a block boundary
    t_us = 5_000_000 + k * 20_000 + 10_000 * (k > 0) + instance * 7
    temp = 20.0 + 40.0 * k / (N - 1) + instance
    z = -G + 0.002 * (temp - 25.0) + 0.01 * instance
    return {
        "timestamp": t_us.astype(np.uint64),
        "x": np.float32(0.05) + np.zeros(N, np.float32),
        "y": np.float32(-0.03) + np.zeros(N, np.float32),
        "z": z.astype(np.float32),
        "temperature": temp.astype(np.float32),
    }


def _write_ulog(path: Path, topics: dict[str, dict[int, dict[str, np.ndarray]]]) -> None:
    ulog_cls = pyulog.ULog
    ulog = ulog_cls(None)
    ulog._start_timestamp = 1_000_000
    msg_id = 0
    for name, instances in topics.items():
        fields = "uint64_t timestamp;uint32_t device_id;float x;float y;float z;float temperature;"
        ulog._message_formats[name] = ulog_cls.MessageFormat(f"{name}:{fields}".encode(), None)
        for multi_id, cols in instances.items():
            added = ulog_cls._MessageAddLogged(
                struct.pack("<BH", multi_id, msg_id) + name.encode(), None, ulog._message_formats
            )
            msg_id += 1
            rows = np.zeros(len(cols["timestamp"]), dtype=added.dtype)
            rows["device_id"] = 2_424_842 + multi_id
            for key, value in cols.items():
                rows[key] = value
            added.buffer = bytearray(rows.tobytes())
            ulog._data_list.append(ulog_cls.Data(added))
    ulog.write_ulog(str(path))


def _df_message(kind: int, fmt: str, *values: object) -> bytes:
    return b"\xa3\x95" + bytes([kind]) + struct.pack("<" + fmt, *values)


def _fmt(kind: int, name: str, fmt: str, columns: str, length: int) -> bytes:
    return _df_message(
        0x80, "BB4s16s64s", kind, length, name.encode(), fmt.encode(), columns.encode()
    )


def _write_dataflash(
    path: Path,
    instances: dict[int, dict[str, np.ndarray]],
    params: dict[str, float] | None = None,
    later: dict[int, dict[str, float]] | None = None,
) -> None:
    """Write a DataFlash log; ``later[k]`` are PARM messages logged just before sample ``k``
    (time-stamped as it), as ArduPilot's parameter dump runs on beside the IMU messages."""
    imu_fmt = "QBfffffffff"  # TimeUS, I, GyrX..Z, AccX..Z, EG, EA, T (EG/EA as floats here)
    columns = "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T"
    length = 3 + struct.calcsize("<" + imu_fmt)
    out = [
        _fmt(0x80, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns", 89),
        _fmt(163, "IMU", imu_fmt, columns, length),
        _fmt(64, "PARM", "QNf", "TimeUS,Name,Value", 3 + struct.calcsize("<Q16sf")),
    ]
    # The parameters, as ArduPilot writes them at the start of a log.
    out += [_df_message(64, "Q16sf", 1000, k.encode(), v) for k, v in (params or {}).items()]
    n = len(next(iter(instances.values()))["timestamp"])
    for k in range(n):
        stamp = int(next(iter(instances.values()))["timestamp"][k])
        out += [
            _df_message(64, "Q16sf", stamp, p.encode(), v)
            for p, v in (later or {}).get(k, {}).items()
        ]
        for i, c in instances.items():
            out.append(
                _df_message(
                    163, imu_fmt, int(c["timestamp"][k]), i, 0.0, 0.0, 0.0,
                    float(c["x"][k]), float(c["y"][k]), float(c["z"][k]), 0.0, 0.0,
                    float(c["temperature"][k]),
                )
            )  # fmt: skip
    path.write_bytes(b"".join(out))


def _block_means(values: np.ndarray, factor: int = 10) -> np.ndarray:
    v = np.asarray(values, dtype=np.float64)
    means: np.ndarray = v[: v.size // factor * factor].reshape(-1, factor).mean(axis=1)
    return means


@pytest.fixture(scope="module")
def sweep_ulg(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("ulog") / "sweep.ulg"
    _write_ulog(path, {"sensor_accel": {0: _sweep(0), 1: _sweep(1)}})
    return path


@pytest.fixture(scope="module")
def sweep_bin(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("df") / "sweep.bin"
    _write_dataflash(path, {0: _sweep(0), 1: _sweep(1)})
    return path


@pytest.mark.parametrize("kind", ["ulog", "dataflash"])
@pytest.mark.parametrize("instance", [0, 1])
def test_thermal_sweep_is_decimated_like_every_reader(
    kind: str, instance: int, sweep_ulg: Path, sweep_bin: Path
) -> None:
    read, path = (read_ulog, sweep_ulg) if kind == "ulog" else (read_dataflash, sweep_bin)
    session = read(path, instance=instance, decimation_factor=10)
    truth = _sweep(instance)
    assert session.units == "m/s2"
    assert session.rate_hz == RATE
    assert session.decimation_factor == 10
    assert len(session.runs) == 1
    run = session.runs[0]
    assert run.orientation == "OZ-"
    stream = "sensor_accel" if kind == "ulog" else "IMU"
    assert run.source == f"{path}#{stream}[{instance}]:messages=1-{N}"
    assert run.stats.n_rows == N
    assert run.time_s.shape == (N // 10,) and (run.count == 10).all()
    time_s = truth["timestamp"].astype(np.float64) * 1e-6
    np.testing.assert_allclose(run.time_s, _block_means(time_s), rtol=1e-12)
    np.testing.assert_allclose(run.temperature_c, _block_means(truth["temperature"]), rtol=1e-12)
    for j, axis in enumerate("xyz"):
        np.testing.assert_allclose(run.output[:, j], _block_means(truth[axis]), rtol=1e-12)
    # the z offset grows 2 mm/s² per °C: the slope of the decimated blocks says so
    slope = np.polyfit(run.temperature_c, run.output[:, 2], 1)[0]
    assert slope == pytest.approx(0.002, rel=1e-3)


def test_instance_keyword_and_rate(sweep_ulg: Path) -> None:
    a = read_ulog(sweep_ulg, rate_hz=25.0, orientation="oz+", decimation_factor=5)
    assert a.rate_hz == 25.0 and a.runs[0].orientation == "OZ+"
    b = read_ulog(sweep_ulg, instance=1)
    assert b.runs[0].temperature_c[0] > read_ulog(sweep_ulg).runs[0].temperature_c[0] + 0.5


@pytest.mark.skipif(not ULG.is_file(), reason="real PX4 log not available")
def test_real_ulog() -> None:
    for instance, (t_lo, t_hi) in enumerate([(40.0, 40.4), (28.2, 28.4), (29.4, 29.8)]):
        session = read_ulog(ULG, instance=instance, decimation_factor=1)
        run = session.runs[0]
        assert run.stats.n_rows == 6
        assert session.rate_hz == pytest.approx(1.0, rel=1e-2)  # logged once a second
        assert 21.0 < run.time_s[0] < 22.0 and run.stats.duration_s == pytest.approx(5.0, 1e-3)
        assert t_lo <= run.temperature_c.min() and run.temperature_c.max() <= t_hi
        mean = run.output.mean(axis=0)
        assert abs(mean[0]) < 1.0 and abs(mean[1]) < 1.0
        assert -10.0 < mean[2] < -9.6  # lying flat: -1 g on z (FRD)
    with pytest.raises(ParameterError, match=r"sample_log_small\.ulg.*instance 3.*0, 1, 2"):
        read_ulog(ULG, instance=3)


@pytest.mark.skipif(not BIN.is_file(), reason="real ArduPilot log not available")
def test_real_dataflash() -> None:
    """The log's accelerometer calibration (INS_ACCOFFS/SCAL, INS_ACC2OFFS/SCAL; its
    temperature correction is off and the board not rotated) is taken back out: each
    sample is OFFS + logged / SCAL, the logged values and parameters read here with
    pymavlink itself. Level: the logged z is -g within 0.1 m/s²."""
    dfreader = pytest.importorskip("pymavlink.DFReader")
    params: dict[str, float] = {}
    logged: dict[int, list[tuple[float, float, float]]] = {0: [], 1: []}
    with dfreader.DFReader_binary(str(BIN), zero_time_base=False) as log:
        while (m := log.recv_match(type=["PARM", "IMU"])) is not None:
            if m.get_type() == "PARM":
                params.setdefault(m.Name, float(m.Value))
            else:
                logged[m.I].append((m.AccX, m.AccY, m.AccZ))
    temps = {0: (37.2, 37.4), 1: (28.4, 28.6)}
    for instance, (t_lo, t_hi) in temps.items():
        session = read_dataflash(BIN, instance=instance, decimation_factor=1)
        run = session.runs[0]
        assert run.stats.n_rows == 10
        assert 140.0 < run.time_s[0] < 141.0
        assert t_lo <= run.temperature_c.min() and run.temperature_c.max() <= t_hi
        body = np.asarray(logged[instance])
        assert abs(body[:, 0].mean()) < 1.0 and abs(body[:, 1].mean()) < 1.0
        assert -9.9 < body[:, 2].mean() < -9.7
        p = "INS_ACC" if instance == 0 else "INS_ACC2"
        offs = np.array([params[f"{p}OFFS_{u}"] for u in "XYZ"])
        scal = np.array([params[f"{p}SCAL_{u}"] for u in "XYZ"])
        assert (offs != 0).all() and (scal != 1).all()
        # float64 arithmetic on the same float32 values: to 1e-12 relative
        np.testing.assert_allclose(run.output, offs + body / scal, rtol=1e-12)
    with pytest.raises(ParameterError, match=r"backend_log_80k\.bin.*instance 2.*0, 1"):
        read_dataflash(BIN, instance=2)


def test_wrong_kind_of_file(tmp_path: Path, sweep_ulg: Path, sweep_bin: Path) -> None:
    text = tmp_path / "log.csv"
    text.write_text("time_s,temp_c,x,y,z\n0,25,0,0,1\n")
    for read, good, other in (
        (read_ulog, sweep_ulg, sweep_bin),
        (read_dataflash, sweep_bin, sweep_ulg),
    ):
        for wrong in (text, other):
            with pytest.raises(ParseError, match=f"^{wrong}: not a"):
                read(wrong)
        assert read(good).runs  # the right kind reads
    truncated = tmp_path / "cut.ulg"
    truncated.write_bytes(sweep_ulg.read_bytes()[:12])
    with pytest.raises(ParseError, match=r"cut\.ulg"):
        read_ulog(truncated)


def test_missing_message(tmp_path: Path) -> None:
    baro = tmp_path / "baro.ulg"
    _write_ulog(baro, {"sensor_baro": {0: _sweep(0)}})
    with pytest.raises(ParseError, match=r"baro\.ulg: no 'sensor_accel' topic"):
        read_ulog(baro)
    no_imu = tmp_path / "no_imu.bin"
    no_imu.write_bytes(_fmt(0x80, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns", 89))
    with pytest.raises(ParseError, match=r"no_imu\.bin: no IMU message format"):
        read_dataflash(no_imu)


def test_unknown_instance_and_bad_arguments(sweep_ulg: Path, sweep_bin: Path) -> None:
    with pytest.raises(ParameterError, match=r"sweep\.ulg: no 'sensor_accel' instance 2.*0, 1"):
        read_ulog(sweep_ulg, instance=2)
    with pytest.raises(ParameterError, match=r"sweep\.bin: no IMU instance 5.*0, 1"):
        read_dataflash(sweep_bin, instance=5)
    with pytest.raises(ParameterError, match="instance"):
        read_ulog(sweep_ulg, instance=-1)
    with pytest.raises(ParameterError, match="orientation"):
        read_dataflash(sweep_bin, orientation="up")
    with pytest.raises(ParameterError, match="rate_hz"):
        read_ulog(sweep_ulg, rate_hz=0.0)


@pytest.mark.parametrize(
    ("read", "module", "extra"),
    [(read_ulog, "pyulog", "px4"), (read_dataflash, "pymavlink.DFReader", "ardupilot")],
)
def test_missing_optional_dependency(
    read: object, module: str, extra: str, monkeypatch: pytest.MonkeyPatch, sweep_ulg: Path
) -> None:
    monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError
    with pytest.raises(AccelcoreError, match=rf"needs .*: pip install accelcore\[{extra}\]$"):
        read(sweep_ulg)  # type: ignore[operator]


@pytest.mark.parametrize("kind", ["ulog", "dataflash"])
def test_the_command_line_takes_a_flight_log_in_place_of_a_session(
    kind: str, sweep_ulg: Path, sweep_bin: Path, tmp_path: Path
) -> None:
    import io
    import json

    from accelcore.apps.cli import main

    log = sweep_ulg if kind == "ulog" else sweep_bin
    before = log.read_bytes()
    out = io.StringIO()
    code = main(["calibrate", str(log), "--window", "15", "65", "--json", "-"], stdout=out)
    assert code == 0, out.getvalue()
    body = json.loads(out.getvalue())["result"]
    z = next(r for r in body["summary"] if r["axis"] == "z")
    # The sweep's z offset moves 2 mm/s² per °C: 0.002 / 9.80665 g = 0.2039 mg/°C, with
    # float32 samples (rounding ~1e-6 m/s²) over 400 block means: the fit is exact to 1e-3.
    assert z["offset_tc_mg_per_c"] == pytest.approx(2.0 / 9.80665, rel=1e-3)
    assert main(["calibrate", str(log), "--json", str(log)], stdout=io.StringIO()) == 2
    assert log.read_bytes() == before


@pytest.mark.parametrize("kind", ["ulog", "dataflash"])
def test_a_garbage_temperature_is_refused_at_its_message(kind: str, tmp_path: Path) -> None:
    """DataFlash has no checksum: garbage decodes as a message, here T = -6.08e26 °C."""
    sweep = _sweep(0)
    sweep["temperature"][1234] = np.float32(-6.08e26)
    if kind == "ulog":
        path = tmp_path / "bad.ulg"
        _write_ulog(path, {"sensor_accel": {0: sweep}})
        read, stream = read_ulog, r"sensor_accel\[0\]"
    else:
        path = tmp_path / "bad.bin"
        _write_dataflash(path, {0: sweep})
        read, stream = read_dataflash, r"IMU\[0\]"
    with pytest.raises(
        ParseError,
        match=rf"bad\.(ulg|bin):{stream} message 1235: temperature -6\.08\d*e\+26 is not",
    ):
        read(path)


@pytest.mark.parametrize("kind", ["ulog", "dataflash"])
def test_factor_one_keeps_every_sample_as_logged(kind: str, tmp_path: Path) -> None:
    """Samples on an exact grid, or jittered: factor 1 (what compensate reads) keeps each.

    The grid of factor 1 put two samples in one block and left the next empty: 9,215
    of 67,500 rows of a thermal log came out as averages, at times the log does not
    hold (the interop round of session 20).
    """
    sweep = _sweep(0)
    rng = np.random.default_rng(4)
    k = np.arange(N)
    jitter = np.where(k % 2 == 0, 0, rng.integers(-6_000, 6_000, N))  # µs, ±30 % of 20 ms
    sweep["timestamp"] = (5_000_000 + k * 20_000 + jitter).astype(np.uint64)
    path = tmp_path / ("s.ulg" if kind == "ulog" else "s.bin")
    if kind == "ulog":
        _write_ulog(path, {"sensor_accel": {0: sweep}})
        read = read_ulog
    else:
        _write_dataflash(path, {0: sweep})
        read = read_dataflash
    run = read(path, decimation_factor=1).runs[0]
    assert len(run) == N and np.all(run.count == 1)
    np.testing.assert_array_equal(run.time_s, sweep["timestamp"].astype(np.float64) * 1e-6)
    np.testing.assert_array_equal(run.output[:, 2], sweep["z"].astype(np.float64))


@pytest.mark.parametrize("instance", [0, 1])
def test_the_exports_take_the_logged_sensor_by_default(
    instance: int, sweep_ulg: Path, sweep_bin: Path, tmp_path: Path
) -> None:
    """A PX4 thermal calibration is matched to its sensor by TC_A<i>_ID: the ULog's
    sensor_accel.device_id of the instance read (the sweep writes 2424842 + instance).
    ArduPilot's INS_TCAL<n> is the DataFlash IMU instance + 1. Given, an argument wins;
    through a saved calibration file the defaults stay."""
    from accelcore import Calibration, calibrate
    from accelcore.outputs.exports import export_ardupilot, export_px4

    px4 = read_ulog(sweep_ulg, instance=instance)
    assert px4.log_sensor == {"px4_instance": instance, "px4_device_id": 2_424_842 + instance}
    cal = calibrate(px4)
    saved = tmp_path / "cal.json"
    cal.save(saved)
    for c in (cal, Calibration.load(saved)):
        out = export_px4(c)
        assert (out.instance, out.device_id) == (instance, 2_424_842 + instance)
        assert out.params[f"TC_A{instance}_ID"][0] == 2_424_842 + instance
    assert export_px4(cal, instance=3, device_id=7).params["TC_A3_ID"][0] == 7
    ardu = read_dataflash(sweep_bin, instance=instance)
    assert ardu.log_sensor == {"ardupilot_imu": instance + 1}
    assert export_ardupilot(calibrate(ardu)).imu == instance + 1
    assert export_ardupilot(calibrate(ardu), imu=3).imu == 3


def test_a_device_id_above_int32_is_written_as_px4_holds_it(sweep_ulg: Path) -> None:
    """sensor_accel.device_id is a uint32, TC_A<i>_ID an int32 of the same bits."""
    import dataclasses

    from accelcore import calibrate
    from accelcore.outputs.exports import export_px4

    cal = calibrate(read_ulog(sweep_ulg))
    big = {**cal.provenance, "log_sensor": {"px4_instance": 1, "px4_device_id": 3_000_000_000}}
    out = export_px4(dataclasses.replace(cal, provenance=big))
    assert (out.instance, out.device_id) == (1, 3_000_000_000 - 2**32)
