"""The one HTML page builder the report, identify and diagnose pages use: a title,
paragraphs, lists, tables and figures, escaped, in one style."""
from __future__ import annotations

import html
import math
from pathlib import Path

STYLE = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto}img{max-width:100%}"
         "table{border-collapse:collapse}td,th{padding:2px 8px;text-align:right;border-bottom:1px solid #ddd}"
         "td:first-child,th:first-child{text-align:left}")


def number(v):
    """A value for a table: 4 significant digits, '-' for none or not finite."""
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.4g}"


def save(fig, path: Path):
    """Write a matplotlib figure as PNG, close it; its file name (for the page)."""
    import matplotlib.pyplot as plt
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name


class Page:
    """Parts appended in order, written as index.html. Text is escaped; `raw` is not.
    `blocks` keeps the same content as data ((kind, payload)) for the printable PDF
    (protocols/reports/pdf.py)."""

    def __init__(self, title: str):
        self.title = title
        self.blocks = []
        self.parts = [f"<!doctype html><meta charset='utf-8'><title>{html.escape(title)}</title>",
                      f"<style>{STYLE}</style>", f"<h1>{html.escape(title)}</h1>"]

    def heading(self, text):
        self.blocks.append(("heading", text))
        self.parts.append(f"<h2>{html.escape(text)}</h2>")

    def paragraph(self, text):
        self.blocks.append(("paragraph", text))
        self.parts.append(f"<p>{html.escape(text)}</p>")

    def raw(self, markup):
        self.parts.append(markup)

    def items(self, pairs):
        """A list of (bold label, text)."""
        pairs = list(pairs)
        self.blocks.append(("items", pairs))
        self.parts.append("<ul>" + "".join(f"<li><b>{html.escape(str(k))}</b>: {html.escape(str(v))}</li>"
                                           for k, v in pairs) + "</ul>")

    def table(self, header, rows):
        rows = [list(r) for r in rows]
        self.blocks.append(("table", (list(header), rows)))
        cells = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
        self.parts.append(f"<table><tr>{cells}</tr>{body}</table>")

    def figure(self, title, png):
        self.heading(title)
        self.blocks.append(("figure", png))
        self.parts.append(f"<img src='{html.escape(png)}' alt='{html.escape(title)}'>")

    def write(self, out_dir: Path) -> Path:
        index = Path(out_dir) / "index.html"
        index.write_text("\n".join(self.parts))
        return index
