"""`dyno import FILE.csv --out FILE.mcap --map NAME=COLUMN[:UNIT] ...`: a recording made
elsewhere as an MCAP recording (the columns' parsing: protocols/io/csv_import.py)."""
from __future__ import annotations

import json
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from protocols import catalogue
from protocols.io.files import Claim
from protocols.io.csv_import import CHANNELS, SI, parse_map, read, velocity_from
from protocols.io.recording import Recorder


def run(args):
    mapping = parse_map(args.map)
    claim = Claim(args.out, args.overwrite, inputs=[args.file])  # checked before the CSV is read
    try:
        return _import(args, mapping, claim)
    finally:
        claim.abandon()  # nothing, once the recording was committed
        claim.release()


def _import(args, mapping, claim):
    data, units = read(args.file, mapping)
    t = data.pop("time")
    if "velocity" not in data:
        ok = ~np.isnan(data["displacement"])
        data["velocity"] = np.full_like(t, np.nan)
        data["velocity"][ok] = velocity_from(t[ok], data["displacement"][ok])
        units["velocity"] = "derived from displacement"
    channels = {}
    for name, a in data.items():
        ok = ~np.isnan(a)
        if not ok.any():  # an empty column
            continue
        ch = CHANNELS.get(name, name)
        channels[ch] = (t[ok] - t[0], a[ok], SI.get(name, units.get(name, "")))
    cfg = SimpleNamespace(
        name="imported", path=Path(args.file),
        channels={n: SimpleNamespace(unit=u, device="csv", signal=n, gain=1.0, offset=0.0)
                  for n, (_, _, u) in channels.items()},
        text=f'# imported by dyno import\n[import]\nsource = "{Path(args.file).name}"\n'
             f"map = {json.dumps(args.map)}\n")
    duration = float(t[-1] - t[0])
    # the CSV's own start is unknown: its file time less its duration stands for it
    wall_start = os.path.getmtime(args.file) - duration
    rec = Recorder(claim, cfg, "", "import", {"source": str(args.file), "map": args.map}, wall_start=wall_start,
                   run_info={"wall_start_source": "CSV file time less its duration"})
    try:
        for n, (tt, v, _) in channels.items():
            for i in range(0, len(tt), 5000):
                rec.samples({n: (tt[i:i + 5000], v[i:i + 5000])})
        rec.commit()
    finally:
        rec.close()
    print(f"{rec.path}: {len(t)} rows, channels " + ", ".join(
        f"{n} [{u}]" for n, (_, _, u) in channels.items()) + (" (velocity derived from displacement)"
                                                               if units.get("velocity", "").startswith("derived") else ""))
    print(catalogue.add(rec.path))
    return 0
