"""The test sheet: page 1 of the printed report, the page a lab files and signs. Which damper
(serial, setup, note), how it was tested (protocol, rig, each channel's instrument and
calibration date), the conditions measured (body temperature at the start and the end, gas
force), the force-velocity curve with its table, the verdict against a reference when one
is given (the same as `dyno check`), the software, the recording's name and SHA-256, and a
sign-off. Traceability as ISO/IEC 17025 asks: instrument, calibration, method, software.

What the recording does not say is printed "not given", never left out: a blank on a
signed sheet reads as "checked, nothing to say"."""
from __future__ import annotations

import hashlib
import json
from datetime import datetime, timezone
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from records.recorder import software
from views.reports.velocity_table import html_table
from protocols.units import Units, fmt

NOT_GIVEN = "not given"
SHEET_NAMES = ("shaft speed", "compression", "rebound", "damping, compression", "damping, rebound")  # spelled out
# the channels whose instrument a sheet names: what the curve and the conditions are read from
TRACED = ("force", "x", "v", "T_body", "P_gas")
CHANNEL_NAMES = {"force": "force (load cell)", "x": "displacement", "v": "velocity", "T_body": "body temperature",
                 "P_gas": "gas pressure"}


@dataclass
class Sheet:
    """What page 1 says, as text already in the chosen units; figures by file name."""
    template = "sheet.html"
    title: str
    identity: list  # [(label, text)]
    test: list  # [(label, text)]: protocol, rig, started, operator
    channels: list  # [(channel, instrument, calibrated)]
    conditions: list  # [(label, text)]
    curve: tuple | None  # (title, PNG beside the page), or None without a curve
    table: tuple | None  # (header, rows) of the velocity table
    verdict: str | None  # "PASS: ..." / "FAIL: ..." against the reference, None without one
    reference: str  # what the verdict is against, or how to get one
    traceability: list  # [(label, text)]: software, file, SHA-256
    signoff: list = field(default_factory=list)  # [(role, name already known or "")]
    table_note: str = ""  # what the velocity table leaves out (velocity_table.repeats_note)

    @property
    def passed(self):
        return None if self.verdict is None else self.verdict.startswith("PASS")

    def blocks(self):
        """The sheet as a page's plain blocks (views/reports/page.py), where it cannot be
        typeset (the PDF's fallback without WeasyPrint)."""
        return [("items", [*self.identity, *self.test, *self.conditions,
                           ("verdict", f"{self.verdict}, against {self.reference}" if self.verdict else self.reference)]),
                *([("table", self.table)] if self.table else []),
                *([("paragraph", self.table_note)] if self.table and self.table_note else []),
                *([("figure", self.curve[::-1])] if self.curve else []),
                ("table", (["channel", "instrument", "calibrated"], self.channels)),
                ("items", self.traceability + [(role, f"{name} ____ signature ____ date ____")
                                               for role, name in self.signoff])]


def sha256(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _identity(meta):
    run = meta.get("run", {})
    damper = json.loads(meta.get("damper", {}).get("model", "{}") or "{}")
    setup = ", ".join(f"{k.removeprefix('setup.')} {v}" for k, v in run.items() if k.startswith("setup."))
    return [("damper", damper.get("name") or NOT_GIVEN), ("serial", run.get("damper_serial") or NOT_GIVEN),
            ("setup", setup or NOT_GIVEN), ("note", run.get("note") or NOT_GIVEN)]


def _test(meta, params):
    run, proto = meta.get("run", {}), meta.get("protocol", {})
    started = str(run.get("wall_start", ""))[:19].replace("T", " ")
    return [("protocol", f"{proto.get('name', '?')}" + (f" ({params})" if params else "")),
            ("rig", meta.get("rig", {}).get("name") or NOT_GIVEN),
            ("started (UTC)", started or NOT_GIVEN), ("operator", run.get("operator") or NOT_GIVEN)]


def _channels(meta):
    """[(channel, instrument, calibrated)] of the recorded channels a sheet traces."""
    cal = {n: json.loads(v) for n, v in meta.get("calibration", {}).items()}
    rows = []
    for name in [n for n in TRACED if n in cal] + sorted(n for n in cal if n.startswith("aux.")):
        c = cal[name]
        rows.append((CHANNEL_NAMES.get(name, name),
                     c.get("sensor") or f"{NOT_GIVEN} ({c.get('device', '?')}.{c.get('signal', '?')})",
                     c.get("calibrated") or NOT_GIVEN))
    return rows


def _conditions(ch, gas_N, turns, units: Units, centred=False):
    """Body temperature at the start and the end and its range, gas force (a static test's,
    else at the stroke's turning points, records/gas_force.py; centred: the force reads as
    centred on zero by its source) and pressure."""
    out = []
    T_ = (lambda v: fmt(units.show("temperature", v), 3))
    if "T_body" in ch and len(ch["T_body"][1]):
        t, T = ch["T_body"]
        i = int(np.nanargmax(T))
        out.append(("body temperature", f"{T_(T[0])} {units.unit('temperature')} at the start, {T_(T[-1])} at the end; "
                                        f"{T_(np.nanmin(T))} to {T_(T[i])} over the run (highest at "
                                        f"{t[i] - t[0]:.4g} s)"))
    else:
        out.append(("body temperature", "not measured (no thermocouple channel)"))
    out.append(("gas force", _gas(gas_N, turns, units, centred)))
    if "P_gas" in ch and len(ch["P_gas"][1]):
        p = ch["P_gas"][1]
        out.append(("gas pressure", f"{fmt(units.show('pressure', p[0]), 3)} {units.unit('pressure')} at the start, "
                                    f"{fmt(units.show('pressure', p[-1]), 3)} at the end"))
    return out


def _at_turns(ch):
    """records/gas_force.at_turns of the channels (the displacement on the force's clock)."""
    from records.gas_force import at_turns
    if not ({"force", "x"} <= set(ch) and len(ch["x"][0]) > 1):
        return None
    (tF, F), (tx, x) = ch["force"], ch["x"]
    with np.errstate(all="ignore"):
        return at_turns(tF, np.interp(tF, tx, x), F)


def _gas(gas_N, gas, units: Units, centred=False) -> str:
    """The gas force a sheet states: a static test's range over the stroke, else the force at
    the stroke's turning points with its 95 % interval (gas: _at_turns), else not measured;
    unknown where the force reads as centred on zero by its source (its zero is not the
    load cell's, so no reading about it is the gas force), with what it reads there."""
    f = units.unit("force")
    if gas_N is not None and np.isfinite(gas_N[0]):
        lo, hi = (fmt(units.show("force", g), 3) for g in gas_N)
        return f"{lo} to {hi} {f} over the stroke (static test)" if lo != hi else f"{lo} {f} (static test)"
    if gas is None:
        return "not measured (no static test, too few turning points)"
    read = (f"{fmt(units.show('force', gas.level), 3)} ± {fmt(units.show('force', gas.half_width), 2)} {f} at the "
            f"turning points (friction cancelled, 95 %)")
    if centred:
        return f"unknown: the force is centred on zero (source data); about that zero it reads {read}"
    return read + ("; below zero: no gas spring's" if gas.below_zero else "")


def _centred(meta, ch, name, gas) -> bool:
    """Whether an imported file's channel reads as centred on zero by its source
    (records/gas_force.centred; gas: the force's at the turning points)."""
    from records.gas_force import centred
    imported = meta.get("protocol", {}).get("name") == "import"
    return imported and name in ch and centred(ch[name][1], gas if name == "force" else None)


def _source(meta, ch, gas) -> str:
    """What was done to the data between the sensor and this recording: by the source (a
    smoothing declared at import, a mean seen removed) and by the import (flips, gains,
    offsets, the units read), or "as recorded by dyno" for a run of ours."""
    from records.source_filter import of as filtered
    proto = meta.get("protocol", {})
    if proto.get("name") != "import":
        return "as recorded by dyno (each channel's calibration below)"
    given = json.loads(proto.get("params", "{}") or "{}")
    done = []
    smooth = filtered(meta)
    done += [f"smoothed by its source ({smooth.text()})"] if smooth else []
    done += [f"{unit} centred on zero (a mean removed, or zeroed mid-way)"
             for name, unit in (("x", "displacement"), ("force", "force")) if _centred(meta, ch, name, gas)]
    done += [f"{v} flipped at import" for v in given.get("flip", [])]
    done += [f"gain {v} at import" for v in given.get("gain", [])]
    done += [f"offset {v} at import" for v in given.get("offset", [])]
    units = [m.rsplit(":", 1)[1] for m in given.get("map", []) if "=" in m and ":" in m]
    done += [f"read in {', '.join(units)}"] if units else []
    return "; ".join(done) if done else "as recorded (no filter, flip, gain or offset)"


def sheet(path, meta, ch, params="", table=None, curve=None, gas_N=None, check=None, units=Units(),
          table_note="") -> Sheet:
    """The sheet of the recording at path (its metadata and channels already read); table:
    the velocity table ([VelocityRow]) or None, table_note: what it leaves out; curve: the force-velocity figure (title, PNG);
    gas_N: (lowest, highest) gas force of a static test [N]; check: (verdict sentence,
    what it is against) from views/reports/qa.py, or None."""
    identity, turns = _identity(meta), _at_turns(ch)  # the gas force at the turning points, read once
    named = [f"{'serial ' if k == 'serial' else ''}{v}" for k, v in identity[:2] if v != NOT_GIVEN]
    return Sheet(
        title="Damper test sheet" + (f": {', '.join(named)}" if named else ""),
        identity=identity, test=_test(meta, params), channels=_channels(meta),
        conditions=[("source data", _source(meta, ch, turns)),
                    *_conditions(ch, gas_N, turns, units, _centred(meta, ch, "force", turns))], curve=curve,
        table=html_table(table, units, SHEET_NAMES, measured_only=True) if table else None,
        verdict=check[0] if check else None,
        reference=check[1] if check else "no reference given (dyno report --against REF.mcap|MODEL|TABLE)",
        traceability=[("recorded with", _software(meta.get("software", {}))), ("printed with", printed_with()), ("recording", Path(path).name),
                      ("SHA-256", sha256(path))],
        signoff=[("tested by", meta.get("run", {}).get("operator", "")), ("checked by", "")], table_note=table_note)


@dataclass
class ComparisonSheet:
    """Page 1 of `dyno report A B C`: the runs' identities in one table, their curves overlaid,
    the force differences per shaft speed, and one verdict per run."""
    template = "comparison_sheet.html"
    title: str
    runs: tuple  # (header, rows): tag, damper, serial, setup, note, started, operator
    curve: tuple | None  # (title, PNG) of the curves overlaid
    table: tuple | None  # (how read, header, rows) of the velocity tables side by side
    verdicts: list  # [(tag, sentence, what against)]
    traceability: list  # [(tag, recording, SHA-256)]
    printed: str
    signoff: list = field(default_factory=lambda: [("tested by", ""), ("checked by", "")])

    def blocks(self):
        """As Sheet.blocks."""
        return [("table", self.runs), ("items", [(tag, f"{said}, against {against}") for tag, said, against in
                                                 self.verdicts]),
                *([("figure", self.curve[::-1])] if self.curve else []),
                *([("table", self.table[1:])] if self.table else []),
                ("table", (["run", "recording", "SHA-256"], self.traceability)),
                ("items", [("printed with", self.printed)] + [(role, "____ signature ____ date ____")
                                                             for role, _ in self.signoff])]


def _software(s: dict) -> str:
    """'dyno 0.1.0 (a806eb95f980)' of a software record (records/recorder.py software())."""
    return f"dyno {s.get('version', '?')}" + (f" ({s['commit']})" if s.get("commit") else "")


def printed_with() -> str:
    return _software(software())


def document(subject, author="dyno") -> list:
    """A page's document metadata (the PDF's Author, Subject, Creator and CreationDate)."""
    return [("author", author), ("description", subject), ("generator", f"dyno {software()['version']}"),
            ("dcterms.created", datetime.now(timezone.utc).isoformat(timespec="seconds"))]


def comparison(runs, curve, table, verdicts) -> ComparisonSheet:
    """runs: [(tag, path, meta)]; curve: the overlaid curves' (title, PNG); table: (how, header, rows)
    or None; verdicts: [(tag, sentence, against)]."""
    rows = []
    for tag, _, meta in runs:
        ident = dict(_identity(meta))
        test = dict(_test(meta, ""))
        rows.append([tag, ident["damper"], ident["serial"], ident["setup"], ident["note"],
                     test["protocol"], test["started (UTC)"], test["operator"]])
    names = ", ".join(f"{r[0]} {r[2] if r[2] != NOT_GIVEN else r[1]}" for r in rows)
    return ComparisonSheet(
        title=f"Damper comparison sheet: {names}",
        runs=(["run", "damper", "serial", "setup", "note", "protocol", "started (UTC)", "operator"], rows),
        curve=curve, table=table, verdicts=verdicts,
        traceability=[(tag, Path(path).name, sha256(path)) for tag, path, _ in runs], printed=printed_with())
