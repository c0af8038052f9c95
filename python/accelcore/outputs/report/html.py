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
from pathlib import Path
from typing import TYPE_CHECKING, Any

from accelcore._accelcore import __version__
from accelcore.errors import AccelcoreError
from accelcore.files import atomic_write

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "CSS",
    "escape",
    "figure_html",
    "guarded",
    "new_figure",
    "note",
    "number",
    "page",
    "spec_class",
    "table",
    "write_page",
]

CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; }
h1 { font-size: 1.5em; } h2 { border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: right; }
th { background: #f2f2f2; } td.text { text-align: left; }
td.ok { background: #dff0d8; } td.out { background: #f8d0d0; font-weight: bold; }
figure { margin: 0.8em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: 0.9em; color: #555; }
td.text { overflow-wrap: break-word; }
table.effects td.text, table.diagnosis td.text { max-width: 22em; }
.scroll { overflow-x: auto; } .note { color: #8a5a00; } .muted { color: #777; }
code, pre { font-size: 0.85em; } pre { background: #f7f7f7; padding: 0.5em; overflow-x: auto; }
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


def table(
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
    head = "".join(f"<th>{escape(rename.get(c, c))}</th>" for c in columns)
    body = []
    for row in rows:
        cells = []
        for c in columns:
            v = row.get(c)
            if c in spec:
                label = {"ok": "yes", "out": "NO"}.get(spec_class(v), "–")
                cells.append(f'<td class="{spec_class(v) or "text"}">{escape(label)}</td>')
            elif c in numeric:
                cells.append(f"<td>{escape(number(v))}</td>")
            else:
                text = "" if v is None or (isinstance(v, float) and math.isnan(v)) else v
                cells.append(f'<td class="text">{escape(text)}</td>')
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


def page(title: str, sections: Sequence[str]) -> str:
    """Return the page: head with the inline style, the sections, a footer naming the version."""
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{escape(title)}</title><style>{CSS}</style></head>\n<body>\n"
        + "\n".join(sections)
        + f'\n<footer class="muted"><p>Written by accelcore {escape(__version__)}.</p></footer>'
        "\n</body></html>\n"
    )


def write_page(out_dir: str | os.PathLike[str], text: str) -> Path:
    """Write ``out_dir/index.html`` atomically (the folder is created); return its path."""
    target = Path(out_dir) / "index.html"
    atomic_write(target, text)
    return target


def new_figure(width: float, height: float) -> Figure:
    """Return a matplotlib figure (inches); ImportError with the install hint without it."""
    try:
        from matplotlib.figure import Figure  # optional: the [plot] extra
    except ImportError as exc:
        raise ImportError(
            "accelcore's reports need matplotlib, an optional extra: pip install accelcore[plot]"
        ) from exc
    return Figure(figsize=(width, height), layout="constrained")


def guarded(label: str, draw: Callable[[], str]) -> str:
    """Run one section's drawing; a data problem becomes a note instead of failing the page."""
    try:
        return draw()
    except (AccelcoreError, ValueError, KeyError) as exc:
        return note(f"{label} not available: {' '.join(str(exc).split())}")
