"""A TDMS file (what National Instruments' LabVIEW, DIAdem and VeriStand write) as import's
columns, read with npTDMS: each channel `NAME [unit]` from its `unit_string` (its group's
name first where two groups share a channel name); a waveform's time from its
`wf_increment` and `wf_start_offset`, as date-time stamps from its `wf_start_time` when it
has one (the recording's start)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.errors import UsageError


def columns(path: str | Path) -> dict:
    """{column name: values}; UsageError for a file npTDMS cannot read, one without a
    numeric channel, or channels of different lengths (sampled at different rates)."""
    from nptdms import TdmsFile
    try:
        f = TdmsFile.read(path)
    except Exception as e:  # noqa: BLE001 - whatever npTDMS refuses
        raise UsageError(f"{path}: not a readable TDMS file ({str(e).splitlines()[0] if str(e) else type(e).__name__})") \
            from None
    chans = [(g.name, c) for g in f.groups() for c in g.channels() if len(c) and c.dtype.kind in "iufM"]
    names = [c.name for _, c in chans]
    cols, wave = {}, None
    for group, c in chans:
        name = c.name if names.count(c.name) == 1 else f"{group}/{c.name}"
        unit = str(c.properties.get("unit_string", "")).strip()
        a = c[:]
        cols[f"{name} [{unit}]" if unit and a.dtype.kind != "M" else name] = a if a.dtype.kind == "M" else a.astype(float)
        wave = wave or (c if "wf_increment" in c.properties else None)
    if not cols:
        raise UsageError(f"{path}: no channel of numbers in this TDMS file")
    sizes = {n: len(a) for n, a in cols.items()}
    if len(set(sizes.values())) > 1:
        raise UsageError(f"{path}: its channels differ in length (sampled at different rates?): "
                         + ", ".join(f"{n} {k}" for n, k in sizes.items()) + "; import reads channels of one rate")
    if wave is not None and not any(a.dtype.kind == "M" for a in cols.values()):
        t = float(wave.properties.get("wf_start_offset", 0.0)) + np.arange(len(wave)) * float(
            wave.properties["wf_increment"])
        start = wave.properties.get("wf_start_time")
        time = (np.datetime64(start, "ns") + np.round(t * 1e9).astype("timedelta64[ns]"), "Time") \
            if isinstance(start, np.datetime64) else (t, "Time [s]")
        cols = {time[1]: time[0], **cols}
    return cols
