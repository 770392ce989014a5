"""A force-velocity table: a customer's spec sheet, another dyno's peak-velocity export, or
the velocity.csv `dyno report` writes. A speed column, a compression and a rebound force
column (found by their names, in the languages column_guess reads), each unit in its
name as import reads one (`Speed [in/sec]`, `Comp (lbs)`, `v_mm_s`, `F_reb_N`). What
`dyno check --against TABLE` holds a run to. SI out; compression positive, rebound
negative whichever sign the table gives it."""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from records import table
from records.column_units import UNITS, unit, unit_in_name
from records.csv_import import source
from rig.errors import UsageError

# what each column is called; a name holding one of these words (or a longer word starting
# with one of the longer ones) is that column, the first such column counts
WORDS = {"speed": ("v", "vel", "velocity", "speed", "geschw", "geschwindigkeit", "vitesse", "velocidad", "velocità"),
         "compression": ("comp", "compression", "bump", "druck", "druckstufe", "compresión", "compresion",
                         "compressione"),
         "rebound": ("reb", "rebound", "ext", "extension", "tension", "zug", "zugstufe", "détente", "detente",
                     "rebote", "extensión", "estensione")}
QUANTITY = {"speed": "velocity", "compression": "force", "rebound": "force"}


@dataclass
class ForceVelocity:
    v_m_s: np.ndarray  # shaft speeds [m/s], rising
    F_comp_N: np.ndarray  # compression force at each [N] (positive; nan where the table gives none)
    F_reb_N: np.ndarray  # rebound force [N] (negative; nan where none)


def _which(name: str, what: str) -> bool:
    tokens = [w for w in re.split(r"[^\wµμ]+|_", name.lower()) if w]
    return any(w in WORDS[what] or any(w.startswith(x) for x in WORDS[what] if len(x) > 2) for w in tokens)


def _unit(name: str, quantity: str, path) -> str:
    """The unit a column's name gives (`v_mm_s`: mm/s, as `dyno report` writes it)."""
    u = unit_in_name(name, quantity) or unit(quantity, name.partition("_")[2].replace("_", "/"))
    if u is None:
        raise UsageError(f"{path}: column {name!r} gives no {quantity} unit: name it like "
                         f"'{name} [{'mm/s' if quantity == 'velocity' else 'N'}]' (a table's numbers are not guessed)")
    return u


def read(path: str | Path) -> ForceVelocity:
    """The table's speeds and forces in SI; UsageError naming what is missing."""
    cols, layout = source(path)
    found = {}
    for what in WORDS:
        found[what] = next((n for n in cols if n not in found.values() and _which(n, what)), None)
    if found["speed"] is None or (found["compression"] is None and found["rebound"] is None):
        raise UsageError(f"{path}: a force-velocity table needs a speed column and a compression or rebound force "
                         f"column, named so (e.g. 'Velocity [mm/s]', 'Compression [N]', 'Rebound [N]'); columns: "
                         f"{', '.join(cols)}")
    values = {}
    for what, name in found.items():
        if name is None:
            continue
        cells = cols[name]
        a, bad = (np.asarray(cells, float), None) if isinstance(cells, np.ndarray) else table.numbers(
            list(cells), layout.decimal if layout else ".")
        if bad is not None:
            raise UsageError(f"{path}: column {name!r}: {cells[bad]!r} is not a number")
        scale, offset = UNITS[QUANTITY[what]][_unit(name, QUANTITY[what], path)]
        values[what] = a * scale + offset
    v = np.abs(values["speed"])
    keep = np.isfinite(v) & (v > 0)
    if not keep.any():
        raise UsageError(f"{path}: no speed above zero in column {found['speed']!r}")
    order = np.argsort(v[keep])
    nan = np.full(len(v), np.nan)
    comp, reb = np.abs(values.get("compression", nan)), -np.abs(values.get("rebound", nan))
    return ForceVelocity(v[keep][order], comp[keep][order], reb[keep][order])
