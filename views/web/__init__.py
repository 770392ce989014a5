"""The browser view of a folder of recordings (`dyno serve`, issue 33): the run index's
table to filter, sort and search; a run's report; runs overlaid; a serial's trend; the QA
checks; and the runs being recorded now. Flask, with the report's own pages and figures
(matplotlib) made on first view into a folder of the server's and kept while it runs.
Read-only toward the rig: it reads recordings and the run index, and indexes new
recordings as they appear.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import urlencode

from flask import Flask, abort, current_app, render_template, request, send_from_directory, url_for
from jinja2 import ChoiceLoader, FileSystemLoader

from models.damper import DamperError
from models.damper import load as load_damper
from views import run_index, run_terms
from views.reports import trend as trend_report
from views.reports.comparison import compare
from views.reports.page import TEMPLATES
from views.reports.recording import report
from protocols.units import Units, fmt
from views.web.in_progress import being_written, in_progress
from rig.errors import RigError, UsageError

REINDEX_S = 5.0  # new recordings show up on the runs page within this
COLUMNS = {"id": "id", "started": "started", "serial": "serial", "damper": "damper", "protocol": "protocol",
           "duration_s": "duration [s]", "outcome": "outcome", "qa": "QA", "path": "file"}
SEARCHED = ("serial", "damper", "note", "operator", "protocol", "path", "setup")
PAGE_ERRORS = (UsageError, RigError, DamperError, OSError, ValueError)  # a page that cannot be made says why


@dataclass
class View:
    folder: Path
    units: Units
    cache: Path  # pages and figures made for the browser
    reindex_s: float
    made: threading.Lock = field(default_factory=threading.Lock)  # one at a time: matplotlib, two cores
    indexed_at: float = -1e9
    problem: str | None = None  # why the run index cannot be indexed now (read-only, not ours, ...)

    def db(self):
        """The run index, read-only, with recordings new since the last look indexed
        first; RunIndexError (a page saying why) when it cannot be read at all."""
        if time.monotonic() - self.indexed_at >= self.reindex_s:
            try:
                run_index.index(self.folder)
                self.problem = None
            except run_index.RunIndexError as e:
                self.problem = str(e)
            self.indexed_at = time.monotonic()
        return run_index.reading(self.folder)

    def page(self, kind, paths, make):
        """The URL of a page made by make(folder) for these recordings, made first if they
        are new or changed since."""
        stamp = [(p, st.st_mtime_ns, st.st_size) for p, st in ((p, Path(p).stat()) for p in paths)]
        name = f"{kind}-{hashlib.sha1(repr(stamp).encode()).hexdigest()[:16]}"
        with self.made:
            if not (self.cache / name / "index.html").exists():
                make(self.cache / name)
        return url_for("made_file", name=f"{name}/index.html")


def view() -> View:
    return current_app.config["VIEW"]


def create_app(folder, units=Units(), cache=None, reindex_s=REINDEX_S) -> Flask:
    """The view of `folder`'s recordings; made pages and figures go to `cache` (a new
    temporary folder by default); new recordings are indexed at most every reindex_s."""
    app = Flask(__name__)
    # the reports' page parts (views/reports/templates/blocks.html) are the web view's too
    app.jinja_loader = ChoiceLoader([app.jinja_loader, FileSystemLoader(TEMPLATES)])
    app.config["VIEW"] = View(Path(folder).resolve(), units, Path(cache or tempfile.mkdtemp(prefix="dyno-serve-")),
                              reindex_s)
    for rule, endpoint, fn in (("/", "runs", runs), ("/run/<int:run_id>", "run", run), ("/compare", "comparison",
                               comparison), ("/trend", "trend", trend), ("/qa", "qa", qa), ("/live", "live", live),
                               ("/live.json", "live_json", live_json),
                               ("/made/<path:name>", "made_file", made_file)):
        app.add_url_rule(rule, endpoint, fn)
    app.add_template_filter(lambda args, key, desc: urlencode({**args, "sort": key, "desc": desc}), "urlencode_sort")
    app.context_processor(lambda: {"folder": view().folder, "units": view().units, "fmt": fmt,
                                   "live_count": len(being_written(view().folder)), "problem": view().problem})
    app.register_error_handler(run_index.RunIndexError, lambda e: (render_template("base.html", error=str(e)), 503))
    return app


def runs():
    a = request.args
    error, rows = None, []
    with view().db() as c:
        try:
            rows = run_index.runs(c, serial=a.get("serial") or None, since=a.get("since") or None,
                                  protocol=a.get("protocol") or None, where=a.get("where") or None)
        except run_index.RunIndexError as e:
            error = str(e)
        checks, serials = run_index.latest_checks(c), run_index.serials(c)
    rows = [dict(r, qa=_verdict(checks.get(r["id"]))) for r in rows]
    q = a.get("q", "").strip().lower()
    if q:
        rows = [r for r in rows if any(q in str(r[k] or "").lower() for k in SEARCHED)]
    key = a.get("sort", "started")
    if key in COLUMNS:
        rows.sort(key=lambda r: (r[key] is None, r[key] if r[key] is not None else 0), reverse=a.get("desc") == "1")
    return render_template("runs.html", rows=rows, columns=COLUMNS, sort=key, desc=a.get("desc") == "1", args=a,
                           error=error, serials=serials), 400 if error else 200


def run(run_id):
    v = view()
    with v.db() as c:
        try:
            row, peaks = run_index.run(c, run_id)
        except run_index.RunIndexError:
            abort(404)
        checks, models, diagnoses = (run_index.attached(c, t, run_id) for t in ("checks", "models", "diagnoses"))
    checks = [dict(k, verdict=_verdict(k)) for k in checks]
    made, error = None, row["error"]
    if not error:
        try:
            made = v.page(f"run-{run_id}", [row["path"]], lambda out: report(row["path"], out, _model(row["path"]),
                                                                             units=v.units))
        except PAGE_ERRORS as e:
            error = str(e).splitlines()[0]
    return render_template("run.html", row=row, setup=json.loads(row["setup"] or "{}"), peaks=peaks, checks=checks,
                           models=models, diagnoses=diagnoses, report=made, error=error,
                           effects=run_terms.diagnosis_words, quality=run_terms.model_quality)


def comparison():
    v = view()
    with v.db() as c:
        chosen = []
        for i in request.args.getlist("id", type=int):
            with contextlib.suppress(run_index.RunIndexError):  # gone since the page was drawn
                chosen.append(run_index.run(c, i)[0])
    chosen = [r for r in chosen if not r["error"]]
    error, made = None, None
    if len(chosen) < 2:
        error = "Choose two or more readable runs to compare (tick them in the runs table)."
    else:
        paths = [r["path"] for r in chosen]
        try:
            made = v.page("compare", paths, lambda out: compare(paths, out, v.units))
        except PAGE_ERRORS as e:
            error = str(e).splitlines()[0]
    return render_template("compare.html", chosen=chosen, page=made, error=error), 400 if error else 200


def trend():
    v = view()
    serial, quantity = request.args.get("serial", ""), request.args.get("quantity", "rebound@0.5m/s")
    points, error, png = [], None, None
    with v.db() as c:
        serials = run_index.serials(c)
        if serial:
            try:
                points = run_index.trend(c, serial, quantity)
            except run_index.RunIndexError as e:
                error = str(e)
    if points:
        png = f"trend-{hashlib.sha1(repr((serial, quantity, points)).encode()).hexdigest()[:16]}.png"
        with v.made:
            if not (v.cache / png).exists():
                trend_report.figure(points, serial, quantity, v.cache / png, v.units)
    return render_template("trend.html", serials=serials, serial=serial, quantity=quantity, points=points, png=png,
                           error=error), 400 if error else 200


def qa():
    with view().db() as c:
        rows = run_index.checks(c)
    return render_template("qa.html", rows=[dict(r, verdict=_verdict(r)) for r in rows])


def live():
    return render_template("live.html", runs=in_progress(view().folder))


def live_json():
    return {"runs": [r.as_json(view().units) for r in in_progress(view().folder)]}


def made_file(name):
    return send_from_directory(view().cache, name)


def _verdict(check) -> str:
    if check is None:
        return ""
    from views.reports.qa import verdict
    return verdict(check["points"], check["failed"])


def _model(path):
    """The run's identified model (RECORDING.model.json) to overlay, if there is one."""
    model = Path(path).with_suffix(".model.json")
    return load_damper(str(model)) if model.is_file() else None
