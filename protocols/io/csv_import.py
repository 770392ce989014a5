"""`dyno import FILE.csv --out FILE.mcap --map NAME=COLUMN[:UNIT] ...`: a recording made
elsewhere, as a dyno recording that `dyno identify` and `dyno report` read.

Standard names and the channels they become: time, displacement (x), velocity (v), force,
temperature (T_body), pressure (P_gas); `aux.NAME` for anything else, its unit kept as
given. Units are converted to SI here, at the edge; pressures are absolute unless given
as gauge (barg, psig, kPag). Without a velocity column the velocity is derived from the
displacement by a Savitzky-Golay first derivative (quadratic over 11 samples, about 5 ms
at 2 kHz): smoother than a plain difference and without its half-sample lag.
"""
from __future__ import annotations

import csv
import math

import numpy as np
from scipy.signal import savgol_filter

from protocols.io.files import input_file
from rig.config import quantity
from rig.errors import RigError

P_ATM = 101_325.0
CHANNELS = {"time": "t", "displacement": "x", "velocity": "v", "force": "force", "temperature": "T_body",
            "pressure": "P_gas"}
# unit -> (scale, offset): SI = value * scale + offset
UNITS = {
    "time": {"s": (1, 0), "ms": (1e-3, 0), "us": (1e-6, 0), "min": (60, 0)},
    "displacement": {"m": (1, 0), "mm": (1e-3, 0), "cm": (1e-2, 0), "um": (1e-6, 0), "in": (0.0254, 0)},
    "velocity": {"m/s": (1, 0), "mm/s": (1e-3, 0), "cm/s": (1e-2, 0), "in/s": (0.0254, 0)},
    "force": {"N": (1, 0), "kN": (1e3, 0), "lbf": (4.4482216, 0), "kgf": (9.80665, 0)},
    "temperature": {"K": (1, 0), "C": (1, 273.15), "degC": (1, 273.15), "F": (5 / 9, 273.15 - 32 * 5 / 9)},
    "pressure": {"Pa": (1, 0), "kPa": (1e3, 0), "MPa": (1e6, 0), "bar": (1e5, 0), "psi": (6894.757, 0),
                 "kPag": (1e3, P_ATM), "barg": (1e5, P_ATM), "psig": (6894.757, P_ATM)},
}
SI = {"time": "s", "displacement": "m", "velocity": "m/s", "force": "N", "temperature": "K", "pressure": "Pa"}


MAX_SPAN_S = 7 * 86400.0  # s: a week; longer is a wrong unit or a corrupt stamp
BOMS = ((b"\xef\xbb\xbf", "utf-8"), (b"\xff\xfe", "utf-16-le"), (b"\xfe\xff", "utf-16-be"))


def decode(data: bytes) -> str:
    """The text of a file as acquisition software writes it: UTF-8 with or without a byte
    order mark, UTF-16 (with its mark, or without one when every other byte is zero), or
    Latin-1 (Windows' 8-bit exports) when it is not UTF-8. UnicodeDecodeError for binary
    data (a zero byte anywhere else)."""
    for bom, codec in BOMS:
        if data.startswith(bom):
            return data[len(bom):].decode(codec)
    head = data[:4096]
    if len(head) >= 4 and head[1::2].count(0) > 0.9 * len(head[1::2]) and 0 not in head[0::2]:
        return data.decode("utf-16-le")
    if len(head) >= 4 and head[0::2].count(0) > 0.9 * len(head[0::2]) and 0 not in head[1::2]:
        return data.decode("utf-16-be")
    if b"\x00" in data:
        raise UnicodeDecodeError("binary", data[:1], 0, 1, "a zero byte: not text")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def parse_map(items):
    """[(name, column, unit)] from NAME=COLUMN[:UNIT] strings, checking names and units."""
    out = []
    for item in items:
        name, sep, rest = item.partition("=")
        if not sep or not rest:
            raise RigError(f"--map {item}: expected NAME=COLUMN[:UNIT]")
        column, _, unit = rest.partition(":")
        if name not in CHANNELS and not (name.startswith("aux.") and len(name) > 4):
            raise RigError(f"--map {item}: unknown channel name {name!r} (standard: {', '.join(CHANNELS)}, "
                           f"or aux.NAME)")
        if name in CHANNELS:
            unit = unit or SI[name]
            if unit not in UNITS[name]:
                raise RigError(f"--map {item}: unknown {name} unit {unit!r} (known: {', '.join(UNITS[name])})")
        out.append((name, column, unit))
    names = [n for n, _, _ in out]
    for n in set(names):
        if names.count(n) > 1:
            raise RigError(f"--map: {n} mapped twice")
    for need in ("time", "displacement", "force"):
        if need not in names:
            raise RigError(f"--map: needs {need}=COLUMN (time, displacement and force are required)")
    return out


def read(path, mapping):
    """{channel: SI array} from the CSV. Unmapped and empty columns and a trailing
    separator are ignored; unknown mapped columns, non-numbers and time that does not
    goes backwards are refused, naming the row."""
    path = input_file(path)
    try:
        text = decode(path.read_bytes())
    except UnicodeDecodeError:
        raise RigError(f"{path}: not a text (CSV) file") from None
    except OSError as e:
        raise RigError(f"{path}: cannot read ({e.strerror})") from None
    sample = text[:4096]
    try:
        dialect = csv.Sniffer().sniff(sample, delimiters=",;\t")
    except csv.Error:
        dialect = csv.excel
    try:
        rows = list(csv.reader(text.splitlines(), dialect))
    except csv.Error as e:
        raise RigError(f"{path}: not a table of numbers ({e})") from None
    if not rows:
        raise RigError(f"{path}: empty file")
    header = [h.strip() for h in rows[0]]
    while header and header[-1] == "":  # trailing separator
        header.pop()
    for name, column, _ in mapping:
        if column not in header:
            raise RigError(f"{path}: no column {column!r} (mapped to {name}); columns: {', '.join(header)}")
    cols = {column: header.index(column) for _, column, _ in mapping}
    data = {}
    for name, column, unit in mapping:
        j = cols[column]
        values = []
        for i, r in enumerate(rows[1:], start=2):
            cell = r[j].strip() if j < len(r) else ""
            if cell == "":
                values.append(np.nan)
                continue
            try:
                values.append(float(cell))
            except ValueError:
                raise RigError(f"{path}:{i}: column {column!r}: {cell!r} is not a number") from None
            if not math.isfinite(values[-1]):
                raise RigError(f"{path}:{i}: column {column!r}: {cell!r} is not a finite number")
        a = np.array(values)
        if name in UNITS:
            scale, offset = UNITS[name][unit]
            a = a * scale + offset
        _plausible(path, name, column, a)
        data[name] = a
    t = data["time"]
    keep = ~np.isnan(t)
    bad = np.nonzero(np.diff(t[keep]) < 0)[0]  # repeated stamps happen in logged data; going back does not
    if len(bad):
        row = np.nonzero(keep)[0][bad[0] + 1] + 2
        raise RigError(f"{path}:{row}: time goes backwards ({t[keep][bad[0]]:.9g} then {t[keep][bad[0] + 1]:.9g} s)")
    if keep.sum() < 10:
        raise RigError(f"{path}: {keep.sum()} rows with a time (need at least 10)")
    if not t[keep][-1] - t[keep][0] <= MAX_SPAN_S:
        raise RigError(f"{path}: the time column spans {t[keep][-1] - t[keep][0]:.3g} s; a recording spans at most "
                       f"{MAX_SPAN_S / 86400:g} days: check its unit")
    if not t[keep][-1] > t[keep][0]:
        column = next(c for n, c, _ in mapping if n == "time")
        raise RigError(f"{path}: the time column {column!r} does not advance (all {t[keep][0]:g} s)")
    for name, column, _ in mapping:  # an empty optional column is left out; one number is no channel
        have = int(np.sum(~np.isnan(data[name][keep])))
        need = 10 if name in ("time", "displacement", "force") else 2
        if 0 < have < need or (have == 0 and need == 10):
            raise RigError(f"{path}: column {column!r} ({name}) holds {have} number{'s' * (have != 1)} "
                           f"with a time (needs at least {need})")
    return {k: v[keep] for k, v in data.items()}, {n: u for n, _, u in mapping}


def _plausible(path, name, column, a):
    """Refuse values no working sensor gives (a wrong unit, a corrupt file): the ranges are
    the rig's, per quantity (rig/config.py QUANTITIES)."""
    q = quantity(CHANNELS.get(name, ""))
    if name == "time":
        q = ("s", -1e9, 1e9)
    if q is None:
        bad = np.nonzero(np.abs(np.nan_to_num(a)) > 1e12)[0]
    else:
        bad = np.nonzero((a < q[1]) | (a > q[2]))[0]
    if len(bad):
        i = bad[0]
        where = f"{q[1]:g}..{q[2]:g} {q[0]}" if q else "+-1e12"
        raise RigError(f"{path}:{i + 2}: column {column!r}: {a[i]:.6g} {q[0] if q else ''} is not a plausible "
                       f"{name} (outside {where}): check its unit")


def velocity_from(t, x):
    """Velocity [m/s] from displacement: Savitzky-Golay derivative (module docstring).
    Rows sharing a time stamp share the velocity of their mean displacement."""
    tu, inverse = np.unique(t, return_inverse=True)
    if len(tu) < len(t):
        xu = np.bincount(inverse, weights=x) / np.bincount(inverse)
        return velocity_from(tu, xu)[inverse]
    h = np.diff(t)
    if len(x) >= 11 and np.allclose(h, h.mean(), rtol=1e-3):
        return savgol_filter(x, 11, 2, deriv=1, delta=float(h.mean()))
    return np.gradient(x, t)
