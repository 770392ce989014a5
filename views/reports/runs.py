"""The run index (views/run_index.py) as a person reads it: the list of runs, and
one run's page (identity, setup, outcome, peaks, and the checks, models and diagnoses made
of it), for `dyno runs list` and `dyno runs show`."""
from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

from views.reports import markdown as md

LIST = ("id", "started", "serial", "damper", "protocol", "duration_s", "outcome", "path")


def _cell(row, k):
    v = row[k]
    if k == "path":
        return Path(v).name
    if k == "duration_s" and v is not None:
        return f"{v:.0f}"
    if k == "outcome" and row["error"]:
        return f"unreadable: {row['error']}"
    if k == "started" and v is None and not row["error"]:
        return "unknown"
    return "-" if v is None else v


def run_list(rows) -> str:
    """The runs as a table, oldest first."""
    return md.table(LIST, [[_cell(r, k) for k in LIST] for r in rows]) if rows else "no runs match"


def _shown(key, value):
    """A run index field as a person reads it: file times as UTC dates, durations in s."""
    if key == "mtime":
        return datetime.fromtimestamp(value, timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    if key == "started":
        try:
            return datetime.fromisoformat(value).astimezone(timezone.utc).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3] + " UTC"
        except ValueError:
            return value
    if key == "duration_s":
        return f"{value:.1f}"
    return value


def run_page(row, peaks, checks, models, diagnoses, units) -> str:
    """One run's page: its run index row's fields, then its peaks, checks, models and
    diagnoses as tables, in the chosen units."""
    from views import run_terms
    from protocols.units import fmt
    out = [f"{k:11s} {_shown(k, row[k])}" for k in row.keys() if row[k] not in (None, "", "{}")]
    V, F = (lambda si, q=q: fmt(units.show(q, si)) for q in ("velocity", "force"))
    if peaks:
        out.append("\n" + md.table(
            ("segment", *(units.label(n, q) for n, q in (("v comp", "velocity"), ("F comp", "force"),
                                                         ("v reb", "velocity"), ("F reb", "force")))),
            [(p["segment"], V(p["v_comp"]), F(p["F_comp"]), V(p["v_reb"]), F(p["F_reb"])) for p in peaks]))
    if checks:
        from views.reports.qa import verdict
        out.append("\n" + md.table(
            ("checked (UTC)", "against", "tolerance", "verdict", units.label("worst margin", "force")),
            [(k["checked"], k["reference"], k["tolerance"], verdict(k["points"], k["failed"]), F(k["worst_margin_n"]))
             for k in checks]))
    if models:
        out.append("\n" + md.table(
            ("identified (UTC)", "model", "held-out NRMSE [%]"),
            [(m["identified"], m["model"], run_terms.model_quality(m["heldout_nrmse"])) for m in models]))
    if diagnoses:
        out.append("\n" + md.table(
            ("diagnosed (UTC)", "baseline", "effects", "left over"),
            [(d["diagnosed"], d["baseline"], run_terms.diagnosis_words(d),
              "within the noise" if d["within_noise"] else "above the noise") for d in diagnoses]))
    return "\n".join(out)
