"""Hostile inputs (issue 17): no input may give a wrong number in silence or destroy a file.

Every case of the issue is a named test here, grouped by the class of check that
closes it (docs/bad-input.md lists what each class gets):

1. outputs never alias inputs (refused before anything is read, exit status 2);
2. a session is checked for consistency before any fit (labels, columns,
   headers, units, rate, samples per term);
3. every path into a Session and every calibration file fails with an
   AccelcoreError subclass naming what is wrong and where;

plus some of the cases that already gave the right answer, and a property test
that corrupts simulated sessions at random and accepts only a typed error or a
calibration that is right within noise. Every test that runs a command checks
that no input file changed (SHA-256 of every file before and after).
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import shutil
import subprocess
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypedDict

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import accelcore
from accelcore import simulate
from accelcore.apps import cli
from accelcore.constants import AXES, ORIENTATIONS
from accelcore.errors import OutputConflictError
from accelcore.files import check_outputs
from accelcore.input.format import gravity_of


class Short(TypedDict):
    duration_h: float
    soak_min: float


SHORT: Short = {"duration_h": 0.05, "soak_min": 0.5}  # 3600 rows per run at 20 Hz


# --------------------------------------------------------------------------- helpers
def run_main(*argv: str | Path) -> tuple[int, str, str]:
    """Run the CLI in-process; return (status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    old = sys.stderr
    sys.stderr = err
    try:
        status = cli.main([str(a) for a in argv], stdout=out)
    finally:
        sys.stderr = old
    return status, out.getvalue(), err.getvalue()


def hashes(*roots: Path) -> dict[str, str]:
    """SHA-256 of every regular file under the roots (links not followed)."""
    out: dict[str, str] = {}
    for root in roots:
        files = [root] if root.is_file() else sorted(root.rglob("*"))
        for f in files:
            if f.is_file() and not f.is_symlink():
                out[str(f)] = hashlib.sha256(f.read_bytes()).hexdigest()
    return out


@contextmanager
def untouched(*roots: Path) -> Iterator[None]:
    """No input file may change inside the block (content compared by hash)."""
    before = hashes(*roots)
    yield
    after = {k: v for k, v in hashes(*roots).items() if k in before}
    assert after == before, "an input file changed"


def edit_toml(folder: Path, old: str, new: str) -> None:
    toml = folder / "session.toml"
    text = toml.read_text()
    assert old in text, old
    toml.write_text(text.replace(old, new))


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("adv") / "S"
    simulate.session(folder, "ADXL335", seed=17, **SHORT)
    return folder


@pytest.fixture(scope="module")
def base_cal(base: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    target = tmp_path_factory.mktemp("adv-cal") / "cal.json"
    accelcore.calibrate(accelcore.load_session(base, cache=False)).save(target)
    return target


@pytest.fixture
def S(base: Path, tmp_path: Path) -> Path:
    """A private copy of the simulated session."""
    folder = tmp_path / "S"
    shutil.copytree(base, folder)
    return folder


@pytest.fixture
def CAL(base_cal: Path, tmp_path: Path) -> Path:
    target = tmp_path / "cal.json"
    shutil.copyfile(base_cal, target)
    return target


def refused(status: int, err: str, *paths: Path) -> None:
    """Exit status 2, one line on stderr naming every path."""
    assert status == 2, err
    assert err.count("\n") == 1, err
    for p in paths:
        assert str(p) in err, (p, err)


def load_and_calibrate(folder: Path) -> accelcore.Calibration:
    return accelcore.calibrate(accelcore.load_session(folder, cache=False))


# ------------------------------------------------------------- 1. outputs never alias inputs
def test_compensate_onto_its_input_log_is_refused(S: Path, CAL: Path) -> None:
    with untouched(S, CAL):
        status, out, err = run_main("compensate", CAL, S / "x_pos.csv", "-o", S / "x_pos.csv")
    refused(status, err, S / "x_pos.csv")
    assert out == ""


def test_compensate_onto_the_calibration_file_is_refused(S: Path, CAL: Path) -> None:
    with untouched(S, CAL):
        status, _, err = run_main("compensate", CAL, S / "x_pos.csv", "-o", CAL)
    refused(status, err, CAL)


def test_calibrate_json_onto_a_log_is_refused(S: Path) -> None:
    with untouched(S):
        status, _, err = run_main("calibrate", S, "--json", S / "x_pos.csv")
    refused(status, err, S / "x_pos.csv")


def test_calibrate_save_onto_session_toml_is_refused(S: Path) -> None:
    with untouched(S):
        status, _, err = run_main("calibrate", S, "--save", S / "session.toml")
    refused(status, err, S / "session.toml")


def test_diagnose_json_onto_a_log_is_refused(S: Path) -> None:
    with untouched(S):
        status, _, err = run_main("diagnose", S, "--json", S / "z_neg.csv")
    refused(status, err, S / "z_neg.csv")


def test_an_output_symlinked_to_an_input_is_refused(S: Path, CAL: Path, tmp_path: Path) -> None:
    link = tmp_path / "link.csv"
    link.symlink_to(S / "x_pos.csv")
    with untouched(S, CAL):
        status, _, err = run_main("compensate", CAL, S / "x_pos.csv", "-o", link)
    refused(status, err, link, S / "x_pos.csv")
    assert link.is_symlink()


def test_an_output_hard_linked_to_an_input_is_refused(S: Path, CAL: Path, tmp_path: Path) -> None:
    twin = tmp_path / "twin.csv"
    os.link(S / "y_pos.csv", twin)
    with untouched(S, CAL):
        status, _, err = run_main("compensate", CAL, S / "y_pos.csv", "-o", twin)
    refused(status, err, twin, S / "y_pos.csv")


def test_an_output_onto_a_session_log_through_session_option_is_refused(
    S: Path, CAL: Path, tmp_path: Path
) -> None:
    log = tmp_path / "flight.csv"
    shutil.copyfile(S / "z_pos.csv", log)
    with untouched(S, CAL, log):
        status, _, err = run_main("compensate", CAL, log, "-o", S / "session.toml", "--session", S)
    refused(status, err, S / "session.toml")


def test_bulk_output_onto_the_archive_is_refused(S: Path) -> None:
    archive = S.parent
    with untouched(archive):
        status, _, err = run_main("bulk", archive, "-o", archive, "--quiet")
    refused(status, err, archive)


def test_bulk_output_into_a_session_folder_is_refused(S: Path) -> None:
    with untouched(S):
        status, _, err = run_main("bulk", S.parent, "-o", S, "--quiet")
    refused(status, err, S)


def test_calibration_save_onto_a_file_it_was_fitted_on_is_refused(S: Path) -> None:
    cal = load_and_calibrate(S)
    with untouched(S), pytest.raises(OutputConflictError) as info:
        cal.save(S / "x_neg.csv")
    assert info.value.output == str(S / "x_neg.csv")


def test_two_outputs_onto_one_file_are_refused(S: Path, tmp_path: Path) -> None:
    """--save o.json --json o.json: the JSON replaced the calibration it said it saved."""
    target = tmp_path / "o.json"
    with untouched(S):
        status, _, err = run_main("calibrate", S, "--save", target, "--json", target)
    assert status == 2 and "two outputs name one file" in err, err
    assert not target.exists()


def test_a_new_file_next_to_the_inputs_is_allowed(S: Path, CAL: Path) -> None:
    with untouched(S, CAL):
        status, _, err = run_main("calibrate", S, "--save", S / "new.cal.json", "--json", "-")
    assert status == 0, err
    check_outputs([S / "x_pos.csv"], [S / "x_pos_g.csv", "-", None])


# ------------------------------------------------- 2. session consistency before any fit
def test_two_runs_labelled_ox_plus_and_none_ox_minus_is_an_error(S: Path) -> None:
    edit_toml(S, 'orientation = "OX-"', 'orientation = "OX+"')
    with untouched(S), pytest.raises(accelcore.SessionFormatError, match="mislabelled") as info:
        load_and_calibrate(S)
    assert "x_neg.csv" in str(info.value) or "x_pos.csv" in str(info.value)


def test_two_ox_plus_runs_exit_1_in_the_cli(S: Path) -> None:
    edit_toml(S, 'orientation = "OX-"', 'orientation = "OX+"')
    with untouched(S):
        status, out, err = run_main("calibrate", S)
    assert status == 1 and out == "" and "mislabelled" in err


def test_a_run_labelled_with_another_axis_is_an_error(S: Path) -> None:
    edit_toml(
        S, 'file = "x_pos.csv"\norientation = "OX+"', 'file = "x_pos.csv"\norientation = "OY+"'
    )
    edit_toml(
        S, 'file = "y_pos.csv"\norientation = "OY+"', 'file = "y_pos.csv"\norientation = "OX+"'
    )
    with pytest.raises(accelcore.SessionFormatError, match="mislabelled"):
        load_and_calibrate(S)


def test_swapped_plus_and_minus_runs_still_look_swapped(S: Path) -> None:
    edit_toml(S, 'orientation = "OZ+"', 'orientation = "OZ?"')
    edit_toml(S, 'orientation = "OZ-"', 'orientation = "OZ+"')
    edit_toml(S, 'orientation = "OZ?"', 'orientation = "OZ-"')
    with pytest.raises(accelcore.SessionFormatError, match="look swapped"):
        load_and_calibrate(S)


def test_columns_mapping_two_roles_to_one_log_column_is_an_error(S: Path) -> None:
    edit_toml(S, 'y = "y"', 'y = "x"')
    with pytest.raises(accelcore.SessionFormatError, match=r"both x and y .*'x'"):
        accelcore.load_session(S, cache=False)


def test_a_duplicated_header_name_is_a_parse_error(S: Path) -> None:
    lines = (S / "y_neg.csv").read_text().splitlines()
    lines[0] = lines[0] + ",x"
    lines[1:] = [line + ",0.0" for line in lines[1:]]
    (S / "y_neg.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(accelcore.ParseError, match="'x' appears twice") as info:
        accelcore.load_session(S, cache=False)
    assert info.value.line == 1 and info.value.column == 6
    assert info.value.path.endswith("y_neg.csv")


@pytest.mark.parametrize("split", [False, True])
def test_the_rust_reader_itself_refuses_a_repeated_header_name(S: Path, split: bool) -> None:
    """No pre-check in front: the reader (one pass or in pieces) names line 1 and the repeat."""
    from accelcore._accelcore import read_run
    from accelcore.apps.bulk import read_run_split

    log = S / "z_pos.csv"
    lines = log.read_text().splitlines()
    lines[0] = lines[0].replace("temp_c", "temp_c,y", 1)
    cells = [line.split(",") for line in lines[1:]]
    lines[1:] = [",".join([c[0], c[1], "0.5", *c[2:]]) for c in cells]
    log.write_text("\n".join(lines) + "\n")
    with pytest.raises(accelcore.ParseError, match=r"'y' appears twice .*columns 3 and 5") as info:
        if split:
            read_run_split(log, pieces=3)
        else:
            read_run(str(log))
    assert (info.value.line, info.value.column) == (1, 5)
    assert info.value.path.endswith("z_pos.csv")


def test_a_duplicated_header_name_in_an_orientation_log_is_a_parse_error(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("time_s,temp_c,x,y,z,z,orientation\n0,25,1,2,3,4,OZ+\n0.05,25,1,2,3,4,OZ+\n")
    from accelcore.input.readers import read_orientation_log

    with pytest.raises(accelcore.ParseError, match="'z' appears twice"):
        read_orientation_log(log, units="V", rate_hz=20.0)


def test_a_rate_far_below_the_logs_is_an_error_not_six_samples(S: Path) -> None:
    edit_toml(S, "rate_hz = 20.0", "rate_hz = 1e-9")
    with pytest.raises(accelcore.SessionFormatError, match="rate_hz or time_unit is wrong"):
        load_and_calibrate(S)


def test_fewer_samples_than_terms_is_an_error_not_a_number() -> None:
    t = np.arange(20) / 20.0
    data = {"time_s": t, "temp_c": 20 + t, "x": 0 * t, "y": 0 * t, "z": 1 + 0 * t}
    session = accelcore.Session.from_arrays([("OZ+", data)], units="g", rate_hz=20.0)
    with pytest.raises(accelcore.InsufficientDataError, match="more samples than terms"):
        accelcore.calibrate(session, window_c=None)


def test_volts_declared_for_a_digital_part_is_an_error(tmp_path: Path) -> None:
    folder = tmp_path / "mpu"
    simulate.session(folder, "MPU9255", seed=5, **SHORT)
    edit_toml(folder, 'units = "LSB"', 'units = "V"')
    with pytest.raises(accelcore.SessionFormatError, match="datasheet gives its output in LSB"):
        load_and_calibrate(folder)


def test_lsb_declared_for_an_analog_part_is_an_error(S: Path) -> None:
    edit_toml(S, 'units = "V"', 'units = "LSB"')
    with pytest.raises(accelcore.SessionFormatError, match="datasheet gives its output in V"):
        load_and_calibrate(S)


def test_g_declared_for_a_volt_log_is_an_error(S: Path) -> None:
    edit_toml(S, 'units = "V"', 'units = "g"')
    edit_toml(S, 'sensor = "ADXL335"', 'sensor = ""')
    with pytest.raises(accelcore.SessionFormatError, match=r"are the units in session\.toml right"):
        load_and_calibrate(S)


def test_the_same_file_listed_twice_is_an_error(S: Path) -> None:
    edit_toml(S, 'file = "x_neg.csv"', 'file = "./x_pos.csv"')
    with pytest.raises(accelcore.SessionFormatError, match="same file as"):
        accelcore.load_session(S, cache=False)


@pytest.mark.parametrize("how", ["symlink", "hard link"])
def test_a_link_to_another_run_file_is_the_same_file(S: Path, how: str) -> None:
    # One stat per run file decides: a link names the file it leads to.
    (S / "x_neg.csv").unlink()
    if how == "symlink":
        (S / "x_neg.csv").symlink_to(S / "y_pos.csv")
    else:
        os.link(S / "y_pos.csv", S / "x_neg.csv")
    with pytest.raises(accelcore.SessionFormatError, match="the same file as") as info:
        accelcore.load_session(S, cache=False)
    assert "'x_neg.csv'" in str(info.value) and "'y_pos.csv'" in str(info.value)


# --------------------------------------------------- 3. typed errors on every path in
def _sim_runs() -> list[tuple[str, dict[str, np.ndarray]]]:
    sim = simulate.arrays("ADXL335", seed=3, orientations=("OZ+", "OZ-"), **SHORT)
    return [(r.orientation, dict(r.columns)) for r in sim.runs]


def test_from_arrays_with_columns_of_different_lengths_names_run_and_column() -> None:
    runs = _sim_runs()
    runs[1][1]["y"] = runs[1][1]["y"][:-5]
    with pytest.raises(accelcore.ShapeError, match=r"run 2 \(OZ-\): column 'y' has"):
        accelcore.Session.from_arrays(runs, units="V", rate_hz=20.0)


def test_from_arrays_text_cell_in_a_dataframe_names_run_column_and_row() -> None:
    runs = _sim_runs()
    frame = pd.DataFrame(runs[0][1]).astype({"x": object})
    frame.loc[17, "x"] = "n/a"
    with pytest.raises(accelcore.ParseError, match=r"run 1 \(OZ\+\), column 'x'.*row 17") as info:
        accelcore.Session.from_arrays([("OZ+", frame)], units="V", rate_hz=20.0)
    assert info.value.line == 18 and info.value.column == 3


def test_from_arrays_datetime64_time_is_read_as_seconds() -> None:
    runs = _sim_runs()
    data = dict(runs[0][1])
    start = np.datetime64("2024-05-01T12:00:00", "ns")
    data["time_s"] = start + (data["time_s"] * 1e9).astype("timedelta64[ns]")
    session = accelcore.Session.from_arrays([("OZ+", data)], units="V", rate_hz=20.0)
    assert session.runs[0].stats.duration_s == pytest.approx(SHORT["duration_h"] * 3600, rel=1e-3)


def test_from_arrays_with_no_runs_is_an_error() -> None:
    with pytest.raises(accelcore.InsufficientDataError, match="no runs"):
        accelcore.Session.from_arrays([], units="V", rate_hz=20.0)


def test_from_arrays_dataframe_with_a_repeated_column_is_an_error() -> None:
    runs = _sim_runs()
    frame = pd.DataFrame(runs[0][1])
    frame = pd.concat([frame, frame[["x"]]], axis=1)
    with pytest.raises(accelcore.SessionFormatError, match="'x' appears twice"):
        accelcore.Session.from_arrays([("OZ+", frame)], units="V", rate_hz=20.0)


def test_a_bom_in_session_toml_is_read(S: Path) -> None:
    toml = S / "session.toml"
    toml.write_bytes(b"\xef\xbb\xbf" + toml.read_bytes())
    assert len(accelcore.load_session(S, cache=False).runs) == 6


@pytest.mark.parametrize("kind", ["folder", "fifo", "device"])
def test_a_log_that_is_not_a_regular_file_is_named_for_what_it_is(S: Path, kind: str) -> None:
    if kind == "folder":
        (S / "x_pos.csv").unlink()
        (S / "x_pos.csv").mkdir()
        target, word = "x_pos.csv", "a folder"
    elif kind == "fifo":
        (S / "x_pos.csv").unlink()
        os.mkfifo(S / "x_pos.csv")
        target, word = "x_pos.csv", "FIFO"
    else:
        edit_toml(S, 'file = "x_pos.csv"', 'file = "/dev/zero"')
        target, word = "/dev/zero", "a device"
    with pytest.raises(accelcore.AccelcoreIOError, match=word) as info:
        accelcore.load_session(S, cache=False)
    assert target in str(info.value) and "does not exist" not in str(info.value)


def test_t_ref_nan_is_a_parameter_error(S: Path) -> None:
    session = accelcore.load_session(S, cache=False)
    with pytest.raises(accelcore.ParameterError, match="t_ref_c"):
        accelcore.calibrate(session, t_ref_c=math.nan)
    # 1e308 °C: finite, but its design (T - t_ref) was inf, blamed on the data.
    with pytest.raises(accelcore.ParameterError, match=r"t_ref_c.*-273.15 to 1000"):
        accelcore.calibrate(session, t_ref_c=1e308)
    with pytest.raises(accelcore.ParameterError, match="window_c"):
        accelcore.calibrate(session, window_c=(60.0, 0.0))


def test_a_reversed_window_is_a_usage_error(S: Path) -> None:
    with untouched(S):
        status, out, err = run_main("calibrate", S, "--window", "60", "0")
    assert status == 2 and out == "" and "--window" in err


def _tamper(cal_file: Path, edit: object) -> None:
    doc = json.loads(cal_file.read_text())
    edit(doc["body"])  # type: ignore[operator]
    text = json.dumps(doc["body"], sort_keys=True, allow_nan=True)
    doc["sha256"] = hashlib.sha256(text.encode()).hexdigest()
    cal_file.write_text(json.dumps(doc))


def test_a_calibration_with_zero_gain_is_refused_at_load(CAL: Path) -> None:
    def zero(body: dict[str, object]) -> None:
        axis = body["axes"]["y"]  # type: ignore[index]
        i = [t["kind"] == "gain" and t.get("source") in ("y", None) for t in axis["terms"]]
        axis["coefficients"][i.index(True)] = 0.0

    _tamper(CAL, zero)
    with pytest.raises(accelcore.CalibrationFileError, match="sensitivity is 0"):
        accelcore.Calibration.load(CAL)


def test_a_calibration_with_an_unknown_basis_is_refused_at_load(CAL: Path) -> None:
    def unknown(body: dict[str, object]) -> None:
        body["axes"]["x"]["terms"][1]["basis"] = "warp^9"  # type: ignore[index]

    _tamper(CAL, unknown)
    with pytest.raises(accelcore.CalibrationFileError):
        accelcore.Calibration.load(CAL)


def test_compensate_with_a_bad_calibration_blames_the_calibration(S: Path, CAL: Path) -> None:
    def zero_x(body: dict[str, object]) -> None:
        body["axes"]["x"]["coefficients"] = [0.0] * len(body["axes"]["x"]["coefficients"])  # type: ignore[index]

    _tamper(CAL, zero_x)
    with untouched(S, CAL):
        status, _, err = run_main("compensate", CAL, S / "x_pos.csv", "-o", S.parent / "o.csv")
    assert status == 1 and str(CAL) in err and str(S / "x_pos.csv") not in err


def test_an_unwritable_output_folder_is_reported_against_the_output(S: Path, CAL: Path) -> None:
    target = S / "x_pos.csv" / "out.csv"  # its folder is a file
    with untouched(S, CAL):
        status, _, err = run_main("compensate", CAL, S / "z_pos.csv", "-o", target)
    assert status == 1 and err.count("\n") == 1
    assert err.split("error: ")[1].startswith(str(target))


def test_a_bad_cell_in_compensate_names_line_and_column(S: Path, CAL: Path) -> None:
    lines = (S / "z_pos.csv").read_text().splitlines()
    fields = lines[40].split(",")
    fields[3] = "hot"
    lines[40] = ",".join(fields)
    (S / "z_pos.csv").write_text("\n".join(lines) + "\n")
    out_csv = S.parent / "o.csv"
    with untouched(S, CAL):
        status, _, err = run_main("compensate", CAL, S / "z_pos.csv", "-o", out_csv)
    assert status == 1 and "z_pos.csv:41:4: column 'y': 'hot'" in err
    assert not out_csv.exists()


def test_min_count_above_the_factor_is_a_parameter_error(S: Path) -> None:
    with pytest.raises(accelcore.ParameterError, match="min_count") as info:
        accelcore.load_session(S, min_count=11, cache=False)
    assert str(S) not in str(info.value)


# ------------------------------------------------------------------------ 4. bulk
def test_bulk_jobs_are_capped_by_the_sessions_and_the_cores() -> None:
    from accelcore.apps.bulk import worker_count

    cores = os.cpu_count() or 1
    assert worker_count(1000, 4) == min(4, cores)
    assert worker_count(None, 1) == 1
    assert worker_count(3, 0) == 1
    assert worker_count(1, 50) == 1


def test_a_bulk_worker_ends_when_its_parent_is_gone() -> None:
    """A process whose recorded parent is not its parent exits with status 1 (not 0)."""
    code = (
        "import os, time\n"
        "from accelcore.apps.bulk import watch_parent\n"
        "watch_parent(os.getppid() + 1_000_000, interval_s=0.01)\n"
        "time.sleep(60)\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.run([sys.executable, "-c", code], env=env, check=False)
    assert proc.returncode == 1


def test_the_bulk_fleet_table_flags_a_run_cut_short(S: Path, tmp_path: Path) -> None:
    """The issue's case: a run cut to 6 % of its sweep calibrates, and its session is flagged."""
    from accelcore.apps.bulk import FLEET_COLUMNS, bulk
    from accelcore.outputs.report import fleet_report

    archive = tmp_path / "archive"
    shutil.copytree(S, archive / "clean")
    shutil.copytree(S, archive / "cut")
    log = archive / "cut" / "x_pos.csv"
    lines = log.read_text().splitlines()
    log.write_text("\n".join(lines[: int(0.06 * len(lines))]) + "\n")
    out = tmp_path / "out"
    with untouched(archive), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = bulk(archive, out, jobs=1, progress=False, cache=False)
    assert result.ok
    assert "warnings" in FLEET_COLUMNS
    fleet = pd.read_csv(out / "fleet.csv", dtype=str, keep_default_na=False)
    cells = dict(zip(fleet["session"], fleet["warnings"], strict=True))
    assert cells["cut"].startswith("short run (x_pos.csv)"), cells["cut"]
    assert "short run" not in cells["clean"]
    assert "step (" in cells["clean"]  # this quick simulation has steps: said too
    page = fleet_report(out, tmp_path / "page").read_text()
    assert "session(s) with data-quality warnings" in page and "short run (x_pos.csv)" in page
    # The diagnosis was told the findings: no thermal lag on the strength of the cut run.
    diagnosis = json.loads((out / "cut" / "diagnosis.json").read_text())
    assert any("'short' (x_pos.csv) could explain thermal_lag" in w for w in diagnosis["warnings"])
    assert not any(
        "could explain" in w
        for w in json.loads((out / "clean" / "diagnosis.json").read_text())["warnings"]
    )


def test_the_warnings_cell_is_short_ordered_and_never_empty() -> None:
    from accelcore.apps.fleet_rows import warnings_cell
    from accelcore.input.quality import QualityIssue

    assert warnings_cell([]) == "none"
    issues = [
        QualityIssue("outliers", "…", run="b.csv", channel="z"),
        QualityIssue("outliers", "…", run="a.csv", channel="y"),
        QualityIssue("outliers", "…", run="b.csv", channel="y"),
        QualityIssue("temperature", "…"),
        QualityIssue("short", "…", run="a.csv"),
    ]
    want = "short run (a.csv); sweep not covering the window; spikes left out (b.csv, a.csv)"
    assert warnings_cell(issues) == want
    assert warnings_cell(issues[::-1]) == want  # the order of the findings does not matter


def test_a_run_cut_short_is_a_quality_finding(S: Path) -> None:
    from accelcore.input.quality import check_session

    log = S / "x_pos.csv"
    lines = log.read_text().splitlines()
    log.write_text("\n".join(lines[: int(0.25 * len(lines))]) + "\n")
    issues = check_session(accelcore.load_session(S, cache=False), warn=False)
    short = [i for i in issues if i.kind == "short"]
    assert [i.run for i in short] == ["x_pos.csv"]
    assert "cut short" in short[0].message


def test_a_log_stored_in_two_files_is_not_a_run_cut_short(S: Path) -> None:
    from accelcore.input.quality import check_session

    log = S / "x_pos.csv"
    lines = log.read_text().splitlines()
    cut = int(0.4 * len(lines))
    log.write_text("\n".join(lines[:cut]) + "\n")
    (S / "x_pos_2.csv").write_text("\n".join([lines[0], *lines[cut:]]) + "\n")
    edit_toml(
        S,
        'file = "x_pos.csv"\norientation = "OX+"\n',
        'file = "x_pos.csv"\norientation = "OX+"\n\n[[run]]\nfile = "x_pos_2.csv"\n'
        'orientation = "OX+"\n',
    )
    session = accelcore.load_session(S, cache=False)
    assert len(session.runs) == 7
    assert [i for i in check_session(session, warn=False) if i.kind == "short"] == []


def test_a_log_in_two_files_listed_last_first_is_diagnosed_as_one(S: Path) -> None:
    """The pieces are one record whatever the session's order; folds are named by it."""
    from accelcore.diagnosis import diagnose

    whole = diagnose(accelcore.load_session(S, cache=False))
    log = S / "x_pos.csv"
    lines = log.read_text().splitlines()
    cut = 1 + 10 * int(0.04 * len(lines))  # the header, then whole blocks of 10 rows
    (S / "x_pos_b.csv").write_text("\n".join([lines[0], *lines[cut:]]) + "\n")
    log.write_text("\n".join(lines[:cut]) + "\n")
    edit_toml(
        S,
        'file = "x_pos.csv"\norientation = "OX+"\n',
        'file = "x_pos_b.csv"\norientation = "OX+"\n\n[[run]]\nfile = "x_pos.csv"\n'
        'orientation = "OX+"\n',
    )
    split = diagnose(accelcore.load_session(S, cache=False))
    assert split.folds == whole.folds
    assert split.effects == whole.effects
    for a in "xyz":
        # Cut between two decimation blocks: the same blocks, the same samples; only
        # sums taken in another order (rounding, ~1e-16 relative per operation).
        before, after = whole.steps[-1].rms_out_axis_mg[a], split.steps[-1].rms_out_axis_mg[a]
        assert after == pytest.approx(before, rel=1e-9), a


def test_a_run_cut_short_gets_no_thermal_lag_from_the_diagnosis(S: Path) -> None:
    """Effects a quality finding could explain are not tried, and a warning says so."""
    from accelcore.diagnosis import diagnose

    log = S / "x_pos.csv"
    lines = log.read_text().splitlines()
    log.write_text("\n".join(lines[: int(0.25 * len(lines))]) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        session = accelcore.load_session(S, cache=False)
        told = diagnose(session)
        untold = diagnose(session, quality=[])
    assert "thermal_lag" not in told.effects
    assert "thermal_lag" not in set(told.candidates.get("family", []))
    notes = [w for w in told.warnings if "could explain" in w]
    assert len(notes) == 1 and "'short' (x_pos.csv) could explain thermal_lag" in notes[0], notes
    # Told no findings, the family is tried as before: the finding is what held it back.
    assert "thermal_lag" in set(untold.candidates["family"])
    assert not any("could explain" in w for w in untold.warnings)


# ----------------------------------------------------- cases that already were right
def test_invalid_toml_is_a_session_format_error(S: Path) -> None:
    (S / "session.toml").write_text("format = \n")
    with pytest.raises(accelcore.SessionFormatError, match="not valid TOML"):
        accelcore.load_session(S, cache=False)


def test_a_symlink_loop_as_a_log_is_an_io_error(S: Path) -> None:
    (S / "x_pos.csv").unlink()
    (S / "x_pos.csv").symlink_to(S / "x_pos.csv")
    with pytest.raises(accelcore.AccelcoreIOError, match=r"x_pos\.csv"):
        accelcore.load_session(S, cache=False)


def test_a_truncated_calibration_file_is_refused(CAL: Path) -> None:
    CAL.write_bytes(CAL.read_bytes()[:200])
    with pytest.raises(accelcore.CalibrationFileError, match="truncated or corrupted"):
        accelcore.Calibration.load(CAL)


def test_an_empty_log_is_a_parse_error(S: Path) -> None:
    (S / "z_neg.csv").write_text("")
    with pytest.raises(accelcore.ParseError, match="empty file"):
        accelcore.load_session(S, cache=False)


def test_a_missing_session_folder_exits_1_naming_it(tmp_path: Path) -> None:
    status, _, err = run_main("calibrate", tmp_path / "nowhere")
    assert status == 1 and str(tmp_path / "nowhere") in err


# ------------------------------------------------------------- property: never silent
_SIM = simulate.arrays("ADXL335", seed=23, **SHORT)


def _columns_of(run: simulate.SimulatedRun) -> dict[str, np.ndarray]:
    return {k: np.asarray(v) for k, v in run.columns.items()}


def _compensated_error_g(cal: accelcore.Calibration) -> float:
    """Largest error, g, of the mean compensated output of each clean run against its label.

    Only samples inside the calibration's temperature range are used: there
    the calibration makes its claim.
    """
    lo, hi = cal.temperature_range_c
    worst = 0.0
    for run in _SIM.runs:
        c = run.columns
        keep = (c["temp_c"] >= lo) & (c["temp_c"] <= hi)
        if keep.sum() < 100:
            continue
        raw = np.column_stack([c["x"], c["y"], c["z"]])[keep]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            g = cal.compensate(raw, c["temp_c"][keep], c["time_s"][keep])
        truth = np.array(gravity_of(run.orientation))
        worst = max(worst, float(np.max(np.abs(g.mean(axis=0) - truth))))
    return worst


@st.composite
def corruptions(draw: st.DrawFn) -> dict[str, Any]:
    """A small description of one corruption (built into a session by :func:`corrupt`)."""
    n = len(_SIM.runs)
    kind = draw(st.sampled_from(["label", "swap", "columns", "header", "units", "rate", "cut"]))
    case: dict[str, Any] = {"kind": kind}
    if kind == "label":
        case["run"] = draw(st.integers(0, n - 1))
        case["label"] = draw(st.sampled_from(list(ORIENTATIONS)))
    elif kind == "swap":
        case["runs"] = draw(st.lists(st.integers(0, n - 1), min_size=2, max_size=2, unique=True))
    elif kind == "columns":
        roles = draw(st.lists(st.sampled_from(AXES), min_size=2, max_size=2, unique=True))
        case["mapping"] = {roles[0]: roles[1]}
        if draw(st.booleans()):
            case["mapping"][roles[1]] = roles[0]  # a swap of two axes' columns
    elif kind == "header":
        case["run"] = draw(st.integers(0, n - 1))
        case["column"] = draw(st.sampled_from(["x", "y", "z", "temp_c"]))
    elif kind == "units":
        case["units"] = draw(st.sampled_from(["LSB", "g", "m/s2"]))
    elif kind == "rate":
        case["factor"] = draw(st.sampled_from([1e-9, 0.01, 0.1, 0.5, 2.0]))
    else:
        runs = draw(st.sets(st.integers(0, n - 1), min_size=1))
        case["keep"] = {i: draw(st.floats(0.02, 1.0)) for i in sorted(runs)}
    return case


def corrupt(case: dict[str, Any]) -> accelcore.Session:
    """The simulated session with one corruption applied (may raise an AccelcoreError)."""
    runs: list[tuple[str, Any]] = [(r.orientation, _columns_of(r)) for r in _SIM.runs]
    units, rate, columns = "V", _SIM.rate_hz, None
    kind = case["kind"]
    if kind == "label":
        runs[case["run"]] = (case["label"], runs[case["run"]][1])
    elif kind == "swap":
        i, j = case["runs"]
        runs[i], runs[j] = (runs[j][0], runs[i][1]), (runs[i][0], runs[j][1])
    elif kind == "columns":
        columns = {**{a: a for a in AXES}, **case["mapping"]}
    elif kind == "header":
        i, name = case["run"], case["column"]
        frame = pd.DataFrame(runs[i][1])
        runs[i] = (runs[i][0], pd.concat([frame, frame[[name]] * 0.5], axis=1))
    elif kind == "units":
        units = case["units"]
    elif kind == "rate":
        rate = _SIM.rate_hz * case["factor"]
    else:
        for i, fraction in case["keep"].items():
            end = max(2, int(len(runs[i][1]["time_s"]) * fraction))
            runs[i] = (runs[i][0], {k: v[:end] for k, v in runs[i][1].items()})
    return accelcore.Session.from_arrays(
        runs, units=units, rate_hz=rate, sensor="ADXL335", columns=columns
    )


@settings(
    max_examples=100,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(case=corruptions())
def test_a_corrupted_session_gives_a_typed_error_or_a_right_calibration(
    case: dict[str, Any],
) -> None:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cal = accelcore.calibrate(corrupt(case))
    except accelcore.AccelcoreError:
        return
    if cal.not_identified:
        return  # what the data cannot identify is said, not given a number
    # Within noise: the clean calibration of this simulation is off by well
    # under 1 mg; 5 mg is far below the 1 g a wrong label, column or unit causes.
    assert _compensated_error_g(cal) < 5e-3


def test_the_clean_simulation_passes_the_property_check() -> None:
    session = accelcore.Session.from_arrays(
        [(r.orientation, _columns_of(r)) for r in _SIM.runs],
        units="V",
        rate_hz=_SIM.rate_hz,
        sensor="ADXL335",
    )
    assert _compensated_error_g(accelcore.calibrate(session)) < 5e-3
