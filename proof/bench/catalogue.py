"""`dyno bench catalogue`: the run index at a season's size (issue 33's goals). N
recordings made from four templates recorded on the direct cell (a short sine matrix on
each of four dampers): each copy gets its own serial (one of 50) and start time, patched in
place into the template's metadata at the same length, so every file is a distinct, valid
recording that the index must read whole. Then: index them all, index again with nothing
new, a filtered list, the browser's runs page, and `dyno check` on a standard recording."""
from __future__ import annotations

import tempfile
import time
from contextlib import closing
from datetime import datetime, timedelta, timezone
from pathlib import Path

from rig import config as rig_config

from protocols import cell, runner
from views import run_index
from protocols.recorded import for_run
from protocols.library import PROTOCOLS
from protocols.plan import Plan
from protocols.units import Units

DAMPERS = ("koni", "mechformance", "fox-light", "fox-heavy")
SERIALS = 50
START = datetime(2026, 1, 1, tzinfo=timezone.utc)
SERIAL_SLOT = "S-0000"  # the templates' serial, replaced at the same length
GOALS = {"index_s": 60.0, "reindex_s": 2.0, "list_ms": 100.0, "page_s": 1.0, "browser_s": 1.0, "check_s": 10.0}


def _template(folder, damper):
    module = PROTOCOLS["sine-matrix"]
    plan = Plan(module, module.Params(amplitudes_mm=[12.7], freqs_hz=[2.0, 8.0], ramp_cycles=1, settle_cycles=1,
                                      record_cycles=2))
    path = Path(folder) / f"template-{damper}.mcap"
    with cell.direct(rig_config.load("virtual"), damper) as c:
        started = datetime.fromtimestamp(c.rig.wall_start, timezone.utc).isoformat(timespec="microseconds")
        with closing(for_run(path, c, plan, {"damper_serial": SERIAL_SLOT, "note": "bench"})) as rec:
            runner.run_plan(plan, c, [rec])
    return path.read_bytes(), started.encode()


def make_runs(folder, n):
    """n recordings in folder from the four templates; their total size [bytes]."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as d:
        templates = [_template(d, damper) for damper in DAMPERS]
    size = 0
    for i in range(n):
        data, started = templates[i % len(templates)]
        when = (START + timedelta(hours=7 * i)).isoformat(timespec="microseconds").encode()
        data = data.replace(SERIAL_SLOT.encode(), f"S-{i % SERIALS:04d}".encode(), 1).replace(started, when, 1)
        (folder / f"run-{i:05d}.mcap").write_bytes(data)
        size += len(data)
    return size


def _timed(fn, repeat=1):
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bench_catalogue(n=1000, check_recording=None):
    from views.web import create_app
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d) / "runs"
        size = make_runs(folder, n)
        index_s, first = _timed(lambda: run_index.index(folder))
        reindex_s, again = _timed(lambda: run_index.index(folder))
        with run_index.connect(folder) as c:
            list_s, rows = _timed(lambda: run_index.runs(c, serial="S-0007", since="2026-03-01"), repeat=5)
            where_s, _ = _timed(lambda: run_index.runs(c, where="damper = koni and duration_s > 1"), repeat=5)
        app = create_app(folder, cache=Path(d) / "made")
        page_s, page = _timed(lambda: app.test_client().get("/"), repeat=3)  # the first includes the index's look
        browser_s = _in_browser(app)
        result = {"runs": n, "mb": size / 1e6, "index_s": index_s, "added": first.added, "failed": first.failed,
                  "reindex_s": reindex_s, "unchanged": again.unchanged, "list_ms": 1e3 * list_s,
                  "listed": len(rows), "where_ms": 1e3 * where_s, "page_s": page_s, "browser_s": browser_s,
                  "page_kb": len(page.data) / 1e3, "page_status": page.status_code}
        result["check_s"] = _check_time(check_recording, Path(d))
    result["goals"] = GOALS
    result["goals_met"] = {k: result[k] <= v for k, v in GOALS.items() if result.get(k) is not None}
    return result


def _in_browser(app):
    """Seconds from asking headless Chromium for the runs page to its load event (best of
    three), served on 127.0.0.1; None without Playwright and Chromium (the test extra)."""
    import logging
    import os
    import shutil
    import threading
    from werkzeug.serving import make_server
    chromium = os.environ.get("DYNO_CHROMIUM") or shutil.which("chromium")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return None
    if chromium is None:
        return None
    logging.getLogger("werkzeug").setLevel(logging.ERROR)  # no access log in the benchmark's output
    server = make_server("127.0.0.1", 0, app, threaded=True)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=[
                "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--no-first-run"])
            page = browser.new_page()
            best, _ = _timed(lambda: page.goto(f"http://127.0.0.1:{server.server_port}/", wait_until="load"),
                             repeat=3)
            browser.close()
    finally:
        server.shutdown()
    return best


def _check_time(recording, folder):
    """Seconds of a QA check of a standard recording against itself (both read, as a
    reference run would be), with the band's PNG and the run index's row; the recording
    made first on the direct cell and indexed, as `dyno run` leaves it, when none is given."""
    from views.reports import qa
    if recording is None:
        module = PROTOCOLS["standard"]
        recording, plan = folder / "standard.mcap", Plan(module, module.Params())
        with cell.direct(rig_config.load("virtual"), "koni") as c, closing(for_run(recording, c, plan)) as rec:
            runner.run_plan(plan, c, [rec])
    run_index.add(recording)
    t0 = time.perf_counter()
    tol = qa.parse_tolerance("5%")
    checked = qa.check(recording, recording, tol)
    qa.band_figure(checked.results, folder / "check.png", "bench", Units())
    run_index.add_check(recording, checked.reference, tol, checked.results)
    return time.perf_counter() - t0


def said(r):
    """(text, Markdown table, note) of bench_catalogue's result against GOALS."""
    from views.reports import markdown as md
    met = r["goals_met"]
    rows = [("index every recording (cold)", f"{r['index_s']:.1f} s", f"< {GOALS['index_s']:g} s", met["index_s"]),
            ("index again, nothing new", f"{r['reindex_s']:.2f} s", f"< {GOALS['reindex_s']:g} s", met["reindex_s"]),
            ("filtered list (serial and since)", f"{r['list_ms']:.2f} ms", f"< {GOALS['list_ms']:g} ms",
             met["list_ms"]),
            ("filtered list (--where on two fields)", f"{r['where_ms']:.2f} ms", "", None),
            ("runs page, every run (at the server)", f"{r['page_s']:.2f} s", f"< {GOALS['page_s']:g} s",
             met["page_s"]),
            ("runs page, every run (in Chromium, to its load event)",
             "not measured (no Playwright or Chromium)" if r["browser_s"] is None else f"{r['browser_s']:.2f} s",
             f"< {GOALS['browser_s']:g} s", met.get("browser_s")),
            ("dyno check, standard recording", f"{r['check_s']:.1f} s", f"< {GOALS['check_s']:g} s", met["check_s"])]
    table = [(what, value, goal, "" if ok is None else "met" if ok else "NOT met") for what, value, goal, ok in rows]
    text = (f"{r['runs']} recordings ({r['mb']:.0f} MB, {r['failed']} unreadable); "
            + "; ".join(f"{w}: {v}" for w, v, _, _ in table))
    note = (f"{r['runs']} recordings of {r['mb'] / r['runs']:.1f} MB each, made from four short sine matrices on "
            f"the direct cell (proof/bench/catalogue.py); the filtered list returned {r['listed']} runs; "
            f"the runs page is {r['page_kb']:.0f} kB of HTML; the check reads both recordings, draws its band and "
            f"adds its row to the run index.")
    return text, md.table(("measure", "measured", "goal", ""), table), note
