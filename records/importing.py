"""A recording another dyno or acquisition system made, written as a dyno recording: its
table read (csv_import.py), its signs made ours, its velocity derived where it has none,
its motion segmented as a run of ours marks it, and what the file could not tell said as
notes (`dyno import`, `dyno import --inspect`)."""
from __future__ import annotations

import gc
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from records.files import Claim
from records.table import Layout
from rig.errors import UsageError

FLIPS = ("force", "displacement", "velocity")
PLOT_POINTS = 10_000  # /plot messages per channel at most: over two per pixel of a 4k display; /channels keeps every sample
BATCH = 5000  # samples per /channels message


@dataclass
class Source:
    """What to read from the file and how it was made: the map (NAME=COLUMN[:UNIT]), gains
    and offsets into the mapped units, channels counted the other way, the rate when no
    time column says it, the sheet, the aux channels that drive the damper, the source's
    own filter (records/source_filter.py) and who tested which damper (run metadata)."""
    file: str
    map: list
    gains: dict = field(default_factory=dict)
    offsets: dict = field(default_factory=dict)
    flips: tuple = ()
    rate: float | None = None
    sheet: str | None = None
    drives: dict = field(default_factory=dict)
    smoothing: object = None
    identity: dict = field(default_factory=dict)
    start: float | None = None  # s since the epoch: when the test began (--start), for a file that holds no date
    given: dict = field(default_factory=dict)  # the options as given, kept in the recording's params
    allow_gaps: bool = False  # rows of displacement or force without a number imported (--allow-gaps), not refused


@dataclass
class Imported:
    """What was written: the recording, its rows, when it started (and how that is known),
    its channels with their units, the segments found (records/segmentation.py) and the notes."""
    path: Path
    rows: int
    wall_start: float | None  # s since the epoch; None: unknown (the file holds no date, no --start)
    dated: str  # "" when the file says its date, else how its start was taken
    channels: dict  # {channel: unit}
    velocity_derived: bool
    named_units: dict  # {name: unit} taken from the columns' names
    segments: list  # segmentation.Segment, in order: they cover the recording
    notes: list[str]


def scales(items: list[str], what: str) -> dict[str, float]:
    """{channel: number} from NAME=NUMBER options (--gain, --offset)."""
    out = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if not sep or not math.isfinite(v) or (what == "--gain" and v == 0) or abs(v) > 1e12:
            raise UsageError(f"{what} {item}: expected NAME=NUMBER (a finite number{', not 0' * (what == '--gain')})")
        out[name] = v
    return out


def start_of(text: str | None) -> float | None:
    """s since the epoch of --start DATE-TIME (ISO 8601; without a zone, UTC); None without it."""
    from datetime import datetime, timezone
    if text is None:
        return None
    try:
        when = datetime.fromisoformat(text.strip())
    except ValueError:
        raise UsageError(f"--start {text}: expected an ISO 8601 date and time, e.g. 2025-11-14T20:14:37") from None
    return (when if when.tzinfo else when.replace(tzinfo=timezone.utc)).timestamp()


def drives(items: list[str], mapping: list[tuple[str, str, str]]) -> dict[str, str]:
    """{aux channel: what of the damper it drives} from --drive NAME=KIND."""
    from rig.config import DRIVES
    out = {}
    for item in items or ():
        name, _, kind = item.partition("=")
        if not name.startswith("aux.") or name not in {n for n, _, _ in mapping}:
            raise UsageError(f"--drive {item}: {name!r} is not a mapped aux.NAME channel")
        if kind not in DRIVES:
            raise UsageError(f"--drive {item}: say what it drives: {', '.join(f'{name}={k}' for k in DRIVES)}")
        out[name] = kind
    return out


def import_file(src: Source, claim: Claim) -> Imported:
    """Read src, write it through claim (files.Claim) as an MCAP recording; UsageError names
    what cannot be read."""
    gc_was = gc.isenabled()
    gc.disable()  # millions of cells and floats, no cycles among them: the collector would take most of the time
    try:
        return _import(src, claim)
    finally:
        if gc_was:
            gc.enable()


def _import(src, claim):
    from records import gas_force, segmentation
    from records.csv_import import parse_map, read
    from records.velocity import derived_velocity
    from records.data import flips, sign_sentence
    from records.recorder import UNDATED, Recorder
    got = read(src.file, parse_map(src.map), src.gains, src.offsets, src.rate, src.sheet)
    data, units = got.data, got.units
    _gaps(src, got)
    flip(data, set(src.flips))
    t = data.pop("time")
    if "velocity" not in data:
        ok = ~np.isnan(data["displacement"])
        data["velocity"] = np.full_like(t, np.nan)
        data["velocity"][ok] = derived_velocity(t[ok], data["displacement"][ok])
        units["velocity"] = "derived from displacement"
    channels, gaps = _channels(t, data, units, got.lines)
    cfg = SimpleNamespace(
        name="imported", path=Path(src.file),
        channels={n: SimpleNamespace(unit=u, device="import", signal=n, gain=1.0, offset=0.0,
                                     drives=src.drives.get(n, "")) for n, (_, _, u) in channels.items()},
        text=f'# imported by dyno import\n[import]\nsource = "{Path(src.file).name}"\n'
             f"map = {json.dumps(src.map)}\n")
    if got.start_epoch is not None:
        wall_start, how = got.start_epoch, got.start_source
    elif src.start is not None:
        wall_start, how = src.start, "--start"
    else:  # never the file's time (when it was copied): log times count from 1970, the date says unknown
        wall_start, how = None, UNDATED
    params = {"source": str(src.file), **src.given,
              **({"sheet": got.layout.sheet} if got.layout and got.layout.sheet else {})}
    every = -(-len(t) // PLOT_POINTS)
    ok = ~np.isnan(data["displacement"])
    found = segmentation.find(t[ok] - t[0], data["displacement"][ok], src.smoothing)
    # what the report says again; it says the rest itself
    kept = (_time_notes(got, t, src.map) + ([got.layout.cut] if got.layout and got.layout.cut else [])
            + got.unit_notes + gaps + _zero_note(data, units) + _velocity_note(t, data, units))
    kept += _smoothing_note(src.smoothing, found)
    other = flips(data["displacement"], data["force"], t)
    holds = gas_force.holds_of(found)
    if not other:
        gas = gas_force.at_turns(t, data["displacement"], data["force"])
        kept += [gas_force.said(gas, gas_force.centred(data["force"], gas))]
    kept += gas_force.said_at_rest(gas_force.at_rest(t[ok] - t[0], data["force"][ok], holds), holds)
    notes = list(kept)
    notes += [f"sign: {sign_sentence(other)}"] if other else []
    notes += [postamble(got.layout)] if got.layout and got.layout.postamble else []
    rec = Recorder(claim, cfg, "", "import", params, wall_start=wall_start or 0.0, plot_every=every,
                   run_info=_run_info(got, how, every, src, kept))
    try:
        for n, (tt, v, _) in channels.items():
            for i in range(0, len(tt), BATCH):
                rec.samples({n: (tt[i:i + BATCH], v[i:i + BATCH])})
        for e in segmentation.events(found):  # as a run of ours marks its segments
            rec.event(e)
        rec.commit()
    finally:
        rec.close()
    return Imported(rec.path, len(t), wall_start, "" if got.start_epoch is not None else how,
                    {n: u for n, (_, _, u) in channels.items()}, units.get("velocity", "").startswith("derived"),
                    dict(got.named_units or {}), list(found), notes)


def _smoothing_note(smoothing, found) -> list[str]:
    """What import says of the source's filter; a share of a period where nothing repeats is refused."""
    from records import source_filter
    if smoothing is None:
        return []
    if isinstance(smoothing, source_filter.LowPass):
        return [f"filtered by its source: the force through a {'zero-phase' if smoothing.zero_phase else 'causal'} "
                f"{smoothing.text()} low-pass; the analyses compare every model with it through the same filter"]
    if smoothing.per_period and not any(f.kind == "sine" for f in found):
        raise UsageError(f"--smoothed {smoothing.text()}: no stroke of this file repeats, so it has no period to "
                         f"take a share of: give the moving average's width as a time (e.g. 20ms)")
    return [f"smoothed by its source: a centred moving average of {smoothing.text()}; the analyses compare every "
            f"model with it through the same filter"]


GAPLESS = ("displacement", "force")  # a row without a number among theirs is refused, or said (--allow-gaps)


def _gaps(src, got):
    """UsageError naming the first line where a displacement or force holds no number
    among its numbers (NaN, an empty or missing cell), unless src.allow_gaps."""
    from records.csv_import import parse_map
    found = [(got.lines[e[0]], name, len(e)) for name in GAPLESS if name in got.data and not src.allow_gaps
             for e in [np.nonzero(np.isnan(got.data[name]))[0]] if len(e)]
    if found:
        line, name, n = min(found)
        column = next(c for m, c, _ in parse_map(src.map) if m == name)
        raise UsageError(f"{src.file}:{line}: column {column!r} ({name}): {n} row{'s' * (n > 1)} with no number among "
                         f"its numbers (NaN, an empty or missing cell); --allow-gaps imports the rest and says each line")


def _channels(t, data, units, lines):
    """({channel: (t [s] from the first row, values, unit)}, notes): each mapped column's
    rows that hold a number; a column with none is left out, and rows without one (NaN,
    an empty or missing cell) are said with their count and lines (the file's line of
    each row)."""
    from records.column_units import SI
    from records.csv_import import CHANNELS
    channels, gaps = {}, []
    for name, a in data.items():
        ok = ~np.isnan(a)
        if not ok.any():  # an empty column
            continue
        channels[CHANNELS.get(name, name)] = (t[ok] - t[0], a[ok], SI.get(name, units.get(name, "")))
        if not ok.all() and name != "velocity":  # a derived velocity has a gap where its displacement has
            at = lines[~ok] if lines is not None and name in GAPLESS else []
            gaps.append(f"{name}: {int((~ok).sum())} of {len(a)} rows hold no number (NaN, or an empty or missing "
                        f"cell): left out of it, the channel read between them"
                        + (f" (line{'s' * (len(at) > 1)} {_lines(at)})" if len(at) else ""))
    return channels, gaps


def _lines(at, most=8) -> str:
    """A file's line numbers, the first `most` of them and how many more."""
    shown = ", ".join(str(int(i)) for i in at[:most])
    return shown + (f" and {len(at) - most} more" if len(at) > most else "")


def _run_info(got, how, every, src, kept) -> dict:
    from records.recorder import UNDATED
    """The recording's run metadata: who tested which damper, where its start and time came
    from, the source's smoothing (records/source_filter.py) and what import said of the
    file, for the report."""
    from records.source_filter import RUN_KEY
    return {**src.identity, "wall_start_source": how, **({"wall_start": UNDATED} if how == UNDATED else {}),
            **({"time_source": got.derived_time} if got.derived_time else {}),
            **({"plot_every": every} if every > 1 else {}),
            **({RUN_KEY: src.smoothing.text()} if src.smoothing else {}),
            **({"import_notes": "\n".join(kept)} if kept else {})}


def postamble(layout: Layout | None) -> str:
    """What import leaves out after the data: an export's summary block."""
    lines = layout.postamble
    return (f"after the data, left out: {len(lines)} line{'s' * (len(lines) > 1)} that are no row of it ("
            + "; ".join(repr(line.strip()) for line in lines[:3]) + (", ..." if len(lines) > 3 else "") + ")")


def flip(data: dict, flips: list[str]) -> dict:
    """The channels counted the other way made ours: the force negated, the displacement
    about its most extended reading (its velocity with it), the velocity alone."""
    if "velocity" in flips and "velocity" not in data:
        raise UsageError("--flip velocity: no velocity is mapped (the one derived from the displacement follows it)")
    for name in flips & {"force", "displacement"}:
        data[name] = -data[name] + (np.nanmax(data[name]) if name == "displacement" else 0.0)
    if "velocity" in data and ("displacement" in flips) != ("velocity" in flips):
        data["velocity"] = -data["velocity"]


def _time_notes(got, t, maps) -> list[str]:
    """What the time column could not tell (the day from the month, its unit) or how it was
    read (tests one after another)."""
    notes = [f"time: {got.time_note}"] if got.time_note else []
    step = float(np.median(np.diff(t))) if len(t) > 2 else 0.0
    if step >= 0.5 and not got.stamped and any(m.startswith("time=") and ":" not in m for m in maps):
        notes.append(f"time: one row every {step:.3g} s ({1 / step:.3g} Hz), read as seconds: a dyno samples "
                     f"faster; in ms? give --map time=COLUMN:ms")
    return notes


def _zero_note(data, units) -> list[str]:
    """A displacement below zero, with the offset that puts its most extended reading at zero."""
    from records.column_units import UNITS
    from records.data import below_extension
    unit = units.get("displacement", "m")
    below = below_extension(data["displacement"], unit, UNITS["displacement"].get(unit, (1.0,))[0])
    return [f"displacement: {below}"] if below else []


def _velocity_note(t, data, units) -> list[str]:
    """A mapped velocity that is not the displacement's rate of change (the other way, or in
    another unit)."""
    from records.data import velocity_disagrees
    if units.get("velocity", "").startswith("derived"):
        return []
    said = velocity_disagrees(t, data["displacement"], data["velocity"])
    return [f"velocity: {said}"] if said else []


@dataclass
class Inspection:
    """What import would read from a file: its layout, its columns with sample values, and
    the map guessed from their names and values."""
    layout: object  # table.Layout, or None (a file format with named columns)
    described: str
    rows: int
    columns: list  # [(1-based position, name, sample values, "date-time" or "")]
    guesses: list[str]  # NAME=COLUMN[:UNIT] from the columns' names
    from_values: list  # [(NAME=COLUMN[:UNIT], why)] from their values
    sign: str  # a sign convention other than ours, said; "" if none seen
    counters: list[str]  # numeric columns that count the rows
    unnamed: list[str]  # numeric columns guessed from nothing


def inspect_file(file: str | Path, sheet: str | None = None, given: list[str] = ()) -> Inspection:
    """What import would read from the file, the map given (--map) kept and the rest
    guessed. Writes nothing."""
    from records import table
    from records.column_guess import SAMPLES, by_name, by_values, counter, key_of, length_units, numeric, sign
    from records.column_units import volts
    from records.csv_import import source
    cols, layout = source(file, sheet)
    rows = len(next(iter(cols.values()))) if cols else 0
    columns, guesses, named = [], list(given or ()), []
    taken = {item.partition("=")[2].partition(":")[0] for item in guesses}  # the columns the map names
    for j, (name, cells) in enumerate(cols.items()):
        sample = [str(c) for c in list(cells[:SAMPLES])]
        columns.append((j + 1, name, sample, "date-time" if sample and table.is_stamp(sample[0]) else ""))
        g = by_name(name, cells)
        if g and not {name, str(j + 1)} & taken:
            named.append((bool(volts(name, np.empty(0))), j, name, g))
    mine = []
    for _, j, name, g in sorted(named, key=lambda n: n[0]):  # a column in engineering units before its volt twin
        if not any(x.split("=")[0] == g.split(":")[0] for x in guesses + mine):
            mine.append(f"{g.split(':')[0]}={key_of(j, name, layout)}" + (f":{g.split(':')[1]}" if ":" in g else ""))
    guesses += length_units(mine, cols, layout)
    mapped = {g.split("=", 1)[1].split(":")[0] for g in guesses}
    found = by_values(cols, layout, guesses)
    mapped |= {g.split("=", 1)[1].split(":")[0] for g, _ in found}
    rest = [(f"{j + 1} ({name})", counter(cells, layout)) for j, (name, cells) in enumerate(cols.items())
            if name not in mapped and str(j + 1) not in mapped and numeric(cells) and by_name(name, cells) is None]
    return Inspection(layout, layout.describe() if layout else Path(file).suffix[1:] + " columns", rows, columns,
                      guesses, list(found), sign(cols, layout, guesses + [g for g, _ in found]) or "",
                      [u for u, c in rest if c], [u for u, c in rest if not c])
