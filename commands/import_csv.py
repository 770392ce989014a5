"""`dyno import FILE --out FILE.mcap --map NAME=COLUMN[:UNIT] ...`: a recording another dyno
or acquisition system made (CSV, a DAQ's text export, Excel, TDMS, Parquet, MATLAB) as a dyno recording;
`--inspect` shows what would be read and writes nothing. The work: records/importing.py;
the table's layout: records/table.py; the columns' units: records/column_units.py."""
from __future__ import annotations

from commands.arguments import FILE, identity, identity_info, number, overwrite, writes
from rig.errors import UsageError
from records.importing import FLIPS


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
    im.add_argument("--start", metavar="DATE-TIME",
                    help="when the test began (ISO 8601, e.g. 2025-11-14T20:14:37; UTC unless it says its zone), "
                         "for a file that holds no date: without it the date is shown as unknown")
    im.add_argument("--allow-gaps", action="store_true", help="import a displacement or force column with rows "
                    "that hold no number among its numbers (each said with its line); without it they are refused")
    identity(im, "test the file holds")
    im.set_defaults(command="import_csv")


def run(args):
    from records import source_filter
    from records.csv_import import parse_map
    from records.files import Claim
    from records.importing import Source, drives, import_file, scales, start_of
    for option in ("inspect", "start", "gain", "offset", "flip", "rate", "drive", "sheet", "smoothed", "filtered",
                   "allow_gaps"):  # a caller's namespace may have only the map
        setattr(args, option, getattr(args, option, None))
    if args.inspect:
        return inspect(args)
    if not args.map:
        raise UsageError("--map: give at least displacement=COLUMN and force=COLUMN (dyno import FILE --inspect "
                         "shows the columns)")
    mapping = parse_map(args.map)
    gains, offsets = scales(args.gain, "--gain"), scales(args.offset, "--offset")
    for name in {*gains, *offsets} - {n for n, _, _ in mapping}:
        raise UsageError(f"--gain/--offset {name}: not a mapped channel")
    if args.filtered is not None and args.smoothed is not None:
        raise UsageError("--filtered and --smoothed: give the one filter the source applied")
    flag, text, parse = (("--filtered", args.filtered, source_filter.parse_filtered) if args.filtered is not None
                         else ("--smoothed", args.smoothed, source_filter.parse))
    try:
        smoothing = None if text is None else parse(text)
    except ValueError as e:
        raise UsageError(f"{flag} {e}") from None
    if args.out is None:
        raise UsageError("--out FILE.mcap: where to write the recording (or --inspect to only look)")
    src = Source(args.file, args.map, gains, offsets, tuple(args.flip or ()), args.rate, args.sheet,
                 drives(args.drive, mapping), smoothing, identity_info(args), start_of(args.start),
                 {"map": args.map, "flip": args.flip or [], "gain": args.gain or [], "offset": args.offset or [],
                  "drive": args.drive or []}, bool(args.allow_gaps))
    claim = Claim(args.out, args.overwrite, inputs=[args.file])  # checked before the file is read
    try:
        done = import_file(src, claim)
    finally:
        claim.abandon()  # nothing, once the recording was committed
        claim.release()
    _said(done)
    return 0


def _said(done):
    from views import run_index
    from records import table
    if done.wall_start is None:
        when = "an unknown date (the file holds none: --start gives it)"
    else:
        when = f"{table.iso(done.wall_start)[:23]} UTC" + (f" ({done.dated})" if done.dated else "")
    print(f"{done.path}: {done.rows} rows from {when}, channels "
          + ", ".join(f"{n} [{u}]" for n, u in done.channels.items())
          + (" (velocity derived from displacement)" if done.velocity_derived else ""))
    if done.named_units:
        print("units from the columns' names: " + ", ".join(f"{n} [{u}]" for n, u in done.named_units.items()))
    from records.segmentation import division
    sines = [f for f in done.segments if f.kind == "sine"]
    duration = max((f.t1 for f in done.segments), default=0.0) - min((f.t0 for f in done.segments), default=0.0)
    print(f"segments: {division(done.segments, duration) or 'none'}"
          + ("; " + ", ".join(f"{f.name} ({f.params['cycles']} cycles)" for f in sines[:6])
             + (", ..." if len(sines) > 6 else "") if sines else ""))
    for note in done.notes:
        print(note)
    print(run_index.add(done.path))


def inspect(args):
    """What import would read from the file: layout, columns with sample values, the rate,
    and a guessed map. Writes nothing."""
    from records.importing import inspect_file, postamble
    seen = inspect_file(args.file, args.sheet, args.map or ())
    layout = seen.layout
    print(f"{args.file}: {seen.described}")
    if layout and layout.preamble:
        print("preamble:\n" + "\n".join(f"  {line.strip()}" for line in layout.preamble[:12]))
    if layout and len(layout.sheets) > 1:
        print(f"sheets: {', '.join(repr(s) for s in layout.sheets)} (--sheet NAME reads another)")
    if layout and layout.postamble:
        print(postamble(layout))
    if layout and layout.cut:
        print(layout.cut)
    print(f"{seen.rows} rows; columns:")
    for j, name, sample, kind in seen.columns:
        print(f"  {j:>2}  {name!r:24} {', '.join(sample)}{'  (' + kind + ')' if kind else ''}")
    if seen.guesses:
        print("guessed map (check the units): " + " ".join(f"--map '{g}'" for g in seen.guesses))
    if seen.from_values:
        print("guessed from the values (check the units): " + " ".join(f"--map '{g}'" for g, _ in seen.from_values)
              + f" ({'; '.join(why for _, why in seen.from_values if why)})")
    if seen.sign:
        print(f"sign: {seen.sign}")
    if seen.counters:
        print(f"counting the rows, no channel: {', '.join(seen.counters)}")
    if seen.unnamed:
        print(f"not guessed from their names or values: {', '.join(seen.unnamed)}: map them yourself, raw volts with a gain "
              f"(e.g. --map force=COLUMN:N --gain force=980.665); any other reading as aux.NAME (samples at its rail left out)")
    return 0
