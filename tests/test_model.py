"""Typed model terms: every basis name parses once into a value and prints back the same."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from accelcore import CalibrationFileError, ParameterError, Session, calibrate, simulate
from accelcore.model import (
    Basis,
    Constant,
    Elapsed,
    Extra,
    Features,
    LaggedTemperaturePower,
    TemperaturePower,
    TemperatureRate,
    Term,
    design_columns,
)
from accelcore.result.calibration import Calibration

NAMES = [
    "1",
    "dT^1",
    "dT^5",
    "lag(600):dT^2",
    "lag(92.5):dT^1",
    "dTdt",
    "elapsed_h",
    "extra:supply_v",
]


@pytest.mark.parametrize("name", NAMES)
def test_name_round_trips(name: str) -> None:
    basis = Basis.parse(name)
    assert basis.name == name
    assert Basis.parse(basis.name) == basis
    assert hash(Basis.parse(name)) == hash(basis)


def test_parsed_values_know_what_they_are() -> None:
    assert Basis.parse("1") == Constant()
    assert Basis.parse("dT^3") == TemperaturePower(3)
    lag = Basis.parse("lag(600):dT^2")
    assert lag == LaggedTemperaturePower(600.0, 2)
    assert (lag.lag_s, lag.temperature_order, lag.without_lag()) == (600.0, 2, TemperaturePower(2))
    assert Basis.parse("dTdt") == TemperatureRate()
    assert Basis.parse("elapsed_h") == Elapsed()
    assert Basis.parse("extra:supply_v").column == "supply_v"
    assert Basis.parse("extra:supply_v") == Extra("supply_v")
    stateful = {b: Basis.parse(b).stateful for b in NAMES}
    assert stateful == {
        "1": False,
        "dT^1": False,
        "dT^5": False,
        "lag(600):dT^2": True,
        "lag(92.5):dT^1": True,
        "dTdt": True,
        "elapsed_h": True,
        "extra:supply_v": False,
    }


@pytest.mark.parametrize(
    "bad",
    [
        "",
        "2",
        "dT^0",
        "dT^10",
        "dT^x",
        "lag(0):dT^1",
        "lag(-5):dT^1",
        "lag(nan):dT^1",
        "extra:",
        "dtdt",
    ],
)
def test_a_name_outside_the_grammar_is_refused(bad: str) -> None:
    with pytest.raises(ParameterError):
        Basis.parse(bad)


def test_a_lag_is_what_its_name_says() -> None:
    # Files keep tau to 6 significant digits; the value in memory is the same one,
    # so a model evaluates identically before and after a save and load.
    lag = LaggedTemperaturePower(123.456789, 2)
    assert lag.tau_s == 123.457
    assert Basis.parse(lag.name) == lag


def test_term_parses_a_name_once_and_equals_the_typed_term() -> None:
    assert Term("offset", "dT^2") == Term("offset", TemperaturePower(2))
    assert Term("gain", "1", source="y").basis == Constant()
    assert Term.from_dict(Term("offset", "lag(300):dT^1").to_dict()) == Term(
        "offset", LaggedTemperaturePower(300.0, 1)
    )
    with pytest.raises(ParameterError):
        Term("gain", "1")  # a gain term needs the axis whose gravity it multiplies
    with pytest.raises(ParameterError):
        Term("scale", "1")  # type: ignore[arg-type]


def test_design_columns_evaluate_each_basis() -> None:
    t = np.arange(0.0, 600.0, 0.5)
    temp = 20.0 + 0.01 * t
    feats = Features(temp, t, {"supply_v": np.full(t.size, 3.3)}, t_ref_c=25.0)
    terms = [
        Term("offset", "1"),
        Term("offset", "dT^2"),
        Term("gain", "dT^1", source="z"),
        Term("offset", "elapsed_h"),
        Term("offset", "extra:supply_v"),
    ]
    x = design_columns(terms, feats, np.array([0.0, 0.0, -1.0]), {"extra:supply_v": 3.0})
    np.testing.assert_array_equal(x[:, 0], 1.0)
    np.testing.assert_array_equal(x[:, 1], (temp - 25.0) ** 2)
    np.testing.assert_array_equal(x[:, 2], -(temp - 25.0))
    np.testing.assert_array_equal(x[:, 3], t / 3600.0)
    # 3.3 - 3.0 in float64: exact to one rounding of the subtraction.
    np.testing.assert_allclose(x[:, 4], 0.3, rtol=0, atol=4 * np.finfo(float).eps)


def test_a_file_with_an_unknown_basis_is_refused_at_load(tmp_path: Path) -> None:
    sim = simulate.arrays("ADXL335", seed=3, duration_h=0.3)
    session = Session.from_arrays(
        [(r.orientation, r.columns) for r in sim.runs], units=sim.units, rate_hz=sim.rate_hz
    )
    path = tmp_path / "cal.json"
    calibrate(session).save(path)
    doc = json.loads(path.read_text())
    doc["body"]["axes"]["x"]["terms"][1]["basis"] = "dT^Q"
    text = json.dumps(doc["body"], sort_keys=True, allow_nan=True)
    doc["sha256"] = hashlib.sha256(text.encode()).hexdigest()  # a well-formed file, bad content
    path.write_text(json.dumps(doc))
    with pytest.raises(CalibrationFileError, match="unknown basis 'dT\\^Q'"):
        Calibration.load(path)


def test_kept_hashes_do_not_travel_with_pickles() -> None:
    """Terms keep their hash; a pickle must not carry it (nor a basis one) to another process.

    String hashes are salted per process, so a carried hash would be wrong there: the
    unpickled object must hash as a freshly built equal one, and hold no kept hash.
    """
    import pickle
    import subprocess
    import sys

    from accelcore.model import Basis, Term

    term = Term("gain", "hinge(2.5):extra:supply_v", source="y", effect="gain on g_y vs supply_v")
    hash(term), hash(term.basis)
    assert "_hash" not in pickle.loads(pickle.dumps(term.basis)).__dict__
    blob = pickle.dumps((term, term.basis))
    # Another process (another string-hash salt) looks both up in a dict of fresh ones.
    code = (
        "import pickle, sys\n"
        "from accelcore.model import Basis, Term\n"
        "t, b = pickle.loads(sys.stdin.buffer.read())\n"
        "fresh = Term('gain', 'hinge(2.5):extra:supply_v', source='y',"
        " effect='gain on g_y vs supply_v')\n"
        "print({fresh: 1}.get(t), {fresh.basis: 1}.get(b))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], input=blob, capture_output=True, check=True
    ).stdout
    assert out.decode().split() == ["1", "1"]
    assert Basis.parse("hinge(2.5):extra:supply_v") == term.basis


def test_a_step_and_its_until_split_one_run_in_two() -> None:
    """``step(R@t0)`` is 1 from t0 on in run R, ``until(R@t0)`` 1 before it; both 0 elsewhere."""
    after, before = Basis.parse("step(OX+@900)"), Basis.parse("until(OX+@900)")
    assert (after.name, before.name) == ("step(OX+@900)", "until(OX+@900)")
    assert after != before and Basis.parse(before.name) == before
    t = np.arange(0.0, 1800.0, 0.5)
    temp = np.full(t.size, 25.0)
    run = Features(temp, t, {}, t_ref_c=25.0, run="OX+")
    other = Features(temp, t, {}, t_ref_c=25.0, run="OX-")
    np.testing.assert_array_equal(after.evaluate(run) + before.evaluate(run), np.ones(t.size))
    np.testing.assert_array_equal(before.evaluate(run), (t < 900.0).astype(float))
    assert not before.evaluate(other).any() and not after.evaluate(other).any()


def test_a_two_way_lag_names_both_time_constants() -> None:
    """``lag(heating,cooling):dT^k``; the same both ways is the plain lag."""
    two = Basis.parse("lag(50,250):dT^2")
    assert two == LaggedTemperaturePower(50.0, 2, 250.0)
    assert (two.name, two.lag_s, two.lag_key) == ("lag(50,250):dT^2", 50.0, (50.0, 250.0))
    assert two.without_lag() == TemperaturePower(2)
    same = LaggedTemperaturePower(90.0, 1, 90.0)
    assert same == Basis.parse("lag(90):dT^1") and same.lag_key == (90.0,)
    with pytest.raises(ParameterError):
        LaggedTemperaturePower(50.0, 1, -1.0)
    # Heating up a ramp it trails by 50 s of it; cooling down one, by 250 s.
    t = np.arange(0.0, 8000.0, 0.5)
    temp = np.where(t < 4000.0, 25.0 + 0.01 * t, 65.0 - 0.01 * (t - 4000.0))
    lagged = two.evaluate(Features(temp, t, {}, t_ref_c=25.0)) ** 0.5
    assert abs((temp[7999] - 25.0) - lagged[7999] - 0.5) < 0.01
    assert abs(lagged[-1] - (temp[-1] - 25.0) - 2.5) < 0.01
