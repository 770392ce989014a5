"""`dyno runs index|list|show|trend`: the run index (views/run_index.py) of a
folder of recordings, one SQLite file beside them."""
from __future__ import annotations

import json
import sys
from contextlib import closing
from pathlib import Path

from rig.errors import UsageError
from commands.arguments import FILE, overwrite, setup_item, units, writes


def add(sub):
    """The `dyno runs` command's arguments."""
    rs = sub.add_parser("runs", help="find and trend runs: a run index of a folder of recordings")
    rsub = rs.add_subparsers(dest="what", required=True)
    ri = rsub.add_parser("index", help="index the folder's recordings (incremental; unreadable files kept as errors)")
    ri.add_argument("dir", nargs="?", default="recordings")
    ri.set_defaults(command="runs:index")
    rl = rsub.add_parser("list", help="the runs, oldest first")
    rl.add_argument("dir", nargs="?", default="recordings")
    rl.add_argument("--serial", help="one damper serial")
    rl.add_argument("--since", help="started on or after this UTC date or time (ISO 8601, e.g. 2026-03-01)")
    rl.add_argument("--protocol", help="one protocol (sine-matrix, standard, ...)")
    rl.add_argument("--where", metavar="EXPR", help='conditions FIELD OP VALUE joined by "and": OP = != < <= > >= ~ '
                    '(contains); FIELD serial, operator, note, damper, protocol, started, duration_s, outcome, ... or '
                    'setup.KEY, e.g. "setup.clicks >= 10 and outcome = completed"')
    rl.add_argument("--json", action="store_true")
    rl.set_defaults(command="runs:list_runs")
    rw = rsub.add_parser("show", help="one run: identity, setup, outcome and its peaks")
    rw.add_argument("id", type=int)
    rw.add_argument("dir", nargs="?", default="recordings")
    rw.add_argument("--json", action="store_true", help="everything in SI, as the run index holds it")
    units(rw)
    rw.set_defaults(command="runs:show")
    re_ = rsub.add_parser("edit", help="correct a run's serial, operator, note or setup KEY=VALUE ('' removes one)")
    for a, kw in (("id", {"type": int}), ("dir", {"nargs": "?", "default": "recordings"}), ("--serial", {}),
                  ("--operator", {}), ("--note", {}), ("--setup", {"action": "append", "type": setup_item, "default": []})):
        re_.add_argument(a, **kw)
    re_.set_defaults(command="runs:edit")
    rt = rsub.add_parser("trend", help="a serial's force at one speed over its runs")
    rt.add_argument("dir", nargs="?", default="recordings")
    rt.add_argument("--serial", required=True)
    rt.add_argument("--quantity", required=True, help="DIRECTION@SPEED, e.g. rebound@0.5m/s or compression@10in/s")
    writes(rt, "--out", FILE, help="also plot it to this PNG (or .svg, .pdf)")
    overwrite(rt, "--out")
    units(rt)
    rt.set_defaults(command="runs:trend")


def _folder(args):
    folder = Path(args.dir)
    if not folder.is_dir():
        raise UsageError(f"{folder}: no such folder of recordings")
    return folder


def _connect(args):
    """The folder's run index, read-only: listing never changes it."""
    from views import run_index
    return run_index.reading(_folder(args))


def index(args):
    from views import run_index
    n = run_index.index(_folder(args))
    print(f"{args.dir}: {n.added} added, {n.updated} updated, {n.unchanged} unchanged, {n.failed} unreadable "
          f"(kept with their error)" + (f", {n.writing} being recorded (indexed once finished)" if n.writing else "")
          + f" -> {Path(args.dir) / run_index.DB_NAME}")
    return 0


def list_runs(args):
    from views import run_index
    from views.reports.runs import run_list
    with _connect(args) as c:
        rows = run_index.runs(c, serial=args.serial, since=args.since, protocol=args.protocol,
                              where=getattr(args, "where", None))
    if args.json:
        print(json.dumps([dict(r) for r in rows], indent=1))
    else:
        print(run_list(rows))
    return 0


def show(args):
    from views import run_index
    from views.reports.runs import run_page
    with _connect(args) as c:
        row, peaks = run_index.run(c, args.id)
        checks, models, diagnoses = (run_index.attached(c, t, args.id) for t in ("checks", "models", "diagnoses"))
    if args.json:
        print(json.dumps({**dict(row), "peaks": [dict(p) for p in peaks], "checks": [dict(k) for k in checks],
                          "models": [dict(m) for m in models], "diagnoses": [dict(d) for d in diagnoses]}, indent=1))
        return 0
    print(run_page(row, peaks, checks, models, diagnoses, args.units))
    return 0


def trend(args):
    from views import run_index
    from records.files import written
    from views.reports import markdown as md
    from protocols.units import fmt
    from views.reports import trend as trend_report
    kind = Path(args.out).suffix.lower().lstrip(".") if args.out else None
    if args.out and kind not in trend_report.FORMATS:
        raise UsageError(f"--out {args.out}: a figure is written as .{', .'.join(trend_report.FORMATS)}")
    with _connect(args) as c:
        points = run_index.trend(c, args.serial, args.quantity)
    if not points:
        raise UsageError(f"no readable runs of serial {args.serial!r} in {args.dir}")
    units = args.units
    print(md.table(("started", units.label(args.quantity, "force"), "run id", "setup"),
                   [(s or "unknown", fmt(units.show("force", F)), i, setup or "-") for s, F, i, setup in points]))
    if args.out:
        with written(args.out) as tmp:
            trend_report.figure(points, args.serial, args.quantity, tmp, units, kind)
        print(f"figure: {args.out}", file=sys.stderr)
    return 0


def edit(args):
    """`dyno runs edit ID --serial/--operator/--note/--setup KEY=VALUE`: what was typed wrong
    or left out at the run, in the recording's metadata and its run index row both."""
    from views import run_index
    from records.recorder import edit_run_info
    changes = {k: v for k, v in (("damper_serial", args.serial), ("operator", args.operator), ("note", args.note))
               if v is not None}
    changes.update({f"setup.{k}": v for k, v in args.setup})
    if not changes:
        raise UsageError("runs edit: nothing to change: give --serial, --operator, --note or --setup KEY=VALUE")
    with closing(run_index.connect(_folder(args))) as c:
        row, _ = run_index.run(c, args.id)
        new = edit_run_info(row["path"], changes)
        run_index.index_file(c, row["path"])
    print(f"run {args.id} ({Path(row['path']).name}): " + ", ".join(f"{k} {new.get(k, '(removed)')}" for k in changes))
    return 0
