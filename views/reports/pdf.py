"""The printable report: a Page (views/reports/page.py) typeset on A4 or Letter, in
landscape (a dyno sheet's peak table has fourteen columns), by
WeasyPrint from the page's own HTML and a print stylesheet (tables as text at 8 pt,
a heading kept with what follows it, figures fitted to the page). Where WeasyPrint cannot
load (it needs Pango from the OS: `make test` installs it with Chromium), the blocks are
laid out with matplotlib's PDF backend instead, and the report says which."""
from __future__ import annotations

import textwrap
from pathlib import Path

from matplotlib.backends.backend_pdf import PdfPages

from views.reports.plots import plt

PAPER_IN = {"a4": (8.27, 11.69), "letter": (8.5, 11.0)}  # inches
MARGIN_IN = 0.6
SHEET_FIGURE_IN = 3.6  # the test sheet's curve at most this high [in], so that the sheet keeps to one page
# (font size [pt], line height [in], characters per line) of each kind of text
TEXT = {"title": (13, 0.30, 80), "heading": (10, 0.24, 100), "paragraph": (8, 0.16, 125), "table": (6, 0.12, 150)}


class _Sheet:
    """One page being filled from the top; a new one when the next block does not fit."""

    def __init__(self, pdf, paper):
        self.pdf, self.w, self.h = pdf, *PAPER_IN[paper]
        self.fig = None

    def new(self):
        self.close()
        self.fig = plt.figure(figsize=(self.w, self.h))
        self.y = self.h - MARGIN_IN

    def room(self, height):
        if self.fig is None or self.y - height < MARGIN_IN:
            self.new()

    def lines(self, kind, lines, family="sans-serif", weight="normal", fit=False):
        size, step, _ = TEXT[kind]
        if fit:  # a monospaced table narrowed to the page: DejaVu Sans Mono is 0.6 em wide
            width = max(len(ln) for ln in lines)
            size = min(size, (self.w - 2 * MARGIN_IN) * 72 / (0.602 * width))
            step *= size / TEXT[kind][0]
        for line in lines:
            self.room(step)
            self.fig.text(MARGIN_IN / self.w, self.y / self.h, line, fontsize=size, family=family,
                          weight=weight, va="top")
            self.y -= step

    def image(self, path, most_in=None):
        """The PNG across the page, at most most_in [in] high (default: the page's)."""
        img = plt.imread(path)
        most = self.h - 2 * MARGIN_IN if most_in is None else most_in
        height = min((self.w - 2 * MARGIN_IN) * img.shape[0] / img.shape[1], most)
        width = height * img.shape[1] / img.shape[0]
        self.room(height)
        ax = self.fig.add_axes([MARGIN_IN / self.w, (self.y - height) / self.h, width / self.w, height / self.h])
        ax.imshow(img)
        ax.set_axis_off()
        self.y -= height + 0.1

    def close(self):
        if self.fig is not None:
            self.pdf.savefig(self.fig)
            plt.close(self.fig)
            self.fig = None


def _wrap(kind, text):
    return textwrap.wrap(str(text), TEXT[kind][2]) or [""]


def _table(header, rows):
    """The table as fixed-width text lines, each column as wide as its widest cell."""
    cells = [[str(c) for c in header]] + [[str(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in cells if i < len(r)) for i in range(len(header))]
    fmt = [" ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in cells]
    return [fmt[0], "-" * len(fmt[0]), *fmt[1:]]


PRINT_CSS = """@page {{ size: {paper} landscape; margin: 12mm 12mm; @bottom-right {{ content: counter(page) " / " counter(pages);
font: 8pt sans-serif; }} }}
@page sheet {{ size: {paper} portrait; margin: 10mm 12mm; }}
body {{ font: 9pt sans-serif; max-width: none; margin: 0; }}
section.sheet {{ page: sheet; break-after: page; }}
section.sheet table {{ font-size: 8.5pt; }}
section.sheet td {{ white-space: normal; }}
section.sheet .overlay img {{ width: auto; max-width: 100%; max-height: 85mm; }}
h1 {{ font-size: 14pt; margin: 0 0 4mm; }}
h2 {{ font-size: 10.5pt; margin: 5mm 0 2mm; break-after: avoid; }}
p, li {{ orphans: 3; widows: 3; }}
table {{ font-size: 8pt; border-collapse: collapse; width: 100%; }}
table.short {{ break-inside: avoid; }}
thead {{ display: table-header-group; }}
tr {{ break-inside: avoid; }}
td, th {{ padding: 1px 3px; }}
td {{ white-space: nowrap; }}
td:first-child {{ white-space: normal; }}
th {{ vertical-align: bottom; }}
figure {{ margin: 0; break-inside: avoid; }}
img {{ max-width: 100%; max-height: 150mm; }}"""


def _weasyprint():
    """The weasyprint module, or None where it or the OS's Pango cannot load."""
    try:
        import weasyprint
    except (ImportError, OSError):
        return None
    return weasyprint


def write_pdf(page, out_dir, name="report.pdf", paper="a4") -> Path:
    """Write the page as DIR/NAME; its path. Figures are read from DIR. The title and the
    page's meta (author, description, dcterms.created) are the PDF's Title, Author,
    Subject and CreationDate."""
    out = Path(out_dir) / name
    wp = _weasyprint()
    if wp is not None:
        wp.HTML(string=page.html(), base_url=str(Path(out_dir).resolve())).write_pdf(
            out, stylesheets=[wp.CSS(string=PRINT_CSS.format(paper=paper.upper() if paper == "a4" else paper))])
        return out
    meta = dict(page.meta)
    with PdfPages(out, metadata={"Title": page.title, "Creator": "dyno", "Author": meta.get("author", ""),
                                 "Subject": meta.get("description", "")}) as pdf:
        sheet = _Sheet(pdf, paper)
        if page.sheet is not None:  # its facts as plain blocks, then the appendix from a new page
            _blocks(sheet, page.sheet.title, page.sheet.blocks(), out_dir, SHEET_FIGURE_IN)
            sheet.new()
        _blocks(sheet, page.title, page.blocks, out_dir)
        sheet.close()
    return out


def _blocks(sheet, title, blocks, out_dir, figure_in=None):
    """A title and a page's blocks laid out on the sheet from where it stands; figure_in:
    the figures' height at most [in]."""
    sheet.lines("title", _wrap("title", title), weight="bold")
    for kind, payload in blocks:
        if kind == "heading":
            sheet.y -= 0.08
            sheet.lines("heading", _wrap("heading", payload), weight="bold")
        elif kind == "paragraph":
            sheet.lines("paragraph", _wrap("paragraph", payload))
        elif kind == "items":
            sheet.lines("paragraph", [ln for k, v in payload for ln in _wrap("paragraph", f"- {k}: {v}")])
        elif kind == "table":
            sheet.lines("table", _table(*payload), family="monospace", fit=True)
        elif kind == "figure":
            sheet.lines("heading", _wrap("heading", payload[1]), weight="bold")
            sheet.image(Path(out_dir) / payload[0], figure_in)
            if len(payload) > 2 and payload[2]:
                sheet.lines("paragraph", _wrap("paragraph", payload[2]))


PNG_DPI = 150  # the sheet as an image: A4 at 1240 x 1754 pixels, its 8 pt text legible


def first_page_png(pdf_path, png_path, dpi=PNG_DPI) -> Path:
    """Page 1 of the PDF (the test sheet) as a PNG, for a chat or an email (pypdfium2: PDFium,
    the renderer of Chromium, draws the PDF itself, so the image is what prints)."""
    import pypdfium2
    doc = pypdfium2.PdfDocument(str(pdf_path))
    try:
        doc[0].render(scale=dpi / 72).to_pil().save(png_path)
    finally:
        doc.close()
    return Path(png_path)
