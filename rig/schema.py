"""The TOML schema primitives the rig configuration is checked with: typed fields (a
number is never a boolean or a string, always finite), ranges, choices, and FILE:LINE for
every problem with a "did you mean" for a near miss. The tables' contents are declared
where they belong (rig/config.py, each transport in rig/devices/)."""
from __future__ import annotations

import datetime
import difflib
import math
import re
from dataclasses import dataclass

from rig.errors import RigError


@dataclass(frozen=True)
class Field:
    kind: str  # "number", "integer", "string", "port" (an integer 1-65535 or "auto"), "date" (2026-03-01)
    required: bool = False
    lo: float | None = None
    hi: float | None = None
    above: float | None = None  # strictly greater than
    choices: tuple = ()
    nonzero: bool = False


def number(**kw):
    return Field("number", **kw)


def _header(parts):
    """Regex for the TOML table header [a.b.c], each part bare or quoted."""
    body = r"\s*\.\s*".join(rf"(?:{re.escape(p)}|\"{re.escape(p)}\"|'{re.escape(p)}')" for p in parts)
    return re.compile(rf"^\s*\[\s*{body}\s*\]")


def line_of(text, parts, key=None):
    """1-based line of the table `parts` (or of `key` inside it) in the TOML text, 0 if
    not found."""
    lines = text.splitlines()
    head = _header(parts)
    for i, ln in enumerate(lines):
        if head.match(ln):
            if key is None:
                return i + 1
            keyre = re.compile(rf"^\s*(?:{re.escape(key)}|\"{re.escape(key)}\")\s*=")
            for j in range(i + 1, len(lines)):
                if lines[j].lstrip().startswith("["):
                    break
                if keyre.match(lines[j]):
                    return j + 1
            return i + 1
    return 0


class Checker:
    """Checks tables of a parsed TOML document against the schema, naming FILE:LINE."""

    def __init__(self, text, where):
        self.text, self.where = text, where

    def fail(self, line, msg):
        raise RigError(f"{self.where}:{line or 1}: {msg}")

    def line(self, parts, key=None):
        return line_of(self.text, parts, key) or (line_of(self.text, parts[:1]) if len(parts) > 1 else 0)

    def table(self, data, parts, what):
        if not isinstance(data, dict):
            self.fail(self.line(parts[:-1], parts[-1]) or self.line(parts), f"{what}: expected a table "
                      f"[{'.'.join(parts)}], got {type(data).__name__} {data!r}"[:160])
        return data

    def fields(self, data, parts, schema, what):
        """Checked values of one table: unknown keys refused, types and ranges enforced."""
        for key in data:
            if key not in schema:
                near = difflib.get_close_matches(key, list(schema), n=1, cutoff=0.6)
                self.fail(self.line(parts, key), f"{what}: unknown key {key!r}"
                          + (f"; did you mean {near[0]!r}?" if near else f" (known: {', '.join(schema)})"))
        out = {}
        for key, f in schema.items():
            if key not in data:
                if f.required:
                    self.fail(self.line(parts), f"{what}: missing {key!r}")
                continue
            out[key] = self.value(data[key], f, f"{what}: {key}", self.line(parts, key))
        return out

    def value(self, v, f, what, line):
        if f.kind == "string":
            if not isinstance(v, str) or not v.strip():
                self.fail(line, f"{what}: expected a text in quotes, got {v!r}")
            if f.choices and v not in f.choices:
                self.fail(line, f"{what}: {v!r} is not one of {', '.join(f.choices)}")
            return v
        if f.kind == "date":  # a TOML date, or the same in quotes; kept as its ISO text
            text = v.isoformat() if isinstance(v, datetime.date) and not isinstance(v, datetime.datetime) else v
            try:
                return datetime.date.fromisoformat(text).isoformat()
            except (TypeError, ValueError):
                self.fail(line, f"{what}: expected a date like 2026-03-01, got {v!r}")
        if f.kind == "port":
            if v == "auto":
                return v
            if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 65535:
                self.fail(line, f"{what}: expected a port number 1-65535, got {v!r}")
            return v
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (f.kind == "integer" and not isinstance(v, int)):
            self.fail(line, f"{what}: expected {'an integer' if f.kind == 'integer' else 'a number'}, got {v!r}")
        if not (abs(v) < 1e300 if isinstance(v, int) else math.isfinite(v)):  # an int beyond any float
            self.fail(line, f"{what}: must be a finite number, got {v!r}")
        if f.nonzero and v == 0:
            self.fail(line, f"{what}: must not be zero")
        if f.above is not None and not v > f.above:
            self.fail(line, f"{what}: must be above {f.above:g}, got {v!r}")
        if f.lo is not None and v < f.lo or f.hi is not None and v > f.hi:
            self.fail(line, f"{what}: must be within {f.lo if f.lo is not None else f.above:g}.."
                            f"{f.hi:g}, got {v!r}")
        return v
