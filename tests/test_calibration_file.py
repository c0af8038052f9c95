"""The calibration file: JSON Schema, RFC 8785 canonical checksum, non-finite numbers, old files."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import accelcore
from accelcore import simulate
from accelcore.errors import CalibrationFileError
from accelcore.input.session import Session
from accelcore.model import Term, base_terms
from accelcore.result.calibration import Calibration
from accelcore.result.calibration_file import canonical_json, checksum, schema
from accelcore.simulate import effects as se

ROOT = Path(__file__).resolve().parents[1]


def _session(effects: tuple[object, ...] = (), seed: int = 3) -> Session:
    sim = simulate.arrays(
        "ADXL335",
        seed=seed,
        duration_h=0.5,
        cool_back=True,
        effects=effects,  # type: ignore[arg-type]
    )
    return Session.from_arrays(
        [(r.orientation, r.columns) for r in sim.runs],
        units=sim.units,
        rate_hz=sim.rate_hz,
        sensor=sim.sensor,
    )


@pytest.fixture(scope="module")
def session() -> Session:
    return _session()


@pytest.fixture(scope="module")
def written(session: Session) -> dict[str, Calibration]:
    """Every kind of calibration the library writes."""
    one = Session.from_arrays(
        [(session.runs[0].orientation, _columns(session.runs[0]))],
        units=session.units,
        rate_hz=session.rate_hz,
        sensor=session.sensor,
        decimation_factor=1,
    )
    extended = {
        a: (
            *base_terms(a),
            Term("offset", "lag(120):dT^2", effect="thermal_lag"),
            Term("offset", "hinge(30):dT^1", effect="generic"),
            Term("offset", "dTdt", effect="rate"),
            Term("offset", "elapsed_h", effect="drift"),
        )
        for a in "xyz"
    }
    joint = accelcore.calibrate(session)
    nan_axis = dataclasses.replace(
        joint.axes["z"], coefficients=np.full(joint.axes["z"].coefficients.shape, np.nan)
    )
    return {
        "joint": joint,
        "paper": accelcore.calibrate(session, "paper"),
        "one orientation": accelcore.calibrate(one),
        "unbounded window": accelcore.calibrate(session, terms=extended, window_c=None),
        "uncalibrated axis": dataclasses.replace(joint, axes={**joint.axes, "z": nan_axis}),
    }


def _columns(run: Any) -> dict[str, Any]:
    return {
        "time_s": run.time_s,
        "temp_c": run.temperature_c,
        "x": run.output[:, 0],
        "y": run.output[:, 1],
        "z": run.output[:, 2],
    }


def _validate(doc: Any) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.Draft202012Validator.check_schema(schema())
    jsonschema.Draft202012Validator(schema()).validate(doc)


def _same(a: Calibration, b: Calibration) -> None:
    da, db = a.to_dict(), b.to_dict()
    assert json.dumps(da, sort_keys=True) == json.dumps(db, sort_keys=True)  # NaN, inf too


# ---------------------------------------------------------------- canonical JSON


def test_canonical_json_is_rfc_8785() -> None:
    """The examples of RFC 8785, sections 3.2.2 and 3.2.3."""
    text = (
        '{"numbers": [333333333.33333329, 1E30, 4.50, 2e-3, 0.000000000000000000000000001],'
        ' "string": "\\u20ac$\\u000F\\u000aA\'\\u0042\\u0022\\u005c\\\\\\"\\/",'
        ' "literals": [null, true, false]}'
    )
    want = (
        '{"literals":[null,true,false],"numbers":[333333333.3333333,1e+30,4.5,0.002,1e-27],'
        '"string":"€$\\u000f\\nA\'B\\"\\\\\\\\\\"/"}'
    )
    assert canonical_json(json.loads(text)) == want.encode("utf-8")
    keys = {"\u20ac": 0, "\r": 0, "\ufb33": 0, "1": 0, "\U0001f600": 0, "\u0080": 0, "ö": 0}
    order = list(json.loads(canonical_json(keys)))
    assert order == ["\r", "1", "\u0080", "ö", "\u20ac", "\U0001f600", "\ufb33"]  # UTF-16 order


@pytest.mark.parametrize(
    ("number", "text"),
    [
        (0.0, "0"),
        (-0.0, "0"),
        (1.0, "1"),
        (100.0, "100"),
        (1e20, "100000000000000000000"),
        (1e21, "1e+21"),
        (1e-6, "0.000001"),
        (1e-7, "1e-7"),
        (-1.5e-7, "-1.5e-7"),
        (5e-324, "5e-324"),
        (1.7976931348623157e308, "1.7976931348623157e+308"),
        (2**60, "1152921504606847000"),
    ],
)
def test_numbers_print_as_ecmascript_does(number: float, text: str) -> None:
    assert canonical_json(number) == text.encode()


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_a_canonical_number_reads_back_the_same_double(x: float) -> None:
    assert float(canonical_json(x)) == x


def test_canonical_json_refuses_what_json_cannot_hold() -> None:
    for bad in (math.nan, math.inf, {1: 2}, object()):
        with pytest.raises(ValueError, match="canonical JSON"):
            canonical_json(bad)


# ---------------------------------------------------------------- the file


def test_the_schema_ships_in_the_package_and_the_wheel() -> None:
    assert schema()["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    maturin = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["maturin"]
    shipped = [i["path"] for i in maturin["include"] if "wheel" in i["format"]]
    assert "python/accelcore/result/calibration.schema.json" in shipped


def test_every_calibration_the_library_writes_validates_and_reads_back(
    written: dict[str, Calibration], tmp_path: Path
) -> None:
    for name, cal in written.items():
        path = tmp_path / f"{name}.json"
        cal.save(path)
        doc = json.loads(path.read_text(), parse_constant=_no_constant)  # strict JSON
        _validate(doc)
        _same(Calibration.load(path), cal)
    body = json.loads((tmp_path / "unbounded window.json").read_text())["body"]
    assert body["window_c"] == ["-Infinity", "Infinity"]
    body = json.loads((tmp_path / "uncalibrated axis.json").read_text())["body"]
    assert set(body["axes"]["z"]["coefficients"]) == {"NaN"}


def _no_constant(name: str) -> None:
    raise AssertionError(f"the file holds {name}, which strict JSON has not")


def test_a_diagnosed_calibration_validates(tmp_path: Path) -> None:
    from accelcore.diagnosis import diagnose

    d = diagnose(_session((se.ThermalLag(90.0), se.OffsetCurvature()), seed=6), max_steps=2)
    names = {t.basis.name for m in d.calibration.axes.values() for t in m.terms}
    assert d.calibration.method == "diagnosed" and len(names) > 2, d.text()
    path = tmp_path / "diagnosed.json"
    d.calibration.save(path)
    _validate(json.loads(path.read_text()))
    _same(Calibration.load(path), d.calibration)


def test_the_checksum_is_sha256_of_the_canonical_body(
    written: dict[str, Calibration], tmp_path: Path
) -> None:
    path = tmp_path / "cal.json"
    written["unbounded window"].save(path)
    doc = json.loads(path.read_text())
    want = hashlib.sha256(canonical_json(doc["body"])).hexdigest()
    assert doc["sha256"] == want == checksum(written["unbounded window"].to_dict())


def test_reformatting_keeps_the_file_valid_and_a_changed_number_does_not(
    written: dict[str, Calibration], tmp_path: Path
) -> None:
    path = tmp_path / "cal.json"
    cal = written["joint"]
    cal.save(path)
    doc = json.loads(path.read_text())

    def reversed_keys(value: Any) -> Any:
        if isinstance(value, dict):
            return {k: reversed_keys(value[k]) for k in reversed(list(value))}
        if isinstance(value, list):
            return [reversed_keys(v) for v in value]
        return value

    for text in (
        json.dumps(doc),  # one line
        json.dumps(reversed_keys(doc), indent=4, ensure_ascii=False),
        json.dumps(reversed_keys(doc), separators=(",", ":"), ensure_ascii=True),
    ):
        path.write_text(text)
        _same(Calibration.load(path), cal)
    doc["body"]["axes"]["y"]["coefficients"][1] *= 1 + 1e-12
    path.write_text(json.dumps(doc, indent=1))
    with pytest.raises(CalibrationFileError, match="checksum mismatch"):
        Calibration.load(path)


def test_a_file_written_before_the_canonical_checksum_still_loads(
    written: dict[str, Calibration], tmp_path: Path
) -> None:
    """What an older accelcore wrote: NaN tokens, the digest of Python's json.dumps."""
    cal = written["uncalibrated axis"]
    body = cal.to_dict()
    text = json.dumps(body, sort_keys=True, allow_nan=True)
    doc: dict[str, Any] = {"body": body, "sha256": hashlib.sha256(text.encode()).hexdigest()}
    path = tmp_path / "old.json"
    path.write_text(json.dumps(doc, indent=1, sort_keys=True, allow_nan=True))
    assert "NaN" in path.read_text()
    _same(Calibration.load(path), cal)
    doc["body"]["t_ref_c"] = 26.0  # the old digest no longer matches
    path.write_text(json.dumps(doc, allow_nan=True))
    with pytest.raises(CalibrationFileError, match="checksum mismatch"):
        Calibration.load(path)


def test_docs_describe_every_body_field() -> None:
    text = (ROOT / "docs" / "calibration-file.md").read_text()
    for field in schema()["$defs"]["body"]["required"]:
        assert f"`{field}`" in text, field
    assert "RFC 8785" in text
