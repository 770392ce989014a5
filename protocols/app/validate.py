"""`dyno validate`: the thesis validation table."""
from __future__ import annotations

from models.validation import format_table, rows
from protocols.app.output import emit
from protocols.reports import markdown as md


def run(args):
    r = rows()
    body = []
    for group in dict.fromkeys(x["group"] for x in r):
        g = [x for x in r if x["group"] == group]
        body.append(f"## {group} rows: {sum(x['pass'] for x in g)} of {len(g)} pass\n\n" + md.table(
            ("source", "case", "unit", "thesis", "model", "error", "tolerance", "pass", "kind"),
            [(x["source"], x["case"], x["unit"], f"{x['thesis']:.4g}", f"{x['model']:.4g}",
              "-" if x["rel_error"] is None else f"{100 * x['rel_error']:.1f} %",
              f"±{x['tolerance']:g} {x['unit']}" if x["tolerance_type"] == "absolute" else f"{100 * x['tolerance']:.0f} %",
              "PASS" if x["pass"] else "**FAIL**", x["note"]) for x in g]))
    n = sum(x["pass"] for x in r)
    return emit(args, "Validation against the thesis", {"rows": r}, format_table(r), "\n\n".join(body),
                 f"{n} of {len(r)} rows pass. Why rows fail: docs/model.md.")
