"""accelcore.residuals: error per decimated sample in mg, beside the observables."""

from __future__ import annotations

import numpy as np

from accelcore import simulate
from accelcore.diagnosis import residuals
from accelcore.fitting.calibrate import calibrate
from accelcore.input.session import Session
from accelcore.simulate import effects as se


def _session(effects: tuple[object, ...] = ()) -> Session:
    sim = simulate.arrays(
        "ADXL335",
        seed=21,
        duration_h=0.5,
        cool_back=True,
        effects=effects,  # type: ignore[arg-type]
        extra_columns=("supply_v",),
    )
    se.attach_extra_columns(sim, effects)
    return Session.from_arrays(
        [(r.orientation, r.columns) for r in sim.runs], units=sim.units, rate_hz=sim.rate_hz
    )


def test_columns_and_values_on_clean_data() -> None:
    session = _session()
    cal = calibrate(session)
    df = residuals(cal, session)
    expected = {
        "run",
        "run_index",
        "orientation",
        "time_s",
        "elapsed_s",
        "temperature_c",
        "dtemp_dt_c_per_min",
        "branch",
        "err_x_mg",
        "err_y_mg",
        "err_z_mg",
        "err_norm_mg",
        "in_range",
        "supply_v",
    }
    assert expected <= set(df.columns)
    assert len(df) == sum(len(r) for r in session.runs)
    assert set(df["branch"]) == {"heating", "cooling", "steady"}
    inside = df[df["in_range"]]
    for a in "xyz":
        rms = float(np.sqrt(np.mean(inside[f"err_{a}_mg"] ** 2)))
        assert rms < 1.5, (a, rms)
    # Orientation labels and elapsed time start at 0 in every run.
    assert set(df["orientation"]) == {"OX+", "OX-", "OY+", "OY-", "OZ+", "OZ-"}
    assert (df.groupby("run_index")["elapsed_s"].min() == 0).all()
    # The norm error is about the error of the axis that sees gravity.
    z_up = inside[inside["orientation"] == "OZ+"]
    assert np.allclose(z_up["err_norm_mg"], z_up["err_z_mg"], atol=0.05)


def test_residual_shows_an_injected_drift_in_time() -> None:
    session = _session((se.Drift(mg_per_h=(0.0, 0.0, 20.0)),))
    cal = calibrate(session)
    df = residuals(cal, session)
    inside = df[df["in_range"] & (df["orientation"] == "OX+")]
    slope = np.polyfit(inside["elapsed_s"] / 3600.0, inside["err_z_mg"], 1)[0]
    assert slope > 5.0


def test_branch_matches_sign_of_rate() -> None:
    session = _session()
    df = residuals(calibrate(session), session)
    heating = df[df["branch"] == "heating"]
    cooling = df[df["branch"] == "cooling"]
    assert (heating["dtemp_dt_c_per_min"] > 0).all()
    assert (cooling["dtemp_dt_c_per_min"] < 0).all()
