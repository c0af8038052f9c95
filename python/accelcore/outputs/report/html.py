"""The pieces of a self-contained HTML page: escaping, tables, embedded figures, the page.

Part of the outputs room (imports the foundation only; matplotlib, the
``[plot]`` extra, is imported when a figure is made).
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from accelcore._accelcore import __version__
from accelcore.errors import AccelcoreError
from accelcore.files import atomic_write

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "CSS",
    "NOT_IDENTIFIED",
    "escape",
    "figure_html",
    "guarded",
    "header",
    "new_figure",
    "note",
    "number",
    "page",
    "set_margins",
    "spec_class",
    "table",
    "write_page",
    "written_at",
]

CSS = """
body { font-family: sans-serif; margin: 0 auto; padding: 0.5em 1.5em 1.5em; max-width: 1200px;
  color: #222; line-height: 1.35; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; }
h2 { border-bottom: 1px solid #ccc; margin-top: 1.6em; }
header .stamp, footer { color: #666; font-size: 0.9em; }
nav { font-size: 0.9em; margin: 0.6em 0; padding: 0.3em 0; border-bottom: 1px solid #eee; }
nav a { margin-right: 1em; color: #1a5490; text-decoration: none; white-space: nowrap; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.85em; max-width: 100%; }
th, td { border: 1px solid #ccc; padding: 2px 6px; vertical-align: top; }
th { background: #f2f2f2; text-align: left; font-weight: 600; }
th.num { text-align: right; }
td { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
td.text { text-align: left; white-space: normal; overflow-wrap: break-word; }
td.wide { min-width: 12em; overflow-wrap: anywhere; }
table.kv td.text, table.lab td.text { overflow-wrap: anywhere; }
td .se { display: block; color: #666; font-size: 0.85em; }
td.ok { background: #dff0d8; } td.out { background: #f8d0d0; font-weight: bold; }
td.ni { color: #777; font-style: italic; }
table.kv th { width: 11em; }
figure { margin: 0.8em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 0.9em; color: #555; }
.scroll { overflow-x: auto; } .note { color: #8a5a00; } .muted { color: #777; }
code, pre { font-size: 0.85em; overflow-wrap: anywhere; }
pre { background: #f7f7f7; padding: 0.5em; white-space: pre-wrap; }
@media print {
  @page { size: A4; margin: 12mm; }
  body { max-width: none; margin: 0; padding: 0; font-size: 10pt; }
  nav { display: none; }
  .scroll { overflow: visible; }
  table { font-size: 8pt; } th, td { padding: 1px 3px; }
  h2, h3 { break-after: avoid; page-break-after: avoid; }
  table, figure, tr, ul { break-inside: avoid; page-break-inside: avoid; }
  thead { display: table-header-group; }
  figure img { border: none; }
  td.ok, td.out { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
}
"""


def escape(value: object) -> str:
    """HTML-escape ``str(value)``, quotes included."""
    return html.escape(str(value), quote=True)


def number(value: Any, digits: int = 5) -> str:
    """Format a number with ``digits`` significant digits (empty for None and NaN)."""
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


def spec_class(value: Any) -> str:
    """CSS class of an in-spec flag: ``ok`` for true, ``out`` for false, else empty."""
    text = str(value).strip().lower()
    return {"true": "ok", "false": "out"}.get(text, "")


def header(name: str) -> str:
    """Return a column's plain header: ``snake_case`` names become words."""
    return name.replace("_", " ").strip()


#: Key of a row holding the value columns that are not identified (shown greyed,
#: "not identified" instead of their standard error).
NOT_IDENTIFIED = "__not_identified__"


def table(
    columns: Sequence[str],
    rows: Iterable[Mapping[Any, Any]],
    *,
    numeric: Sequence[str] = (),
    spec: Sequence[str] = (),
    rename: Mapping[str, str] | None = None,
    cls: str = "",
    se: Mapping[str, str] | None = None,
    flags: Mapping[str, str] | None = None,
    wide: Sequence[str] = (),
) -> str:
    """Render rows as an HTML table with plain headers; text is escaped and wraps.

    Parameters
    ----------
    columns : sequence of str
        Keys of the rows, in order.
    rows : iterable of mapping
        One per table row.
    numeric : sequence of str
        Columns formatted as numbers (right-aligned, never wrapped).
    spec : sequence of str
        In-spec flag columns, shown as yes / NO on green / red.
    rename : mapping, optional
        Header of a column; default its name with underscores as spaces.
    cls : str
        CSS class of the table.
    se : mapping, optional
        Value column -> its standard-error column, shown under the value.
    flags : mapping, optional
        Column -> an in-spec flag column colouring its cell (green / red).
    wide : sequence of str
        Text columns given a minimum width (long notes, reasons).

    Returns
    -------
    str
        The table in a horizontally scrollable box (a last resort: the styles
        make tables fit the page).
    """
    rename = rename or {}
    se = se or {}
    flags = flags or {}
    head = "".join(
        ('<th class="num">' if c in numeric else "<th>")
        + f"{escape(rename.get(c) or header(c))}</th>"
        for c in columns
    )
    body = []
    for row in rows:
        held = row.get(NOT_IDENTIFIED, ())
        cells = []
        for c in columns:
            v = row.get(c)
            if c in spec:
                label = {"ok": "yes", "out": "NO"}.get(spec_class(v), "–")
                cells.append(f'<td class="{spec_class(v) or "text"}">{escape(label)}</td>')
            elif c in numeric:
                klass = spec_class(row.get(flags[c])) if c in flags else ""
                extra = ""
                if c in held:
                    klass, extra = "ni", '<span class="se">not identified</span>'
                elif c in se and number(row.get(se[c]), 2):
                    extra = f'<span class="se">± {escape(number(row.get(se[c]), 2))}</span>'
                attr = f' class="{klass}"' if klass else ""
                cells.append(f"<td{attr}>{escape(number(v))}{extra}</td>")
            else:
                text = "" if v is None or (isinstance(v, float) and math.isnan(v)) else v
                klass = "text wide" if c in wide else "text"
                if c in flags and spec_class(row.get(flags[c])):
                    klass += " " + spec_class(row.get(flags[c]))
                cells.append(f'<td class="{klass}">{escape(text)}</td>')
        body.append(f"<tr>{''.join(cells)}</tr>")
    klass = f' class="{escape(cls)}"' if cls else ""
    return (
        f'<div class="scroll"><table{klass}><thead><tr>{head}</tr></thead>'
        f"<tbody>{''.join(body)}</tbody></table></div>"
    )


def figure_html(fig: Figure, caption: str, alt: str) -> str:
    """Embed a figure as a PNG ``data:`` URI with its caption."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return (
        f'<figure><img src="data:image/png;base64,{data}" alt="{escape(alt)}">'
        f"<figcaption>{escape(caption)}</figcaption></figure>"
    )


def note(text: str) -> str:
    """Return a highlighted paragraph (escaped)."""
    return f'<p class="note">{escape(text)}</p>'


def written_at() -> str:
    """When the page is written: UTC now, or ``SOURCE_DATE_EPOCH`` when set (reproducible)."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    when = datetime.fromtimestamp(int(epoch), tz=UTC) if epoch.isdigit() else datetime.now(tz=UTC)
    return when.strftime("%Y-%m-%d %H:%M UTC")


def page(
    title: str,
    sections: Sequence[str],
    *,
    heading: str,
    lead: str = "",
    nav: Sequence[tuple[str, str]] = (),
) -> str:
    """Return the page: header (heading, date and version, ``lead``), a nav, sections, footer.

    Parameters
    ----------
    title : str
        The document title.
    sections : sequence of str
        HTML of the body, in order.
    heading : str
        The ``<h1>`` text (escaped here).
    lead : str
        HTML under the heading (already escaped).
    nav : sequence of (str, str)
        Section id and link text of each entry of the navigation bar (hidden in print).

    Returns
    -------
    str
        The whole document.
    """
    when = written_at()
    stamp = f"Report written {when} by accelcore {__version__}"
    links = "".join(f'<a href="#{escape(i)}">{escape(label)}</a>' for i, label in nav)
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f'<meta name="generator" content="accelcore {escape(__version__)}">'
        f"<title>{escape(title)}</title><style>{CSS}</style></head>\n<body>\n"
        f'<header><h1>{escape(heading)}</h1><p class="stamp">{escape(stamp)}.</p>{lead}</header>\n'
        + (f"<nav>{links}</nav>\n" if links else "")
        + "\n".join(sections)
        + f'\n<footer class="muted"><p>{escape(stamp)}.</p></footer>'
        "\n</body></html>\n"
    )


def write_page(out_dir: str | os.PathLike[str], text: str) -> Path:
    """Write ``out_dir/index.html`` atomically (the folder is created); return its path."""
    target = Path(out_dir) / "index.html"
    atomic_write(target, text)
    return target


def new_figure(
    width: float,
    height: float,
    *,
    left: float = 0.95,
    right: float = 0.15,
    bottom: float = 0.55,
    top: float = 0.35,
    wspace: float = 1.05,
    hspace: float = 0.45,
    columns: int = 1,
    rows: int = 1,
) -> Figure:
    """Return a matplotlib figure with fixed margins; ImportError with the install hint without it.

    Parameters
    ----------
    width, height : float
        Size in inches.
    left, right, bottom, top : float
        Margins in inches (room for tick labels, axis labels and titles).
    wspace, hspace : float
        Space between panels in inches.
    columns, rows : int
        The grid of panels the figure will hold.

    Returns
    -------
    matplotlib.figure.Figure
        Laid out by fixed margins, not by a layout engine: a layout engine
        draws every figure twice and would double the report's rendering time.
    """
    try:
        from matplotlib.figure import Figure  # optional: the [plot] extra
    except ImportError as exc:
        raise ImportError(
            "accelcore's reports need matplotlib, an optional extra: pip install accelcore[plot]"
        ) from exc
    fig = Figure(figsize=(width, height))
    set_margins(
        fig,
        left=left,
        right=right,
        bottom=bottom,
        top=top,
        wspace=wspace,
        hspace=hspace,
        columns=columns,
        rows=rows,
    )
    return fig


def set_margins(
    fig: Figure,
    *,
    left: float,
    right: float,
    bottom: float,
    top: float,
    wspace: float,
    hspace: float,
    columns: int = 3,
    rows: int = 1,
) -> None:
    """Set a figure's margins and the space between panels, all in inches.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    left, right, bottom, top, wspace, hspace : float
        Inches.
    columns, rows : int
        The panel grid the spaces are for (matplotlib takes them as a fraction
        of the mean panel size).
    """
    w, h = fig.get_size_inches()
    if left + right >= w or bottom + top >= h:
        return  # too small for these margins: keep matplotlib's defaults
    panel_w = max((w - left - right - wspace * (columns - 1)) / columns, 0.1)
    panel_h = max((h - bottom - top - hspace * (rows - 1)) / rows, 0.1)
    fig.subplots_adjust(
        left=left / w,
        right=1.0 - right / w,
        bottom=bottom / h,
        top=1.0 - top / h,
        wspace=wspace / panel_w,
        hspace=hspace / panel_h,
    )


def guarded(label: str, draw: Callable[[], str]) -> str:
    """Run one section's drawing; a data problem becomes a note instead of failing the page."""
    try:
        return draw()
    except (AccelcoreError, ValueError, KeyError) as exc:
        return note(f"{label} not available: {' '.join(str(exc).split())}")
