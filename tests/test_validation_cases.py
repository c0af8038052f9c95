"""The cheapest cases of ``benches/validation.py``, on short sessions: scored on another session.

The bench module is loaded by its path (the ``bench`` fixture of ``conftest.py``: the
tests do not put the checkout's ``benches`` package on the import path); the cases,
the scoring and the rules are those of the table in ``docs/diagnosis.md``, with 0.5 h
runs instead of 1 h.
"""

from __future__ import annotations

from types import ModuleType

import pytest

HOURS = 0.5


def case(bench: ModuleType, name: str) -> object:
    """The case of that name, for runs of ``HOURS``."""
    found = [c for c in bench._cases(HOURS * 3600.0) if c.name == name]
    assert len(found) == 1, name
    return found[0]


def test_a_clean_part_is_not_made_worse_on_another_session(bench: ModuleType) -> None:
    out = bench.run_case(case(bench, "clean"), 1, HOURS)
    assert out.diagnosed_mg <= 1.05 * out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)
    assert out.met
    # Nothing to learn: the base model is already at the noise floor.
    assert out.base_mg < 1.2 * out.floor_mg, (out.base_mg, out.floor_mg)


@pytest.mark.parametrize("name", ["offset curvature", "misalignment", "nonlinearity (K2)"])
def test_a_part_effect_is_cut_at_least_twice_on_another_session(
    bench: ModuleType, name: str
) -> None:
    out = bench.run_case(case(bench, name), 2, HOURS)
    assert out.base_mg >= 2.0 * out.ideal_mg, "the effect must stand out of the noise"
    assert out.diagnosed_mg * 2.0 <= out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)
    assert out.met


@pytest.mark.parametrize(
    ("name", "found"),
    [
        ("tilted run (1.5° about x, OZ+)", "event: level of run OZ+"),
        ("output step (10 mg, OX+ mid-run)", "event: step in OX+ at 900 s"),
        ("warm-up (10 mg, τ 300 s)", "event: warm-up"),
    ],
)
def test_a_session_event_is_fitted_and_not_carried(
    bench: ModuleType, name: str, found: str
) -> None:
    """An event of the calibration session (a tilted run, a knock, a warm-up) is found,
    named, fitted beside the model and left out of the calibration: the validation
    session, which did not have it, is compensated at least 1.5x better."""
    out = bench.run_case(case(bench, name), 1, HOURS)
    assert found in out.added, out.added
    # The part has no effect: none is carried (an effect chosen before the events
    # were known is chosen again with them held in every model).
    assert all(e.startswith("event: ") for e in out.added), out.added
    assert out.diagnosed_mg * 1.5 <= out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)
    assert out.met


def test_a_step_at_one_temperature_is_found_by_the_generic_terms(bench: ModuleType) -> None:
    """Out of the named catalogue: the generic offset-vs-temperature terms take it."""
    out = bench.run_case(case(bench, "temperature step at 38 °C (outside catalogue)"), 1, HOURS)
    assert "offset vs temperature_c" in out.added, out.added
    assert out.diagnosed_mg * 2.0 <= out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)
