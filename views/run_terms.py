"""The run index's terms, both ways: what a user asks it (`runs list --where`,
`--since`, `runs trend --quantity`) parsed into SQL and SI, and how its rows are said (a
diagnosis's named effects, a model's held-out error). views/run_index.py reads and writes
the file."""
from __future__ import annotations

import json
import re
from datetime import datetime, timezone

from rig.errors import UsageError
from protocols.units import parse_with_unit


class RunIndexError(UsageError, ValueError):
    """A query the run index cannot answer, or a run index file it cannot use; the message
    says why in one line."""


FIELDS = ("serial", "operator", "note", "damper", "rig", "protocol", "started", "duration_s", "outcome", "reason",
          "path")
OPS = {"=": "=", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">=", "~": "LIKE"}
MAX_TERMS, MAX_WHERE_CHARS = 32, 4000  # a filter a person writes; SQLite's own limits are far above
TERM = re.compile(r"\s*(setup\.[\w.-]+|\w+)\s*(!=|<=|>=|=|<|>|~)\s*(\"[^\"]*\"|'[^']*'|[^\s'\"]+)\s*")


def condition(text):
    """(SQL, arguments) of `dyno runs list --where`: terms FIELD OP VALUE joined by `and`;
    FIELD one of FIELDS or setup.KEY, OP one of = != < <= > >= ~ (contains), VALUE a
    number or text (quoted if it has spaces). RunIndexError names what is wrong."""
    sql, args = [], []
    parts = re.split(r"\s+and\s+", text.strip(), flags=re.I)
    if len(parts) > MAX_TERMS:
        raise RunIndexError(f"--where: {len(parts)} conditions; at most {MAX_TERMS}")
    if len(text) > MAX_WHERE_CHARS:
        raise RunIndexError(f"--where: {len(text)} characters; at most {MAX_WHERE_CHARS}")
    for part in parts:
        m = TERM.fullmatch(part)
        if m is None:
            raise RunIndexError(f"--where: {part!r} is not FIELD OP VALUE (OP one of {' '.join(OPS)})")
        field, op, value = m.groups()
        value = value[1:-1] if value[:1] in "'\"" else value
        if field.startswith("setup."):
            column, args_ = "json_extract(setup, ?)", ["$." + json.dumps(field[len("setup."):])]
        elif field in FIELDS:
            column, args_ = field, []
        else:
            raise RunIndexError(f"--where: no field {field!r} (fields: {', '.join(FIELDS)}, setup.KEY)")
        try:
            number = float(value)
        except ValueError:
            number = None
        if op == "~":
            value = f"%{value}%"
        elif number is not None:
            column, value = f"CAST({column} AS REAL)", number
        sql.append(f"{column} {OPS[op]} ?")
        args += [*args_, value]
    return "(" + " AND ".join(sql) + ")", args


MAX_SPEED = 20.0  # m/s: beyond any damper dyno


def quantity(text):
    """("compression" | "rebound", speed [m/s]) from e.g. "rebound@0.5m/s", "rebound@500mm/s"
    or "compression@10in/s": any velocity unit units.toml names."""
    direction, at, speed_text = text.replace(" ", "").partition("@")
    if direction not in ("compression", "rebound") or not at:
        raise RunIndexError(f"--quantity {text!r}: give DIRECTION@SPEED with a unit, e.g. rebound@0.5m/s "
                             f"(DIRECTION: compression or rebound)")
    try:
        speed = parse_with_unit("velocity", speed_text)
    except ValueError as e:
        raise RunIndexError(f"--quantity {text!r}: the speed {e}") from None
    if not 0 < speed <= MAX_SPEED:
        raise RunIndexError(f"--quantity {text!r}: a speed above 0 and at most {MAX_SPEED:g} m/s")
    return direction, speed


def since_time(text):
    """A --since filter as the run index stores start times (ISO, UTC): a date or a date and
    time; RunIndexError otherwise ("yesterday" matched nothing without a word)."""
    if text is None:
        return None
    try:
        t = datetime.fromisoformat(text.strip())
    except ValueError:
        raise RunIndexError(f"--since {text!r}: not a date: give YYYY-MM-DD or YYYY-MM-DDTHH:MM (UTC)") from None
    return (t.astimezone(timezone.utc) if t.tzinfo else t).isoformat()  # compared as the stored UTC text


def diagnosis_words(row) -> str:
    """A catalogued diagnosis's effects as the diagnosis says them (docs/diagnosis.md): those
    named, then those kept in the model but not named (small, a rival group's, a stand-in's).
    A diagnosis catalogued before findings carried `named` listed the named ones alone."""
    accepted, findings = json.loads(row["accepted"] or "[]"), json.loads(row["findings"] or "[]")
    named = [f["effect"] for f in findings if f.get("named", True) and f["effect"] in accepted]
    unnamed = [e for e in accepted if e not in named]
    return ("named: " + (", ".join(named) or "nothing")
            + (f"; also in the model, not named: {', '.join(unnamed)}" if unnamed else ""))


def model_quality(nrmse) -> str:
    """A catalogued model's held-out error [%], marked poor beyond POOR_NRMSE."""
    from models.identify.result import POOR_NRMSE
    if nrmse is None:
        return "-"
    return f"{100 * nrmse:.2f}" + (f" (poor: beyond {100 * POOR_NRMSE:g} %)" if nrmse > POOR_NRMSE else "")
