"""`dyno export RECORDING --csv FILE | --parquet FILE [--channels a,b]`: one wide table on
the force channel's clock: time [s], the segment and its kind, then each channel (its
unit in the column name) interpolated onto that clock; a sample outside every segment has
an empty segment. Parquet through pyarrow (rerun-sdk installs it)."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from models.recording import segments
from protocols.io.files import output_file, written
from protocols.io.reader import load_recording
from rig.errors import RigError


def table(channels, events, units, names=None):
    """(columns [str], rows as column arrays): the wide table on the force clock."""
    if "force" not in channels:
        raise RigError("the recording has no force channel to put the table on")
    t = channels["force"][0]
    names = names or sorted(channels, key=lambda n: (n != "force", n))
    unknown = [n for n in names if n not in channels]
    if unknown:
        raise RigError(f"--channels: no channel {unknown[0]!r} in the recording (it has {', '.join(sorted(channels))})")
    seg = np.full(len(t), "", dtype=object)
    kind = np.full(len(t), "", dtype=object)
    for name, params, t0, t1 in segments(events, measured=False):
        k = (t >= t0) & (t <= t1)
        seg[k], kind[k] = name, params["kind"]
    cols = ["t [s]", "segment", "kind"]
    data = [t, seg, kind]
    for n in names:
        ts, vs = channels[n]
        cols.append(f"{n} [{units.get(n, '')}]" if units.get(n) else n)
        data.append(vs if ts is t or np.array_equal(ts, t) else
                    np.interp(t, ts, vs, left=np.nan, right=np.nan) if len(ts) > 1 else np.full(len(t), np.nan))
    return cols, data


def run(args):
    if bool(args.csv) == bool(args.parquet):
        raise RigError("give one of --csv FILE or --parquet FILE")
    what = "--csv" if args.csv else "--parquet"
    out = output_file(args.csv or args.parquet, [args.recording], args.overwrite, what)
    channels, events, meta = load_recording(args.recording)
    names = [n.strip() for n in args.channels.split(",")] if args.channels else None
    cols, data = table(channels, events, meta.get("units", {}), names)
    with written(out, what) as tmp:
        _write(args, cols, data, tmp)
    print(f"{out}: {len(data[0])} rows, {len(cols)} columns ({', '.join(cols[3:])})")
    return 0


def _write(args, cols, data, out):
    if args.parquet:
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise RigError("--parquet needs pyarrow: .venv/bin/pip install pyarrow (or use --csv)") from None
        pq.write_table(pa.table({c: (list(d) if d.dtype == object else d) for c, d in zip(cols, data)}), out)
    else:
        with open(out, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(cols)
            w.writerows(zip(*[d.tolist() for d in data]))
