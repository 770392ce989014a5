"""The one HTML page builder the report, identify and diagnose pages use: a title,
paragraphs, lists, tables and figures, escaped, in one style (templates/page.html)."""
from __future__ import annotations

import math
import os
import warnings
from functools import cache
from pathlib import Path

STYLE = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto}img{max-width:100%}"
         "table{border-collapse:collapse}td,th{padding:2px 8px;text-align:right;border-bottom:1px solid #ddd}"
         "td:first-child,th:first-child{text-align:left}")


# rows a printed table is kept on one page with: even at two lines a row (a wrapped segment
# name) it fits a landscape page under its heading; a longer one flows, its header repeated
SHORT_TABLE = 15


def number(v):
    """A value for a table: 4 significant digits, '-' for none or not finite."""
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.4g}"


@cache
def _captions() -> dict:
    import tomllib
    with open(Path(__file__).with_name("captions.toml"), "rb") as f:
        return tomllib.load(f)


def caption(png) -> str:
    """What the figure in png shows (captions.toml, by its name or, for a damper's own
    figures, by what follows the damper's name), "" for one without a caption."""
    name = Path(str(png)).name
    return next((c for key, c in _captions().items() if name == key or name.endswith("_" + key)), "")


class LayoutWarning(UserWarning):
    """A figure's text is clipped by its edge or overlaps another plot's."""


def _drawn_ticks(axis):
    """The tick labels drawn: those within the axis's view (matplotlib keeps more)."""
    lo, hi = sorted(axis.get_view_interval())
    eps = 1e-6 * (hi - lo)  # of the span: dates are large numbers a second apart
    return [t.label1 for t, loc in zip(axis.get_major_ticks(), axis.get_majorticklocs()) if lo - eps <= loc <= hi + eps]


def _texts(ax):
    return [t for t in (ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label,
                        *_drawn_ticks(ax.xaxis), *_drawn_ticks(ax.yaxis)) if t.get_visible() and t.get_text()]


def layout_problems(fig, drawn=False) -> list[str]:
    """Text that leaves the figure, or overlaps the text of another plot in it (titles,
    axis labels, tick labels), as drawn (drawn: it has just been, by savefig)."""
    if not drawn:
        fig.canvas.draw()
    r = fig.canvas.get_renderer()
    W, H = fig.bbox.width, fig.bbox.height
    boxes = [[(t.get_text(), t.get_window_extent(r)) for t in _texts(ax)] for ax in fig.axes if ax.get_visible()]
    out = [f"{s!r} is clipped by the figure's edge" for bs in boxes for s, b in bs
           if b.x0 < -1 or b.y0 < -1 or b.x1 > W + 1 or b.y1 > H + 1]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            out += [f"{s!r} overlaps {u!r}" for s, p in a for u, q in b if p.overlaps(q)]
    return out


def save(fig, path: Path, dpi=100, fmt=None):
    """Write a matplotlib figure as PNG (or fmt), close it; its file name (for the page). Text the
    layout clips or overlaps is warned of (LayoutWarning), naming the figure; raised with
    DYNO_STRICT_FIGURES set in the environment (the test suite sets it)."""
    import matplotlib.pyplot as plt
    fig.tight_layout()
    fig.savefig(path, dpi=dpi, format=fmt)  # drawn once: the check reads the text where savefig put it
    for problem in layout_problems(fig, drawn=True):
        if os.environ.get("DYNO_STRICT_FIGURES"):  # the test suite's: a bad figure fails the command
            plt.close(fig)
            raise LayoutWarning(f"{Path(path).name}: {problem}")
        warnings.warn(f"{Path(path).name}: {problem}", LayoutWarning, stacklevel=2)
    plt.close(fig)
    return Path(path).name


TEMPLATES = Path(__file__).parent / "templates"  # page.html and the blocks the web view shares


@cache
def templates():
    """The Jinja2 environment of TEMPLATES, escaping every value."""
    import jinja2
    return jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), autoescape=True)


class Page:
    """Parts appended in order as data ((kind, payload) blocks), written as index.html
    through templates/page.html; the printable PDF reads the same blocks
    (views/reports/pdf.py)."""

    def __init__(self, title: str, sheet=None, meta=()):
        """sheet: the test sheet (views/reports/sheet.py) the page opens with, the rest its
        appendix; meta: [(name, content)] of the document (author, description,
        dcterms.created: the PDF's Author, Subject and CreationDate)."""
        self.title, self.sheet, self.meta = title, sheet, list(meta)
        self.blocks = []

    def heading(self, text):
        self.blocks.append(("heading", text))

    def paragraph(self, text):
        self.blocks.append(("paragraph", text))

    def items(self, pairs):
        """A list of (bold label, text)."""
        self.blocks.append(("items", [(str(k), str(v)) for k, v in pairs]))

    def table(self, header, rows):
        self.blocks.append(("table", (list(header), [list(r) for r in rows])))

    def figure(self, title, png):
        """A figure under its title with what it shows (captions.toml), kept together on a
        printed page: a page that holds a figure is never its title alone."""
        self.blocks.append(("figure", (png, title, caption(png))))

    def html(self) -> str:
        # printed (views/reports/pdf.py): the header repeats on each page; a short table is kept whole
        return templates().get_template("page.html").render(title=self.title, style=STYLE, blocks=self.blocks,
                                                            short_table=SHORT_TABLE, sheet=self.sheet, meta=self.meta)

    def write(self, out_dir: Path) -> Path:
        index = Path(out_dir) / "index.html"
        index.write_text(self.html())
        return index
