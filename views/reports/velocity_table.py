"""The dyno sheet's table: force per direction at standard shaft velocities, interpolated
from the sine segments' peaks (views/reports/peaks.py), or, for a run of one speed (a
crank dyno's, or any single sine), read along its stroke: the force at each speed on the
way up to the top speed, both halves of the cycle averaged. Speeds come from
velocities.toml unless given. SI inside (m/s, N; compression positive, rebound
negative); the CSV and the page in the chosen unit system."""
from __future__ import annotations

import csv
import tomllib
from dataclasses import astuple, dataclass, fields
from pathlib import Path

import numpy as np

from protocols.units import Units, fmt
from records.data import REPEATS_DIFFER, Test, differing

SPEEDS_FILE = Path(__file__).with_name("velocities.toml")
MERGE = 0.05  # peaks within 5 % of each other's speed are one point (their forces averaged)


def standard_speeds(units=Units()) -> list[float]:
    """The default table speeds [m/s] (velocities.toml): round numbers of in/s for US units."""
    with open(SPEEDS_FILE, "rb") as f:
        table = tomllib.load(f)
    if units.system == "us":
        return [float(Units("us").to_si("velocity", v)) for v in table["speeds_in_s"]]
    return [float(v) for v in table["speeds_m_s"]]


@dataclass
class VelocityRow:
    v_m_s: float  # shaft speed [m/s]
    F_comp_N: float  # measured force at +v [N]; nan outside the measured speeds
    F_reb_N: float  # at -v [N] (negative)
    Fd_comp_N: float = np.nan  # damping force (measured less gas and friction) [N]
    Fd_reb_N: float = np.nan
    W_comp_N: float = np.nan  # the loop's half-width there [N]: read along the stroke, F is its mid-line
    W_reb_N: float = np.nan


def _curve(v, F):
    """Sorted speeds and forces with peaks of nearly the same speed merged."""
    k = np.isfinite(v) & np.isfinite(F)
    order = np.argsort(v[k])
    v, F = v[k][order], F[k][order]
    vs, Fs = [], []
    for vi, Fi in zip(v, F):
        if vs and vi <= vs[-1][0] * (1 + MERGE):
            vs[-1].append(vi), Fs[-1].append(Fi)
        else:
            vs.append([vi]), Fs.append([Fi])
    return np.array([np.mean(g) for g in vs]), np.array([np.mean(g) for g in Fs])


def _at(speeds, v, F):
    """F interpolated at speeds, nan outside the measured speeds (no extrapolation)."""
    vc, Fc = _curve(np.abs(v), F)
    if len(vc) == 0:
        return np.full(len(speeds), np.nan)
    return np.interp(speeds, vc, Fc, left=np.nan, right=np.nan)


def method(*runs) -> str:
    """"peaks" when every run's sine segments reached two speeds or more, else "stroke":
    runs compared are read alike, along the stroke when one of them ran one speed."""
    def speeds(rows):
        rows = [p for p in rows if np.isnan(p.target_c)]
        return len(_curve(np.array([p.v_comp for p in rows], float), np.array([p.F_comp for p in rows], float))[0])
    return "peaks" if all(speeds(rows) >= 2 for rows in runs) else "stroke"


SHARES = (0.25, 0.5, 0.75)  # of the top speed: a slow run's own table speeds


def own_speeds(rows) -> list[float]:
    """Speeds [m/s] within a run that reached none of the standard ones (a slow crank, a
    0.1 Hz sine): SHARES of the lower of its top compression and rebound speeds."""
    top = min((min(abs(p.v_comp), abs(p.v_reb)) for p in rows if np.isnan(p.target_c)), default=0.0)
    return [s * top for s in SHARES] if top > 0 else []


def _along_stroke(speeds, rows, field):
    """F at +speeds and -speeds read along the segments' strokes (the mean of the segments
    that reached each speed), nan where none did."""
    comp, reb = np.full((2, len(rows), len(speeds)), np.nan)
    for i, p in enumerate(rows):
        F = getattr(p, field, ())  # (the run index keeps peaks, not strokes: nothing to read)
        if len(F):
            comp[i] = np.interp(speeds, p.stroke_v, F, left=np.nan, right=np.nan)
            reb[i] = np.interp(-speeds, p.stroke_v, F, left=np.nan, right=np.nan)
    return _mean(comp), _mean(reb)


def _mean(a):
    """Column means over the finite values, nan for a column with none."""
    n = np.isfinite(a).sum(axis=0)
    return np.where(n > 0, np.nansum(a, axis=0) / np.maximum(n, 1), np.nan)


def repeats_left_out(rows) -> list[tuple[str, list[str]]]:
    """[(the first run's segment, [its repeats' segments])] of each sine test run more than
    once whose repeats differ (records/data.differing, on the peaks' force range): something
    the recording does not carry changed between them (a coil current, an adjuster), so one
    table of their mean would be no damper's. The table is the first run's."""
    rows = [p for p in rows if np.isnan(p.target_c)
            and np.all(np.isfinite([p.amplitude_mm, p.freq_hz, p.F_comp, p.F_reb]))]
    tests = [Test(p.amplitude_mm, p.freq_hz) for p in rows]
    return [(rows[g[0]].segment, [rows[i].segment for i in g[1:]])
            for g in differing(tests, [p.F_comp - p.F_reb for p in rows])]


def repeats_note(rows) -> str:
    """repeats_left_out() in words, "" when none."""
    return " ".join(f"The table is {first}'s alone: {len(names)} later run{'s' * (len(names) > 1)} of the test "
                    f"differ{'s' * (len(names) == 1)} from it by more than {100 * REPEATS_DIFFER:.0f} % in force range "
                    f"(a setting the recording does not carry changed); each is in the curve and the peak table."
                    for first, names in repeats_left_out(rows))


def width_note(table) -> str:
    """What "F ± W" means where the table gives a loop's half-width, "" where it gives none."""
    if not any(np.isfinite(r.W_comp_N) or np.isfinite(r.W_reb_N) for r in table):
        return ""
    return ("Read along the stroke, each force is its loop's mid-line (the accelerating and decelerating halves "
            "averaged); ± gives the loop's half-width there.")


def velocity_table(rows, speeds=None, units=Units(), how=None) -> list[VelocityRow]:
    """[VelocityRow] at speeds [m/s] from the Peak rows of sine segments at the cell's
    temperature (a temperature sweep's segments are left out: they are another curve; so are
    repeats that differ, repeats_left_out). how: "peaks" or "stroke" (method()); by default
    the run's own."""
    speeds = np.asarray(standard_speeds(units) if speeds is None else speeds, float)
    dropped = {name for _, names in repeats_left_out(rows) for name in names}
    rows = [p for p in rows if np.isnan(p.target_c) and p.segment not in dropped]
    if (how or method(rows)) == "stroke":
        nan = np.full(len(speeds), np.nan)
        out = [*_along_stroke(speeds, rows, "stroke_F"), nan, nan, *_along_stroke(speeds, rows, "stroke_W")]
        return [VelocityRow(float(s), *(float(c[i]) for c in out)) for i, s in enumerate(speeds)]
    col = {name: np.array([getattr(p, name) for p in rows], float)
           for name in ("v_comp", "v_reb", "F_comp", "F_reb", "Fd_comp", "Fd_reb")}
    out = [_at(speeds, col["v_comp"], col["F_comp"]), _at(speeds, col["v_reb"], col["F_reb"]),
           _at(speeds, col["v_comp"], col["Fd_comp"]), _at(speeds, col["v_reb"], col["Fd_reb"])]
    return [VelocityRow(float(s), *(float(c[i]) for c in out)) for i, s in enumerate(speeds)]


def has_rows(table) -> bool:
    return any(np.isfinite(r.F_comp_N) or np.isfinite(r.F_reb_N) for r in table)


# each field's CSV name (its unit added by the unit system) and quantity
CSV = {"v_m_s": ("v", "velocity"), "F_comp_N": ("F_comp", "force"), "F_reb_N": ("F_reb", "force"),
       "Fd_comp_N": ("Fd_comp", "force"), "Fd_reb_N": ("Fd_reb", "force"), "W_comp_N": ("W_comp", "force"),
       "W_reb_N": ("W_reb", "force")}


def write_csv(table, path, units=Units()):
    """velocity.csv: speed, force and damping force per direction, units in the names."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow([units.column(*CSV[f.name]) for f in fields(VelocityRow)])
        for r in table:
            w.writerow(["" if not np.isfinite(v) else f"{units.show(CSV[f.name][1], v):.4g}"
                        for f, v in zip(fields(VelocityRow), astuple(r))])
    return path


TABLE_NAMES = ("speed", "F comp", "F reb", "damping comp", "damping reb")  # the report's column names


def html_table(table, units=Units(), names=TABLE_NAMES, measured_only=False):
    """(header, rows) for the page; a blank where the speed was not measured (measured_only:
    such a speed left out); names: the columns' (the test sheet spells the directions out).
    A force read along the stroke is the loop's mid-line: "F ± its half-width"."""
    has_d = any(np.isfinite(r.Fd_comp_N) for r in table)
    lab = units.label
    head = [lab(names[0], "velocity")] + [lab(n, "force") for n in names[1:3 + 2 * has_d]]

    def n(v, w=np.nan):
        if not np.isfinite(v):
            return "-"
        return fmt(units.show("force", v), 3) + (f" ± {fmt(units.show('force', w), 2)}" if np.isfinite(w) else "")
    return head, [[f"{units.show('velocity', r.v_m_s):.4g}", n(r.F_comp_N, r.W_comp_N), n(r.F_reb_N, r.W_reb_N)]
                  + ([n(r.Fd_comp_N), n(r.Fd_reb_N)] if has_d else []) for r in table
                  if not measured_only or np.isfinite(r.F_comp_N) or np.isfinite(r.F_reb_N)]
