"""A table of numbers as dyno software and acquisition systems write it, found without
being told: the encoding (recordings/csv_import.decode), the delimiter (comma,
semicolon, tab or whitespace), a decimal comma, a preamble before the header (a DAQ's
`Sampling Rate: 1000` read from it), a header or none, trailing delimiters and an empty
last column, and time as numbers or date-time stamps.

    layout = sniff(text)                  # what was found: Layout
    cols = split(text, layout)            # {column name: [cell text, ...]}
    values = numbers(cells, layout, ...)  # float array, NaN for an empty cell
    epoch = stamps(cells)                 # seconds since 1970 (UTC) of date-time stamps, or of the day

Columns are named by their header, and also by their 1-based position ("1", "2", ...):
a file without a header is mapped by position.
"""
from __future__ import annotations

import csv
import re
import warnings
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone

import numpy as np

from rig.errors import UsageError

DELIMITERS = (",", ";", "\t", None)  # None: runs of whitespace
TAIL = 40  # data lines looked at to learn the table's shape
NUMBER = re.compile(r"^[+-]?(\d+([.,]\d*)?|[.,]\d+)([eE][+-]?\d+)?$")
ISO = re.compile(r"^(\d{4})([-/])(\d{2})\2(\d{2})[ T](\d{1,2}):(\d{2})(?::(\d{2}(?:[.,]\d+)?))?"
                 r"\s*(Z|[+-]\d{2}:?\d{2})?$")
# a date the other way round: MM/DD/YYYY (US) or DD/MM/YYYY, DD.MM.YYYY (European; the dots say day first)
DMY = re.compile(r"^(\d{1,2})([/.])(\d{1,2})\2(\d{4})[ T]+(\d{1,2}):(\d{2})(?::(\d{2}(?:[.,]\d+)?))?"
                 r"\s*([AaPp][Mm])?$")
CLOCK = re.compile(r"^(\d{1,2}):(\d{2}):(\d{2}(?:[.,]\d+)?)\s*([AaPp][Mm])?$")  # the time of day, no date
DATE = re.compile(r"^(\d{4}[-/]\d{2}[-/]\d{2}|\d{1,2}[/.]\d{1,2}[/.]\d{4})$")  # a date alone, its clock elsewhere
ELAPSED = re.compile(r"^(\d{1,4}):([0-5]\d[.,]\d+)$")  # minutes:seconds.fff a logger counts from its start
RATE = re.compile(r"^\s*(sampling rate|sample rate|sampling frequency|rate|fs)\s*[:=]\s*([0-9.eE+-]+)\s*(hz)?\s*$",
                  re.I)
INTERVAL = re.compile(r"^\s*(sampling interval|sample interval|dt)\s*[:=]\s*([0-9.eE+-]+)\s*(s)?\s*$", re.I)


@dataclass
class Layout:
    delimiter: str | None  # None: whitespace
    decimal: str  # "." or ","
    header: int | None  # line index (0-based) of the column names; None: no header
    first: int  # line index of the first data row
    names: list  # the columns' names (their positions "1", "2", ... without a header)
    rate_hz: float | None = None  # from the preamble (Sampling Rate, or 1 / Sampling Interval)
    preamble: list = field(default_factory=list)  # the lines before the header
    units: int | None = None  # line index of a row of units under the names (joined to them: "Force [kN]")
    sheet: str | None = None  # an Excel workbook's sheet the rows come from (lines are its rows)
    sheets: list = field(default_factory=list)  # the workbook's sheets, by name
    postamble: list = field(default_factory=list)  # lines after the data (a summary), left out by split
    cut: str = ""  # what split said of a last row the file stops inside (dropped), else ""

    def describe(self) -> str:
        sep = {",": "comma", ";": "semicolon", "\t": "tab", None: "whitespace"}[self.delimiter]
        head = f"header on line {self.header + 1}" if self.header is not None else "no header"
        head += f" (units on line {self.units + 1})" if self.units is not None else ""
        kind = f"sheet {self.sheet!r}" if self.sheet else \
            f"{sep}-separated, decimal {'comma' if self.decimal == ',' else 'point'}"
        return (f"{kind}, {head}, data from line "
                f"{self.first + 1}" + (f", {len(self.preamble)} preamble lines" if self.preamble else "")
                + (f", sampling rate {self.rate_hz:g} Hz" if self.rate_hz else ""))


def _fields(line, delimiter):
    if delimiter is None:
        return line.split()
    try:
        out = next(csv.reader([line], delimiter=delimiter))
    except csv.Error as e:  # a quoted cell beyond the csv module's limit (131,072 characters)
        raise UsageError(f"not a table of numbers: a line with a cell longer than any number or name ({e})") from None
    while out and out[-1].strip() == "":  # a trailing delimiter, an empty last column
        out.pop()
    return [f.strip() for f in out]


def _is_value(cell, decimal="."):
    """A number (with this decimal mark) or a date-time stamp."""
    if decimal == "," and "." in cell and "," not in cell:
        return bool(NUMBER.match(cell))
    return bool(NUMBER.match(cell)) or is_stamp(cell)


def _shape(lines, delimiter):
    """(the field count most tail lines have, how many of the tail's cells are values) of
    the lines split by delimiter."""
    rows = [_fields(line, delimiter) for line in lines]
    counts = [len(r) for r in rows if len(r) >= 2] or [len(r) for r in rows]  # rows of one cell: the rest empty
    n = max(set(counts), key=counts.count)
    values = sum(_is_value(c) for r in rows if len(r) == n for c in r)
    return n, values


def sniff(text: str, units: frozenset | set = frozenset()) -> Layout:
    """The table's layout; UsageError when no delimiter gives at least two columns of
    values. units: the unit names (lower case) a row of units under the names may hold,
    besides a DAQ's own (OTHER_UNITS) and any in brackets."""
    lines = text.splitlines()
    filled = [i for i, line in enumerate(lines) if line.strip()]
    if not filled:
        raise UsageError("an empty file")
    tail = [lines[i] for i in filled[-TAIL:]]
    best = None
    for d in DELIMITERS:
        try:
            n, values = _shape(tail, d)
        except csv.Error:
            continue
        # a tie: whitespace splits a stamp's date from its clock (both values), so it never wins one
        if n >= 2 and (best is None or values > best[2] or values == best[2] and n > best[1] and d is not None):
            best = (d, n, values)
    if best is not None and best[2] == 0 and len(filled) <= 3:  # names, perhaps units: a header and nothing under it
        more = len(filled) - 1
        raise UsageError(f"no rows of data: the file holds only its header ({lines[filled[0]].strip()[:60]!r}"
                         + (f" and {more} more line{'s' * (more > 1)}" if more else "") + ")")
    if best is None or best[2] == 0:
        raise UsageError("not a table: no delimiter (comma, semicolon, tab, spaces) gives two columns of numbers")
    d, n, _ = best
    # a comma in a number with no point (quoted, where the comma delimits): 1,5 is one and a half
    decimal = "," if any("," in c and "." not in c and NUMBER.match(c) for line in tail for c in _fields(line, d)) \
        else "."
    first = None
    for i in filled:  # the first line shaped as the data, its leading cells values
        f = _fields(lines[i], d)
        shaped = len(f) >= max(n - 1, 2) and _is_value(f[1], decimal) or (  # or a value, then empty cells
            d is not None and len(f) == 1 and lines[i].count(d) >= max(n - 1, 2))
        if f and (_is_value(f[0], decimal) or DATE.match(f[0])) and shaped:  # a date alone: its clock beside it
            first = i
            break
    if first is None:
        raise UsageError("not a table: no row of numbers")
    before = [i for i in filled if i < first]
    header = before[-1] if before else None
    names = _fields(lines[header], d) if header is not None else []
    if names:  # a header written as a comment (`# time [s], ...`, `%time`): the mark is no part of the name
        names[0] = names[0].lstrip("#% ").strip() or names[0]
    if header is not None and (len(names) < 2 or all(_is_value(c, decimal) for c in names)):
        header, names = None, []
    units_line = None
    if header is not None and len(before) >= 2 and _units_row(names, units):  # names, then their units (a DAQ's)
        above = _fields(lines[before[-2]], d)
        if len(above) == len(names) and not any(_is_value(c, decimal) for c in above if c):
            units_line, header = header, before[-2]
            names = [f"{a} [{u.strip('[]()')}]" if u else a for a, u in zip(above, names)]
    preamble = [lines[i] for i in before if i not in (header, units_line)]
    rate = None
    for line in preamble:
        m = RATE.match(line) or INTERVAL.match(line)
        if m:
            try:
                v = float(m.group(2))
            except ValueError:
                continue
            if v > 0:
                rate = v if m.re is RATE else 1.0 / v
                if m.re is RATE:
                    break
    n = max([n, *(len(_fields(lines[i], d)) for i in filled if first <= i < first + TAIL)])  # an events column
    names = _distinct([c or str(j + 1) for j, c in enumerate(names)] + [str(j + 1) for j in range(len(names), n)])
    return Layout(d, decimal, header, first, names, rate, preamble, units_line)


def _distinct(names):
    """Column names made distinct: a name the header repeats (two load cells both `Force`)
    gets its column's position, `Force #3`, so that no column hides another."""
    return [f"{c} #{j + 1}" if names.count(c) > 1 and names.index(c) != j else c for j, c in enumerate(names)]


# units a DAQ writes that import does not convert (volts, hertz, ...)
OTHER_UNITS = {"v", "mv", "hz", "-", "g", "%", "deg", "rad", "m/s^2", "m/s²", "a", "ma"}


def _units_row(cells, units) -> bool:
    """A row of units (s, mm, [kN], (V), ...) rather than of names: every cell empty, in
    brackets, or one of units or a DAQ's own, and one at least filled."""
    filled = [c for c in cells if c]
    return bool(filled) and all(c[:1] + c[-1:] in ("[]", "()") or c.lower() in units or c.lower() in OTHER_UNITS
                                for c in filled)


def split(text: str, layout: Layout) -> dict[str, list[str]]:
    """{column name: [cell, ...]} of the data rows (a short row's missing cells empty)."""
    d = layout.delimiter
    n = len(layout.names)
    every = text.splitlines()
    lines = every[layout.first:]
    while lines and not lines[-1].strip():
        lines.pop()
    lines, layout.postamble = _postamble(lines, d)
    if lines and not layout.postamble and _cut_short(lines, d, n, text.endswith(("\n", "\r"))):
        layout.cut = (f"line {layout.first + len(lines)}: the file stops inside its last row "
                      f"({lines[-1].strip()[-40:]!r}): a cut file; the row is left out")
        lines = lines[:-1]
    empty = "" if d is None else d * (n - 1)
    lines = [line if line.strip() else empty for line in lines]  # a row of empty cells: each row keeps its line
    if layout.header is not None and text.count(every[layout.header].strip()) > 1:  # the header again: joined exports
        lines = _repeats_emptied(lines, every[layout.header:layout.first], d, n)
    if d is not None and '"' not in text and all(line.count(d) == n - 1 for line in lines):
        # every row complete (the common case): one split of the whole body, columns by slicing
        flat = d.join(lines).split(d)
        cols = {name: flat[j::n] for j, name in enumerate(layout.names)}
        for name, cells in cols.items():  # padded cells (a DAQ's ", 05/13/2022"), looked for at both ends
            if any(c != c.strip() for c in cells[:50] + cells[-50:]):
                cols[name] = [c.strip() for c in cells]
        return cols
    if d is None:
        rows = [line.split() for line in lines]
    elif '"' in text:  # quoted cells: the csv module's reading
        try:
            rows = list(csv.reader(lines, delimiter=d))
        except csv.Error as e:
            raise UsageError(f"not a table of numbers ({e})") from None
    else:
        rows = [line.split(d) for line in lines]
    rows = [r if len(r) == n else r[:n] if len(r) > n else r + [""] * (n - len(r)) for r in rows]
    return {name: [c.strip() for c in cells] for name, cells in zip(layout.names, zip(*rows))} if rows else \
        {name: [] for name in layout.names}


CUT_LOOK = 20  # rows before the last whose number format says what a whole last cell looks like


def _cut_short(lines, d, n, ends_cleanly) -> bool:
    """Whether the last data line is a row the file stops inside: short of its columns, or,
    where the file does not end its last line, its last cell shorter than that column's
    fixed format in the rows before (`12` where every row writes `129.83`)."""
    cells = lines[-1].split(d) if d is not None else lines[-1].split()
    if len(cells) < n and len(lines) > 1:
        before = lines[-2].split(d) if d is not None else lines[-2].split()
        return len(before) >= n  # the row before it is whole: this one was cut
    if ends_cleanly or len(cells) != n or len(lines) <= CUT_LOOK:
        return False
    shape = {_digits(line.split(d)[-1] if d is not None else (line.split() or [""])[-1])
             for line in lines[-CUT_LOOK - 1:-1]}
    last = _digits(cells[-1])
    return len(shape) == 1 and last != (s := next(iter(shape))) and s[1] > 0 and (last[1] < s[1])


def _digits(cell) -> tuple[bool, int]:
    """(a number, its decimals) of a cell: the format a column writes its numbers in."""
    c = cell.strip().strip('"')
    if not NUMBER.match(c) or "e" in c.lower():
        return (False, 0)
    mantissa = c.replace(",", ".")
    return (True, len(mantissa.partition(".")[2]) if "." in mantissa else 0)


def _repeats_emptied(lines, head, d, n):
    """lines with each repeat of the header (exports joined one after another), its units
    line and the preamble lines before it made rows of empty cells, which import drops as
    rows without a time: the rows keep their places, and the tests follow on."""
    names = head[0].strip()
    at = [i for i, line in enumerate(lines) if line.strip() == names]
    if not at:
        return lines
    lines = list(lines)
    empty = "" if d is None else d * (n - 1)
    for i in at:
        j = i
        while j > 0 and not _data_row(lines[j - 1], d):
            j -= 1
        k = i + 1 + (len(head) > 1 and i + 1 < len(lines) and lines[i + 1].strip() == head[1].strip())
        lines[j:k] = [empty] * (k - j)
    return lines


POSTAMBLE = 100  # lines at most after the last row of data that are no data (a summary block)


def _postamble(lines, d):
    """(the data lines, the lines after the last row of data): an export's summary block
    (`Max Force,345.2`) closing a table whose rows start with a value."""
    if not lines or not _data_row(lines[0], d):
        return lines, []
    last = next((i for i in range(len(lines) - 1, max(len(lines) - POSTAMBLE - 2, -1), -1)
                 if _data_row(lines[i], d)), None)
    if last is None or last == len(lines) - 1:
        return lines, []
    return lines[:last + 1], [line for line in lines[last + 1:] if line.strip()]


def _data_row(line, d) -> bool:
    """A line whose first cell is a number or a date-time stamp."""
    first = (line.split(d) if d is not None else line.split() or [""])[0].strip().strip('"')
    return bool(NUMBER.match(first) or is_stamp(first) or DATE.match(first))


def column(cols: dict, layout: Layout, key: str) -> str:
    """The name of the column `key` names: its header, or its 1-based position."""
    if key in cols:
        return key
    if key.isdigit() and 1 <= int(key) <= len(layout.names):
        return layout.names[int(key) - 1]
    raise UsageError(f"no column {key!r}; columns: " + ", ".join(
        f"{j + 1}={c}" if c != str(j + 1) else c for j, c in enumerate(layout.names)))


# what spreadsheets and loggers write where a value is missing: read as an empty cell
MISSING = ("#n/a", "n/a", "#na", "na", "null", "none", "<na>", "-", "--", "#value!", "#div/0!", "#num!", "1.#ind",
           "1.#qnan")


def numbers(cells: list[str], decimal: str = ".") -> tuple[np.ndarray, int | None]:
    """(float array with NaN for an empty cell or one marked missing, index of the first
    cell that is not a number or None)."""
    if decimal == ".":
        try:  # every cell a number (the common case): no string array
            return np.fromiter(map(float, cells), float, len(cells)), None
        except ValueError:
            pass  # an empty cell or a non-number: below
    a = np.array(cells, dtype=str)
    if decimal == ",":
        a = np.char.replace(a, ",", ".")
    a = np.where((a == "") | np.isin(np.char.lower(a), MISSING), "nan", a)
    try:
        return a.astype(float), None
    except ValueError:
        for i, c in enumerate(a):
            try:
                float(c)
            except ValueError:
                return np.array([]), i
    return np.array([]), None  # unreachable: astype and float agree


def is_stamp(cell: str) -> bool:
    return bool(ISO.match(cell) or DMY.match(cell) or CLOCK.match(cell) or ELAPSED.match(cell))


def day_first(cells: list[str] | np.ndarray) -> bool | None:
    """Whether a column's DD/MM/YYYY-or-MM/DD/YYYY stamps put the day first: dots
    (DD.MM.YYYY) or a first field over 12 say so; a second over 12 says month first; past
    midnight, the reading whose dates lie closer together; otherwise None: the stamps
    cannot tell (read month first, as the US writes them)."""
    dates = {m.group(1, 2, 3, 4) for c in cells if c and (m := DMY.match(c))}  # a recording spans a few
    if any(sep == "." or int(a) > 12 for a, sep, _, _ in dates):
        return True
    if any(int(b) > 12 for _, _, b, _ in dates):
        return False
    if len(dates) > 1:
        try:
            span = [max(d) - min(d) for d in ([datetime(int(y), int(a), int(b)) for a, _, b, y in dates],
                                              [datetime(int(y), int(b), int(a)) for a, _, b, y in dates])]
        except ValueError:  # a day or month 0: stamps() names the cell
            return None
        return None if span[0] == span[1] else span[1] < span[0]
    return None


def stamps(cells: list[str], order: str = "find") -> tuple[np.ndarray, int | None]:
    """(seconds since 1970-01-01 UTC of each date-time stamp, NaN for an empty cell; index
    of the first cell that is not a stamp, or None). ISO 8601 (or YYYY/MM/DD) with a space
    or T, with or without a zone; MM/DD/YYYY or DD/MM/YYYY (day_first), DD.MM.YYYY, with
    AM/PM or a 24-hour clock. A stamp without a zone is taken as UTC (the recording does not
    say where it was made). The time of day alone (hh:mm:ss.fff) counts from the first
    day's midnight, a day added where the clock goes back past midnight; it gives no date
    (dated says so). order: day_first's answer, when the caller has it."""
    out = np.full(len(cells), np.nan)
    if cells and (m := ISO.match(cells[0])) and m.group(2) == "-" and not m.group(8) and all(cells):
        try:  # the common case, zone-less ISO stamps in every row: numpy parses them at C speed
            with warnings.catch_warnings():
                warnings.simplefilter("error")  # a later row with a zone: numpy would warn and shift it
                return np.array(cells, dtype="datetime64[us]").astype("int64") / 1e6, None
        except (ValueError, UserWarning):
            pass  # one that numpy refuses, or a zone: each row below
    days = {}  # a recording spans a few dates: each converted once
    dmy_day = day_first(cells) if order == "find" else order
    day, last = 0.0, None  # the time of day alone: its day, and the clock's last reading
    for i, c in enumerate(cells):
        if not c:
            continue
        half, offset, key = None, 0.0, None
        if m := ISO.match(c):
            y, _, mo, d, h, mi, s, zone = m.groups()
            if zone and zone != "Z":
                z = zone.replace(":", "")
                offset = (1 if z[0] == "+" else -1) * (int(z[1:3]) * 3600 + int(z[3:5]) * 60)
            key = (y, mo, d)
        elif m := DMY.match(c):
            a, _, b, y, h, mi, s, half = m.groups()
            key = (y, a, b) if dmy_day is False or dmy_day is None else (y, b, a)
        elif m := CLOCK.match(c):
            h, mi, s, half = m.groups()
        elif m := ELAPSED.match(c):
            minutes, s = m.groups()
            h, mi, half = str(int(minutes) // 60), str(int(minutes) % 60), None
        else:
            return out, i
        if half:
            h = str(int(h) % 12 + (12 if half.upper() == "PM" else 0))
        if key is not None and key not in days:
            try:
                days[key] = datetime(int(key[0]), int(key[1]), int(key[2]), tzinfo=timezone.utc).timestamp()
            except ValueError:
                return out, i
        hour, minute, sec = int(h), int(mi), float((s or "0").replace(",", "."))
        if hour > 23 or minute > 59 or sec >= 61:
            return out, i
        clock = hour * 3600 + minute * 60 + sec
        if key is None:
            day += 86400.0 if last is not None and clock < last - 43200.0 else 0.0  # past midnight
            last = clock
        out[i] = (days[key] if key is not None else day) + clock - offset
    return out, None


PREAMBLE_STAMP = re.compile(r"^\s*\"?([A-Za-z][A-Za-z _./-]*?)\"?\s*[:=\t;,]\s*\"?(.+?)\"?[\s,;]*$")
STARTS = ("start", "trigger", "date", "time", "recorded", "acquired", "created")


def preamble_start(lines: list[str]) -> float | None:
    """Seconds since 1970 UTC of the start a preamble gives (`Start time: 13.05.2022
    17:04:23`, `Trigger Date,2022-05-13 17:04:23`, or a `Date` line and a `Time` line),
    or None: a time column of numbers counts from it."""
    found = [m.group(2) for line in lines if (m := PREAMBLE_STAMP.match(line))
             and any(w in m.group(1).lower() for w in STARTS)]
    dates = [v for v in found if not is_stamp(v) and is_stamp(f"{v} 00:00:00")]
    clocks = [v for v in found if CLOCK.match(v)]
    for v in [v for v in found if is_stamp(v) and dated([v])] + [f"{d} {c}" for d in dates[:1] for c in clocks[:1]]:
        t, bad = stamps([v])
        if bad is None:
            return float(t[0])
    return None


def with_date(cols: dict, clock: list) -> list:
    """A time-of-day column's cells with the date a column of dates alone gives each row
    (`Date` beside `Time`), else as they are."""
    if dated(clock):
        return clock
    dates = next((c for c in cols.values() if not isinstance(c, np.ndarray) and c is not clock
                  and (first := next((x for x in c[:5] if x), None)) and DATE.match(first)), None)
    return clock if dates is None else [f"{d} {c}" if d and c else "" for d, c in zip(dates, clock)]


def dated(cells: list[str] | np.ndarray) -> bool:
    """Whether a column's stamps carry a date (not the time of day alone)."""
    return not any(CLOCK.match(c) or ELAPSED.match(c) for c in cells[:5] if c)


def iso(epoch: float) -> str:
    """An epoch time [s] as ISO 8601 UTC."""
    return (datetime(1970, 1, 1, tzinfo=timezone.utc) + timedelta(seconds=float(epoch))).isoformat(timespec="milliseconds")
