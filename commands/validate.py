"""`dyno validate`: the thesis validation table, each row with the reading of the thesis
it rests on (models/validation/readings.toml), the experiment apart from the thesis's
model where the thesis gives both, and, with --sensitivity, what unstated value would
reconcile a missed row."""
from __future__ import annotations

import sys
from pathlib import Path

from commands.arguments import FOLDER, overwrite, writes

SEED = "../shared/seed/000_79c7770b026c394b.txt"


def add(sub):
    """The `dyno validate` command's arguments."""
    v = sub.add_parser("validate", help="reproduce the thesis validation table")
    v.add_argument("--json", action="store_true", help="machine-readable {\"rows\": [...]}")
    v.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    v.add_argument("--sensitivity", action="store_true",
                   help="for each missed step row, the install position that would reconcile it (slower)")
    writes(v, "--report", FOLDER, metavar="DIR", help="also write the step and ride-height figures there")
    overwrite(v, "--report's figures")
    v.set_defaults(command="validate")


def _err(x, key):
    v = x.get(key)
    if v is None:
        return "-"
    return f"{v:.3g} {x['unit']}" if x["tolerance_type"] == "absolute" else f"{100 * v:.1f} %"


def _closer(x):
    """Is our model nearer the thesis's experiment than the thesis's own model?"""
    ours, theirs = x.get("model_vs_experiment"), x.get("thesis_vs_experiment")
    return ours is not None and theirs is not None and ours < theirs


def _cells(x):
    tol = (f"±{x['tolerance']:g} {x['unit']}" if x["tolerance_type"] == "absolute"
           else f"{100 * x['tolerance']:.0f} %")
    exp = x.get("experiment")
    closer = " (closer)" if _closer(x) else ""
    return (x["source"], x["case"], x["unit"], f"{x['thesis']:.4g}", f"{x['model']:.4g}",
            "-" if x["rel_error"] is None else f"{100 * x['rel_error']:.1f} %", tol,
            "PASS" if x["pass"] else "**FAIL**", "-" if exp is None else f"{exp:.4g}",
            _err(x, "thesis_vs_experiment"), _err(x, "model_vs_experiment") + closer,
            ", ".join(x.get("reading", [])), x.get("sensitivity") or "-")


HEADER = ("source", "case", "unit", "thesis model", "ours", "error", "tolerance", "pass", "experiment",
          "thesis model vs experiment", "ours vs experiment", "reading", "sensitivity")


def _readings_table():
    from models.validation import readings
    from views.reports import markdown as md
    return md.table(("reading", "how the test is read", "seed line", "where the text is silent or contradicts"),
                    [(k, v["reading"], v["line"], v.get("ambiguity", "-")) for k, v in readings().items()])


def _report(path, kept):
    """The figures, written into a temporary folder that becomes `path` once all are done."""
    from models.validation import quarter_car
    from records.files import filled
    from views.reports import validation as figures
    with filled(path, "--report") as folder:
        figures.plot_steps(kept["steps"], quarter_car.STEPS, folder / "steps.png", quarter_car.SETTLE_S)
        figures.plot_ride_height(kept["sweeps"], quarter_car.TABLE_6_6, folder / "ride-height.png")
    return [Path(path) / "steps.png", Path(path) / "ride-height.png"]


def run(args):
    from models.validation import format_table, rows
    from commands.output import emit
    from records.files import output_folder
    from views.reports import markdown as md
    if args.report:  # checked before the minute of simulation, not after
        output_folder(args.report, overwrite=args.overwrite, what="--report")
    kept = {} if args.report else None
    r = rows(sensitivity=args.sensitivity, kept=kept)
    body = [f"How each test is read, with the line of the seed text ({SEED}) it rests on:\n\n"
            + _readings_table()]
    for group in dict.fromkeys(x["group"] for x in r):
        g = [x for x in r if x["group"] == group]
        body.append(f"## {group} rows: {sum(x['pass'] for x in g)} of {len(g)} pass\n\n"
                    + md.table(HEADER, [_cells(x) for x in g]))
    n = sum(x["pass"] for x in r)
    closer = sum(1 for x in r if not x["pass"] and _closer(x))
    note = (f"{n} of {len(r)} rows pass; {closer} of the misses are closer to the experiment than the thesis's "
            f"own model. A row passes against the thesis's model (analytical) column, to the tolerance declared "
            f"before looking. Sensitivity: the value of an unstated parameter that would reconcile a missed row, "
            f"reported, never applied. Method: docs/model.md.")
    code = emit(args, "Validation against the thesis", {"rows": r}, format_table(r), "\n\n".join(body), note)
    if args.report:
        for png in _report(args.report, kept):
            print(f"figure: {png}", file=sys.stderr)
    return code
