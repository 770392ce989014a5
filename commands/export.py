"""`dyno export RECORDING --csv FILE | --parquet FILE [--channels a,b]`: one wide table on
the force channel's clock: time on the run clock [s] and in UTC, the segment and its
kind, then each channel in the `--units` system (its unit in the column name; pressures
gauge outside SI) interpolated onto that clock, over
the span every exported channel covers (a slow channel's last sample ends the table, so
no row has an empty cell); a sample outside every segment has an empty segment. Values
are written to the decimals each channel resolves. The run's metadata goes with the
table: Parquet schema metadata, or FILE.meta.json beside a CSV (docs/recording.md,
"Exported tables"). Parquet through pyarrow (rerun-sdk installs it). The table:
views/export.py."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from commands.arguments import FILE, overwrite, units, writes
from rig.errors import UsageError

def add(sub):
    """The `dyno export` command's arguments."""
    ex = sub.add_parser("export", help="a recording as one wide table (CSV or Parquet) on the force clock")
    ex.add_argument("recording")
    writes(ex, "--csv", FILE, metavar="FILE", help="write CSV")
    writes(ex, "--parquet", FILE, metavar="FILE", help="write Parquet (needs pyarrow)")
    writes(ex, "--target", FILE, metavar="FILE", help="write a replay target: time [s] and displacement [mm] about "
                                                     "mid-stroke (dyno run replay --target FILE)")
    ex.add_argument("--segment", help="--target: only this segment (its name, e.g. 'road iso8608:C:50')")
    ex.add_argument("--channels", help="comma-separated channels (default: all, force first)")
    units(ex)
    overwrite(ex)
    ex.set_defaults(command="export")


def run(args):
    from views.export import json_safe, table, write
    from records.files import output_file, written
    from records.reader import load_recording
    if sum(bool(getattr(args, k, None)) for k in ("csv", "parquet", "target")) != 1:
        raise UsageError("give one of --csv FILE, --parquet FILE or --target FILE")
    if args.target:
        return _target(args)
    if getattr(args, "segment", None):
        raise UsageError("--segment goes with --target (a replay target of one segment)")
    what = "--csv" if args.csv else "--parquet"
    out = output_file(args.csv or args.parquet, [args.recording], args.overwrite, what)
    side = out.with_name(out.name + ".meta.json") if args.csv else None
    if side is not None:
        output_file(side, [args.recording], args.overwrite, "--csv's metadata")
    channels, events, meta = load_recording(args.recording)
    names = [n.strip() for n in args.channels.split(",")] if args.channels else None
    cols, data, dec = table(channels, events, meta.get("units", {}), names, meta.get("run", {}).get("wall_start"),
                            args.units)
    rounded = [np.round(d, k) if k is not None else d for d, k in zip(data, dec)]
    info = {"recording": Path(args.recording).name, "columns": cols, "unit_system": args.units.system, **json_safe(meta)}
    with written(out, what) as tmp:
        write(tmp, cols, rounded, dec, info, parquet=bool(args.parquet))
    if side is not None:
        with written(side, "--csv's metadata") as tmp:
            Path(tmp).write_text(json.dumps(info, indent=1) + "\n")
    n_ch = len(cols) - cols.index("kind") - 1
    print(f"{out}: {len(data[0])} rows, {len(cols)} columns: time, segment and kind, and {n_ch} channels "
          f"({', '.join(cols[-n_ch:])})" + (f"; metadata in {side.name}" if side else ""))
    return 0


def _target(args):
    """A replay target from the recording's position (protocols/library/replay.py reads it):
    time [s] from 0 and displacement [mm] about the recorded damper's mid-stroke (the
    recording's mean position without a model), at the position's own samples."""
    from views.export import replay_target
    from records.files import output_file, written
    from records.reader import load_recording
    out = output_file(args.target, [args.recording], args.overwrite, "--target")
    t, x, mid, damper = replay_target(args.recording, *load_recording(args.recording), args.segment)
    with written(out, "--target") as tmp:
        np.savetxt(tmp, np.c_[t - t[0], 1e3 * (x - mid)], delimiter=",", fmt=("%.6f", "%.4f"),
                   header="t_s,displacement_mm", comments="")
    print(f"{out}: {len(t)} rows, {t[-1] - t[0]:.2f} s of displacement about "
          f"{'the damper' + chr(39) + 's mid-stroke' if damper is not None else 'the mean position'} "
          f"({1e3 * mid:.2f} mm from full extension); dyno run replay --target {out}")
    return 0
