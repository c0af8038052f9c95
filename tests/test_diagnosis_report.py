"""The report of a diagnosis: added effects ± se, held-out error per axis, what stays unexplained.

Checked in every form a user reads it: the tables, the terminal text, the JSON and
the HTML session page, on small simulated sessions with an injected effect, with an
effect outside the catalogue, and clean.
"""

from __future__ import annotations

import dataclasses
import html
import json
import math
from collections.abc import Hashable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from accelcore import simulate
from accelcore.diagnosis import Diagnosis, diagnose
from accelcore.diagnosis.tables import (
    EFFECT_COLUMNS,
    HELDOUT_COLUMNS,
    effects_table,
    value_se_text,
)
from accelcore.input.session import Session
from accelcore.model import AXES
from accelcore.simulate import effects as se

CURVATURE_MG_PER_C2 = {"x": 0.004, "y": 0.003, "z": 0.008}


def _session(effects: Sequence[object], seed: int) -> Session:
    """Six orientations, half an hour each, heat and cool back; 20 Hz decimated to 2 Hz."""
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
        decimation_factor=10,
    )


@pytest.fixture(scope="module")
def curved() -> tuple[Session, Diagnosis]:
    c2 = tuple(CURVATURE_MG_PER_C2[a] for a in AXES)
    session = _session((se.OffsetCurvature(mg_per_c2=c2),), 3)  # type: ignore[arg-type]
    return session, diagnose(session)


@pytest.fixture(scope="module")
def clean() -> tuple[Session, Diagnosis]:
    session = _session((), 3)
    return session, diagnose(session)


@pytest.fixture(scope="module")
def cycling() -> Diagnosis:
    """A compressor cycle on z: outside the catalogue, left unexplained."""
    return diagnose(_session((se.CompressorCycle(),), 5))


def _page(session: Session, diag: Diagnosis, out: Path) -> str:
    matplotlib = pytest.importorskip("matplotlib", reason="matplotlib is the [plot] extra")
    matplotlib.use("Agg")
    from accelcore.outputs.report import session_report

    return html.unescape(session_report(session, out, diagnosis=diag).read_text(encoding="utf-8"))


def _held(d: Diagnosis) -> dict[str, dict[Hashable, Any]]:
    """:meth:`Diagnosis.heldout_by_axis` as one record per axis name."""
    return {str(r["axis"]): r for r in d.heldout_by_axis().to_dict(orient="records")}


def _section(page: str, sid: str) -> str:
    start = page.index(f'<section id="{sid}">')
    return page[start : page.index("</section>", start)]


# ---------------------------------------------------------------------- tables
def test_effects_table_holds_the_injected_curvature_within_its_standard_error(
    curved: tuple[Session, Diagnosis],
) -> None:
    _, d = curved
    assert "offset_curvature" in d.effects, d.text()
    t = d.effects_table()
    assert tuple(t.columns) == EFFECT_COLUMNS
    rows = t[(t["effect"] == "offset_curvature") & t["parameter"].str.endswith("dT^2")]
    assert sorted(rows["axis"]) == list(AXES), t
    for r in rows.to_dict(orient="records"):
        assert r["unit"] == "mg/°C^2"
        assert math.isfinite(r["se"]) and r["se"] > 0, r
        truth = CURVATURE_MG_PER_C2[r["axis"]]
        assert abs(r["value"] - truth) <= 5.0 * r["se"], (r, truth)
        assert r["se"] < 0.1 * truth  # a standard error that resolves the effect


def test_effects_table_reads_the_steps_parameters_and_nothing_else(
    curved: tuple[Session, Diagnosis],
) -> None:
    _, d = curved
    t = d.effects_table()
    expected = [
        (s.index, s.effect, p["axis"], p["name"], p["value"], p["unit"])
        for s in d.steps[1:]
        for p in s.parameters
    ]
    cols = ["step", "effect", "axis", "parameter", "value", "unit"]
    got = [tuple(r) for r in t[cols].itertuples(index=False)]
    assert sorted(got, key=str) == sorted(expected, key=str)
    for r in t.to_dict(orient="records"):
        assert r["variant"] == d.steps[r["step"]].variant[r["axis"]]


def test_an_axis_without_a_readable_parameter_keeps_its_row(
    curved: tuple[Session, Diagnosis],
) -> None:
    _, d = curved
    step = d.steps[1]
    dropped = dataclasses.replace(step, parameters=[p for p in step.parameters if p["axis"] != "z"])
    t = effects_table((d.steps[0], dropped))
    z = t[t["axis"] == "z"]
    assert len(z) == 1 and z["parameter"].iloc[0] == "" and np.isnan(z["value"].iloc[0])
    assert z["effect"].iloc[0] == step.effect


def test_heldout_by_axis_sets_base_beside_diagnosed(curved: tuple[Session, Diagnosis]) -> None:
    _, d = curved
    h = d.heldout_by_axis()
    assert tuple(h.columns) == HELDOUT_COLUMNS
    assert list(h["axis"]) == [*AXES, "pooled"]
    held = _held(d)
    for a in AXES:
        assert held[a]["base_mg"] == d.steps[0].rms_out_axis_mg[a]
        assert held[a]["diagnosed_mg"] == d.steps[-1].rms_out_axis_mg[a]
        # Curvature on every axis: every axis improves on held-out data.
        assert held[a]["diagnosed_mg"] < 0.8 * held[a]["base_mg"], h
    pooled = math.sqrt(sum(held[a]["diagnosed_mg"] ** 2 for a in AXES) / len(AXES))
    assert held["pooled"]["diagnosed_mg"] == pytest.approx(pooled, rel=1e-9)
    assert held["pooled"]["base_mg"] == d.steps[0].rms_out_mg
    np.testing.assert_allclose(h["ratio"], h["diagnosed_mg"] / h["base_mg"], rtol=1e-12)
    np.testing.assert_allclose(h["cut_pct"], 100.0 * (1.0 - h["ratio"]), rtol=1e-12)


def test_value_and_error_are_written_to_the_errors_precision() -> None:
    assert value_se_text(0.6001102, 0.0003827) == ("0.60011", "0.00038")
    assert value_se_text(89.5, 0.25) == ("89.50", "0.25")
    assert value_se_text(2060.3, 450.0) == ("2060", "450")
    assert value_se_text(0.0040004, 9.4e-6) == ("0.0040004", "0.0000094")
    assert value_se_text(1.234e-7, 3.1e-10) == ("1.2340e-07", "3.1e-10")
    assert value_se_text(3.14159, math.nan) == ("3.142", "")
    assert value_se_text(math.nan, 1.0) == ("–", "")


# ---------------------------------------------------------------------- text, JSON
def test_text_has_the_three_blocks(curved: tuple[Session, Diagnosis]) -> None:
    _, d = curved
    text = d.text()
    lines = text.splitlines()
    for heading in ("Added effects", "Held-out error per axis", "Unexplained"):
        assert sum(line.startswith(heading) for line in lines) == 1, text
    added = [line for line in lines if "offset·dT^2" in line]
    assert len(added) == 3, text
    t = {
        (r["effect"], r["axis"], r["parameter"]): r
        for r in d.effects_table().to_dict(orient="records")
    }
    for a, line in zip(AXES, added, strict=True):
        r = t[("offset_curvature", a, "offset·dT^2")]
        v, e = value_se_text(r["value"], r["se"])
        assert line.split()[0] == a and f"{v}  ± {e}" in line and line.endswith("mg/°C^2")
    for a, h in _held(d).items():
        row = next(line for line in lines if line.split()[:1] == [a] and "→" in line)
        assert f"{h['base_mg']:.3f}" in row and f"{h['diagnosed_mg']:.3f}" in row
        assert f"cut {h['cut_pct']:.1f} %" in row


def test_json_round_trips_with_the_report(curved: tuple[Session, Diagnosis]) -> None:
    _, d = curved
    doc = json.loads(json.dumps(d.to_dict()))
    for key in ("scheme", "folds", "effects", "steps", "report", "candidates", "structures"):
        assert key in doc
    assert doc["effects"] == list(d.effects)  # the family names, as before
    added = doc["added_effects"]
    json.dumps(added, allow_nan=False)
    json.dumps(doc["heldout_rms_mg"], allow_nan=False)
    t = d.effects_table()
    assert len(added) == len(t)
    for rec, r in zip(added, t.to_dict(orient="records"), strict=True):
        assert set(rec) == set(EFFECT_COLUMNS)
        assert rec["value"] == r["value"] and rec["se"] == r["se"] and rec["unit"] == r["unit"]
    held = _held(d)
    for which, col in (("base", "base_mg"), ("diagnosed", "diagnosed_mg")):
        assert set(doc["heldout_rms_mg"][which]) == {*AXES, "pooled"}
        for a, v in doc["heldout_rms_mg"][which].items():
            assert v == held[a][col]
    assert doc["unexplained"] == [s.to_dict() for s in d.unexplained]


def test_html_page_has_the_added_effects_section(
    curved: tuple[Session, Diagnosis], tmp_path: Path
) -> None:
    session, d = curved
    part = _section(_page(session, d, tmp_path), "effects")
    assert "<h2>Added effects</h2>" in part and 'class="effects"' in part
    assert part.count("offset·dT^2") == 3
    t = d.effects_table()
    for r in t.to_dict(orient="records"):
        v, e = value_se_text(r["value"], r["se"])
        assert f"<td>{v} ± {e}</td>" in part
    assert "Held-out error per axis" in part
    assert f"<td>{_held(d)['pooled']['diagnosed_mg']:.3f}</td>" in part
    assert "None: no structure left" in part


# ---------------------------------------------------------------------- leftovers, clean
def test_what_stays_unexplained_is_listed_everywhere(cycling: Diagnosis) -> None:
    d = cycling
    assert d.unexplained and d.unexplained[0].axis == "z", d.text()
    top = d.unexplained[0]
    lines = d.text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Unexplained"))
    assert "none" not in lines[start]
    listed = lines[start + 1 : start + 1 + len(d.unexplained)]
    assert listed[0].split()[:3] == ["z", "vs", top.observable]
    assert f"{top.structure_rms_mg:.3f} mg rms" in listed[0]
    doc = json.loads(json.dumps(d.to_dict()))
    assert [u["observable"] for u in doc["unexplained"]] == [s.observable for s in d.unexplained]


def test_clean_session_reports_no_effect_added(
    clean: tuple[Session, Diagnosis], tmp_path: Path
) -> None:
    session, d = clean
    assert d.effects == (), d.text()
    t = d.effects_table()
    assert t.empty and tuple(t.columns) == EFFECT_COLUMNS
    text = d.text()
    assert "Added effects: none (no effect added" in text
    h = d.heldout_by_axis()
    assert (h["ratio"] == 1.0).all() and (h["cut_pct"] == 0.0).all()
    doc = json.loads(json.dumps(d.to_dict(), allow_nan=True))
    assert doc["added_effects"] == []
    assert doc["heldout_rms_mg"]["base"] == doc["heldout_rms_mg"]["diagnosed"]
    part = _section(_page(session, d, tmp_path), "effects")
    assert "No effect added" in part and 'class="effects"' not in part


def test_what_the_orientations_cannot_tell_is_in_the_text(
    curved: tuple[Session, Diagnosis],
) -> None:
    """Two orientations (OZ+ and OZ-): x's and y's sensitivities are held at nominal.

    The held-out errors are on OZ±, where those do not show; the text says so, once.
    """
    session = _session((), 4)
    two = Session.from_arrays(
        [
            (
                r.orientation,
                {
                    "time_s": r.time_s,
                    "temp_c": r.temperature_c,
                    "x": r.output[:, 0],
                    "y": r.output[:, 1],
                    "z": r.output[:, 2],
                },
            )
            for r in session.runs
            if r.orientation in ("OZ+", "OZ-")
        ],
        units=session.units,
        rate_hz=session.rate_hz,
        sensor=session.sensor,
        decimation_factor=1,
    )
    d = diagnose(two)
    assert "x:sensitivity" in d.calibration.not_identified
    lines = d.text().splitlines()
    start = [i for i, line in enumerate(lines) if line.startswith("Not identified")]
    assert len(start) == 1, d.text()
    block = lines[start[0] + 1 :]
    assert "x:sensitivity" in block[0] and "y:sensitivity" in block[0]
    held = [line for line in block if "held at nominal" in line]
    assert len(held) == len(set(held)) >= 2  # each note once (they were written twice)
    # A session of six orientations identifies everything: no such block.
    _, six = curved
    assert not six.calibration.not_identified
    assert not any(line.startswith("Not identified") for line in six.text().splitlines())
