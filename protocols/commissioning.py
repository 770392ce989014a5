"""Commissioning a cell (`dyno rig zero`): a plan of a hold at mid-stroke, where the load
cell is tared and the position referenced, then a slow sine, along which the LVT's
velocity is checked against the LVDT's derivative. Not a test: nothing is recorded. And
the new offsets, written into the cell file with a dated comment."""
from __future__ import annotations

import datetime
import math
from dataclasses import dataclass

import numpy as np

from records.data import segments
from rig.errors import UsageError
from protocols.plan import RigInfo, Segment
from protocols.units import Units

NAME = "zero"
LVT_TOLERANCE = 0.05  # the LVT's gain against the LVDT's derivative: more than 5 % off is reported (a wrong gain, not jitter)


@dataclass
class Params:
    hold_s: float = 2.0
    amplitude_mm: float = 2.0
    freq_hz: float = 1.0
    cycles: int = 3


def check(p: Params, rig: RigInfo):
    return []


def plan(p: Params, rig: RigInfo):
    yield Segment("zero hold", {"x_mm": 1e3 * rig.x_mid}, p.hold_s, lambda t: rig.x_mid, kind="hold")
    A, w = p.amplitude_mm / 1e3, 2 * math.pi * p.freq_hz
    yield Segment(f"lvt check {p.amplitude_mm:g} mm {p.freq_hz:g} Hz",
                  {"freq_hz": p.freq_hz, "cycles": p.cycles, "kind": "sine"}, p.cycles / p.freq_hz,
                  lambda t: rig.x_mid + A * math.sin(w * t), kind="sine")


def findings(channels, events):
    """{force_mean [N], x_mean [m] over the hold's second half; lvt_gain [-]: the LVT's
    velocity amplitude over the LVDT's derivative's along the sine}."""
    (_, _, h0, h1), (_, p, s0, s1) = segments(events)
    out = {}
    for name in ("force", "x"):
        t, y = channels[name]
        k = (t >= 0.5 * (h0 + h1)) & (t <= h1)
        out[f"{name}_mean"] = float(np.mean(y[k]))
    # amplitudes of the sine fitted to each: the LVT's over the LVDT's times omega (neither
    # noise nor a lag between the two biases a fitted amplitude)
    w = 2 * np.pi * p["freq_hz"]
    amp = []
    for name in ("x", "v"):
        t, y = channels[name]
        k = (t >= s0) & (t <= s1)
        A = np.column_stack([np.sin(w * t[k]), np.cos(w * t[k]), np.ones(int(k.sum()))])
        c = np.linalg.lstsq(A, y[k], rcond=None)[0]
        amp.append(float(np.hypot(c[0], c[1])))
    out["lvt_gain"] = amp[1] / (w * amp[0])
    return out


# --- zeroing (`dyno rig zero`): the offsets the commissioning finds, written to the cell file ---
RESOLUTION = {"force": 0.1, "length": 1e-6}  # N, m: what offsets and readings are printed to
QUANTITY = {"force": "force", "x": "length"}  # the channels zeroed
GAS_LIKE = 0.25  # an "unloaded" reading within 25 % of the damper's gas force looks like the damper still in
GAS_MIN_N = 50.0  # ... when that force is large enough to be told from a load cell's zero error


def looks_loaded(force_n, damper, x_m) -> float | None:
    """The damper's static gas force [N] at x (eq 3.16, at its charge temperature) when the
    load cell's reading is that close to it, else None."""
    from models.physics.gas_spring import static_force
    g = damper.gas_spring
    F = float(static_force(x_m, g.T0, g.P0, g.V0, g.T0, damper.geometry.A_r, g.K_voil, g.K_voint))
    return F if F > GAS_MIN_N and abs(force_n - F) < GAS_LIKE * F else None


def set_offset(text, channel, value, note):
    """The cell file's text with [channels.CHANNEL]'s offset set to value and a comment
    line after it, every other line as it was (tomlkit keeps comments and layout);
    UsageError if the section or its offset is missing."""
    import tomlkit
    from tomlkit.exceptions import TOMLKitError
    try:
        doc = tomlkit.parse(text)
    except TOMLKitError as e:
        raise UsageError(f"the cell file is not TOML: {e}") from None
    table = doc.get("channels", {}).get(channel)
    if table is None:
        raise UsageError(f"no [channels.{channel}] section to write the offset into")
    if "offset" not in table:
        raise UsageError(f"[channels.{channel}] has no offset line to change")
    table["offset"] = float(f"{value:.9g}")  # its comment and place kept
    table["offset"].trivia.trail += f"# {note}\n"  # the dated line right below it
    return tomlkit.dumps(doc)


def as_shown(units, quantity, si):
    """A reading or offset in the unit system, to the sensor's resolution: '1.50000 in'."""
    scale = units.show(quantity, 1.0) - units.show(quantity, 0.0)
    places = max(0, -math.floor(math.log10(RESOLUTION[quantity] * scale)))
    return f"{units.show(quantity, si):.{places}f} {units.unit(quantity)}"


def span(cfg, name) -> float:
    """How far a channel's zero may move [SI]: the stroke between the position limits, the
    force limit; a larger offset is a wrong reading, not a zero error."""
    lim = cfg.limits
    return lim["x_max"] - lim["x_min"] if name == "x" else lim["force_max"]


def write_offsets(path, cfg, changes, units=Units()):
    """Write [(channel, new offset [SI], why)] into the cell file at path, each with a dated
    comment: all or nothing, and only offsets that move a zero by less than the channel's
    span. A link is followed: its target is edited, the link kept. The file written."""
    from rig import config as rig_config
    from records.files import written
    for name, value, _ in changes:
        q = QUANTITY[name]
        if not abs(value - cfg.channels[name].offset) <= span(cfg, name):
            raise UsageError(f"{name}: the new offset {as_shown(units, q, value)} moves the zero by more than the "
                           f"channel's range ({as_shown(units, q, span(cfg, name))}); nothing written: check the "
                           f"sensor and its wiring")
    path = path.resolve()
    today = datetime.date.today().isoformat()
    text = path.read_text(encoding="utf-8")
    for name, value, why in changes:
        text = set_offset(text, name, value, f"dyno rig zero {today}: {why} (offset was "
                                             f"{cfg.channels[name].offset:.9g})")
    rig_config.parse(text, path.name)  # still a valid cell file, before it replaces the old one
    with written(path, "--rig") as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path
