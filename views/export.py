"""A recording as one wide table on the force channel's clock (`dyno export`, docs/recording.md
"Exported tables"), and a replay target from its position."""
from __future__ import annotations

import csv
import json
from datetime import datetime, timezone

import numpy as np

from rig.errors import UsageError
from protocols.units import Units

SIGNIFICANT = 7  # digits of a channel's range kept where its samples sit on no coarser grid


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
    from records.data import segments
    from records.recorder import UNDATED
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
    if wall_start and wall_start != UNDATED:
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


def replay_target(path, channels, events, meta, segment=None):
    """(t [s], x [m], mid-stroke [m], the recorded damper or None) of the recording's position,
    over one segment if named: the displacement a replay follows (protocols/library/replay.py),
    about the damper's mid-stroke (the mean position without a model)."""
    from records.data import segments
    from views.reports.peaks import recorded_damper
    if "x" not in channels or len(channels["x"][0]) < 2:
        raise UsageError(f"{path}: no position channel x to make a target of")
    t, x = channels["x"]
    if segment:
        span = [(t0, t1) for name, _, t0, t1 in segments(events, measured=False) if name == segment]
        if not span:
            names = ", ".join(dict.fromkeys(n for n, *_ in segments(events, measured=False))) or "none"
            raise UsageError(f"--segment {segment!r}: no such segment (segments: {names})")
        keep = (t >= span[0][0]) & (t <= span[0][1])
        t, x = t[keep], x[keep]
    damper = recorded_damper(meta)
    return t, x, damper.mid_stroke if damper is not None else float(np.mean(x)), damper


def json_safe(meta):
    """The run metadata with what JSON cannot hold as text."""
    return json.loads(json.dumps(meta, default=str))


def write(out, cols, data, dec, info, parquet=False):
    """The table to out: Parquet with info as its schema metadata, else CSV with each column
    to its decimals (UTC times in ISO 8601 with Z)."""
    if parquet:
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
