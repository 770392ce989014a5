"""`dyno import FILE.csv --out FILE.mcap --map NAME=COLUMN[:UNIT] ...`: a recording made
elsewhere, as a dyno recording that `dyno identify` and `dyno report` read.

Standard names and the channels they become: time, displacement (x), velocity (v), force,
temperature (T_body), pressure (P_gas); `aux.NAME` for anything else, its unit kept as
given. Units are converted to SI here, at the edge; pressures are absolute unless given
as gauge (barg, psig, kPag). Without a velocity column the velocity is derived from the
displacement by a Savitzky-Golay first derivative (quadratic over 11 samples, about 5 ms
at 2 kHz): smoother than a plain difference and without its half-sample lag.
"""
from __future__ import annotations

import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from records import table
from records.column_units import BRACKETED, SI, UNIT_NAMES, UNITS, unit, unit_in_name, volts
from records.files import input_file
from rig.config import quantity
from rig.errors import UsageError

CHANNELS = {"time": "t", "displacement": "x", "velocity": "v", "force": "force", "temperature": "T_body",
            "pressure": "P_gas"}
MAX_SPAN_S = 7 * 86400.0  # s: a week; longer is a wrong unit or a corrupt stamp
BOMS = ((b"\xef\xbb\xbf", "utf-8"), (b"\xff\xfe", "utf-16-le"), (b"\xfe\xff", "utf-16-be"))


def decode(data: bytes) -> str:
    """The text of a file as acquisition software writes it: UTF-8 with or without a byte
    order mark, UTF-16 (with its mark, or without one when every other byte is zero), or
    Latin-1 (Windows' 8-bit exports) when it is not UTF-8. UnicodeDecodeError for binary
    data (a zero byte anywhere else)."""
    for bom, codec in BOMS:
        if data.startswith(bom):
            return data[len(bom):].decode(codec)
    head = data[:4096]
    if len(head) >= 4 and head[1::2].count(0) > 0.9 * len(head[1::2]) and 0 not in head[0::2]:
        return data.decode("utf-16-le")
    if len(head) >= 4 and head[0::2].count(0) > 0.9 * len(head[0::2]) and 0 not in head[1::2]:
        return data.decode("utf-16-be")
    if b"\x00" in data:
        raise UnicodeDecodeError("binary", data[:1], 0, 1, "a zero byte: not text")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def parse_map(items: list[str]) -> list[tuple[str, str, str]]:
    """[(name, column, unit)] from NAME=COLUMN[:UNIT] strings, checking names and units (a
    standard channel's unit "" when not given: read() takes the column name's, else SI)."""
    out = []
    for item in items:
        name, sep, rest = item.partition("=")
        if not sep or not rest:
            raise UsageError(f"--map {item}: expected NAME=COLUMN[:UNIT]")
        column, _, given = rest.partition(":")
        if name not in CHANNELS and not (name.startswith("aux.") and len(name) > 4):
            raise UsageError(f"--map {item}: unknown channel name {name!r} (standard: {', '.join(CHANNELS)}, "
                           f"or aux.NAME)")
        if name in CHANNELS and given:
            known = unit(name, given)
            if known is None:
                raise UsageError(f"--map {item}: unknown {name} unit {given!r} (known: {', '.join(UNITS[name])})")
            given = known
        out.append((name, column, given))
    names = [n for n, _, _ in out]
    for n in set(names):
        if names.count(n) > 1:
            raise UsageError(f"--map: {n} mapped twice")
    for need in ("displacement", "force"):
        if need not in names:
            raise UsageError(f"--map: needs {need}=COLUMN (displacement and force are required; time too, unless "
                           f"the file or --rate gives the sampling rate)")
    return out


@dataclass
class ColumnsRead:
    """What import read: {channel name: SI array} on the rows that have a time, the units as given, where the rows
    came from (the file's lines), and the recording's own start."""
    data: dict
    units: dict
    layout: table.Layout | None  # None: Parquet or MAT
    start_epoch: float | None = None  # s since 1970 UTC: the first date-time stamp; None without one
    derived_time: str = ""  # how the time was made when no column gives it
    time_note: str = ""  # what the time column could not tell, or how it was read
    start_source: str = "the file's first date-time stamp"  # where start_epoch came from
    stamped: bool = False  # the time column is date-time stamps, not numbers in a unit
    named_units: dict = field(default_factory=dict)  # {channel: unit} its column's name gave, the map none
    unit_notes: list = field(default_factory=list)  # a unit a name says that import did not read
    lines: np.ndarray = None  # the file's line of each row kept (a workbook's: the row's number)


def source(path: str | Path, sheet: str | None = None) -> tuple[dict, table.Layout | None]:
    """({column name: cells (text) or values (array)}, Layout or None) of a text table,
    an Excel workbook (its sheet named so, else its fullest), a Parquet file, a TDMS file
    (records/tdms.py) or a MATLAB file (columns VAR, or VAR[N] for a matrix's N-th)."""
    path = input_file(path)
    if sheet is not None and path.suffix.lower() not in (".xlsx", ".xlsm"):
        raise UsageError(f"--sheet {sheet}: {path} is not an Excel workbook")
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        try:
            import pyarrow.parquet as pq
        except ImportError:
            raise UsageError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow)") from None
        try:
            t = pq.read_table(path)
        except Exception as e:  # noqa: BLE001 - whatever pyarrow refuses
            raise UsageError(f"{path}: not a readable Parquet file ({str(e).splitlines()[0]})") from None
        return {n: np.asarray(t.column(n).to_numpy(zero_copy_only=False)) for n in t.column_names}, None
    if suffix == ".tdms":
        from records import tdms
        return tdms.columns(path), None
    if suffix == ".mat":
        from scipy.io import loadmat
        try:
            m = loadmat(path, squeeze_me=False)
        except Exception as e:  # noqa: BLE001 - whatever scipy refuses
            raise UsageError(f"{path}: not a readable MATLAB file ({str(e).splitlines()[0]})") from None
        cols = {}
        for k, v in m.items():
            if k.startswith("__") or not isinstance(v, np.ndarray) or v.dtype.kind not in "iuf" or v.ndim != 2:
                continue
            v = v.T if v.shape[0] < v.shape[1] else v  # samples along the longer side
            if v.shape[1] == 1:
                cols[k] = v[:, 0].astype(float)
            for j in range(v.shape[1]):
                cols[f"{k}[{j + 1}]"] = v[:, j].astype(float)
        if not cols:
            raise UsageError(f"{path}: no numeric matrix in this MATLAB file")
        return cols, None
    if suffix in (".xlsx", ".xlsm", ".xls"):
        return _workbook(path, sheet)
    try:
        text = decode(path.read_bytes())
    except UnicodeDecodeError:
        raise UsageError(f"{path}: not a text (CSV) file") from None
    except OSError as e:
        raise UsageError(f"{path}: cannot read ({e.strerror})") from None
    try:
        layout = table.sniff(text, UNIT_NAMES)
        return table.split(text, layout), layout
    except UsageError as e:
        raise UsageError(f"{path}: {e}") from None


def _workbook(path, name=None):
    """(columns, Layout) of an Excel workbook's sheet of that name, else its fullest, its
    rows read as a text table's lines (a preamble, a row of units, stamps: as in a CSV
    export)."""
    import openpyxl
    from openpyxl.utils.exceptions import InvalidFileException
    if path.suffix.lower() == ".xls":
        raise UsageError(f"{path}: an Excel 97-2003 workbook: save it as .xlsx or CSV")
    try:
        book = openpyxl.load_workbook(path, read_only=True, data_only=True)
    except (InvalidFileException, zipfile.BadZipFile, OSError, KeyError, ValueError) as e:
        raise UsageError(f"{path}: not a readable Excel workbook ({str(e).splitlines()[0] if str(e) else e})") \
            from None
    try:
        titles = [ws.title for ws in book.worksheets]
        if name is not None and name not in titles:
            raise UsageError(f"--sheet {name}: no such sheet in {path.name}; its sheets: "
                             + ", ".join(repr(t) for t in titles))
        sheet = book[name] if name is not None else max(book.worksheets, key=lambda ws: ws.max_row or 0)
        lines = ["\t".join(_cell(c) for c in row) for row in sheet.iter_rows(values_only=True)]
    finally:
        book.close()
    text = "\n".join(lines)
    try:
        layout = table.sniff(text, UNIT_NAMES)
    except UsageError as e:
        raise UsageError(f"{path}: sheet {sheet.title!r}: {e}") from None
    layout.sheet, layout.sheets = sheet.title, titles
    return table.split(text, layout), layout


def _column_unit(name, key, given, gained):
    """(unit, whether the column's name gave it, a note or "") of a mapped column: the map's
    unit, else the one its name carries, else SI; the note where the name says a unit that
    is not this channel's (raw volts without a gain, another channel's unit) or not the
    map's (a map copied from another file)."""
    if name not in UNITS:
        return given, False, ""
    u = unit_in_name(key, name)
    if given:
        return given, False, "" if u in (None, given) or gained else (
            f"{name}: its column {key!r} says {u}, read as {given} as the map says")
    if u:
        return u, u != SI[name], ""
    said = next((t for t in BRACKETED.findall(key) if t.lower() in table.OTHER_UNITS or unit_in_name(f"[{t}]")), None)
    return SI[name], False, "" if said is None or gained else (
        f"{name}: its column {key!r} says {said}, read as {SI[name]}: give its unit (--map {name}=COLUMN:UNIT) "
        f"or a raw channel's --gain")


def _cell(v) -> str:
    """An Excel cell as a text export writes it: numbers in full, date-times as ISO."""
    if v is None:
        return ""
    if hasattr(v, "isoformat"):
        return v.isoformat(sep=" ") if hasattr(v, "date") else v.isoformat()
    return repr(v) if isinstance(v, float) else str(v).replace("\t", " ").replace("\n", " ").strip()


def read(path: str | Path, mapping: list[tuple[str, str, str]], gains: dict | None = None, offsets: dict | None = None,
         rate_hz: float | None = None, sheet: str | None = None) -> ColumnsRead:
    """The mapped columns in SI. A time column of date-time stamps gives the recording's start; without
    a time column, the rate (given, or the preamble's) makes one. Values are raw x gain + offset in the
    mapped unit, then SI. Unmapped and empty columns are ignored; unknown mapped columns, non-numbers and
    time that goes backwards are refused, naming the row. sheet: a workbook's sheet (else its fullest)."""
    cols, layout = source(path, sheet)
    gains, offsets = gains or {}, offsets or {}
    first_row = (layout.first + 1) if layout else 1  # a data row's line in the file: first_row + index
    data, start, derived, note, stamped = {}, None, "", "", False
    units, named, unit_notes = {}, {}, []
    for name, column, given in mapping:
        key = table.column(cols, layout, column) if layout else column
        if key not in cols:
            raise UsageError(f"{path}: no column {column!r} (mapped to {name}); columns: {', '.join(cols)}")
        u, from_name, said = _column_unit(name, str(key), given, name in gains)
        named.update({name: u} if from_name else {})
        unit_notes += [said] if said else []
        cells = cols[key]
        if isinstance(cells, np.ndarray):
            if cells.dtype.kind == "M":  # Parquet's or TDMS's time stamps: the recording's start
                ns = cells.astype("datetime64[ns]")
                a = np.where(np.isnat(ns), np.nan, ns.astype("int64") / 1e9)
                a, bad = (a, None) if name == "time" else (None, 0)
                if a is not None and np.any(np.isfinite(a)):
                    start, u, stamped = float(a[np.isfinite(a)][0]), "s", True
                    a = a - start
            else:
                try:
                    a, bad = cells.astype(float), None
                except (TypeError, ValueError):
                    a, bad = None, 0
        elif name == "time" and any(table.is_stamp(c) for c in cells[:5]):
            a, bad, start, note = _stamped(table.with_date(cols, cells))
            u, stamped = "s", True
        else:
            a, bad = table.numbers(cells, layout.decimal if layout else ".")
        if bad is not None:
            cell = cells[bad] if not isinstance(cells, np.ndarray) else str(cells[bad])
            cell = cell if len(cell) <= 60 else f"{cell[:40]}... ({len(cell):,} characters)"  # a message is one line
            raise UsageError(f"{path}:{first_row + bad}: column {column!r}: {cell!r} is not a "
                           f"{'date-time stamp' if name == 'time' and start is None and table.is_stamp(cols[key][0]) else 'number'}")
        if not np.all(np.isfinite(a[~np.isnan(a)])):
            i = int(np.nonzero(np.isinf(a))[0][0])
            raise UsageError(f"{path}:{first_row + i}: column {column!r}: {cells[i]!r} is not a finite number")
        if name in UNITS and name != "time" and name not in gains:
            _not_volts(path, name, column, str(key), a, u)
        a = a * gains.get(name, 1.0) + offsets.get(name, 0.0)
        if name in UNITS:
            scale, offset = UNITS[name][u]
            a = a * scale + offset
        _plausible(path, name, column, a, first_row)
        data[name], units[name] = a, u
    preamble_start = table.preamble_start(layout.preamble) if start is None and layout is not None else None
    if "time" not in data:
        rate = rate_hz or (layout.rate_hz if layout else None)
        if not rate:
            raise UsageError(f"{path}: no time column mapped and no sampling rate in the file: give --map time=COLUMN "
                           f"or --rate HZ")
        n = len(next(iter(data.values())))
        data["time"] = np.arange(n) / rate
        derived = f"time from the sampling rate, {rate:g} Hz"
    if stamped:
        data["time"], note = _coarse_stamps(path, data["time"], rate_hz or (layout.rate_hz if layout else None), note)
    keep = ~np.isnan(data["time"])
    if not stamped:
        note = _follow_on(data["time"], keep, first_row) or note
    t = data["time"]
    _time_advances(path, t[keep], np.nonzero(keep)[0], first_row, mapping)
    for name, column, _ in mapping:  # an empty optional column is left out; one number is no channel
        have = int(np.sum(~np.isnan(data[name][keep])))
        need = 10 if name in ("time", "displacement", "force") else 2
        if 0 < have < need or (have == 0 and need == 10):
            raise UsageError(f"{path}: column {column!r} ({name}) holds {have} number{'s' * (have != 1)} "
                           f"with a time (needs at least {need})")
    if preamble_start is not None:  # the time's numbers count from the start the preamble gives
        start = preamble_start + float(t[keep][0])
    how = "the start the file's preamble gives" if preamble_start is not None else "the file's first date-time stamp"
    return ColumnsRead({k: v[keep] for k, v in data.items()}, units, layout, start, derived, note, how, stamped, named,
                    unit_notes, (first_row if layout else 1) + np.nonzero(keep)[0])


def _not_volts(path, name, column, key, a, u):
    """UsageError naming --gain where a mapped quantity's column reads volts (column_units.volts)."""
    raw = volts(key, a)
    if raw:
        raise UsageError(f"{path}: column {column!r} ({name}) reads volts ({raw}): give its gain into "
                         f"{u}, --gain {name}=NUMBER (per volt), or --gain {name}=1 if it is in {u} already")


def _follow_on(t, keep, first_row) -> str:
    """Make a time column of tests exported one after another follow on, in place (_restarts);
    what was done, or ""."""
    restarted = _restarts(t[keep])
    if restarted is None:
        return ""
    t[keep], rows = restarted
    lines = [str(first_row + np.nonzero(keep)[0][i]) for i in rows]
    return (f"it restarts {len(rows)} time{'s' * (len(rows) > 1)} from its first value (line{'s' * (len(rows) > 1)} "
            f"{', '.join(lines[:5])}{', ...' if len(lines) > 5 else ''}): tests exported one after another, read as "
            f"following on")


def _time_advances(path, t, rows, first_row, mapping):
    """UsageError unless the kept times t [s] (at row indices rows) never go back, number
    10 or more, span at most MAX_SPAN_S and advance."""
    bad = np.nonzero(np.diff(t) < 0)[0]  # repeated stamps happen in logged data; going back does not
    if len(bad):
        raise UsageError(f"{path}:{first_row + rows[bad[0] + 1]}: time goes backwards ({t[bad[0]]:.9g} then "
                         f"{t[bad[0] + 1]:.9g} s)")
    if len(t) < 10:
        raise UsageError(f"{path}: {len(t)} rows with a time (need at least 10)")
    if not t[-1] - t[0] <= MAX_SPAN_S:
        raise UsageError(f"{path}: the time column spans {t[-1] - t[0]:.3g} s; a recording spans at most "
                         f"{MAX_SPAN_S / 86400:g} days: check its unit")
    if not t[-1] > t[0]:
        column = next((c for n, c, _ in mapping if n == "time"), "time")
        raise UsageError(f"{path}: the time column {column!r} does not advance (all {t[0]:g} s)")


RESTART_ROWS = 10  # a section counting from the first's start holds at least this many rows


def _restarts(t):
    """(t made to follow on, [index of each restart]) of a time column whose sections each
    count from the first section's start (tests exported one after another: each section
    back to within one sample step of the first value, RESTART_ROWS rows or more), or None
    when time never goes back or goes back otherwise (a corrupt file: refused)."""
    back = np.nonzero(np.diff(t) < 0)[0]
    steps = np.diff(t)[np.diff(t) > 0]
    if not len(back) or not len(steps):
        return None
    step = float(np.median(steps))
    edges = np.r_[-1, back, len(t) - 1]
    if np.any(np.diff(edges) < RESTART_ROWS) or np.any(np.abs(t[back + 1] - t[0]) > step):
        return None
    out = t.copy()
    for i in back:
        out[i + 1:] += out[i] + step - out[i + 1]
    return out, [int(i) + 1 for i in back]


def _stamped(cells):
    """(seconds from the first stamp, index of a cell that is no stamp or None, the start
    [s since 1970 UTC] or None without a date, what the stamps could not tell)."""
    dmy = next((c for c in cells[:5] if c and table.DMY.match(c)), None)
    order = table.day_first(cells) if dmy else None  # ISO stamps: no day to tell from a month
    a, bad = table.stamps(cells, order)
    if bad is not None:
        return a, bad, None, ""
    first = float(a[~np.isnan(a)][0]) if np.any(~np.isnan(a)) else None
    note = ""
    if dmy and order is None:
        note = (f"the stamps cannot tell the day from the month (both at most 12): read month first "
                f"({dmy.split()[0]} as MM/DD/YYYY); the date may be wrong, the times are not")
    return (a - first if first is not None else a), None, first if table.dated(cells) else None, note  # a clock: no date


def _coarse_stamps(path, a, rate, note):
    """(time [s], note) of stamps that many rows share (a logger stamping whole seconds):
    the time from the sampling rate, its start the first stamp's; the stamps and the rate
    must agree on the span to within two stamps. Stamps that mostly advance: as they are."""
    ok = np.nonzero(~np.isnan(a))[0]
    step = np.diff(a[ok])
    if len(step) < 2 or np.median(step) > 0:
        return a, note
    per = float(np.median(np.unique(a[ok], return_counts=True)[1]))
    tick = float(np.median(step[step > 0])) if np.any(step > 0) else 0.0
    if not rate:
        raise UsageError(f"{path}: its date-time stamps repeat ({per:.0f} rows share each, a stamp every {tick:g} s): "
                         f"give the sampling rate, --rate HZ")
    span, counted = float(a[ok[-1]] - a[ok[0]]), (len(ok) - 1) / rate
    if abs(counted - span) > 2 * tick + 0.01 * span:
        raise UsageError(f"{path}: {len(ok)} rows at {rate:g} Hz span {counted:.4g} s, the stamps {span:.4g} s: "
                         f"check the sampling rate")
    t = np.full(len(a), np.nan)
    t[ok] = a[ok[0]] + np.arange(len(ok)) / rate
    said = (f"the stamps advance only every {tick:g} s ({per:.0f} rows share each): the time is from the sampling "
            f"rate, {rate:g} Hz, the start from the first stamp")
    return t, f"{note}; {said}" if note else said


def _plausible(path, name, column, a, first_row=2):
    """Refuse values no working sensor gives (a wrong unit, a corrupt file): the ranges are
    the rig's, per quantity (rig/config.py QUANTITIES)."""
    q = quantity(CHANNELS.get(name, ""))
    if name == "time":
        q = ("s", -1e10, 1e10)  # epoch seconds too (to 2286); the span is checked apart
    if q is None:
        bad = np.nonzero(np.abs(np.nan_to_num(a)) > 1e12)[0]
    else:
        bad = np.nonzero((a < q[1]) | (a > q[2]))[0]
    if len(bad):
        i = bad[0]
        where = f"{q[1]:g}..{q[2]:g} {q[0]}" if q else "+-1e12"
        raise UsageError(f"{path}:{i + first_row}: column {column!r}: {a[i]:.6g} {q[0] if q else ''} is not a plausible "
                       f"{name} (outside {where}): check its unit")
