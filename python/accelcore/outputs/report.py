"""Self-contained HTML reports: one session, or a whole bulk output (a fleet).

:func:`session_report` writes ``OUT/index.html`` for one session: the
datasheet comparison (the seed paper's Tables 3/4 and 5/6, out-of-spec values
highlighted), the paper's Figures 4, 6 and 7 for this part, the diagnosis
table with residual plots before and after, the notes and what the data could
not identify, and provenance (accelcore version, SHA-256 of every input file).

:func:`fleet_report` writes ``index.html`` for a folder written by
:func:`accelcore.apps.bulk.bulk` (recognised by its ``fleet.csv``): per sensor type
and temperature coefficient, the distribution across parts per axis against
the datasheet limits, then the fleet table and the failures.

Pages are single files: figures are PNG embedded as ``data:`` URIs, styles are
inline, there is no script and nothing is fetched. Every piece of text from
data (names, notes, reasons) is HTML-escaped. matplotlib (the ``[plot]``
extra) draws the figures; without it both functions raise :class:`ImportError`.
"""

from __future__ import annotations

import base64
import functools
import html
import io
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from accelcore._accelcore import __version__
from accelcore.constants import AXES
from accelcore.errors import AccelcoreError
from accelcore.input.session import Session

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from accelcore.diagnosis import Diagnosis
    from accelcore.result.calibration import Calibration

__all__ = ["FLEET_PARAMETERS", "fleet_report", "is_bulk_output", "session_report"]

#: Temperature coefficients plotted by :func:`fleet_report`: column, label, unit.
FLEET_PARAMETERS: tuple[tuple[str, str, str], ...] = (
    ("offset_tc_mg_per_c", "zero-g offset temperature coefficient", "mg/°C"),
    ("sensitivity_tc_pct_per_c", "sensitivity temperature coefficient", "%/°C"),
)

_CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; }
h1 { font-size: 1.5em; } h2 { border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
th { background: #f2f2f2; } td.text { text-align: left; }
td.ok { background: #dff0d8; } td.out { background: #f8d0d0; font-weight: bold; }
figure { margin: 0.8em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: 0.9em; color: #555; }
.scroll { overflow-x: auto; } .note { color: #8a5a00; } .muted { color: #777; }
code, pre { font-size: 0.85em; } pre { background: #f7f7f7; padding: 0.5em; overflow-x: auto; }
"""


# ---------------------------------------------------------------------- HTML pieces
def _e(value: object) -> str:
    return html.escape(str(value), quote=True)


def _num(value: Any, digits: int = 5) -> str:
    if value is None or isinstance(value, bool):
        return "" if value is None else str(value)
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    if math.isnan(v):
        return ""
    if v == 0 or 1e-3 <= abs(v) < 1e6:
        return f"{v:.{digits}g}"
    return f"{v:.{max(digits - 2, 1)}e}"


def _spec_class(value: Any) -> str:
    text = str(value).strip().lower()
    return {"true": "ok", "false": "out"}.get(text, "")


def _table(
    columns: Sequence[str],
    rows: Iterable[Mapping[Any, Any]],
    *,
    numeric: Sequence[str] = (),
    spec: Sequence[str] = (),
    rename: Mapping[str, str] | None = None,
    cls: str = "",
) -> str:
    """Render rows as an HTML table; ``spec`` columns get ok/out classes, text is escaped."""
    rename = rename or {}
    head = "".join(f"<th>{_e(rename.get(c, c))}</th>" for c in columns)
    body = []
    for row in rows:
        cells = []
        for c in columns:
            v = row.get(c)
            if c in spec:
                label = {"ok": "yes", "out": "NO"}.get(_spec_class(v), "–")
                cells.append(f'<td class="{_spec_class(v) or "text"}">{_e(label)}</td>')
            elif c in numeric:
                cells.append(f"<td>{_e(_num(v))}</td>")
            else:
                text = "" if v is None or (isinstance(v, float) and math.isnan(v)) else v
                cells.append(f'<td class="text">{_e(text)}</td>')
        body.append(f"<tr>{''.join(cells)}</tr>")
    klass = f' class="{_e(cls)}"' if cls else ""
    return (
        f'<div class="scroll"><table{klass}><thead><tr>{head}</tr></thead>'
        f"<tbody>{''.join(body)}</tbody></table></div>"
    )


def _figure_html(fig: Figure, caption: str, alt: str) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return (
        f'<figure><img src="data:image/png;base64,{data}" alt="{_e(alt)}">'
        f"<figcaption>{_e(caption)}</figcaption></figure>"
    )


def _note(text: str) -> str:
    return f'<p class="note">{_e(text)}</p>'


def _page(title: str, sections: Sequence[str]) -> str:
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{_e(title)}</title><style>{_CSS}</style></head>\n<body>\n"
        + "\n".join(sections)
        + f'\n<footer class="muted"><p>Written by accelcore {_e(__version__)}.</p></footer>'
        "\n</body></html>\n"
    )


def _write_page(out_dir: str | os.PathLike[str], text: str) -> Path:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    target = out / "index.html"
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()
    return target


def _new_figure(width: float, height: float) -> Figure:
    try:
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise ImportError(
            "accelcore's reports need matplotlib, an optional extra: pip install accelcore[plot]"
        ) from exc
    return Figure(figsize=(width, height), layout="constrained")


def _guarded(label: str, draw: Callable[[], str]) -> str:
    """Run one section's drawing; a data problem becomes a note instead of failing the page."""
    try:
        return draw()
    except (AccelcoreError, ValueError, KeyError) as exc:
        return _note(f"{label} not available: {' '.join(str(exc).split())}")


# ---------------------------------------------------------------------- session report
def _figure4(session: Session, cal: Calibration) -> str:
    from accelcore.outputs import plots

    picks: list[tuple[str, str]] = []
    orientations = set(session.orientations)
    for a in AXES:
        for sign in "+-":
            o = f"O{a.upper()}{sign}"
            if o in orientations:
                picks.append((o, a))
                break
    fig = _new_figure(4.6 * max(len(picks), 1), 4.0)
    if picks:
        axs = fig.subplots(1, len(picks), squeeze=False)[0]
        for ax, (o, a) in zip(axs, picks, strict=True):
            plots.plot_raw_vs_decimated(session, o, a, ax=ax, calibration=cal)
    else:
        plots.plot_raw_vs_decimated(session, ax=fig.subplots(), calibration=cal)
    return _figure_html(
        fig,
        "Figure 4: raw log, 2 Hz decimated blocks, temperature-bin means and the calibration, "
        "one run per axis (the axis gravity acts on).",
        "Figure 4: raw and decimated output against temperature",
    )


def _paired_figure(session: Session, cal: Calibration, kind: str) -> str:
    from accelcore.outputs import plots

    names = [a for a in AXES if a in cal.axes]
    fig = _new_figure(4.2 * max(len(names), 1), 3.8)
    axs = list(fig.subplots(1, max(len(names), 1), squeeze=False)[0])
    if kind == "gain":
        plots.plot_sensitivity_vs_temperature(session, cal, ax=axs, sensor_axes=names)
        caption = "Figure 6: sensitivity (V+ − V−)/2 per temperature bin and the fitted line."
        alt = "Figure 6: sensitivity against temperature"
    else:
        plots.plot_offset_vs_temperature(session, cal, ax=axs, sensor_axes=names)
        caption = "Figure 7: zero-g offset (V+ + V−)/2 per temperature bin and the fitted line."
        alt = "Figure 7: zero-g offset against temperature"
    return _figure_html(fig, caption, alt)


def _residual_figure(diag: Diagnosis) -> str:
    import matplotlib.pyplot as plt

    fig = diag.plot()
    try:
        obs = diag._default_observable()
        return _figure_html(
            fig,
            "Residual error (mg) of the base model (left) and the diagnosed model (right), "
            f"against temperature (top) and {obs} (bottom).",
            "Residual plots before and after the diagnosis",
        )
    finally:
        plt.close(fig)


def _datasheet_tables(cal: Calibration) -> str:
    from accelcore import datasheets

    if not cal.sensor:
        return _note("No datasheet comparison: the session names no sensor.")
    try:
        df = cal.compare_datasheet().reset_index()
    except (datasheets.DatasheetError, KeyError, AccelcoreError) as exc:
        return _note(f"No datasheet comparison: {exc}")
    parts = [
        f"<p>Measured at T_ref = {_e(f'{cal.t_ref_c:g}')} °C against the {_e(cal.sensor)} "
        "datasheet (layout of the paper's Tables 3/4 and 5/6). "
        '<span class="muted">Highlighted: in spec (green), out of spec (red); '
        "– where the datasheet gives no limit or the value is not identified.</span></p>"
    ]
    titles = {
        "at T_ref": "Offset and sensitivity at T_ref (Tables 3/4)",
        "temperature coefficients": "Temperature coefficients (Tables 5/6)",
    }
    for table, part in df.groupby("table", sort=False):
        parts.append(f"<h3>{_e(titles.get(str(table), str(table)))}</h3>")
        parts.append(
            _table(
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
                part.to_dict(orient="records"),
                numeric=["min", "typ", "max", "measured", "measured_se"],
                spec=["in_spec"],
                rename={"measured_se": "± se", "in_spec": "in spec"},
                cls="datasheet",
            )
        )
    return "\n".join(parts)


def _summary_table(cal: Calibration) -> str:
    df = cal.summary().reset_index()
    cols = [str(c) for c in df.columns]
    return _table(cols, df.to_dict(orient="records"), numeric=cols[1:])


def _diagnosis_section(diag: Diagnosis) -> str:
    rep = diag.report()
    cols = [
        "step",
        "effect",
        "axes",
        "variant",
        "parameters",
        "rms_in_after_mg",
        "rms_out_before_mg",
        "rms_out_after_mg",
        "max_out_after_mg",
        "cut_pct",
    ] + [f"rms_out_{a}_after_mg" for a in AXES]
    cols = [c for c in cols if c in rep.columns]
    numeric = [c for c in cols if c.endswith("_mg") or c == "cut_pct"]
    effects = ", ".join(diag.effects) or "none"
    head = (
        f"<p>Effects added: <b>{_e(effects)}</b>. Held-out folds: {_e(diag.scheme)} "
        f"({_e(', '.join(diag.folds))}). Errors in mg, all axes pooled unless named; "
        "step 0 is the base model.</p>"
    )
    return head + _table(cols, rep.to_dict(orient="records"), numeric=numeric, cls="diagnosis")


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
    return "<ul>" + "".join(f"<li>{_e(i)}</li>" for i in items) + "</ul>"


def _provenance_section(session: Session, cal: Calibration) -> str:
    prov = cal.provenance
    hashes = prov.get("files_sha256") or {}
    rows = [{"file": k, "sha256": v} for k, v in sorted(hashes.items())]
    opts = ", ".join(f"{k}={v}" for k, v in sorted(cal.options.items()))
    lines = [
        f"<p>accelcore {_e(__version__)} (calibration written by "
        f"{_e(prov.get('accelcore_version', 'unknown'))}); method {_e(cal.method)}; "
        f"options: <code>{_e(opts)}</code></p>",
        f"<p>Session folder: <code>{_e(session.path or 'in memory')}</code></p>",
    ]
    if rows:
        lines.append(_table(["file", "sha256"], rows))
    else:
        lines.append(_note("No input file hashes (the session was built in memory)."))
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
    import accelcore
    from accelcore.diagnosis import diagnose

    _new_figure(1, 1)  # fail early, with the install hint, when matplotlib is missing
    sess = session if isinstance(session, Session) else accelcore.load_session(Path(session))
    if calibration is None:
        calibration = diagnosis.base if diagnosis is not None else accelcore.calibrate(sess)
    if diagnosis is None:
        diagnosis = diagnose(sess, calibration)
    cal = calibration
    name = Path(sess.path).name if sess.path else "in-memory session"
    title = f"{sess.sensor or 'unnamed sensor'}" + (f" #{sess.serial}" if sess.serial else "")
    lo, hi = cal.temperature_range_c
    runs = ", ".join(f"{r.label} ({r.orientation})" for r in sess.runs)
    diag = diagnosis
    sections = [
        f"<h1>{_e(title)} — session {_e(name)}</h1>",
        f'<p class="muted">Sensor {_e(sess.sensor or "not named")}, serial '
        f"{_e(sess.serial or 'not given')}, units {_e(sess.units)}, "
        f"{_e(f'{sess.rate_hz:g}')} Hz; runs: {_e(runs)}; fitted over "
        f"{_e(f'{lo:.1f}')}…{_e(f'{hi:.1f}')} °C ({_e(cal.method)} fit).</p>",
        '<section id="summary"><h2>Calibration summary</h2>',
        _guarded("Summary", lambda: _summary_table(cal)),
        "</section>",
        '<section id="datasheet"><h2>Datasheet comparison</h2>',
        _guarded("Datasheet comparison", lambda: _datasheet_tables(cal)),
        "</section>",
        '<section id="figures"><h2>Figures 4, 6 and 7</h2>',
        _guarded("Figure 4", lambda: _figure4(sess, cal)),
        _guarded("Figure 6", lambda: _paired_figure(sess, cal, "gain")),
        _guarded("Figure 7", lambda: _paired_figure(sess, cal, "offset")),
        "</section>",
        '<section id="diagnosis"><h2>Diagnosis</h2>',
        _guarded("Diagnosis table", lambda: _diagnosis_section(diag)),
        _guarded("Residual plots", lambda: _residual_figure(diag)),
        "</section>",
        '<section id="notes"><h2>Notes and not identified</h2>',
        _notes_section(cal, diag),
        "</section>",
        '<section id="provenance"><h2>Provenance</h2>',
        _provenance_section(sess, cal),
        "</section>",
    ]
    return _write_page(out_dir, _page(f"accelcore report: {title}, {name}", sections))


# ---------------------------------------------------------------------- fleet report
def is_bulk_output(path: str | os.PathLike[str]) -> bool:
    """Tell whether ``path`` is a folder written by ``accelcore bulk`` (has fleet.csv)."""
    return (Path(path) / "fleet.csv").is_file()


def _limits(sensor: str, parameter: str, axis: str) -> tuple[float | None, float | None] | None:
    from accelcore import datasheets

    try:
        lim = datasheets.load(sensor).limits(parameter, axis)
    except (KeyError, ValueError):
        return None
    return None if lim is None else (lim.min, lim.max)


def _distribution_figure(
    sensor: str, part: pd.DataFrame, column: str, label: str, unit: str
) -> str:
    from matplotlib.ticker import MaxNLocator

    fig = _new_figure(13.0, 3.4)
    axs = fig.subplots(1, len(AXES), squeeze=False)[0]
    rng = np.random.default_rng(0)  # fixed jitter: the page is reproducible
    for ax, a in zip(axs, AXES, strict=True):
        values = pd.to_numeric(part.loc[part["axis"] == a, column], errors="coerce").to_numpy(
            dtype=np.float64
        )
        values = values[np.isfinite(values)]
        lim = _limits(sensor, column, a)
        bounds = [v for v in (lim or (None, None)) if v is not None]
        if values.size:
            lo = min([float(values.min()), *bounds])
            hi = max([float(values.max()), *bounds])
            pad = 0.05 * (hi - lo) if hi > lo else max(abs(hi), 1e-6) * 0.1
            bins = np.linspace(lo - pad, hi + pad, 41)
            ax.hist(values, bins=bins, color="tab:blue", alpha=0.6, label=f"{values.size} parts")
            top = ax.get_ylim()[1]
            jitter = rng.uniform(0.05, 0.25, values.size) * top
            ax.plot(values, jitter, "o", ms=4, mfc="none", color="black", label="each part")
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))
            ax.set_xlim(lo - pad, hi + pad)
        else:
            ax.text(0.5, 0.5, "no values", transform=ax.transAxes, ha="center")
        if lim is not None:
            for k, v in enumerate(bounds):
                ax.axvline(
                    v, color="tab:red", ls="--", lw=1.2, label="datasheet limit" if k == 0 else None
                )
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.set_title(f"{sensor} {a.upper()}")
        ax.set_xlabel(f"{label} ({unit})")
        ax.set_ylabel("parts")
        ax.legend(loc="best", fontsize="small")
    lim_text = (
        "datasheet limits dashed red"
        if any(_limits(sensor, column, a) for a in AXES)
        else "the datasheet gives no limit"
    )
    return _figure_html(
        fig,
        f"{sensor}: {label} across parts per axis ({lim_text}).",
        f"{sensor} {label} distribution",
    )


def _read_csv(path: Path) -> pd.DataFrame:
    try:
        return pd.read_csv(path, dtype=str, keep_default_na=False)
    except pd.errors.EmptyDataError:
        return pd.DataFrame()


def fleet_report(
    bulk_out_dir: str | os.PathLike[str], out_dir: str | os.PathLike[str] | None = None
) -> Path:
    """Write a self-contained HTML report of a bulk output to ``out_dir/index.html``.

    Parameters
    ----------
    bulk_out_dir : path
        A folder written by :func:`accelcore.apps.bulk.bulk` (holding ``fleet.csv``;
        ``failures.csv`` is shown when present).
    out_dir : path, optional
        Where to write ``index.html``; default ``bulk_out_dir`` itself.

    Returns
    -------
    pathlib.Path
        The page written.

    Raises
    ------
    FileNotFoundError
        ``bulk_out_dir`` holds no ``fleet.csv``.
    ValueError
        ``fleet.csv`` lacks the columns of a fleet table.
    ImportError
        matplotlib is not installed.
    """
    from accelcore.apps.bulk import FLEET_COLUMNS

    src = Path(bulk_out_dir)
    fleet_csv = src / "fleet.csv"
    if not fleet_csv.is_file():
        raise FileNotFoundError(f"{src}: not a bulk output (no fleet.csv)")
    _new_figure(1, 1)
    fleet = _read_csv(fleet_csv)
    needed = ["session", "sensor", "axis"] + [c for c, _, _ in FLEET_PARAMETERS]
    missing = [c for c in needed if c not in fleet.columns]
    if missing:
        raise ValueError(f"{fleet_csv}: not a fleet table, missing column(s) {', '.join(missing)}")
    failures = _read_csv(src / "failures.csv") if (src / "failures.csv").is_file() else None
    n_sessions = fleet["session"].nunique()
    n_failed = 0 if failures is None or failures.empty else len(failures)
    sections = [
        f"<h1>Fleet report — {_e(src.resolve().name)}</h1>",
        f"<p>{n_sessions} session(s) calibrated, {len(fleet)} axis row(s), "
        f"{n_failed} failed session(s). Folder: <code>{_e(src.resolve())}</code></p>",
        '<section id="fleet-plots"><h2>Temperature coefficients across parts</h2>',
    ]
    sensors = sorted({s for s in fleet["sensor"] if s}) if len(fleet) else []
    if not sensors and len(fleet):
        sensors = [""]
    for sensor in sensors:
        part = fleet[fleet["sensor"] == sensor]
        shown = sensor or "unnamed sensor"
        for column, label, unit in FLEET_PARAMETERS:
            sections.append(
                _guarded(
                    f"{shown} {label} plot",
                    functools.partial(_distribution_figure, shown, part, column, label, unit),
                )
            )
    if not len(fleet):
        sections.append(_note("The fleet table is empty: no session was calibrated."))
    sections.append("</section>")
    # In/out of spec counts per sensor and parameter.
    spec_cols = [c for c in FLEET_COLUMNS if c.endswith("_in_spec") and c in fleet.columns]
    counts = []
    for sensor in sensors:
        part = fleet[fleet["sensor"] == sensor]
        for c in spec_cols:
            v = part[c].str.lower()
            counts.append(
                {
                    "sensor": sensor or "unnamed",
                    "parameter": c.removesuffix("_in_spec"),
                    "in spec": int((v == "true").sum()),
                    "out of spec": int((v == "false").sum()),
                    "no limit / n.i.": int(((v != "true") & (v != "false")).sum()),
                }
            )
    sections += [
        '<section id="spec-counts"><h2>In and out of datasheet spec (axis rows)</h2>',
        _table(["sensor", "parameter", "in spec", "out of spec", "no limit / n.i."], counts)
        if counts
        else _note("No rows."),
        "</section>",
        '<section id="fleet-table"><h2>Fleet table</h2>',
    ]
    cols = [str(c) for c in fleet.columns]
    numeric = [
        c
        for c in cols
        if c not in ("session", "serial", "sensor", "units", "axis", "not_identified", "effects")
        and c not in spec_cols
    ]
    sections += [
        _table(cols, fleet.to_dict(orient="records"), numeric=numeric, spec=spec_cols, cls="fleet"),
        "</section>",
        '<section id="failures"><h2>Failures</h2>',
    ]
    if failures is None:
        sections.append(_note("No failures.csv in this folder."))
    elif failures.empty:
        sections.append("<p>No session failed.</p>")
    else:
        sections.append(
            _table([str(c) for c in failures.columns], failures.to_dict(orient="records"))
        )
    sections += [
        "</section>",
        '<section id="provenance"><h2>Provenance</h2>',
        f"<p>accelcore {_e(__version__)}; read {_e(fleet_csv.name)} ({_e(_sha256(fleet_csv))})</p>",
        "</section>",
    ]
    target = Path(out_dir) if out_dir is not None else src
    return _write_page(target, _page(f"accelcore fleet report: {src.resolve().name}", sections))


def _sha256(path: Path) -> str:
    import hashlib

    return f"sha256 {hashlib.sha256(path.read_bytes()).hexdigest()}"
