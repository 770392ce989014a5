"""The browser view of a folder of recordings (`dyno serve`, issue 33): the run catalogue's
table to filter, sort and search; a run's report; runs overlaid; a serial's trend; the QA
checks; and the runs being recorded now. Flask, with the report's own figures (matplotlib)
made on first view into a folder of the server's and kept while it runs. Read-only toward
the rig: it reads recordings and the catalogue, and indexes new recordings as they appear.
"""
from __future__ import annotations

import hashlib
import json
import tempfile
import threading
import time
from pathlib import Path
from urllib.parse import urlencode

from flask import Flask, abort, render_template, request, send_from_directory, url_for

from models.damper import DamperError
from models.damper import load as load_damper
from protocols import catalogue
from protocols.reports import trend as trend_report
from protocols.reports.comparison import compare
from protocols.reports.recording import report
from protocols.units import Units, fmt
from protocols.web.in_progress import in_progress
from rig.errors import RigError

REINDEX_S = 5.0  # new recordings show up on the runs page within this
COLUMNS = {"id": "id", "started": "started", "serial": "serial", "damper": "damper", "protocol": "protocol",
           "duration_s": "duration [s]", "outcome": "outcome", "qa": "QA", "path": "file"}
SEARCHED = ("serial", "damper", "note", "operator", "protocol", "path", "setup")


def create_app(folder, units=Units(), cache=None, reindex_s=REINDEX_S) -> Flask:
    """The view of `folder`'s recordings; made pages and figures go to `cache` (a new
    temporary folder by default); new recordings are indexed at most every reindex_s."""
    folder = Path(folder).resolve()
    cache = Path(cache or tempfile.mkdtemp(prefix="dyno-serve-"))
    app = Flask(__name__)
    made = threading.Lock()  # one figure-making at a time: matplotlib and two cores
    last_index = [0.0]

    def db():
        if time.monotonic() - last_index[0] >= reindex_s:
            catalogue.index(folder)
            last_index[0] = time.monotonic()
        return catalogue.connect(folder)

    @app.template_filter("urlencode_sort")
    def sorted_by(args, key, desc):
        return urlencode({**args, "sort": key, "desc": desc})

    @app.context_processor
    def shared():
        return {"folder": folder, "units": units, "fmt": fmt, "live_count": len(in_progress(folder))}

    @app.route("/")
    def runs():
        a = request.args
        error, rows = None, []
        with db() as c:
            try:
                rows = catalogue.runs(c, serial=a.get("serial") or None, since=a.get("since") or None,
                                      protocol=a.get("protocol") or None, where=a.get("where") or None)
            except catalogue.CatalogueError as e:
                error = str(e)
            checks = catalogue.latest_checks(c)
            serials = [r[0] for r in c.execute("SELECT DISTINCT serial FROM runs WHERE serial IS NOT NULL "
                                               "ORDER BY serial")]
        rows = [dict(r, qa=_verdict(checks.get(r["id"]))) for r in rows]
        q = a.get("q", "").strip().lower()
        if q:
            rows = [r for r in rows if any(q in str(r[k] or "").lower() for k in SEARCHED)]
        key = a.get("sort", "started")
        if key in COLUMNS:
            rows.sort(key=lambda r: (r[key] is None, r[key] if r[key] is not None else 0),
                      reverse=a.get("desc") == "1")
        return render_template("runs.html", rows=rows, columns=COLUMNS, sort=key, desc=a.get("desc") == "1",
                               args=a, error=error, serials=serials), 400 if error else 200

    @app.route("/run/<int:run_id>")
    def run(run_id):
        with db() as c:
            try:
                row, peaks = catalogue.run(c, run_id)
            except catalogue.CatalogueError:
                abort(404)
            checks, models, diagnoses = (catalogue.attached(c, t, run_id) for t in ("checks", "models", "diagnoses"))
        made_report, error = None, row["error"]
        if not error:
            try:
                made_report = _made(f"run-{run_id}", [row["path"]], lambda out: report(
                    row["path"], out, _model(row["path"]), units=units))
            except (RigError, DamperError, OSError, ValueError) as e:
                error = str(e).splitlines()[0]
        return render_template("run.html", row=row, setup=json.loads(row["setup"] or "{}"), peaks=peaks,
                               checks=checks, models=models, diagnoses=diagnoses, report=made_report, error=error,
                               accepted=lambda d: ", ".join(json.loads(d["accepted"])) or "nothing")

    @app.route("/compare")
    def comparison():
        ids = request.args.getlist("id", type=int)
        with db() as c:
            chosen = [c.execute("SELECT * FROM runs WHERE id = ?", (i,)).fetchone() for i in ids]
        chosen = [r for r in chosen if r is not None and not r["error"]]
        error, made_page = None, None
        if len(chosen) < 2:
            error = "Choose two or more readable runs to compare (tick them in the runs table)."
        else:
            try:
                made_page = _made("compare", [r["path"] for r in chosen],
                                  lambda out: compare([r["path"] for r in chosen], out, units))
            except (RigError, OSError, ValueError) as e:
                error = str(e).splitlines()[0]
        return render_template("compare.html", chosen=chosen, page=made_page, error=error), 400 if error else 200

    @app.route("/trend")
    def trend():
        serial, quantity = request.args.get("serial", ""), request.args.get("quantity", "rebound@0.5m/s")
        with db() as c:
            serials = [r[0] for r in c.execute("SELECT DISTINCT serial FROM runs WHERE serial IS NOT NULL "
                                               "ORDER BY serial")]
            points, error, png = [], None, None
            if serial:
                try:
                    points = catalogue.trend(c, serial, quantity)
                except catalogue.CatalogueError as e:
                    error = str(e)
        if points:
            key = hashlib.sha1(repr((serial, quantity, points)).encode()).hexdigest()[:16]
            png = f"trend-{key}.png"
            with made:
                if not (cache / png).exists():
                    trend_report.figure(points, serial, quantity, cache / png, units)
        return render_template("trend.html", serials=serials, serial=serial, quantity=quantity, points=points,
                               png=png, error=error), 400 if error else 200

    @app.route("/qa")
    def qa():
        with db() as c:
            rows = c.execute("SELECT k.*, r.serial, r.damper, r.path FROM checks k JOIN runs r ON r.id = k.run_id "
                             "ORDER BY k.rowid DESC").fetchall()
        return render_template("qa.html", rows=[dict(r, verdict=_verdict(r)) for r in rows])

    @app.route("/live")
    def live():
        return render_template("live.html", runs=in_progress(folder))

    @app.route("/made/<path:name>")
    def made_file(name):
        return send_from_directory(cache, name)

    def _made(kind, paths, make):
        """The folder (under cache) a page for these recordings was made in, made first if
        the recordings are new or changed since."""
        stamp = [(p, Path(p).stat().st_mtime_ns, Path(p).stat().st_size) for p in paths]
        name = f"{kind}-{hashlib.sha1(repr(stamp).encode()).hexdigest()[:16]}"
        with made:
            if not (cache / name / "index.html").exists():
                make(cache / name)
        return url_for("made_file", name=f"{name}/index.html")

    return app


def _verdict(check) -> str:
    if check is None:
        return ""
    return f"FAIL {check['failed']}/{check['points']}" if check["failed"] else f"PASS {check['points']}"


def _model(path):
    """The run's identified model (RECORDING.model.json) to overlay, if there is one."""
    model = Path(path).with_suffix(".model.json")
    return load_damper(str(model)) if model.is_file() else None
