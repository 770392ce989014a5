"""The map `dyno import --inspect` suggests: each column's channel guessed from its name,
or, where no name says (a headerless export, a DAQ's CHANNEL0...), from its values."""
from __future__ import annotations

import numpy as np

from records.table import Layout

SAMPLES = 3  # a column's first values: --inspect shows them, and a number among them makes it numeric


# what a column is called, in English and in the languages dyno software is written in (German,
# French, Spanish, Italian); a name that starts with one of the longer words counts too
NAMES = (("time", ("time", "t", "zeit", "temps", "tiempo", "tempo", "sec")),
         ("force", ("force", "load", "f", "kraft", "effort", "fuerza", "carga", "forza")),
         ("displacement", ("disp", "displacement", "position", "pos", "x", "d", "travel", "stroke", "lvdt", "weg", "hub",
                           "deplacement", "déplacement", "course", "desplazamiento", "posicion", "posición",
                           "spostamento", "corsa")),
         ("velocity", ("vel", "velocity", "speed", "v", "geschw", "geschwindigkeit", "vitesse", "velocidad",
                       "velocità")),
         ("temperature", ("temp", "temperature", "t_body", "temperatur", "température", "temperatura")),
         ("pressure", ("pressure", "p_gas", "druck", "pression", "presion", "presión", "pressione")))


def by_name(name: str, cells: list[str] | np.ndarray) -> str | None:
    """A standard channel a column's name (or first value) suggests, with its unit: the
    map a user would likely write."""
    from records import table
    from records.column_units import unit_in_name
    n = name.lower()
    if cells is not None and len(cells) and (getattr(cells, "dtype", None) is not None and cells.dtype.kind == "M" or
                                             not isinstance(cells, np.ndarray) and table.is_stamp(str(cells[0]))):
        return "time"
    base = n.split("[")[0].split("(")[0].split(":")[0].strip()
    for part in [base, *base.split()[1:]]:  # the whole name, else a later word of it (`Oil temp`, `Rod position`)
        for channel, words in NAMES:
            if part in words or any(part.startswith(w) for w in words if len(w) > 2):
                unit = unit_in_name(name, channel) or (time_unit(cells) if channel == "time" else None)
                return f"{channel}" + (f":{unit}" if unit else "")
    return None


def time_unit(cells: list[str] | np.ndarray) -> str | None:
    """ms or us for a time column whose name gives no unit and whose step is 0.5 or more
    (no dyno samples slower than 2 Hz: 1 a row is 1 kHz in ms; over 50, us), else None."""
    from records import table
    if cells is None or not len(cells):
        return None
    head = np.asarray(cells[:200], float) if isinstance(cells, np.ndarray) else next(
        (a for a, bad in (table.numbers([str(c) for c in cells[:200]], d) for d in ".,") if bad is None), None)
    step = np.nanmedian(np.diff(head)) if head is not None and len(head) > 2 else np.nan
    return None if not step >= 0.5 else "ms" if step <= 50 else "us"


def key_of(j: int, name: str, layout: Layout | None) -> str:
    """How --map names column j: by its header, or by its 1-based position without one or
    when the header holds a colon (which --map reads as the unit's)."""
    return name if (layout is None or layout.header is not None) and ":" not in name else str(j + 1)


def _with_units(found):
    """by_values' guesses with the unit each column's name carries, where it is the
    channel's."""
    from records.column_units import unit_in_name
    out = []
    for g, why in found:
        channel, key = g.split("=", 1)
        u = unit_in_name(key, channel) if ":" not in key else None
        out.append((f"{g}:{u}" if u else g, why))
    return out


def _named(mapping) -> dict:
    """{channel: column key} of NAME=COLUMN[:UNIT] strings (a key holds no colon: key_of)."""
    return dict(g.split(":")[0].split("=", 1) for g in mapping)


def _values(cols, layout, guesses):
    """({column key: values} of the numeric columns no name explained, the time column's
    values [s] if a name gave it, else None)."""
    from records import table
    named = _named(guesses)
    vals, t = {}, None
    for j, (name, cells) in enumerate(cols.items()):
        key = key_of(j, name, layout)
        stamps = not isinstance(cells, np.ndarray) and len(cells) and table.is_stamp(str(cells[0]))
        if key == named.get("time"):
            t = table.stamps(list(cells))[0] if stamps else _numbers(cells, layout)
        elif key not in named.values() and numeric(cells):
            a = _numbers(cells, layout)
            if len(a) >= 16 and np.all(np.isfinite(a)):
                vals[key] = a
    return vals, t if t is not None and len(t) and np.all(np.isfinite(t)) else None


def _cells(cols, layout, key):
    """The cells of the column a map's key names (as key_of writes it, its name or its
    1-based position), or None."""
    for j, (name, cells) in enumerate(cols.items()):
        if key in (key_of(j, name, layout), name, str(j + 1)):
            return cells
    return None


def _numbers(cells, layout):
    """A column's cells as floats (nan where not a number)."""
    from records import table
    return np.asarray(cells, float) if isinstance(cells, np.ndarray) else table.numbers(
        list(cells), layout.decimal if layout else ".")[0]


def sign(cols: dict, layout: Layout | None, mapping: list[str]) -> str | None:
    """What to flip when the guessed map's force and displacement would give energy back
    (records.data.flips), or None. mapping: [NAME=COLUMN[:UNIT]]."""
    from records.data import flips
    named = _named(mapping)
    if not {"displacement", "force"} <= named.keys():
        return None
    x, F = (_cells(cols, layout, named[c]) for c in ("displacement", "force"))
    if x is None or F is None:  # a map given (--inspect --map) may name a column the file lacks
        return None
    x, F = _numbers(x, layout), _numbers(F, layout)
    said = flips(x, F)
    if said is None:
        return None
    _, flip, gas = said
    return ("with this map the damper would give energy back (the integral of F dx is negative): the file counts "
            "force or displacement the other way; " + (
                f"add --flip {flip} (the force at the turning points reads {gas.text('')}as recorded)" if flip else
                "which one the values cannot tell (a static push or the rod's direction settles it): add --flip force "
                "or --flip displacement"))


def by_values(cols: dict, layout: Layout | None, guesses: list[str]) -> list[tuple[str, str]]:
    """[(NAME=COLUMN[:UNIT], why)] read from the values of the numeric columns no name
    explained (a headerless export, a DAQ's CHANNEL0...): time rises by one step every row
    (a counter's step of 1 is no time); a velocity is the rate of change of another column,
    which is then the displacement (mm when it spans more than a metre would allow a damper;
    the two differ by a power of ten, the units'); without one, the displacement is the
    smoothest column and the force the one that follows its rate of change (compression
    positive: a damper's force goes with its velocity), unless two follow it alike; force
    is the one numeric column left. guesses: the map read from the names."""
    with np.errstate(all="ignore"):  # extreme or repeated values guess nothing, quietly
        return _with_units(_by_values(cols, layout, guesses))


def _by_values(cols, layout, guesses):
    channels = {g.split("=")[0] for g in guesses}
    vals, t = _values(cols, layout, guesses)
    out = []
    step = {k: np.diff(a) for k, a in vals.items()}
    if t is None:
        t = next((k for k in vals if "time" not in channels and step[k].min() > 0 and np.ptp(step[k]) < 0.01
                  * step[k].mean() and not np.allclose(step[k], 1.0)), None)
        if t is None:
            return out
        out.append((f"time={t}", f"{t} rises by {step[t].mean():.3g} every row"))
        t = vals.pop(t)
    rest = {k: a for k, a in vals.items() if np.std(a) > 0 and not np.allclose(step[k], 1.0)}  # no counter
    if not {"displacement", "velocity"} & channels:
        out += _motion_pair(rest, t) or _motion_and_force(rest, t, "force" in channels)
    left = [k for k in rest if k not in _named(g for g, _ in out).values()]
    if "force" not in channels and {g.split("=")[0] for g, _ in out} == {"time", "displacement", "velocity"} \
            and len(left) == 1:
        out.append((f"force={left[0]}", f"{left[0]} is the one column left"))
    return out


def _motion_pair(vals, t):
    """[displacement, velocity] guesses of a column and its rate of change (by a power of
    ten: their units), or []."""
    for x, v in ((x, v) for x in vals for v in vals if x != v):
        rate = np.gradient(vals[x], t)
        if np.std(rate) == 0 or not np.corrcoef(rate, vals[v])[0, 1] >= 0.99:
            continue
        ratio = float(np.std(vals[v]) / np.std(rate))
        # a viscous damper's force follows the rate of change as closely, by any factor
        if abs(ratio / 10 ** round(np.log10(ratio)) - 1) > 0.05:
            continue
        mm = np.ptp(vals[x]) > 1.0  # no damper strokes a metre
        return [(f"displacement={x}{':mm' if mm else ''}", f"{v} is the rate of change of {x} times {ratio:.3g}"),
                (f"velocity={v}{':mm/s' if mm and abs(ratio - 1) < 0.05 else ''}", "")]
    return []


FOLLOWS = 0.6  # correlation of a force with the displacement's rate of change (the UTFSM DAQ files: 0.75-0.87)


def _motion_and_force(vals, t, force_named):
    """[displacement, force] guesses of a DAQ's raw channels: the smoothest column, and the
    one that follows its rate of change unless another follows it within 0.05; or []."""
    from records.column_units import unit_in_name
    if len(vals) < 2 or force_named:
        return []
    rough = {k: float(np.std(np.diff(a, 2)) / np.std(a)) for k, a in vals.items()}
    x = min(rough, key=rough.get)
    rate = np.gradient(vals[x], t)
    ok = np.isfinite(rate)  # two rows with one stamp give no rate
    if ok.sum() < 16:
        return []
    # by size: a force counted tension positive follows it the other way (sign() says so)
    r = {k: float(np.corrcoef(rate[ok], a[ok])[0, 1]) for k, a in vals.items() if k != x}
    follow = sorted(((abs(c), k) for k, c in r.items()), reverse=True)
    if not follow[0][0] >= FOLLOWS:
        return []
    why = f"{x} is the smoothest; {follow[0][1]} follows its rate of change (correlation {r[follow[0][1]]:.2f})"
    if len(follow) > 1 and follow[0][0] - follow[1][0] < 0.05:
        a, b = sorted((follow[0][1], follow[1][1]), key=list(vals).index)  # in the file's order
        return [(f"displacement={x}", f"{x} is the smoothest; the force is {a} or {b}, which follow its rate of "
                                     f"change alike (correlation {follow[1][0]:.2f} or more in size): the values "
                                     f"cannot tell")]
    volts = unit_in_name(x) is None and unit_in_name(follow[0][1]) is None  # no unit in either name: a DAQ's volts?
    return [(f"displacement={x}", why + ("; raw volts? give each a --gain" if volts else "")),
            (f"force={follow[0][1]}", "")]


def counter(cells: list[str] | np.ndarray, layout: Layout | None) -> bool:
    """A sample number: 1, 2, 3, ... (the UTFSM DAQ's first column)."""
    a = _numbers(cells, layout)
    return len(a) > 1 and bool(np.all(np.diff(a) == 1.0))


def numeric(cells: list[str] | np.ndarray) -> bool:
    """A column whose first values are numbers (a DAQ's channels, not a sample counter's name)."""
    from records import table
    first = [str(c) for c in list(cells[:SAMPLES]) if str(c)]
    return bool(first) and all(table.NUMBER.match(c) for c in first)


METRE_SPAN = 1.0  # m: no damper strokes a metre; a length that spans more counts in a smaller unit
CM_SPAN = 20.0  # a span of at most this many: cm (2-200 mm, a dyno's strokes), above it mm


def length_units(guesses: list[str], cols: dict, layout: Layout | None) -> list[str]:
    """guesses with a unit where a displacement named without one spans more than a metre
    could (cm up to CM_SPAN of them, else mm: the values cannot tell the two apart for
    certain; --inspect says check the units), and its velocity, named without one too, in
    that unit per second."""
    out, length = [], None
    for g in guesses:
        channel, _, key = g.partition("=")
        if channel == "displacement" and ":" not in key and (cells := _cells(cols, layout, key)) is not None:
            a = _numbers(cells, layout)
            span = float(np.nanmax(a) - np.nanmin(a)) if np.isfinite(a).any() else 0.0
            if span > METRE_SPAN:
                length = "cm" if span <= CM_SPAN else "mm"
                g = f"{g}:{length}"
        out.append(g)
    return [f"{g}:{length}/s" if length and g.startswith("velocity=") and ":" not in g.partition("=")[2] else g
            for g in out]
