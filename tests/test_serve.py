"""`dyno serve`: the run index in a real browser (headless Chromium driven by
Playwright, installed by `make test`): open the runs page, filter and search it, compare
runs, see a QA verdict, a run's report, a trend, and a run while it is being recorded; a
corrupt file is one row and breaks nothing."""
import json
import os
import shutil
import threading
from contextlib import closing

import numpy as np
import pytest

from records.events import Findings, Fault, RunStart, SegmentEnd, SegmentStart, DiscoveryVerdict
from commands.cli import main as dyno
from tests import mcap_files
from protocols.units import Units
from views.web import create_app

pytestmark = pytest.mark.xdist_group("browser")


def _record(folder, name, damper, serial, note):
    """A short sine matrix on the direct cell, recorded as `dyno run` records it."""
    from protocols import cell, runner
    from protocols.recorded import for_run
    from protocols.library import PROTOCOLS
    from protocols.plan import Plan
    from rig import config as rig_config
    module = PROTOCOLS["sine-matrix"]
    plan = Plan(module, module.Params(amplitudes_mm=[12.7], freqs_hz=[1.0, 4.0], record_cycles=2))
    with cell.direct(rig_config.load("virtual"), damper) as c, \
            closing(for_run(folder / name, c, plan, {"damper_serial": serial, "note": note})) as rec:
        result = runner.run_plan(plan, c, [rec])
    assert result.fault is None


@pytest.fixture(scope="module")
def runs_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs")
    _record(folder, "k12-before.mcap", "koni", "K-12", "before service")
    _record(folder, "k12-after.mcap", "koni", "K-12", "after service")
    _record(folder, "m3.mcap", "mechformance", "M-3", "re-valved")
    (folder / "broken.mcap").write_bytes(b"\x89MCAP0\r\n" + os.urandom(300))
    mcap_files.write(folder / "foreign.mcap", topics={"/imu": [{"ax": 0.1}] * 5})  # a valid MCAP of another tool
    # a QA check that fails: the Mechformance against the Koni's reference run
    assert dyno(["check", str(folder / "m3.mcap"), "--against", str(folder / "k12-before.mcap")]) == 1
    return folder


@pytest.fixture(scope="module")
def server(runs_folder, tmp_path_factory):
    from werkzeug.serving import make_server
    app = create_app(runs_folder, Units("metric"), tmp_path_factory.mktemp("made"), reindex_s=0.0)
    srv = make_server("127.0.0.1", 0, app, threaded=True)
    thread = threading.Thread(target=srv.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{srv.server_port}"
    srv.shutdown()
    thread.join(10)


@pytest.fixture(scope="module")
def page(server):
    from playwright.sync_api import sync_playwright
    chromium = os.environ.get("DYNO_CHROMIUM") or shutil.which("chromium")
    if chromium is None:
        pytest.fail("no chromium: `make test` installs Debian's chromium (or set DYNO_CHROMIUM to a Chromium)")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
            "--disable-sync", "--no-first-run"])
        pg = browser.new_page()
        pg.set_default_timeout(60_000)
        yield pg
        browser.close()


def _rows(page):
    return page.locator("#runs tr").count() - 1


def test_the_runs_page_lists_every_run_and_a_corrupt_or_foreign_file_as_one_row(page, server):
    page.goto(server + "/")
    assert _rows(page) == 5
    bad = page.locator("#runs tr.unreadable")
    assert bad.count() == 2 and "not a readable recording" in bad.nth(0).inner_text()
    assert "no dyno channels" in bad.nth(1).inner_text()
    assert page.locator("#count").inner_text() == "5 runs"
    # the QA column carries the last check's verdict
    assert page.locator("#runs td.qa", has_text="FAIL").count() == 1


def test_filter_by_serial_search_and_sort(page, server):
    page.goto(server + "/")
    page.select_option("select[name=serial]", "K-12")
    page.click("#filter button[type=submit]")
    page.wait_for_url("**serial=K-12**")
    assert _rows(page) == 2 and page.locator("#runs", has_text="M-3").count() == 0
    page.goto(server + "/")
    page.fill("input[name=q]", "re-valved")
    page.press("input[name=q]", "Enter")
    page.wait_for_url("**q=re-valved**")
    assert _rows(page) == 1 and "m3.mcap" in page.locator("#runs").inner_text()
    page.goto(server + "/?where=clicks")
    assert "not FIELD OP VALUE" in page.locator("#error").inner_text()
    page.goto(server + "/")
    page.click("#runs th a:text('serial')")
    first = page.locator("#runs tr").nth(1).inner_text()
    page.click("#runs th a:text('serial')")  # again: descending
    assert page.locator("#runs tr").nth(1).inner_text() != first


def test_two_runs_compared_overlaid(page, server):
    page.goto(server + "/?serial=K-12")
    for box in page.locator("#runs input[type=checkbox]").all():
        box.check()
    page.click("#compare")
    page.wait_for_url("**/compare?**")
    assert "Comparison of 2 runs" in page.locator("h1").inner_text()
    frame = page.frame_locator("#comparison")
    assert "Damper comparison sheet" in frame.locator("h1").first.inner_text()  # the sheet, then the rest
    assert "Dyno comparison" in frame.locator("h1.appendix").inner_text()
    for img in (frame.locator("img[src='compare_composite.png']"), frame.locator("img[src='compare_loops.png']")):
        img.wait_for()
        assert img.evaluate("i => i.complete && i.naturalWidth") > 300


def test_the_qa_verdict_and_a_runs_report(page, server):
    page.goto(server + "/qa")
    row = page.locator("#qa tr.fail")
    assert row.count() == 1 and "FAIL" in row.locator(".verdict").inner_text()
    assert "k12-before.mcap" in row.inner_text()
    row.locator("a").first.click()
    page.wait_for_url("**/run/*")
    assert "M-3" in page.locator("h1").inner_text()
    assert "FAIL" in page.locator("#checks").inner_text()
    report = page.frame_locator("#report")
    assert "Damper test sheet: mechformance, serial M-3" in report.locator("h1").first.inner_text()
    assert "Dyno report: m3.mcap" in report.locator("h1.appendix").inner_text()


def test_a_serials_trend(page, server):
    page.goto(server + "/trend")
    page.select_option("select[name=serial]", "K-12")
    page.fill("input[name=quantity]", "rebound@0.1m/s")
    page.click("#trend button")
    page.wait_for_url("**/trend?**")
    assert page.locator("#points tr").count() == 3  # a header and two runs
    assert page.locator("img[alt=trend]").evaluate("i => i.complete && i.naturalWidth") > 300


def test_a_run_in_progress_shows_its_progress_readings_and_trip(page, server, runs_folder):
    from records.recorder import Recorder
    from rig import config as rig_config
    page.goto(server + "/live")
    assert page.locator("#none").count() == 1
    rec = Recorder(runs_folder / "now.mcap", rig_config.load("virtual"), json.dumps({"name": "koni"}), "sine-matrix",
                   {}, run_info={"damper_serial": "K-99"})
    try:
        rec.event(RunStart(0.0, "sine-matrix", message="3 segments, 30 s at most", segment_count=3))
        rec.event(SegmentStart(0.0, "sine 12.7 mm 1 Hz"))
        t = np.arange(0.0, 2.0, 0.001)
        rec.samples({"force": (t, 400.0 + 0 * t), "T_body": (t, 293.15 + 0 * t)})
        rec.flush()
        page.goto(server + "/live")
        text = page.locator("section.live").inner_text()
        assert "koni · K-99" in text and "segment 1 of 3: sine 12.7 mm 1 Hz" in text and "2.0 s" in text, text
        assert "20 | C" in text.replace("\t", " | ") and "Live (1 recording)" in page.locator("#live-link").inner_text()
        rec.event(Fault(2.0, "sine 12.7 mm 1 Hz", message="force 9000 N beyond the load cell's 8000 N"))
        page.goto(server + "/live")
        assert "Tripped: force 9000 N" in page.locator(".trip").inner_text()
        page.goto(server + "/")
        assert "now.mcap" not in page.locator("#runs").inner_text()  # being written: not yet a run
    finally:
        rec.close()
    page.goto(server + "/live")
    assert page.locator("#none").count() == 1
    page.goto(server + "/")
    tripped = page.locator("#runs tr.tripped")
    assert "now.mcap" in tripped.inner_text() and "force 9000 N" in tripped.inner_text()


def test_the_live_page_plots_force_and_the_loops_as_the_run_is_written(page, server, runs_folder):
    """Issue 45: the live page draws force against time and the running segment's force
    against velocity and displacement, with the damper model's force and the rig's limits,
    and the live diagnosis's findings, and redraws them as the recording grows, without
    reloading."""
    from models import damper as dm
    from records.recorder import Recorder
    from rig import config as rig_config
    rec = Recorder(runs_folder / "plots.mcap", rig_config.load("virtual"), json.dumps(dm.to_dict(dm.load("koni"))),
                   "sine-matrix", {})

    def motion(t0, t1, dropout=False):
        t = np.arange(t0, t1, 0.001)
        x = 0.038 + 0.0127 * np.sin(2 * np.pi * t)
        v = 0.0127 * 2 * np.pi * np.cos(2 * np.pi * t)
        F = 300.0 + 4000.0 * v
        F[len(F) // 2] = np.nan if dropout else F[len(F) // 2]  # a sample that is no number: written null
        rec.samples({"force": (t, F), "x": (t, x), "v": (t, v)})
        rec.flush()
    try:
        rec.event(RunStart(0.0, "sine-matrix", message="1 segments, 30 s at most", segment_count=1))
        rec.event(SegmentStart(0.0, "sine 12.7 mm 1 Hz"))
        motion(0.0, 2.0)
        page.goto(server + "/live")
        trace, fv, fx = (page.locator(f"section.live[data-key='plots.mcap'] canvas.{c}") for c in ("trace", "fv", "fx"))
        page.wait_for_function("() => document.querySelector(\"section.live[data-key='plots.mcap'] canvas.fv\")"
                               ".dataset.points > 0", timeout=10_000)
        assert float(trace.get_attribute("data-xmax")) < 2.0
        assert fv.get_attribute("data-series") == "measured,model" == fx.get_attribute("data-series")
        assert "stroke" in fx.get_attribute("data-limits")  # the rig's stroke limits, drawn
        motion(2.0, 3.0, dropout=True)  # more of the run: the same page redraws within a second or two
        page.wait_for_function("() => +document.querySelector(\"section.live[data-key='plots.mcap'] canvas.trace\")"
                               ".dataset.xmax > 2.9", timeout=5_000)
        assert "3.0 s" in page.locator("section.live[data-key='plots.mcap'] .progress-text").inner_text()
        # the live diagnosis's findings (protocols/live_diagnose.py) appear as they are written
        rec.event(Findings(3.0, "sine 12.7 mm 1 Hz", {"findings": [
            "Nothing significant was left out: the held-out residual is within the force noise."]}, "nothing named",
            source="live"))
        rec.flush()
        findings = page.locator("section.live[data-key='plots.mcap'] .findings")
        findings.get_by_text("Nothing significant was left out").wait_for(timeout=5_000)
        assert findings.inner_text().startswith("sine 12.7 mm 1 Hz: Nothing significant")
        page.screenshot(path=str(runs_folder.parent / "live.png"), full_page=True)
    finally:
        rec.close()


def test_dyno_serve_serves_on_loopback_until_ctrl_c_and_refuses_a_busy_port(runs_folder, capsys):
    import re
    import signal
    import socket
    import subprocess
    import sys
    import urllib.request
    p = subprocess.Popen([sys.executable, "-m", "commands.cli", "serve", str(runs_folder), "--port", "0"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = p.stdout.readline()
        url = re.search(r"serving (http://127\.0\.0\.1:\d+/)", line).group(1)
        assert " recordings (2 unreadable); serving" in line, line  # the corrupt and the foreign file
        assert "k12-after.mcap" in urllib.request.urlopen(url, timeout=30).read().decode()
    finally:
        p.send_signal(signal.SIGINT)
        assert p.wait(30) == 0
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        assert dyno(["serve", str(runs_folder), "--port", str(busy.getsockname()[1])]) == 2
    assert "cannot listen on 127.0.0.1 (Address already in use)" in capsys.readouterr().err


def test_a_recording_being_written_is_read_on_from_where_the_last_look_ended(tmp_path):
    from records.recorder import Recorder
    from views.web.in_progress import Live
    from rig import config as rig_config
    rec = Recorder(tmp_path / "r.mcap", rig_config.load("virtual"), "{}", "sine-matrix", {})
    try:
        live = Live(tmp_path / "r.mcap", 1)
        rec.event(RunStart(0.0, "sine-matrix", message="2 segments, 4 s at most", segment_count=2))
        rec.event(SegmentStart(0.0, "a"))
        live.read_on(rec.claim.target)
        first = live.offset
        assert 0 < first <= (tmp_path / "r.mcap").stat().st_size and [e.kind for e in live.events] == \
            ["run_start", "segment_start"] and live.planned == 2
        rec.event(SegmentEnd(1.0, "a"))
        rec.event(SegmentStart(1.0, "b"))
        live.read_on(rec.claim.target)
        assert live.offset > first and [e.segment for e in live.events] == ["sine-matrix", "a", "a", "b"]
        assert live.done == 1 and live.segment == "b"
        live.read_on(rec.claim.target)  # nothing new: nothing read twice
        assert len(live.events) == 4
        # dyno run discover's rounds and verdict are shown with the live diagnosis's findings
        rec.event(Findings(1.5, "", {"round": 1, "unsure": ["friction or a lag"]}, "named nothing"))
        rec.event(DiscoveryVerdict(2.0, "discover", message="Found: nothing. Stopped: the budget is spent."))
        live.read_on(rec.claim.target)
        assert live.findings == [("verdict", ["Found: nothing. Stopped: the budget is spent."]),
                                 ("round 1", ["named nothing", "Unsure: friction or a lag"])]
    finally:
        rec.close()
