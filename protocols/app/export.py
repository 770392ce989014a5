"""`dyno export RECORDING --csv FILE | --parquet FILE [--channels a,b]`: one wide table on
the force channel's clock: time on the run clock [s] and in UTC, the segment and its
kind, then each channel in the `--units` system (its unit in the column name; pressures
gauge outside SI) interpolated onto that clock, over
the span every exported channel covers (a slow channel's last sample ends the table, so
no row has an empty cell); a sample outside every segment has an empty segment. Values
are written to the decimals each channel resolves. The run's metadata goes with the
table: Parquet schema metadata, or FILE.meta.json beside a CSV (docs/recording.md,
"Exported tables"). Parquet through pyarrow (rerun-sdk installs it)."""
from __future__ import annotations

import csv
import json
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from protocols.app.arguments import FILE, overwrite, units, writes
from protocols.errors import UsageError
from protocols.units import Units

SIGNIFICANT = 7  # digits of a channel's range kept where its samples sit on no coarser grid


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


def decimals(values) -> int:
    """Decimals that resolve a channel: its quantum when the samples sit on a grid (a
    16-bit load cell, a 1 C thermocouple), else SIGNIFICANT digits of its range."""
    v = np.unique(np.asarray(values, float)[np.isfinite(values)])
    if len(v) < 2:
        return 6
    span = float(v[-1] - v[0])
    steps = np.diff(v)
    q = float(steps.min())
    res = q if np.allclose(steps / q, np.round(steps / q), atol=1e-3) and q > span * 1e-7 else span * 10.0 ** -SIGNIFICANT
    return int(np.clip(np.ceil(-np.log10(res)), 0, 12))


QUANTITY = {"m": "length", "m/s": "velocity", "N": "force", "Pa": "pressure", "K": "temperature"}  # by SI unit


def table(channels, events, units, names=None, wall_start=None, shown=Units("si")):
    """(columns [str], column arrays, decimals per column or None): the wide table on the
    force clock, channels in the unit system `shown` (units: each channel's SI unit, as
    recorded); wall_start (ISO 8601) adds the UTC time of every row."""
    from models.recording import segments
    if "force" not in channels:
        raise UsageError("the recording has no force channel to put the table on")
    names = names or sorted(channels, key=lambda n: (n != "force", n))
    unknown = [n for n in names if n not in channels]
    if unknown:
        raise UsageError(f"--channels: no channel {unknown[0]!r} in the recording (it has "
                         f"{', '.join(sorted(channels))})")
    t = channels["force"][0]
    spans = [channels[n][0] for n in names if len(channels[n][0]) > 1]
    keep = (t >= max(s[0] for s in spans)) & (t <= min(s[-1] for s in spans)) if spans else np.ones(len(t), bool)
    t = t[keep]
    seg = np.full(len(t), "", dtype=object)
    kind = np.full(len(t), "", dtype=object)
    for s in segments(events, measured=False):
        k = (t >= s.t0) & (t <= s.t1)
        seg[k], kind[k] = s.name, s.kind
    cols, data, dec = ["t [s]"], [t], [6]
    if wall_start:
        start = np.datetime64(datetime.fromisoformat(wall_start).astimezone(timezone.utc).replace(tzinfo=None), "us")
        cols.append("t_utc")
        data.append(start + np.round(t * 1e6).astype("timedelta64[us]"))
        dec.append(None)
    cols += ["segment", "kind"]
    data += [seg, kind]
    dec += [None, None]
    for n in names:
        ts, vs = channels[n]
        q = QUANTITY.get(units.get(n))
        vs = shown.show(q, vs) if q else np.asarray(vs, float)
        unit = shown.unit(q) if q else units.get(n)
        cols.append(f"{n} [{unit}]" if unit else n)
        data.append(vs[keep] if len(ts) == len(keep) and np.array_equal(ts, channels["force"][0]) else
                    np.interp(t, ts, vs) if len(ts) > 1 else np.full(len(t), np.nan))
        dec.append(decimals(vs))
    return cols, data, dec


def run(args):
    from protocols.io.files import output_file, written
    from protocols.io.reader import load_recording
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
    info = {"recording": Path(args.recording).name, "columns": cols, "unit_system": args.units.system, **_json_safe(meta)}
    with written(out, what) as tmp:
        _write(args, cols, rounded, dec, tmp, info)
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
    from models.recording import segments
    from protocols.io.files import output_file, written
    from protocols.io.reader import load_recording
    from protocols.reports.peaks import recorded_damper
    out = output_file(args.target, [args.recording], args.overwrite, "--target")
    channels, events, meta = load_recording(args.recording)
    if "x" not in channels or len(channels["x"][0]) < 2:
        raise UsageError(f"{args.recording}: no position channel x to make a target of")
    t, x = channels["x"]
    if args.segment:
        span = [(t0, t1) for name, _, t0, t1 in segments(events, measured=False) if name == args.segment]
        if not span:
            names = ", ".join(dict.fromkeys(n for n, *_ in segments(events, measured=False))) or "none"
            raise UsageError(f"--segment {args.segment!r}: no such segment (segments: {names})")
        keep = (t >= span[0][0]) & (t <= span[0][1])
        t, x = t[keep], x[keep]
    damper = recorded_damper(meta)
    mid = damper.mid_stroke if damper is not None else float(np.mean(x))
    with written(out, "--target") as tmp:
        np.savetxt(tmp, np.c_[t - t[0], 1e3 * (x - mid)], delimiter=",", fmt=("%.6f", "%.4f"),
                   header="t_s,displacement_mm", comments="")
    print(f"{out}: {len(t)} rows, {t[-1] - t[0]:.2f} s of displacement about "
          f"{'the damper' + chr(39) + 's mid-stroke' if damper is not None else 'the mean position'} "
          f"({1e3 * mid:.2f} mm from full extension); dyno run replay --target {out}")
    return 0


def _json_safe(meta):
    return json.loads(json.dumps(meta, default=str))


def _write(args, cols, data, dec, out, info):
    if args.parquet:
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise UsageError("--parquet needs pyarrow: .venv/bin/pip install pyarrow (or use --csv)") from None
        tab = pa.table({c: (list(d) if d.dtype == object else d) for c, d in zip(cols, data)})
        pq.write_table(tab.replace_schema_metadata({"dyno": json.dumps(info)}), out)
    else:
        text = [d.astype("datetime64[us]").astype(str).astype(object) + "Z" if d.dtype.kind == "M" else
                (d if k is None else np.array([f"{x:.{k}f}" if np.isfinite(x) else "" for x in d], dtype=object))
                for d, k in zip(data, dec)]
        with open(out, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(cols)
            w.writerows(zip(*text))
