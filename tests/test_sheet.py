"""The test sheet (issue 75): page 1 of report.pdf is the page a lab signs, read back from the
PDF as its reader sees it: which damper, the instruments and their calibration, the table,
the verdict, the software and the recording's hash, on one A4 portrait page at 8 pt or more;
the appendix flows (no heading alone at a page's foot); the sheet is also a PNG."""
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from tests import pdf_pages
from tests.conftest import dyno, recorded

ROOT = Path(__file__).resolve().parent.parent
LOAD_CELL = 'sensor = "HBM U9C 10 kN, s/n 2203341"\ncalibrated = 2026-03-01\n'
RUN_INFO = {"damper_serial": "K-7", "operator": "A. Tester", "note": "baseline", "setup.clicks_reb": "12"}


@pytest.fixture(scope="module")
def sheet_run(tmp_path_factory):
    """A short sine matrix of the Koni with its serial and setup, on a cell whose load cell
    names its instrument and calibration date (the rig config's sensor and calibrated)."""
    folder = tmp_path_factory.mktemp("sheet")
    cell = folder / "cell.toml"
    text = (ROOT / "rig/configs/virtual.toml").read_text()
    assert "[channels.force]\n" in text
    cell.write_text(text.replace("[channels.force]\n", "[channels.force]\n" + LOAD_CELL))
    out, _ = recorded(folder / "k7.mcap", "sine-matrix", {"amplitudes_mm": [12.7, 6.4], "freqs_hz": [1.0, 4.0, 12.0],
                                                          "record_cycles": 2}, config=cell, run_info=RUN_INFO)
    return out


@pytest.fixture(scope="module")
def sheet_report(sheet_run, tmp_path_factory):
    """`dyno report` of that run against the Koni's model: its folder."""
    out = tmp_path_factory.mktemp("sheet-report") / "rep"
    r = dyno("report", sheet_run, "--out", out, "--against", "koni", "--tolerance", "5%")
    assert r.returncode == 0, r.stderr
    return out


def _page_one(out):
    """(each page's text, its words joined by single spaces; the smallest font on page 1)."""
    texts, smallest = pdf_pages.text_and_sizes(out / "report.pdf", pages={0})
    return [" ".join(t.split()) for t in texts], smallest


def test_page_one_is_the_sheet_a_lab_signs(sheet_run, sheet_report):
    out = sheet_report
    texts, smallest = _page_one(out)
    one = texts[0]
    assert "Damper test sheet: koni, serial K-7" in one
    assert all(s in one for s in ("clicks_reb 12", "baseline", "A. Tester", "sine-matrix"))  # identity and test
    assert "HBM U9C 10 kN, s/n 2203341" in one and "2026-03-01" in one  # the load cell and its calibration
    assert "not given" in one  # the other channels say so, not left out
    assert "body temperature" in one and "source data as recorded by dyno" in one  # conditions, as far as measured
    assert "N at the turning points (friction cancelled, 95 %)" in one  # no static test: the gas force at the turns
    # the verdict is dyno check's
    check = dyno("check", sheet_run, "--against", "koni", "--tolerance", "5%")
    assert check.stdout.strip().splitlines()[-2].split(";")[0] in one
    # the velocity table: velocity.csv's numbers, on the sheet
    head, *rows = [ln.split(",") for ln in (out / "velocity.csv").read_text().splitlines()]
    row = next(r for r in rows if r[0] == "100")
    assert f" 100 {float(row[1]):.4g} " in one and "compression [N]" in one and "rebound [N]" in one
    # the software, the file and its hash, the sign-off
    assert "dyno 0.1" in one and "k7.mcap" in one and hashlib.sha256(sheet_run.read_bytes()).hexdigest() in one
    assert "tested by" in one and "checked by" in one and "signature" in one
    assert smallest >= 7.99, smallest  # 8 pt at least, as the PDF rounds it
    # nothing else on it: the appendix starts on page 2
    assert "Appendix" not in one and texts[1].startswith("Appendix: Dyno report: k7.mcap")
    from pypdf import PdfReader
    pdf = PdfReader(out / "report.pdf")
    box = pdf.pages[0].mediabox
    assert (round(float(box.width)), round(float(box.height))) == (595, 842)  # A4 portrait in points
    meta = pdf.metadata
    assert meta.title == "Dyno report: k7.mcap" and meta.author == "A. Tester"
    assert meta.subject == "Damper test sheet: koni, serial K-7" and meta.creation_date is not None
    assert not pdf_pages.lone_headings(out / "report.pdf", (out / "index.html").read_text())


def test_the_sheet_is_a_png_that_shows_the_verdict(sheet_run, sheet_report, tmp_path):
    """sheet.png is page 1 drawn: A4's proportions, ink on it, and the verdict's green box
    where a passing check puts it (a failing one is red)."""
    from PIL import Image
    failing = tmp_path / "fail"
    r = dyno("report", sheet_run, "--out", failing, "--against", "fox-heavy")
    assert r.returncode == 0, r.stderr
    for out, colour in ((sheet_report, (0x1a, 0x7f, 0x37)), (failing, (0xc6, 0x28, 0x28))):
        img = np.asarray(Image.open(out / "sheet.png").convert("RGB")).astype(int)
        h, w, _ = img.shape
        assert abs(h / w - 297 / 210) < 0.01 and w >= 1200
        assert (img.sum(axis=2) < 300).mean() > 0.01  # text and lines drawn, not a blank page
        assert (np.abs(img - colour).sum(axis=2) < 40).sum() > 500, out  # the verdict's colour


def test_an_imported_run_says_what_its_file_does_not_hold(tmp_path):
    """A real MR damper's file (UTFSM, 25 mm 0.5 Hz at 1 A) imported: no thermocouple, no static
    test, no instrument named: the sheet says "not measured" and "not given", and without a
    reference it gives no verdict and says how to get one."""
    src = ROOT / "tests/data/mr-damper-utfsm/sine/25mm0x5Hz1A.txt"
    r = dyno("import", src, "--out", tmp_path / "mr.mcap", "--map", "time=1:s", "--map", "displacement=2:mm",
             "--map", "velocity=3:mm/s", "--map", "force=4:N", "--smoothed", "0.1period", "--serial", "MR-1",
             "--setup", "current_A=1")
    assert r.returncode == 0, r.stderr
    assert "gas force: unknown: the force reads as centred on zero" in r.stdout, r.stdout  # as the sheet says
    r = dyno("report", tmp_path / "mr.mcap", "--out", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    one = _page_one(tmp_path / "rep")[0][0]
    assert one.startswith("Damper test sheet: serial MR-1") and "current_A 1" in one
    assert "not measured (no thermocouple channel)" in one
    # what the source did, from the import and the data; the force centred on zero, the gas force is
    # unknown: what it reads at the turning points is about the source's zero, not the load cell's
    assert "source data smoothed by its source (0.1 period); displacement centred on zero" in one
    assert "force centred on zero" in one, one
    assert ("gas force unknown: the force is centred on zero (source data); about that zero it reads" in one
            and "at the turning points (friction cancelled, 95 %)" in one and "no gas spring's" not in one), one
    assert "NO VERDICT" in one and "dyno report --against" in one
    assert "25" in one and "compression [N]" in one  # the table at the speeds the stroke reached
    assert not pdf_pages.lone_headings(tmp_path / "rep" / "report.pdf", (tmp_path / "rep" / "index.html").read_text())


def test_a_comparison_opens_with_one_sheet_for_all_runs(sheet_run, tmp_path, koni_run):
    """`dyno report A B`: the runs' identities in one table, a verdict for each (B against A),
    the differences per speed, on page 1."""
    r = dyno("report", sheet_run, koni_run[0], "--out", tmp_path / "cmp")
    assert r.returncode == 0, r.stderr
    one = _page_one(tmp_path / "cmp")[0][0]
    assert "Damper comparison sheet" in one and "K-7" in one and "std.mcap" in one
    assert "REFERENCE" in one and "against A (k7.mcap, tolerance 5 %)" in one
    assert "B diff comp/" in one and hashlib.sha256(Path(koni_run[0]).read_bytes()).hexdigest() in one
    assert (tmp_path / "cmp" / "sheet.png").is_file()
    assert not pdf_pages.lone_headings(tmp_path / "cmp" / "report.pdf", (tmp_path / "cmp" / "index.html").read_text())


def test_a_calibration_date_is_a_date_and_is_recorded(sheet_run, tmp_path):
    """The rig config's calibrated is a date (TOML's, or the same in quotes), refused with its
    line otherwise; the recording keeps it beside the channel's gain."""
    from records.reader import load_recording
    from rig import config as rig_config
    from rig.errors import RigError
    cal = json.loads(load_recording(sheet_run)[2]["calibration"]["force"])
    assert cal["sensor"].startswith("HBM U9C") and cal["calibrated"] == "2026-03-01"
    text = (ROOT / "rig/configs/virtual.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[channels.force]\n", '[channels.force]\ncalibrated = "March"\n'))
    with pytest.raises(RigError, match=r"bad.toml:\d+: channel 'force': calibrated: expected a date like 2026-03-01"):
        rig_config.load(bad)
    bad.write_text(text.replace("[channels.force]\n", '[channels.force]\ncalibrated = "2026-03-01"\n'))
    assert rig_config.load(bad).channels["force"].calibrated == "2026-03-01"


def test_without_weasyprint_the_sheet_is_still_page_one(sheet_run, tmp_path, monkeypatch):
    """Where the OS has no Pango, matplotlib lays the PDF out: the sheet's facts on page 1,
    the appendix from page 2."""
    from views.reports import pdf
    monkeypatch.setattr(pdf, "_weasyprint", lambda: None)
    r = dyno("report", sheet_run, "--out", tmp_path / "rep", "--against", "koni")
    assert r.returncode == 0, r.stderr
    texts = _page_one(tmp_path / "rep")[0]
    assert texts[0].startswith("Damper test sheet: koni, serial K-7") and "PASS: " in texts[0]
    assert "2026-03-01" in texts[0] and "Dyno report: k7.mcap" not in texts[0]
    assert texts[1].startswith("Dyno report: k7.mcap") and (tmp_path / "rep" / "sheet.png").is_file()
