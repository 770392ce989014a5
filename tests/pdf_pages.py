"""A printed report read back as a reader sees it: each page's text, the smallest font drawn,
which pages draw an image, and headings left alone at a page's foot."""
from __future__ import annotations

import html
import re


def text_and_sizes(path, pages=None):
    """(text per page, smallest font size [pt] drawn on those pages) of a PDF (pypdf)."""
    from pypdf import PdfReader
    sizes, out = [], []
    for i, pg in enumerate(PdfReader(path).pages):
        keep = pages is None or i in pages
        out.append(pg.extract_text(visitor_text=lambda text, cm, tm, font, size: keep and text.strip() and sizes.append(
            abs(size * tm[0] * cm[0]) or abs(size * tm[3] * cm[3]))))
    return out, min(sizes)


def with_images(path) -> list[bool]:
    """Whether each page draws an image (PDFium's page objects: pypdf lists the resources a
    page may use, which WeasyPrint shares across pages)."""
    import pypdfium2
    import pypdfium2.raw as raw
    doc = pypdfium2.PdfDocument(str(path))
    try:
        return [any(True for _ in page.get_objects(filter=[raw.FPDF_PAGEOBJ_IMAGE], max_depth=3)) for page in doc]
    finally:
        doc.close()


FOOTER = re.compile(r"^\d+ / \d+$")  # the page number, "2 / 8"


def headings(html_text) -> tuple[list[str], list[str]]:
    """(section headings, figure titles) of a report's HTML page (templates/page.html)."""
    figures = [html.unescape(t) for t in re.findall(r"<figure><h2>(.*?)</h2>", html_text)]
    every = [html.unescape(t) for t in re.findall(r"<h2>(.*?)</h2>", html_text)]
    return [t for t in every if t not in figures], figures


def lone_headings(path, html_text) -> list[str]:
    """Headings of the page printed at path that end a page without what follows them: a
    heading as its page's last line, or a figure's title on a page that draws no image."""
    texts, _ = text_and_sizes(path)
    images = with_images(path)
    sections, figures = headings(html_text)
    out = []
    for i, text in enumerate(texts):
        lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not FOOTER.match(ln.strip())]
        if lines and lines[-1] in sections:
            out.append(f"page {i + 1} ends with {lines[-1]!r}")
        out += [f"page {i + 1}: {t!r} without its figure" for t in figures if t in lines and not images[i]]
    return out
