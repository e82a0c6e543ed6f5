"""The pages of batch reports, sweeps and traversability studies: one look, built from a few pieces.

A page is :func:`page_head`, the study's own content and :data:`PAGE_END`:
self-contained HTML with inline CSS, no scripts and no external resources, so
it opens from a folder, over HTTP, or alone as one file. Every value goes
through :func:`escape`. Figures (:func:`figure`) link to their PNG, which
opens at full size, and can be embedded in the page (``inline``) so the page
is one file to share. Tables (:func:`table`) take their headers in words with
units from the option registry (:func:`bhr._settings.names.column_title`).
"""
from __future__ import annotations

import base64
import html
from pathlib import Path
from typing import Any, Callable, Sequence

from bhr._settings.names import column_title

__all__ = ["CSS", "page_head", "PAGE_END", "escape", "fmt", "image_src", "figure", "table"]

CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:0;color:#1d2327;
background:#fafafa}
main{max-width:1200px;margin:0 auto;padding:1.2rem 1.5rem 3rem}
h1{font-size:1.6rem;margin:.2rem 0 .4rem} h2{font-size:1.3rem;margin:2.2rem 0 .4rem;padding-top:.6rem;
border-top:2px solid #ccd} h3{font-size:1rem;margin:1rem 0 .3rem}
p.meta{color:#555;margin:.2rem 0 1rem}
table{border-collapse:collapse;margin:.4rem 0 1rem;font-size:.9rem;background:#fff}
th,td{border:1px solid #ccd;padding:.25rem .55rem;text-align:right;white-space:nowrap}
th{background:#eef0f4;text-align:center;white-space:normal;vertical-align:bottom}
.scroll{overflow-x:auto} td.l,th.l{text-align:left}
tr.failed td{background:#fdecea} td.ok{color:#1a7f37;font-weight:600} td.bad{color:#b42318;font-weight:600;
white-space:normal;text-align:left}
.figs{display:grid;grid-template-columns:repeat(auto-fill,minmax(520px,1fr));gap:1rem}
figure{margin:0;background:#fff;border:1px solid #dde;padding:.4rem}
figure img{width:100%;height:auto;display:block;cursor:zoom-in}
th.rank,td.rank{background:#fff6d5;font-weight:600}
figcaption{font-size:.85rem;color:#444;margin-top:.3rem}
.warn{color:#8a5a00} .reason{color:#b42318;font-weight:600} dl{display:grid;grid-template-columns:max-content auto;
gap:.1rem .8rem;font-size:.9rem} dt{color:#555} dd{margin:0}
details{margin:.5rem 0} pre{background:#f3f3f3;padding:.5rem;overflow:auto;font-size:.8rem}
"""

PAGE_END = "</main>\n</body>\n</html>\n"


def escape(value: Any) -> str:
    """``value`` as text safe inside HTML elements and quoted attributes."""
    return html.escape(str(value), quote=True)


def fmt(value: Any, digits: int = 3) -> str:
    """A table cell's text: ``-`` for unknown, floats to ``digits`` decimals."""
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def page_head(title: str) -> str:
    """The opening of a self-contained page (inline CSS, no scripts, no external resources)."""
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            "<link rel=\"icon\" href=\"data:,\">\n"
            f"<title>{escape(title)}</title>\n<style>{CSS}</style>\n</head>\n<body>\n<main>\n")


def image_src(folder: Path, rel: str, inline: bool) -> str:
    """The ``src`` of the PNG ``rel`` (relative to the page's ``folder``): its path, or its bytes when ``inline``."""
    if not inline:
        return escape(rel)
    data = base64.b64encode((Path(folder) / rel).read_bytes()).decode("ascii")
    return f"data:image/png;base64,{data}"


def figure(rel: str, alt: str, caption_html: str, *, folder: Path | None = None, inline: bool = False,
           style: str = "") -> str:
    """A figure that opens its PNG at full size when clicked (the page shows it shrunk to its column).

    ``caption_html`` is already escaped; a "full size" link follows it. ``inline`` embeds the image
    (``folder`` is where the page is); the links still point at the PNG beside the page.
    """
    src = image_src(folder or Path("."), rel, inline)
    attr = f" style=\"{escape(style)}\"" if style else ""
    return (f"<figure{attr}><a href=\"{escape(rel)}\" title=\"open at full size\"><img src=\"{src}\" "
            f"alt=\"{escape(alt)}\"></a><figcaption>{caption_html}; <a href=\"{escape(rel)}\">full size</a>"
            "</figcaption></figure>\n")


def _cls(c: str) -> str:
    return f" class=\"{c}\"" if c else ""


def table(table_id: str, columns: Sequence[str], rows: Sequence[Any],
          cell: Callable[[Any, str], tuple[str, str]], *, heads: dict[str, str] | None = None,
          head_class: Callable[[str], str] | None = None, row_class: Callable[[Any], str] | None = None) -> str:
    """A table, scrolling sideways when wide: one column per key, one row per item.

    Headers are :func:`bhr._settings.names.column_title` of each key unless ``heads``
    names it; ``cell(row, key)`` gives a cell's HTML (escaped) and CSS class;
    ``head_class(key)`` and ``row_class(row)`` the classes of headers and rows.
    """
    out = [f"<div class=\"scroll\"><table id=\"{escape(table_id)}\">\n<thead><tr>"]
    for c in columns:
        title = (heads or {}).get(c) or column_title(c)
        out.append(f"<th{_cls(head_class(c) if head_class else '')}>{escape(title)}</th>")
    out.append("</tr></thead>\n<tbody>\n")
    for r in rows:
        out.append(f"<tr{_cls(row_class(r) if row_class else '')}>")
        for c in columns:
            text, cls = cell(r, c)
            out.append(f"<td{_cls(cls)}>{text}</td>")
        out.append("</tr>\n")
    out.append("</tbody>\n</table></div>\n")
    return "".join(out)
