"""`dyno import FILE --out FILE.mcap --map NAME=COLUMN[:UNIT] ...`: a recording another dyno
or acquisition system made (CSV, a DAQ's text export, Excel, TDMS, Parquet, MATLAB) as a dyno recording;
`--inspect` shows what would be read and writes nothing. The table's layout:
protocols/io/table.py; the columns' units: protocols/io/column_units.py."""
from __future__ import annotations

import gc
import json
import math
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from protocols.app.arguments import FILE, identity, identity_info, number, overwrite, writes
from protocols.errors import UsageError

FLIPS = ("force", "displacement", "velocity")
PLOT_POINTS = 10_000  # /plot messages per channel at most: over two per pixel of a 4k display; /channels keeps every sample
BATCH = 5000  # samples per /channels message


def add(sub):
    """The `dyno import_csv` command's arguments."""
    im = sub.add_parser("import", help="a recording from another dyno or a DAQ (CSV, text export, Excel, TDMS, "
                                       "Parquet, MATLAB) as an MCAP recording")
    im.add_argument("file", metavar="FILE", help="CSV or any delimited text (a preamble, a decimal comma, no header: "
                                                 "found), .xlsx, .tdms, .parquet or .mat")
    im.add_argument("--inspect", action="store_true", help="show what would be read (layout, columns, sample values, "
                                                           "rate, a guessed map); write nothing")
    writes(im, "--out", FILE, metavar="FILE.mcap", help="the recording to write")
    overwrite(im, "--out")
    im.add_argument("--map", action="append", metavar="NAME=COLUMN[:UNIT]",
                    help="time, displacement, velocity, force, temperature, pressure or aux.NAME from a column by "
                         "its header or 1-based position (a MATLAB matrix's: VAR[N]); units e.g. ms, mm, mm/s, kN, C, "
                         "bar (default SI); time may be date-time stamps")
    for flag, meta, what in (("--gain", "NAME=NUMBER", "a raw channel's gain into its mapped unit, e.g. force=980.665"),
                             ("--offset", "NAME=NUMBER", "added after the gain, in the mapped unit, e.g. displacement=29.9"),
                             ("--drive", "aux.NAME=KIND", "an aux channel that drives the damper: coil current, coil "
                                                          "voltage, valve current or valve command (else a reading)")):
        im.add_argument(flag, action="append", metavar=meta, help=what)
    im.add_argument("--flip", action="append", choices=FLIPS,
                    help="the file counts it the other way: force positive in tension, displacement from the "
                         "other end (its velocity with it), or the velocity alone rebound positive (dyno: all "
                         "positive in compression)")
    im.add_argument("--smoothed", metavar="WIDTH",
                    help="the file's source passed force and displacement through a centred moving average this "
                         "wide: a share of the test period (0.1period) or a time (20ms); the analyses compare every "
                         "model with the recording through the same filter")
    im.add_argument("--filtered", metavar="force=SPEC",
                    help="the file's source passed the force alone through a low-pass: force=butter:2:15Hz (a "
                         "causal 2nd-order Butterworth at 15 Hz, as a DAQ's), bessel likewise, ':zero-phase' appended "
                         "for one run forwards and back; every model is compared with the force through it")
    im.add_argument("--sheet", metavar="NAME", help="an Excel workbook's sheet to read (default: its fullest)")
    im.add_argument("--rate", type=number(above=0, hi=1e6), default=None, metavar="HZ",
                    help="the sampling rate, when no time column is mapped and the file does not say it")
    identity(im, "test the file holds")
    im.set_defaults(command="import_csv")


def _scales(items, what):
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


def _drives(items, mapping):
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


def run(args):
    from models import source_filter
    from protocols.io.csv_import import parse_map
    from protocols.io.files import Claim
    for option in ("inspect", "gain", "offset", "flip", "rate", "drive", "sheet", "smoothed", "filtered"):  # a caller's namespace may have only the map
        setattr(args, option, getattr(args, option, None))
    if args.inspect:
        return inspect(args)
    if not args.map:
        raise UsageError("--map: give at least displacement=COLUMN and force=COLUMN (dyno import FILE --inspect "
                       "shows the columns)")
    mapping = parse_map(args.map)
    gains, offsets = _scales(args.gain, "--gain"), _scales(args.offset, "--offset")
    for name in {*gains, *offsets} - {n for n, _, _ in mapping}:
        raise UsageError(f"--gain/--offset {name}: not a mapped channel")
    args.drives = _drives(args.drive, mapping)
    try:
        args.smoothing = None if args.smoothed is None else source_filter.parse(args.smoothed)
    except ValueError as e:
        raise UsageError(f"--smoothed {e}") from None
    if getattr(args, "filtered", None) is not None:
        if args.smoothing is not None:
            raise UsageError("--filtered and --smoothed: give the one filter the source applied")
        try:
            args.smoothing = source_filter.parse_filtered(args.filtered)
        except ValueError as e:
            raise UsageError(f"--filtered {e}") from None
    if args.out is None:
        raise UsageError("--out FILE.mcap: where to write the recording (or --inspect to only look)")
    claim = Claim(args.out, args.overwrite, inputs=[args.file])  # checked before the file is read
    gc_was = gc.isenabled()
    gc.disable()  # millions of cells and floats, no cycles among them: the collector would take most of the time
    try:
        return _import(args, mapping, gains, offsets, claim)
    finally:
        if gc_was:
            gc.enable()
        claim.abandon()  # nothing, once the recording was committed
        claim.release()


def _import(args, mapping, gains, offsets, claim):
    from models import segmentation
    from models.recording import other_sign
    from protocols import catalogue
    from protocols.io import table
    from protocols.io.csv_import import derived_velocity, read
    from protocols.io.recording import Recorder
    got = read(args.file, mapping, gains, offsets, args.rate, args.sheet)
    data, units = got.data, got.units
    _flip(data, set(args.flip or ()))
    t = data.pop("time")
    if "velocity" not in data:
        ok = ~np.isnan(data["displacement"])
        data["velocity"] = np.full_like(t, np.nan)
        data["velocity"][ok] = derived_velocity(t[ok], data["displacement"][ok])
        units["velocity"] = "derived from displacement"
    channels, gaps = _channels(t, data, units)
    cfg = SimpleNamespace(
        name="imported", path=Path(args.file),
        channels={n: SimpleNamespace(unit=u, device="import", signal=n, gain=1.0, offset=0.0,
                                     drives=args.drives.get(n, "")) for n, (_, _, u) in channels.items()},
        text=f'# imported by dyno import\n[import]\nsource = "{Path(args.file).name}"\n'
             f"map = {json.dumps(args.map)}\n")
    duration = float(t[-1] - t[0])
    if got.start_epoch is not None:
        wall_start, how = got.start_epoch, got.start_source
    else:  # the file's own start is unknown: its file time less its duration stands for it
        wall_start, how = os.path.getmtime(args.file) - duration, "file time less its duration"
    params = {"source": str(args.file), "map": args.map, "flip": args.flip or [],
              "gain": args.gain or [], "offset": args.offset or [], "drive": args.drive or [],
              **({"sheet": got.layout.sheet} if got.layout and got.layout.sheet else {})}
    every = -(-len(t) // PLOT_POINTS)
    ok = ~np.isnan(data["displacement"])
    found = segmentation.find(t[ok] - t[0], data["displacement"][ok])
    # what the report says again; it says the rest itself
    kept = (_time_notes(got, t, args.map) + got.unit_notes + gaps + _zero_note(data, units)
            + _velocity_note(t, data, units))
    kept += _smoothing_note(args.smoothing, found)
    notes = list(kept)
    if any(f.kind == "sine" for f in found):
        rest = segmentation.left_out(segmentation.unsegmented(t[ok] - t[0], data["displacement"][ok],
                                                              [(f.t0, f.t1) for f in found]))
        notes += [f"not in a segment: {rest}"] if rest else []
    sign = other_sign(data["displacement"], data["force"])
    notes += [f"sign: {sign}"] if sign else []
    notes += [postamble(got.layout)] if got.layout and got.layout.postamble else []
    rec = Recorder(claim, cfg, "", "import", params, wall_start=wall_start, plot_every=every,
                   run_info=_run_info(got, how, every, args.smoothing, kept, args))
    try:
        for n, (tt, v, _) in channels.items():
            for i in range(0, len(tt), BATCH):
                rec.samples({n: (tt[i:i + BATCH], v[i:i + BATCH])})
        for e in segmentation.events(found):  # as a run of ours marks its segments
            rec.event(e)
        rec.commit()
    finally:
        rec.close()
    dated = "" if got.start_epoch is not None else f" (no date in the file: {how})"
    print(f"{rec.path}: {len(t)} rows from {table.iso(wall_start)[:23]} UTC{dated}, channels " + ", ".join(
        f"{n} [{u}]" for n, (_, _, u) in channels.items()) + (" (velocity derived from displacement)"
                                                               if units.get("velocity", "").startswith("derived") else ""))
    if got.named_units:
        print("units from the columns' names: " + ", ".join(f"{n} [{u}]" for n, u in got.named_units.items()))
    sines = [f for f in found if f.kind == "sine"]
    print(f"segments: {len(sines)} periodic" + (": " + ", ".join(f"{f.name} ({f.params['cycles']} cycles)"
                                                                for f in sines[:6]) + (", ..." if len(sines) > 6 else "")
                                              if sines else " (motion that does not repeat: analysed in blocks)")
          + (f"; {len(found) - len(sines)} holds" if len(found) > len(sines) else ""))
    for note in notes:
        print(note)
    print(catalogue.add(rec.path))
    return 0


def _smoothing_note(smoothing, found) -> list[str]:
    """What import says of --smoothed; a share of a period where nothing repeats is refused."""
    from models import source_filter
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


def _channels(t, data, units):
    """({channel: (t [s] from the first row, values, unit)}, notes): each mapped column's
    rows that hold a number; a column with none is left out, and rows without one (NaN,
    an empty or missing cell) are said with their count."""
    from protocols.io.column_units import SI
    from protocols.io.csv_import import CHANNELS
    channels, gaps = {}, []
    for name, a in data.items():
        ok = ~np.isnan(a)
        if not ok.any():  # an empty column
            continue
        channels[CHANNELS.get(name, name)] = (t[ok] - t[0], a[ok], SI.get(name, units.get(name, "")))
        if not ok.all() and name != "velocity":  # a derived velocity has a gap where its displacement has
            gaps.append(f"{name}: {int((~ok).sum())} of {len(a)} rows hold no number (NaN, or an empty or missing "
                        f"cell): left out of it, the channel read between them")
    return channels, gaps


def _run_info(got, how, every, smoothing, kept, args) -> dict:
    """The recording's run metadata: who tested which damper (--operator, --serial, --note,
    --setup), where its start and time came from, the source's smoothing
    (models/source_filter.py) and what import said of the file, for the report."""
    from models.source_filter import RUN_KEY
    return {**identity_info(args), "wall_start_source": how, **({"time_source": got.derived_time} if got.derived_time else {}),
            **({"plot_every": every} if every > 1 else {}),
            **({RUN_KEY: smoothing.text()} if smoothing else {}),
            **({"import_notes": "\n".join(kept)} if kept else {})}


def postamble(layout) -> str:
    """What import leaves out after the data: an export's summary block."""
    lines = layout.postamble
    return (f"after the data, left out: {len(lines)} line{'s' * (len(lines) > 1)} that are no row of it ("
            + "; ".join(repr(line.strip()) for line in lines[:3]) + (", ..." if len(lines) > 3 else "") + ")")


def _flip(data, flips):
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
    from models.recording import below_extension
    from protocols.io.column_units import UNITS
    unit = units.get("displacement", "m")
    below = below_extension(data["displacement"], unit, UNITS["displacement"].get(unit, (1.0,))[0])
    return [f"displacement: {below}"] if below else []


def _velocity_note(t, data, units) -> list[str]:
    """A mapped velocity that is not the displacement's rate of change (the other way, or in
    another unit)."""
    from models.recording import velocity_disagrees
    if units.get("velocity", "").startswith("derived"):
        return []
    said = velocity_disagrees(t, data["displacement"], data["velocity"])
    return [f"velocity: {said}"] if said else []


def inspect(args):
    """What import would read from the file: layout, columns with sample values, the rate,
    and a guessed map. Writes nothing."""
    from protocols.io import table
    from protocols.io.column_guess import SAMPLES, by_name, by_values, counter, key_of, numeric, sign
    from protocols.io.csv_import import source
    cols, layout = source(args.file, args.sheet)
    print(f"{args.file}: {layout.describe() if layout else Path(args.file).suffix[1:] + ' columns'}")
    if layout and layout.preamble:
        print("preamble:")
        for line in layout.preamble[:12]:
            print(f"  {line.strip()}")
    if layout and len(layout.sheets) > 1:
        print(f"sheets: {', '.join(repr(s) for s in layout.sheets)} (--sheet NAME reads another)")
    if layout and layout.postamble:
        print(postamble(layout))
    rows = len(next(iter(cols.values()))) if cols else 0
    print(f"{rows} rows; columns:")
    guesses = []
    for j, (name, cells) in enumerate(cols.items()):
        sample = [str(c) for c in list(cells[:SAMPLES])]
        kind = "date-time" if sample and table.is_stamp(sample[0]) else ""
        print(f"  {j + 1:>2}  {name!r:24} {', '.join(sample)}{'  (' + kind + ')' if kind else ''}")
        g = by_name(name, cells)
        if g and not any(x.split("=")[0] == g.split(":")[0] for x in guesses):
            guesses.append(f"{g.split(':')[0]}={key_of(j, name, layout)}"
                           + (f":{g.split(':')[1]}" if ":" in g else ""))
    if guesses:
        print("guessed map (check the units): " + " ".join(f"--map '{g}'" for g in guesses))
    mapped = {g.split("=", 1)[1].split(":")[0] for g in guesses}
    found = by_values(cols, layout, guesses)
    if found:
        print("guessed from the values (check the units): " + " ".join(f"--map '{g}'" for g, _ in found)
              + f" ({'; '.join(why for _, why in found if why)})")
        mapped |= {g.split("=", 1)[1].split(":")[0] for g, _ in found}
    flip = sign(cols, layout, guesses + [g for g, _ in found])
    if flip:
        print(f"sign: {flip}")
    rest = [(f"{j + 1} ({name})", counter(cells, layout)) for j, (name, cells) in enumerate(cols.items())
            if name not in mapped and str(j + 1) not in mapped and numeric(cells) and by_name(name, cells) is None]
    counters, unnamed = [u for u, c in rest if c], [u for u, c in rest if not c]
    if counters:
        print(f"counting the rows, no channel: {', '.join(counters)}")
    if unnamed:
        print(f"not guessed from their names or values: {', '.join(unnamed)}: map them yourself, raw volts with a gain "
              f"(e.g. --map force=COLUMN:N --gain force=980.665)")
    return 0
