"""Session events of the simulator do what they say (a tilted run, an output step, a warm-up)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest

from accelcore import simulate
from accelcore.simulate import effects as se
from accelcore.simulate.events import OutputStep, RunTilt, WarmUp, rotation_matrix

ORIENTS = ("OX+", "OZ+")


def sim(
    effects: Sequence[simulate.Effect] = (), seed: int = 3, **kw: object
) -> simulate.SimulatedArrays:
    """Two short runs (6 min at 20 Hz) of an ADXL335 on a mild ramp."""
    return simulate.arrays(
        "ADXL335",
        seed=seed,
        duration_h=0.1,
        soak_min=1.0,
        t_start_c=20.0,
        t_end_c=30.0,
        orientations=ORIENTS,
        effects=effects,
        **kw,  # type: ignore[arg-type]
    )


def in_g(s: simulate.SimulatedArrays, run: int) -> np.ndarray:
    """A run's output converted back to g with the true offset and sensitivity at the die."""
    r = s.runs[run]
    out = np.column_stack([r.columns[a] for a in "xyz"])
    return (out - s.truth.zero_g_offset_at(r.die_temp_c)) / s.truth.sensitivity_at(r.die_temp_c)


def diff_mg(with_event: simulate.SimulatedArrays, without: simulate.SimulatedArrays) -> np.ndarray:
    """Output difference of run 0 in mg (reference sensitivity), same seed so same noise."""
    a, b = with_event.runs[0].columns, without.runs[0].columns
    d = np.column_stack([a[c] - b[c] for c in "xyz"])
    return 1000.0 * d / with_event.truth.sensitivity_per_g


def test_events_follow_the_effect_protocol_and_are_re_exported() -> None:
    for eff, name, stage in (
        (RunTilt("OZ+", 1.0), "run_tilt", "stimulus"),
        (OutputStep("OZ+", 10.0), "output_step", "output"),
        (WarmUp(), "warm_up", "output"),
    ):
        assert isinstance(eff, simulate.Effect)
        assert (eff.name, eff.stage) == (name, stage)
    assert (se.RunTilt, se.OutputStep, se.WarmUp) == (RunTilt, OutputStep, WarmUp)
    names = sim([RunTilt("OZ+", 1.0), WarmUp()]).effects
    assert {"run_tilt", "warm_up"} <= set(names)


def test_rotation_matrix_is_a_right_handed_rotation() -> None:
    rot = rotation_matrix(90.0, "x")
    np.testing.assert_allclose(rot @ [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(rotation_matrix(30.0, (0.0, 0.0, 2.0)), rotation_matrix(30.0, "z"))


@pytest.mark.parametrize(("axis", "cross", "sign"), [("x", 1, -1.0), ("y", 0, 1.0)])
def test_tilted_run_reads_sin_angle_on_the_cross_axis(axis: str, cross: int, sign: float) -> None:
    angle = 1.5
    s = sim([RunTilt("OZ+", angle, axis)])
    g = in_g(s, 1)  # the OZ+ run
    n = len(g)
    sigma = max(s.noise_g) / math.sqrt(n) + 2e-5  # noise of the mean, plus a rounding margin
    assert abs(g[:, cross].mean() - sign * math.sin(math.radians(angle))) < 5 * sigma
    assert abs(g[:, 2].mean() - math.cos(math.radians(angle))) < 5 * sigma
    # The other run is untouched, to the bit.
    plain = sim()
    for c in ("x", "y", "z"):
        np.testing.assert_array_equal(s.runs[0].columns[c], plain.runs[0].columns[c])
    assert not np.array_equal(s.runs[1].columns["xyz"[cross]], plain.runs[1].columns["xyz"[cross]])


def test_tilt_about_the_gravity_axis_changes_nothing() -> None:
    s, plain = sim([RunTilt("OZ+", 2.0, "z")]), sim()
    for c in ("x", "y", "z"):
        np.testing.assert_array_equal(s.runs[1].columns[c], plain.runs[1].columns[c])


def test_output_step_starts_at_its_time_in_its_run_only() -> None:
    at_s = 200.0
    step = (1.0, -3.0, 5.0)
    s, plain = sim([OutputStep("OX+", at_s, step)]), sim()
    d = diff_mg(s, plain)
    t = s.runs[0].columns["time_s"]
    before, after = t < at_s, t >= at_s + 1e-9
    assert np.all(d[before] == 0.0)
    # After the step each sample moves by the step, to within one ADC code (about 1 mg).
    quantum_mg = 1000.0 * s.quantum / np.abs(s.truth.sensitivity_per_g)
    assert np.all(np.abs(d[after] - step) <= quantum_mg + 1e-9)
    np.testing.assert_allclose(d[after].mean(axis=0), step, atol=0.1)
    for c in ("x", "y", "z"):
        np.testing.assert_array_equal(s.runs[1].columns[c], plain.runs[1].columns[c])


def test_output_step_before_holds_until_its_time_only() -> None:
    at_s = 200.0
    step = (-6.0, 5.0, -8.0)
    s, plain = sim([OutputStep("OX+", at_s, step, before=True)]), sim()
    d = diff_mg(s, plain)
    t = s.runs[0].columns["time_s"]
    before, after = t < at_s - 1e-9, t >= at_s
    assert np.all(d[after] == 0.0)
    # Before the step each sample is off by the step, to within one ADC code.
    quantum_mg = 1000.0 * s.quantum / np.abs(s.truth.sensitivity_per_g)
    assert np.all(np.abs(d[before] - step) <= quantum_mg + 1e-9)


def test_warm_up_decays_with_its_time_constant_in_every_run() -> None:
    amp, tau = (5.0, -2.0, 8.0), 60.0
    s, plain = sim([WarmUp(amp, tau)]), sim()
    t = s.runs[0].columns["time_s"]
    model = np.exp(-(t - t[0]) / tau)[:, None] * np.asarray(amp)
    d = diff_mg(s, plain)
    # Window means of the difference follow the model (each sample is off by < 1 code).
    for lo in (0.0, 30.0, 60.0, 120.0, 240.0):
        w = (t >= lo) & (t < lo + 20.0)
        np.testing.assert_allclose(d[w].mean(axis=0), model[w].mean(axis=0), atol=0.25)
    # A warm-up twice as slow would not fit.
    slow = np.exp(-(t - t[0]) / (2 * tau))[:, None] * np.asarray(amp)
    w = (t >= 60.0) & (t < 80.0)
    assert np.max(np.abs(d[w].mean(axis=0) - slow[w].mean(axis=0))) > 1.0
    assert np.abs(diff_mg(s, plain)[-200:].mean(axis=0)).max() < 0.25  # long gone at the end
    only = sim([WarmUp(amp, tau, runs=("OZ+",))])
    for c in ("x", "y", "z"):
        np.testing.assert_array_equal(only.runs[0].columns[c], plain.runs[0].columns[c])


@pytest.mark.parametrize(
    "make",
    [
        lambda: RunTilt("", 1.0),
        lambda: RunTilt("OZ+", float("nan")),
        lambda: RunTilt("OZ+", 1.0, "w"),
        lambda: RunTilt("OZ+", 1.0, (0.0, 0.0, 0.0)),
        lambda: OutputStep("OZ+", -1.0),
        lambda: OutputStep("OZ+", 1.0, (1.0, 2.0)),  # type: ignore[arg-type]
        lambda: WarmUp(5.0, 0.0),
        lambda: WarmUp(float("inf")),
    ],
)
def test_bad_event_arguments_are_refused(make: object) -> None:
    with pytest.raises(ValueError):
        make()  # type: ignore[operator]
