"""A run cut short does not hide an effect the other runs show.

A run that holds only the start of the sweep is a data-quality finding ('short') that
could explain a lag (its lag state and temperature path are unlike the other runs'),
so the families it could explain were not tried at all. A part with a real 90 s lag
and one run cut at 20 min then got a drift and generic terms of temperature instead
(`diagnose` with every default). Now the runs without the finding are diagnosed
alone: what they show (the lag, 89.9-90.1 s on every axis) is tried on the whole
session, and what they do not show (a clean part) stays untried.
"""

from __future__ import annotations

from accelcore import simulate
from accelcore.diagnosis import diagnose
from accelcore.input.session import Session
from accelcore.simulate import effects as se


def _cut_session(effects: tuple[simulate.Effect, ...], rows: int) -> Session:
    sim = simulate.arrays("ADXL335", seed=3, duration_h=1.0, cool_back=True, effects=effects)
    runs = []
    for i, r in enumerate(sim.runs):
        cols = {k: v[:rows] for k, v in r.columns.items()} if i == 0 else r.columns
        runs.append((r.orientation, cols))
    return Session.from_arrays(
        runs, units=sim.units, rate_hz=sim.rate_hz, sensor=sim.sensor, decimation_factor=10
    )


def test_a_lag_the_other_runs_show_is_found_beside_a_run_cut_short() -> None:
    d = diagnose(_cut_session((se.ThermalLag(90.0),), 24_000))  # OX+ cut at 20 min
    assert d.effects == ("thermal_lag",), d.effects
    assert any(
        "'short'" in w and "tried, as the runs without it show it too" in w for w in d.warnings
    )
    # The time constant is the part's: 90 s, within the search's tolerance on each axis.
    lag = next(s for s in d.steps if s.effect == "thermal_lag")
    for variant in lag.variant.values():
        assert "die lag" in variant
        assert 80.0 < float(variant.split("tau ")[1].split(" s")[0]) < 100.0


def test_a_clean_part_with_a_run_cut_short_still_gets_nothing() -> None:
    d = diagnose(_cut_session((), 24_000))
    assert d.effects == (), d.effects
    assert any("could explain thermal_lag" in w and "not tried" in w for w in d.warnings)
