"""The HTML report of one session: :func:`session_report`.

``OUT/index.html`` holds the calibration summary, the lab's record (the
``[lab]`` table of ``session.toml``), the datasheet comparison (the seed
paper's Tables 3/4 and 5/6, out-of-spec values highlighted), the paper's
Figures 4, 6 and 7 for this part, the added effects (parameters ± standard
error, held-out error per axis before and after, what stays unexplained), the
diagnosis steps with residual plots per axis, the notes and what the data
could not identify, and provenance (accelcore version, digest of every input
file). Part of the outputs room.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from accelcore import datasheets
from accelcore._accelcore import __version__
from accelcore.constants import AXES
from accelcore.diagnosis import Diagnosis, diagnose
from accelcore.diagnosis.tables import value_se_text
from accelcore.errors import AccelcoreError
from accelcore.fitting.calibrate import calibrate
from accelcore.input.format import LAB_KEYS
from accelcore.input.session import Session
from accelcore.input.single_log import load_session
from accelcore.outputs import plots
from accelcore.outputs.diagnosis_plot import plot_residuals_per_axis
from accelcore.outputs.plots import not_identified_terms
from accelcore.outputs.report.html import (
    NOT_IDENTIFIED,
    escape,
    figure_html,
    guarded,
    new_figure,
    note,
    page,
    table,
    write_page,
)
from accelcore.result.calibration import Calibration

__all__ = ["session_report"]


def _figure4(session: Session, cal: Calibration) -> str:
    picks: list[tuple[str | None, str | None]] = []
    orientations = set(session.orientations)
    for name in AXES:
        for sign in "+-":
            label = f"O{name.upper()}{sign}"
            if label in orientations:
                picks.append((label, name))
                break
    n = max(len(picks), 1)
    fig = new_figure(4.6 * n, 6.6, columns=n, rows=2, hspace=0.25)
    axs = fig.subplots(2, n, squeeze=False, sharex="col", height_ratios=[3, 2])
    for col, (o, a) in enumerate(picks or [(None, None)]):
        top, bottom = axs[0][col], axs[1][col]
        plots.plot_raw_vs_decimated(
            session, o, a, ax=top, calibration=cal, max_raw_points=plots.MAX_POINTS
        )
        plots.plot_averaging(session, o, a, ax=bottom, calibration=cal)
        top.set_xlabel("")
        top.tick_params(labelbottom=False)
    return figure_html(
        fig,
        f"Figure 4: before and after averaging — the raw {session.rate_hz:g} Hz log (grey), "
        f"its {session.rate_hz / session.decimation_factor:g} Hz block averages (blue), "
        "temperature-bin means (orange) and the calibration's model (black), one run per axis "
        "(the axis gravity acts on). Below: the raw and the averaged points minus the bin "
        "means, σ their spread.",
        "Figure 4: raw and decimated output against temperature",
    )


def _paired_figure(session: Session, cal: Calibration, kind: str) -> str:
    names = [a for a in AXES if a in cal.axes]
    fig = new_figure(4.2 * max(len(names), 1), 3.8, columns=max(len(names), 1))
    axs = list(fig.subplots(1, max(len(names), 1), squeeze=False)[0])
    held = [n for a in names for n in not_identified_terms(cal, a, kind)]
    tail = (
        f" No line where the term was not identified ({', '.join(held)}: held, not fitted)."
        if held
        else ""
    )
    if kind == "gain":
        plots.plot_sensitivity_vs_temperature(session, cal, ax=axs, sensor_axes=names)
        caption = "Figure 6: sensitivity (V+ − V−)/2 per temperature bin and the fitted line."
        alt = "Figure 6: sensitivity against temperature"
    else:
        plots.plot_offset_vs_temperature(session, cal, ax=axs, sensor_axes=names)
        caption = "Figure 7: zero-g offset (V+ + V−)/2 per temperature bin and the fitted line."
        alt = "Figure 7: zero-g offset against temperature"
    return figure_html(fig, caption + tail, alt)


def _residual_figure(diag: Diagnosis) -> str:
    import matplotlib.pyplot as plt  # optional: the [plot] extra

    fig = plot_residuals_per_axis(diag)
    try:
        right = fig.axes[-1].get_xlabel() if len(fig.axes) > len(AXES) else ""
        against = "temperature (left) and " + right + " (right)" if right else "temperature"
        lines = (
            "the binned mean of the residual"
            if not diag.effects
            else "the binned means of the base model (dashed) and of the diagnosed model (solid)"
        )
        return figure_html(
            fig,
            f"Residual error (mg) per axis against {against}: points are the diagnosed "
            f"model's residual (thinned to a fixed stride), lines {lines}.",
            "Residual plots per axis, base model and diagnosed",
        )
    finally:
        plt.close(fig)


def _datasheet_tables(cal: Calibration) -> str:
    if not cal.sensor:
        return note("No datasheet comparison: the session names no sensor.")
    try:
        df = cal.compare_datasheet().reset_index()
    except (datasheets.DatasheetError, KeyError, AccelcoreError) as exc:
        return note(f"No datasheet comparison: {exc}")
    parts = [
        f"<p>Measured at T_ref = {escape(f'{cal.t_ref_c:g}')} °C against the {escape(cal.sensor)} "
        "datasheet (layout of the paper's Tables 3/4 and 5/6). "
        '<span class="muted">Highlighted: in spec (green), out of spec (red); '
        "– where the datasheet gives no limit or the value is not identified.</span></p>"
    ]
    titles = {
        "at T_ref": "Offset and sensitivity at T_ref (Tables 3/4)",
        "temperature coefficients": "Temperature coefficients (Tables 5/6)",
    }
    for name, part in df.groupby("table", sort=False):
        parts.append(f"<h3>{escape(titles.get(str(name), str(name)))}</h3>")
        rows = [
            {**r, "parameter": _PARAMETER_NAMES.get(str(r["parameter"]), str(r["parameter"]))}
            for r in part.to_dict(orient="records")
        ]
        parts.append(
            table(
                [
                    "parameter",
                    "axis",
                    "min",
                    "typ",
                    "max",
                    "measured",
                    "measured_se",
                    "unit",
                    "in_spec",
                ],
                rows,
                numeric=["min", "typ", "max", "measured", "measured_se"],
                spec=["in_spec"],
                rename={"measured_se": "± se", "in_spec": "in spec"},
                cls="datasheet",
            )
        )
    return "\n".join(parts)


#: Plain names of the datasheet parameters and of the summary's columns.
_PARAMETER_NAMES = {
    "zero_g_offset": "zero-g offset",
    "sensitivity": "sensitivity",
    "offset_tc": "offset TC",
    "sensitivity_tc": "sensitivity TC",
    "offset_tc_mg_per_c": "offset TC",
    "sensitivity_tc_pct_per_c": "sensitivity TC",
}


def _summary_table(cal: Calibration) -> str:
    """One row per axis: each parameter with its standard error under it, in plain words."""
    units = cal.units
    columns = {
        "zero_g_offset": (f"zero-g offset ({units})", "offset"),
        "sensitivity": (f"sensitivity ({units}/g)", "sensitivity"),
        "offset_tc_mg_per_c": ("offset TC (mg/°C)", "offset_tc"),
        "sensitivity_tc_pct_per_c": ("sensitivity TC (%/°C)", "sensitivity_tc"),
    }
    rows: list[dict[str, Any]] = []
    summary = cal.summary()
    for a in cal.axes:
        s = cal.axis(a)
        row: dict[str, Any] = {"axis": a}
        for c in columns:
            row[c] = getattr(s, c)
            row[f"{c}_se"] = getattr(s, f"{c}_se")
        row["rms_residual_mg"] = summary.loc[a, "rms_residual_mg"]
        row["n_samples"] = summary.loc[a, "n_samples"]
        row[NOT_IDENTIFIED] = {
            c for c, (_, n) in columns.items() if f"{a}:{n}" in cal.not_identified
        }
        rows.append(row)
    cols = ["axis", *columns, "rms_residual_mg", "n_samples"]
    rename = {c: h for c, (h, _) in columns.items()} | {
        "rms_residual_mg": "RMS residual (mg)",
        "n_samples": "samples",
    }
    return (
        '<p class="muted">Standard errors under each value; T_ref = '
        f"{escape(f'{cal.t_ref_c:g}')} °C; TC: temperature coefficient.</p>"
        + table(
            cols,
            rows,
            numeric=cols[1:],
            rename=rename,
            se={c: f"{c}_se" for c in columns},
            cls="summary",
        )
    )


def _lab_section(session: Session, cal: Calibration) -> str:
    """Render the ``[lab]`` table of ``session.toml`` (as the calibration carries it)."""
    lab: Mapping[str, Any] = cal.provenance.get("lab") or (
        session.format.lab if session.format is not None else {}
    )
    if not lab:
        return (
            '<p class="muted">No lab record: <code>session.toml</code> has no <code>[lab]</code> '
            f"table ({escape(', '.join(LAB_KEYS))}).</p>"
        )
    rows = "".join(
        f"<tr><th>{escape(k.replace('_', ' ').capitalize())}</th>"
        f'<td class="text">{escape(lab.get(k, "") or "–")}</td></tr>'
        for k in LAB_KEYS
    )
    return f'<div class="scroll"><table class="kv lab"><tbody>{rows}</tbody></table></div>'


def _diagnosis_section(diag: Diagnosis) -> str:
    rep = diag.report()
    cols = [
        "step",
        "effect",
        "axes",
        "variant",
        "rms_in_after_mg",
        "rms_out_before_mg",
        "rms_out_after_mg",
        "max_out_after_mg",
        "cut_pct",
    ] + [f"rms_out_{a}_after_mg" for a in AXES]
    cols = [c for c in cols if c in rep.columns]
    numeric = [c for c in cols if c.endswith("_mg") or c == "cut_pct"]
    rename = {
        "rms_in_after_mg": "RMS in",
        "rms_out_before_mg": "RMS out before",
        "rms_out_after_mg": "RMS out after",
        "max_out_after_mg": "max out after",
        "cut_pct": "cut %",
    } | {f"rms_out_{a}_after_mg": f"RMS out {a} after" for a in AXES}
    effects = ", ".join(diag.effects) or "none"
    head = (
        f"<p>Effects added: <b>{escape(effects)}</b>. Held-out folds: {escape(diag.scheme)} "
        f"({escape(', '.join(diag.folds))}). Errors in mg, all axes pooled unless named; "
        "step 0 is the base model; the parameters of each step are under Added effects.</p>"
    )
    return head + table(
        cols, rep.to_dict(orient="records"), numeric=numeric, rename=rename, cls="diagnosis"
    )


def _effects_section(diag: Diagnosis) -> str:
    """Render the added effects (± se), held-out error per axis before and after, leftovers."""
    eff = diag.effects_table()
    if eff.empty and diag.session_events:
        parts = [
            "<p>No effect added: no candidate cut the held-out error by the required margin; "
            "the base model's terms are refitted beside the session events, which change "
            "their values.</p>"
        ]
    elif eff.empty:
        parts = [
            "<p>No effect added: no candidate cut the held-out error by the required margin; "
            "the base model is kept.</p>"
        ]
    else:
        rows = []
        for r in eff.to_dict(orient="records"):
            v, e = value_se_text(r["value"], r["se"])
            rows.append({**r, "value ± se": f"{v} ± {e}" if e else v})
        parts = [
            "<p>One row per parameter an effect added, per axis: its value ± standard error "
            "as fitted at the step that added it.</p>",
            table(
                ["step", "effect", "axis", "variant", "parameter", "value ± se", "unit"],
                rows,
                numeric=["step", "value ± se"],
                cls="effects",
            ),
        ]
    held = diag.heldout_by_axis()
    parts += [
        "<h3>Held-out error per axis (RMS, mg)</h3>",
        f"<p>On the {escape(diag.scheme)} folds"
        + (", of the output less the session events" if diag.session_events else "")
        + "; pooled is the RMS over the three axes.</p>",
        table(
            ["axis", "base_mg", "diagnosed_mg", "ratio", "cut_pct"],
            [
                {
                    "axis": r["axis"],
                    "base_mg": f"{r['base_mg']:.3f}",
                    "diagnosed_mg": f"{r['diagnosed_mg']:.3f}",
                    "ratio": f"{r['ratio']:.3f}",
                    "cut_pct": f"{r['cut_pct']:.1f}",
                }
                for r in held.to_dict(orient="records")
            ],
            numeric=["base_mg", "diagnosed_mg", "ratio", "cut_pct"],
            rename={
                "base_mg": "base",
                "diagnosed_mg": "diagnosed",
                "ratio": "diagnosed / base",
                "cut_pct": "cut %",
            },
            cls="heldout",
        ),
        "<h3>Unexplained</h3>",
    ]
    un = diag.unexplained
    if not un:
        parts.append("<p>None: no structure left in the residual against any observable.</p>")
    else:
        items = [
            f"axis {s.axis} vs {s.observable}: {s.structure_rms_mg:.3f} mg rms "
            f"(noise {s.noise_mg:.3f} mg, chi2 {s.chi2:.0f}/{s.dof}, p {s.p_value:.1e})"
            + (f"; {s.note}" if s.note else "")
            for s in un
        ]
        parts.append(
            "<p>Structure the added effects do not explain, strongest first:</p><ul>"
            + "".join(f"<li>{escape(i)}</li>" for i in items)
            + "</ul>"
        )
    return "\n".join(parts)


def _notes_section(cal: Calibration, diag: Diagnosis | None) -> str:
    items: list[str] = []
    if cal.not_identified:
        items.append(f"Not identified (held at nominal or 0): {', '.join(cal.not_identified)}")
    items += [f"Note: {n}" for n in cal.notes]
    if diag is not None:
        items += [f"Diagnosis warning: {w}" for w in diag.warnings]
        for s in diag.unexplained:
            items.append(
                f"Unexplained structure: axis {s.axis} vs {s.observable}: "
                f"{s.structure_rms_mg:.3f} mg rms (noise {s.noise_mg:.3f} mg, p {s.p_value:.1e})"
                + (f"; {s.note}" if s.note else "")
            )
    if not items:
        return "<p>Everything was identified; no notes.</p>"
    return "<ul>" + "".join(f"<li>{escape(i)}</li>" for i in items) + "</ul>"


def _provenance_section(session: Session, cal: Calibration) -> str:
    prov = cal.provenance
    algorithm, hashes = cal.file_digests()
    rows = [{"file": k, algorithm: v} for k, v in sorted(hashes.items())]
    opts = ", ".join(f"{k}={v}" for k, v in sorted(cal.options.items()))
    lines = [
        f"<p>accelcore {escape(__version__)} (calibration written by "
        f"{escape(prov.get('accelcore_version', 'unknown'))}); method {escape(cal.method)}; "
        f"options: <code>{escape(opts)}</code></p>",
        f"<p>Session folder: <code>{escape(session.path or 'in memory')}</code></p>",
    ]
    if rows:
        lines.append(table(["file", algorithm], rows))
    else:
        lines.append(note("No input file hashes (the session was built in memory)."))
    return "\n".join(lines)


def session_report(
    session: Session | str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    calibration: Calibration | None = None,
    diagnosis: Diagnosis | None = None,
) -> Path:
    """Write a self-contained HTML report of one session to ``out_dir/index.html``.

    Parameters
    ----------
    session : Session or path
        A loaded session, or its folder (read with :func:`accelcore.load_session`).
    out_dir : path
        Folder to write ``index.html`` into (created).
    calibration : Calibration, optional
        The model reported; default ``diagnosis.base`` when a diagnosis is
        given, else :func:`accelcore.calibrate` of the session (joint fit).
    diagnosis : Diagnosis, optional
        Default :func:`accelcore.diagnose` of the session and ``calibration``.

    Returns
    -------
    pathlib.Path
        The page written.

    Raises
    ------
    accelcore.AccelcoreError, OSError
        The session cannot be read or calibrated. Problems with a single
        figure or table become a note on the page instead.
    ImportError
        matplotlib is not installed.
    """
    new_figure(1, 1)  # fail early, with the install hint, when matplotlib is missing
    sess = session if isinstance(session, Session) else load_session(Path(session))
    if calibration is None:
        calibration = diagnosis.base if diagnosis is not None else calibrate(sess)
    if diagnosis is None:
        diagnosis = diagnose(sess, calibration)
    cal = calibration
    name = Path(sess.path).name if sess.path else "in-memory session"
    title = f"{sess.sensor or 'unnamed sensor'}" + (f" #{sess.serial}" if sess.serial else "")
    lo, hi = cal.temperature_range_c
    runs = ", ".join(f"{r.label} ({r.orientation})" for r in sess.runs)
    diag = diagnosis
    lead = (
        f'<p class="muted">Sensor {escape(sess.sensor or "not named")}, serial '
        f"{escape(sess.serial or 'not given')}, units {escape(sess.units)}, "
        f"{escape(f'{sess.rate_hz:g}')} Hz; runs: {escape(runs)}; fitted over "
        f"{escape(f'{lo:.1f}')}…{escape(f'{hi:.1f}')} °C ({escape(cal.method)} fit).</p>"
    )
    sections = [
        '<section id="summary"><h2>Calibration summary</h2>',
        guarded("Summary", lambda: _summary_table(cal)),
        "</section>",
        '<section id="lab"><h2>Lab record</h2>',
        _lab_section(sess, cal),
        "</section>",
        '<section id="datasheet"><h2>Datasheet comparison</h2>',
        guarded("Datasheet comparison", lambda: _datasheet_tables(cal)),
        "</section>",
        '<section id="figures"><h2>Figures 4, 6 and 7</h2>',
        guarded("Figure 4", lambda: _figure4(sess, cal)),
        guarded("Figure 6", lambda: _paired_figure(sess, cal, "gain")),
        guarded("Figure 7", lambda: _paired_figure(sess, cal, "offset")),
        "</section>",
        '<section id="effects"><h2>Added effects</h2>',
        guarded("Added effects", lambda: _effects_section(diag)),
        "</section>",
        '<section id="diagnosis"><h2>Diagnosis</h2>',
        guarded("Diagnosis table", lambda: _diagnosis_section(diag)),
        guarded("Residual plots", lambda: _residual_figure(diag)),
        "</section>",
        '<section id="notes"><h2>Notes and not identified</h2>',
        _notes_section(cal, diag),
        "</section>",
        '<section id="provenance"><h2>Provenance</h2>',
        _provenance_section(sess, cal),
        "</section>",
    ]
    return write_page(
        out_dir,
        page(
            f"accelcore report: {title}, {name}",
            sections,
            heading=f"{title} — session {name}",
            lead=lead,
            nav=_NAV,
        ),
    )


#: The navigation bar: section id and link text.
_NAV = (
    ("summary", "Summary"),
    ("lab", "Lab record"),
    ("datasheet", "Datasheet"),
    ("figures", "Figures 4, 6, 7"),
    ("effects", "Added effects"),
    ("diagnosis", "Diagnosis"),
    ("notes", "Notes"),
    ("provenance", "Provenance"),
)
