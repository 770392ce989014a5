"""The run index: one SQLite file beside the recordings (WAL, no server) indexing each
recording's identity, setup, protocol, duration, outcome and sine peaks, and what was made of
it later (QA checks, models, diagnoses). Readers (the CLI, the web view) use these functions:
no SQL elsewhere. Indexing is incremental and idempotent; an unreadable file is a row with
its error; each run is one transaction, safe beside other writers. What a user asks of it
and how its rows are said: views/run_terms.py. SI inside; times as ISO 8601 UTC."""
from __future__ import annotations

import json
import os
import sqlite3
import time
from contextlib import closing, contextmanager, suppress
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from records.events import Fault, OperatorStop
from records.data import segments
from records.files import writer
from records.reader import load_recording
from records.recorder import UNDATED
from views.reports import peaks as peak_rows
from views.reports import velocity_table as vt
from views.run_terms import RunIndexError, condition, quantity, since_time

DB_NAME = "dyno-runs.sqlite"
BUSY_MS = 10_000
SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY, path TEXT UNIQUE NOT NULL, size INTEGER, mtime REAL,
    serial TEXT, operator TEXT, note TEXT, setup TEXT, damper TEXT, rig TEXT,
    protocol TEXT, params TEXT, started TEXT, duration_s REAL, outcome TEXT, reason TEXT, error TEXT);
CREATE TABLE IF NOT EXISTS peaks (
    run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE, segment TEXT,
    amplitude_mm REAL, freq_hz REAL, target_c REAL, v_comp REAL, F_comp REAL, v_reb REAL, F_reb REAL,
    stroke_v TEXT, stroke_F TEXT);
CREATE TABLE IF NOT EXISTS checks (
    run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE, checked TEXT, reference TEXT,
    tolerance TEXT, points INTEGER, failed INTEGER, worst_margin_n REAL);
CREATE TABLE IF NOT EXISTS models (
    run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE, identified TEXT, model TEXT,
    heldout_nrmse REAL, parameters TEXT);
CREATE TABLE IF NOT EXISTS diagnoses (
    run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE, diagnosed TEXT, baseline TEXT,
    accepted TEXT, findings TEXT, within_noise INTEGER);
CREATE INDEX IF NOT EXISTS runs_serial ON runs(serial);
"""
COLUMNS = ("serial", "operator", "note", "setup", "damper", "rig", "protocol", "params", "started", "duration_s",
           "outcome", "reason", "error")  # what describe() fills; a re-index sets every one
ENDINGS = {Fault: "tripped", OperatorStop: "stopped"}


@dataclass
class Indexed:
    added: int = 0
    updated: int = 0
    unchanged: int = 0
    failed: int = 0
    writing: int = 0  # being recorded now: indexed once finished


APPLICATION_ID = 0x44594E4F  # "DYNO": a run index this project made (PRAGMA application_id)


def _path(folder) -> Path:
    return Path(folder) / DB_NAME


def _refuse(db, why):
    raise RunIndexError(f"{db}: {why}")


def _text(b: bytes) -> str:
    return b.decode(errors="replace")  # a garbled text cell is shown, not fatal


def _first(e: Exception) -> str:
    return str(e).splitlines()[0] if str(e) else type(e).__name__


def _columns(c: sqlite3.Connection) -> dict[str, set]:
    """{table: its columns} of a database."""
    tables = [r[0] for r in c.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
    return {t: {r[1] for r in c.execute(f"PRAGMA table_info({json.dumps(t)})")} for t in tables}


with closing(sqlite3.connect(":memory:")) as _c:
    _c.executescript(SCHEMA)
    COLUMNS_OF = _columns(_c)  # what a run index of ours holds: every table with at least these columns
# columns a run index made by an earlier version lacks: added when it is next written (its
# runs then read again), read as missing until then (a one-speed run's force along the stroke)
ADDED = {"peaks": {"stroke_v", "stroke_F"}}


def _ours(c: sqlite3.Connection, db):
    """RunIndexError unless the open database is a run index of ours: its application
    id (an older one has none) and every table of SCHEMA with its columns."""
    try:
        app_id = c.execute("PRAGMA application_id").fetchone()[0]
        have = _columns(c)
    except (sqlite3.DatabaseError, UnicodeDecodeError) as e:  # SQLite's message may quote garbled bytes
        _refuse(db, f"not a readable SQLite file ({_first(e)}); move it away and run `dyno runs index`")
    if app_id == 0 and not have:
        return  # empty: nobody's yet
    if app_id in (0, APPLICATION_ID) and all(cols - ADDED.get(t, set()) <= have.get(t, set())
                                             for t, cols in COLUMNS_OF.items()):
        return
    why = "a dyno run index with tables or columns missing (damaged?)" if app_id == APPLICATION_ID else \
        "a SQLite file that is not a dyno run index"
    _refuse(db, f"{why}; it is left as it is (move it, or index another folder)")


@contextmanager
def _writing(c: sqlite3.Connection):
    """One write transaction, taken at its start (BEGIN IMMEDIATE): a second writer waits
    its turn (BUSY_MS) instead of failing when a read it began turns into a write, and what
    the block read still holds when it writes (another process may have added the row)."""
    c.execute("BEGIN IMMEDIATE")
    try:
        yield c
    except BaseException:
        c.rollback()
        raise
    c.commit()


def _wal(c: sqlite3.Connection):
    """The run index in WAL mode (readers never wait for a writer). Switching a new file to it
    is refused at once, not after the busy wait, while another process holds it (SQLite's
    deadlock rule): tried again until BUSY_MS."""
    deadline = time.monotonic() + BUSY_MS / 1000
    while True:
        try:
            c.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError as e:
            if "locked" not in str(e) or time.monotonic() > deadline:
                raise
            time.sleep(0.01)


def connect(folder, write=True) -> sqlite3.Connection:
    """The run index of recordings in `folder`: created if missing when write, opened
    read-only otherwise (a reader never changes the file). A file that is not a run index
    of ours is never written: RunIndexError in one line, as for a corrupt, unreadable or
    misplaced one."""
    db = _path(folder)
    if db.is_symlink() or (db.exists() and not db.is_file()):
        _refuse(db, "not a regular file (a folder, link or device); move it away")
    if not write and not db.exists():
        _refuse(db, f"no run index yet; run `dyno runs index {Path(folder)}`")
    if db.exists() and not os.access(db, os.R_OK):
        _refuse(db, "cannot read it (permission denied)")
    try:
        if db.exists():
            with closing(sqlite3.connect(f"{db.resolve().as_uri()}?mode=ro", uri=True, timeout=BUSY_MS / 1000)) as look:
                look.text_factory = _text
                _ours(look, db)
        if not write:
            c = sqlite3.connect(f"{db.resolve().as_uri()}?mode=ro", uri=True, timeout=BUSY_MS / 1000)
        else:
            if db.exists() and not os.access(db, os.W_OK):
                _refuse(db, "read-only: cannot record in it (runs list, show and trend still read it)")
            c = sqlite3.connect(db, timeout=BUSY_MS / 1000)
        c.row_factory = sqlite3.Row
        c.text_factory = _text
        c.execute("PRAGMA foreign_keys=ON")
        if write:
            _wal(c)
            with _writing(c):  # made whole or not at all: a second writer never sees it half made
                if c.execute("PRAGMA application_id").fetchone()[0] == 0:
                    c.execute(f"PRAGMA application_id = {APPLICATION_ID}")
                for statement in filter(str.strip, SCHEMA.split(";")):
                    c.execute(statement)
                _add_columns(c)
        return c
    except (sqlite3.DatabaseError, UnicodeDecodeError) as e:  # OperationalError too: locked, read-only folder
        _refuse(db, f"cannot open it ({_first(e)})")


def _add_columns(c: sqlite3.Connection):
    """The ADDED columns an earlier version's catalogue lacks, added; its runs indexed again
    on the next index (their size forgotten) so that the new columns fill."""
    have = _columns(c)
    for table, cols in ADDED.items():
        for col in sorted(cols - have[table]):
            c.execute(f"ALTER TABLE {table} ADD COLUMN {col} TEXT")
            c.execute("UPDATE runs SET size = NULL")


@contextmanager
def reading(folder):
    """The run index of folder opened read-only for the block, closed after; a page of it
    that cannot be read (a torn or garbled file) is a RunIndexError in one line."""
    c = connect(folder, write=False)
    try:
        yield c
    except (sqlite3.DatabaseError, UnicodeDecodeError) as e:
        raise RunIndexError(f"{_path(folder)}: cannot read it ({_first(e)}); move it away and run `dyno runs index`") from None
    finally:
        c.close()


def _recordings(folder):
    """Every *.mcap under folder that is a regular file, sorted; links to one followed, a
    link loop or a dangling link skipped (and an unreadable folder)."""
    out = []
    for root, dirs, names in os.walk(folder, onerror=lambda e: None):
        dirs.sort()
        for n in names:
            if n.endswith(".mcap"):
                p = Path(root) / n
                with suppress(OSError):
                    if p.is_file():
                        out.append(p)
    return sorted(out)


def describe(path):
    """(run row {column: value}, [peak rows]) of one recording; UsageError if unreadable."""
    ch, events, meta = load_recording(path, peak_rows.READS)
    run = meta.get("run", {})
    t = ch["force"][0] if "force" in ch else next(iter(ch.values()))[0]
    end = next((e for e in events if type(e) in ENDINGS), None)
    row = {"serial": run.get("damper_serial"), "operator": run.get("operator"), "note": run.get("note"),
           "setup": json.dumps({k.removeprefix("setup."): v for k, v in run.items() if k.startswith("setup.")}),
           "damper": json.loads(meta.get("damper", {}).get("model", "{}") or "{}").get("name"),
           "rig": meta.get("rig", {}).get("name"), "protocol": meta.get("protocol", {}).get("name"),
           "params": meta.get("protocol", {}).get("params"), "started": _dated(run.get("wall_start")),
           "duration_s": float(t[-1] - t[0]) if len(t) else 0.0,
           "outcome": ENDINGS[type(end)] if end else "completed", "reason": end.message if end else None, "error": None}
    rows = peak_rows.peaks(ch, segments(events))
    return row, [(p.segment, p.amplitude_mm, p.freq_hz, p.target_c, p.v_comp, p.F_comp, p.v_reb, p.F_reb,
                  _floats(p.stroke_v), _floats(p.stroke_F)) for p in rows]


def _dated(wall_start):
    """The run index's start of a run: its UTC date-time, None (NULL) where unknown."""
    return None if wall_start in (None, "", UNDATED) else wall_start


def _floats(a) -> str:
    """An array as JSON, to 6 significant digits (nan as null)."""
    return json.dumps([float(f"{x:.6g}") if np.isfinite(x) else None for x in np.asarray(a, float)])


def index(folder) -> Indexed:
    """Index every *.mcap under folder (recursively) into its run index, but those a run
    is writing now."""
    out = Indexed()
    with closing(connect(folder)) as c:
        for path in _recordings(folder):
            try:
                out_kind = "writing" if writer(path) else index_file(c, path)
            except OSError:  # gone or unreadable between the look and the read
                out_kind = "failed"
            setattr(out, out_kind, getattr(out, out_kind) + 1)
    return out


def index_file(c: sqlite3.Connection, path) -> str:
    """Index one recording: "added", "updated", "unchanged" or "failed" (its error kept). A
    changed recording keeps its row, so its checks, models and diagnoses stay with it. Safe
    beside other writers of the run index: the file is read outside the transaction, its row
    looked up and written inside one (the last writer's description stands)."""
    path = Path(path).resolve()
    st = path.stat()
    old = c.execute("SELECT size, mtime FROM runs WHERE path = ?", (str(path),)).fetchone()
    if old is not None and old["size"] == st.st_size and old["mtime"] == st.st_mtime:
        return "unchanged"
    try:
        row, peaks = describe(path)
    except Exception as e:  # noqa: BLE001 - a file that cannot be read is a row with its error
        row, peaks = {"error": str(e).splitlines()[0] or type(e).__name__}, []
    row = {**dict.fromkeys(COLUMNS), **row, "path": str(path), "size": st.st_size, "mtime": st.st_mtime}
    with _writing(c):  # one transaction per run
        run_id = c.execute("SELECT id FROM runs WHERE path = ?", (str(path),)).fetchone()
        existed = run_id is not None
        if existed:
            run_id = run_id["id"]
            c.execute(f"UPDATE runs SET {', '.join(k + ' = ?' for k in row)} WHERE id = ?", [*row.values(), run_id])
            c.execute("DELETE FROM peaks WHERE run_id = ?", (run_id,))
        else:
            run_id = c.execute(f"INSERT INTO runs ({', '.join(row)}) VALUES ({', '.join('?' * len(row))})",
                               list(row.values())).lastrowid
        c.executemany(f"INSERT INTO peaks VALUES ({', '.join('?' * 11)})", [(run_id, *p) for p in peaks])
    if row.get("error"):
        return "failed"
    return "updated" if existed or old is not None else "added"


@contextmanager
def beside(path):
    """The run index of the folder a recording is in, closed after use."""
    c = connect(Path(path).parent)
    try:
        yield c
    finally:
        c.close()


def add(path) -> str:
    """Index a recording just written (by dyno run, import or recover) into the run index
    of its own folder; one line saying so, or why it could not be (the recording stands)."""
    path = Path(path)
    try:
        with beside(path) as c:
            outcome = index_file(c, path)
    except RunIndexError as e:
        return f"not indexed ({e})"
    except (OSError, sqlite3.Error) as e:
        return f"not indexed ({path.parent / DB_NAME}: {e}); dyno runs index {path.parent} retries"
    return f"indexed in {path.parent / DB_NAME}" + (" (unreadable: its error is kept)" if outcome == "failed" else "")


def _attach(path, table, values, what) -> str:
    """A row of `table` (run id, time now, values) about a recording, in the run index of its
    folder (the recording indexed first if it is not); one line saying so, or why it could
    not be (what was made stands)."""
    path = Path(path).resolve()
    try:
        with beside(path) as c:
            index_file(c, path)
            with _writing(c):
                run_id = c.execute("SELECT id FROM runs WHERE path = ?", (str(path),)).fetchone()["id"]
                c.execute(f"INSERT INTO {table} VALUES ({', '.join('?' * (len(values) + 2))})",
                          (run_id, datetime.now(timezone.utc).isoformat(timespec="seconds"), *values))
    except RunIndexError as e:
        return f"{what} not indexed ({e})"
    except (OSError, sqlite3.Error) as e:
        return f"{what} not indexed ({path.parent / DB_NAME}: {e})"
    return f"{what} indexed in {path.parent / DB_NAME} (run {run_id})"


def add_check(path, reference, tolerance, verdicts) -> str:
    """A `dyno check` of a recording, as a row of its run index."""
    return _attach(path, "checks", (str(reference), str(tolerance), len(verdicts), sum(not v.passed for v in verdicts),
                                    min(v.margin_N for v in verdicts)), "check")


def add_model(path, model_path, heldout_nrmse, parameters) -> str:
    """A model `dyno identify` made of a recording: its file, held-out NRMSE and
    parameters {name: value in SI}."""
    return _attach(path, "models", (str(Path(model_path).resolve()), heldout_nrmse, json.dumps(parameters)), "model")


def add_diagnosis(path, baseline, accepted, findings, within_noise) -> str:
    """A `dyno diagnose` of a recording: its baseline, the effects accepted (kept in its
    model) in order, each one's finding {effect, nature, named, parameters}, and whether
    what is left is within the noise."""
    return _attach(path, "diagnoses", (baseline, json.dumps(accepted), json.dumps(findings), int(within_noise)),
                   "diagnosis")


def attached(c: sqlite3.Connection, table, run_id) -> list[sqlite3.Row]:
    """A run's rows of checks, models or diagnoses, oldest first."""
    if table not in ("checks", "models", "diagnoses"):
        raise RunIndexError(f"no table {table!r}")
    return c.execute(f"SELECT * FROM {table} WHERE run_id = ? ORDER BY rowid", (run_id,)).fetchall()


def latest_checks(c: sqlite3.Connection) -> dict[int, sqlite3.Row]:
    """{run id: its last QA check}."""
    return {r["run_id"]: r for r in c.execute("SELECT * FROM checks WHERE rowid IN (SELECT MAX(rowid) FROM checks GROUP BY run_id)")}


def checks(c: sqlite3.Connection) -> list[sqlite3.Row]:
    """Every QA check, newest first, with its run's serial, damper and path."""
    return c.execute("SELECT k.*, r.serial, r.damper, r.path FROM checks k JOIN runs r ON r.id = k.run_id "
                     "ORDER BY k.rowid DESC").fetchall()


def serials(c: sqlite3.Connection) -> list[str]:
    return [r[0] for r in c.execute("SELECT DISTINCT serial FROM runs WHERE serial IS NOT NULL ORDER BY serial")]


def counts(c: sqlite3.Connection) -> tuple[int, int]:
    """(recordings, of them unreadable) in the run index."""
    return tuple(c.execute("SELECT COUNT(*), COUNT(error) FROM runs").fetchone())


def runs(c: sqlite3.Connection, serial=None, since=None, protocol=None, where=None) -> list[sqlite3.Row]:
    """The run index's runs, oldest first (undated ones last, in the order indexed), filtered by serial, start (ISO date or time,
    UTC), protocol and a `where` expression (condition)."""
    sql, args = [], []
    for col, op, value in (("serial", "=", serial), ("started", ">=", since_time(since)), ("protocol", "=", protocol)):
        if value is not None:
            sql.append(f"{col} {op} ?")
            args.append(value)
    if where:
        more, more_args = condition(where)
        sql.append(more)
        args += more_args
    # undated runs (a lab's file without a date) after the dated, in the order indexed
    query = "SELECT * FROM runs" + (" WHERE " + " AND ".join(sql) if sql else "") + \
        " ORDER BY started IS NULL, started, CASE WHEN started IS NULL THEN id END, path"
    return c.execute(query, args).fetchall()


MAX_ID = 2**63 - 1  # SQLite's largest integer


def run(c: sqlite3.Connection, run_id) -> tuple[sqlite3.Row, list[sqlite3.Row]]:
    if not isinstance(run_id, int) or not 0 < run_id <= MAX_ID:  # a garbled run index's row may have none
        raise RunIndexError(f"no run with id {run_id} in the run index")
    row = c.execute("SELECT * FROM runs WHERE id = ?", (run_id,)).fetchone()
    if row is None:
        raise RunIndexError(f"no run with id {run_id} in the run index")
    return row, c.execute("SELECT * FROM peaks WHERE run_id = ? ORDER BY rowid", (run_id,)).fetchall()


def force_at(peaks, direction, speed):
    """The run's force [N] at speed [m/s] in direction from its peaks, as the velocity table
    reads it: from the peaks, or along the stroke of a run of one speed (an imported test at
    one amplitude and frequency); nan outside the measured speeds."""
    rows = [SimpleNamespace(**{k: p[k] for k in p.keys()}, Fd_comp=np.nan, Fd_reb=np.nan) for p in peaks]
    for r in rows:
        for k in ("amplitude_mm", "freq_hz", "target_c", "v_comp", "F_comp", "v_reb", "F_reb"):
            if getattr(r, k, None) is None:  # SQLite keeps a nan (a random input's amplitude) as null
                setattr(r, k, np.nan)
        for k in ("stroke_v", "stroke_F"):  # null in a run index an earlier version wrote
            setattr(r, k, np.array(json.loads(getattr(r, k, None) or "[]"), float))
    if not rows:
        return float("nan")
    row = vt.velocity_table(rows, [speed])[0]
    return row.F_comp_N if direction == "compression" else row.F_reb_N


def trend(c: sqlite3.Connection, serial, text):
    """[(started, force [N], run id, setup "KEY=VALUE ...")] of a serial's runs at the
    quantity, oldest first."""
    direction, speed = quantity(text)
    out = []
    for r in runs(c, serial=serial):
        if r["error"] is None:
            setup = " ".join(f"{k}={v}" for k, v in json.loads(r["setup"] or "{}").items())
            out.append((r["started"], force_at(run(c, r["id"])[1], direction, speed), r["id"], setup))
    return out
