"""Spikes and output clipped at a rail are left out of the fit, and said so."""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from accelcore import Session, calibrate, simulate
from accelcore.input.quality import check_session, excluded_blocks

SENSOR = "ADXL335"


def _session(columns_of: dict[str, dict[str, np.ndarray]]) -> Session:
    return Session.from_arrays(list(columns_of.items()), units="V", rate_hz=20.0, sensor=SENSOR)


@pytest.fixture(scope="module")
def sim() -> simulate.SimulatedArrays:
    return simulate.arrays(SENSOR, seed=41, duration_h=1.0, orientations=("OZ+", "OZ-"))


def _columns(sim: simulate.SimulatedArrays) -> dict[str, dict[str, np.ndarray]]:
    return {r.orientation: {k: v.copy() for k, v in r.columns.items()} for r in sim.runs}


def _z_tempcos(cal: object) -> tuple[float, float, float, float]:
    s = cal.axis("z")  # type: ignore[attr-defined]
    return (
        s.offset_tc_mg_per_c,
        s.offset_tc_mg_per_c_se,
        s.sensitivity_tc_pct_per_c,
        s.sensitivity_tc_pct_per_c_se,
    )


def test_clean_data_loses_nothing(sim: simulate.SimulatedArrays) -> None:
    session = _session(_columns(sim))
    for run in session.runs:
        mask, n_spikes, n_clipped = excluded_blocks(run)
        assert (n_spikes, n_clipped) == (0, 0) and not mask.any()
    cal = calibrate(session)
    assert not any("left out" in n for n in cal.notes)


def test_spikes_are_left_out_and_the_fit_stays_on_the_truth(
    sim: simulate.SimulatedArrays,
) -> None:
    cols = _columns(sim)
    rng = np.random.default_rng(3)
    z = cols["OZ+"]["z"]
    hot = np.flatnonzero(cols["OZ+"]["temp_c"] > 45)
    starts = rng.choice(hot[:-20], size=60, replace=False)
    for s in starts:  # 60 bursts of 5 raw samples, +0.3 V (1 g): a loose connector
        z[s : s + 5] += 0.3
    session = _session(cols)
    truth = (sim.truth.offset_tc_mg_per_c[2], sim.truth.sensitivity_tc_pct_per_c[2])
    robust = calibrate(session)
    plain = calibrate(session, robust=False)
    off, off_se, sens, sens_se = _z_tempcos(robust)
    # With the spike blocks out, the estimates are within 5 standard errors of the truth
    # (about 20 such checks in this file: a false failure has odds below 1e-4).
    assert abs(off - truth[0]) <= 5 * off_se
    assert abs(sens - truth[1]) <= 5 * sens_se
    # Without, the bursts pull the hot end up: the offset tempco is off by many se.
    p_off, p_off_se, _, _ = _z_tempcos(plain)
    assert abs(p_off - truth[0]) > 10 * p_off_se
    note = next(n for n in robust.notes if "left out" in n)
    assert "spike block(s)" in note and "OZ+" in note


def test_clipped_output_is_left_out(sim: simulate.SimulatedArrays) -> None:
    cols = _columns(sim)
    z, temp = cols["OZ+"]["z"], cols["OZ+"]["temp_c"]
    # Above 50 °C a fault drives the output 1 V up, past the ADC's rail: clipped there.
    rail = float(z.max()) + 0.2
    z[temp > 50] += 1.0
    np.minimum(z, rail, out=z)
    session = _session(cols)
    run = session.runs[0]
    mask, _, n_clipped = excluded_blocks(run)
    assert n_clipped >= 0.09 * len(run)
    # Every block left unmasked is below the rail (partly clipped neighbours are out too).
    assert np.all(run.output[~mask, 2] < rail)
    truth = sim.truth.offset_tc_mg_per_c[2]
    off, off_se, _, _ = _z_tempcos(calibrate(session))
    p_off, p_off_se, _, _ = _z_tempcos(calibrate(session, robust=False))
    assert abs(off - truth) <= 5 * off_se
    assert abs(p_off - truth) > 20 * p_off_se
    paper = calibrate(session, method="paper")
    assert any("clipped block(s)" in n for n in paper.notes)


@pytest.fixture(scope="module")
def coarse() -> simulate.SimulatedArrays:
    # A 12-bit ADC over 20 V: 4.9 mV = 16 mg per code, against 1.3-2.7 mg of noise,
    # so the output sits on one code for whole blocks (the 16-bit default: 1 mg).
    return simulate.arrays(
        SENSOR, seed=41, duration_h=1.0, orientations=("OZ+", "OZ-", "OX+"), adc_bits=12
    )


def test_coarse_codes_are_neither_a_rail_nor_spikes(coarse: simulate.SimulatedArrays) -> None:
    session = _session(_columns(coarse))
    for run in session.runs:
        # Before: 6014, 7200 and 5992 blocks were left out as clipped (every code the
        # output held for a block was taken for a rail), and 84-101 as spikes.
        mask, n_spikes, n_clipped = excluded_blocks(run)
        assert (n_spikes, n_clipped) == (0, 0) and not mask.any()
    assert not any(i.kind in {"clipping", "outliers"} for i in check_session(session, warn=False))
    assert not any("left out" in n for n in calibrate(session).notes)


def test_spikes_on_coarse_codes_are_still_found(coarse: simulate.SimulatedArrays) -> None:
    cols = _columns(coarse)
    z = cols["OZ+"]["z"]
    rng = np.random.default_rng(3)
    starts = rng.choice(np.arange(100, z.size - 100, 50), size=60, replace=False)
    for s in starts:  # 60 bursts of 5 raw samples, +0.3 V (1 g, 61 codes): a loose connector
        z[s : s + 5] += 0.3
    run = _session(cols).runs[0]
    mask, n_spikes, n_clipped = excluded_blocks(run)
    # Each burst lifts one block, or two where it straddles a block's edge; the
    # threshold on coarse codes (8 x step/sqrt(12), 2.3 codes) is far below 61 codes.
    assert 60 <= n_spikes <= 120 and n_clipped == 0
    hit = {int(s) // 10 for s in starts} | {(int(s) + 4) // 10 for s in starts}
    assert set(np.flatnonzero(mask)) <= hit


def test_a_partial_block_after_a_gap_is_judged_by_its_own_noise(
    sim: simulate.SimulatedArrays,
) -> None:
    cols = _columns(sim)
    run = cols["OZ+"]
    # Rows 1000-1208 lost (a 10 s gap): the block of rows 1200-1209 keeps one sample,
    # the noise of one sample, sqrt(10) times a full block's.
    keep = np.ones(run["x"].size, dtype=bool)
    keep[1000:1209] = False
    for k in run:
        run[k] = run[k][keep]
    x = run["x"]
    sigma_raw = float(np.std(np.diff(x[:1000])) / np.sqrt(2.0))
    # That sample 4 sigma high: a draw white noise gives once in 30,000 samples. As a
    # block mean it stood 10.2 robust sigma off its running median (a 'spike', over
    # 8); scaled to a full block's noise, sqrt(10) less.
    x[1000] += 4.0 * sigma_raw
    session = _session(cols)
    r = next(r for r in session.runs if r.orientation == "OZ+")
    assert r.count.min() == 1
    mask, n_spikes, _ = excluded_blocks(r)
    assert n_spikes == 0 and not mask.any()
    # A real spike there (+0.3 V, 1 g, in that one sample) is still one.
    x[1000] += 0.3
    r = next(r for r in _session(cols).runs if r.orientation == "OZ+")
    mask, n_spikes, _ = excluded_blocks(r)
    assert n_spikes == 1 and int(np.flatnonzero(mask)[0]) == int(np.argmin(r.count))


@dataclass(frozen=True)
class _CoarseAdc:
    """The output rounded to the codes of a 12-bit ADC over 20 V (16 mg at 0.3 V/g)."""

    name: str = "adc_12_bit"
    stage: str = "output"

    def apply(self, state: Any, rng: np.random.Generator) -> None:
        step = 20.0 / 2**12
        state.output = np.rint(state.output / step) * step


def test_a_coarse_adc_session_is_not_made_worse_by_the_diagnosis(bench: ModuleType) -> None:
    # Scored as the validation table scores a part: fitted with the defaults on a
    # heat-and-cool session, on a cooling session of the same part at 0-60 °C. Before,
    # the codes held for whole blocks were 'clipped' (75-100 % of every run left out)
    # and the diagnosed calibration scored 12.33 mg against the base model's 6.62.
    case = bench.ValidationCase("12-bit ADC", part=(_CoarseAdc(),), expect="rise <= 5%")
    out = bench.run_case(case, 1, 1.0)
    assert out.met, (out.base_mg, out.diagnosed_mg, out.added)
    # The quantiser's own error, step/sqrt(12) = 4.7 mg per sample, averaged over a
    # block's samples and the axes: both calibrations stay within 5 mg.
    assert out.base_mg < 5.0 and out.diagnosed_mg < 5.0
