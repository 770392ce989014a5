"""Rig configuration (TOML): which device sits on which transport and address, which
channel comes from which device signal, its calibration, and the safety limits.

The schema below is strict: every key has a type (a number is never a boolean or a
string), limits are finite and in range, units are SI, and an unknown key or table is
refused with a "did you mean" for near misses. Every problem is reported as
"FILE:LINE: what is wrong" (RigError) before anything connects. The shipped configs are
rig/configs/virtual.toml (the embedded default), sim-rig.toml and example-cell.toml.
"""
from __future__ import annotations

import dataclasses
import difflib
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from rig.devices import TRANSPORTS
from rig.errors import RigError
from rig.schema import Checker, Field, line_of
from rig.schema import number as _num

CONFIG_DIR = Path(__file__).parent / "configs"
REQUIRED_CHANNELS = ("force", "x")
# what a channel measures, by its name: SI unit, and the range a working sensor can read
QUANTITIES = (
    (r"force", "N", -1e6, 1e6),
    (r"x|x_.+", "m", -0.5, 1.0),
    (r"v|v_.+", "m/s", -20.0, 20.0),
    (r"T_.+", "K", 173.15, 773.15),
    (r"P_.+|P\d+", "Pa", 0.0, 1e8),
)
AUX_UNITS = ("1", "A", "V", "N", "m", "m/s", "m/s^2", "K", "Pa", "Hz", "W", "s", "rad", "rad/s")


# realtime_priority: a wall-clock run's SCHED_FIFO priority (Linux; rig/pacing.py), if asked for
RIG = {"name": Field("string"), "rate_hz": _num(above=0.0, hi=10000.0), "safe_position": _num(),
       "realtime_priority": Field("integer", lo=1, hi=99)}
# what the actuator declares it can do (on the device that takes setpoints): limits within
ACTUATOR_RATINGS = {"stroke": _num(above=0.0, hi=2.0), "force_rating": _num(above=0.0),
                    "velocity_rating": _num(above=0.0, hi=50.0)}
# an aux.* channel that drives the damper (an MR coil's current, an adjuster's command) says
# so and how: only such a channel may scale an effect in the diagnosis (models/diagnose)
DRIVES = ("coil current", "coil voltage", "valve current", "valve command")
CHANNEL = {"device": Field("string", True), "signal": Field("string", True),
           "gain": _num(required=True, nonzero=True), "offset": _num(), "unit": Field("string", True),
           "drives": Field("string", choices=DRIVES),
           # traceability on the test sheet: the instrument (make, model, serial) and its last calibration
           "sensor": Field("string"), "calibrated": Field("date")}
LIMITS = {
    "x_min": _num(required=True, lo=0.0, hi=2.0), "x_max": _num(required=True, above=0.0, hi=2.0),
    "force_max": _num(required=True, above=0.0, hi=1e7),
    "velocity_max": _num(required=True, above=0.0, hi=50.0),
    "temperature_max": _num(required=True, above=273.15, hi=773.15),  # K
    "gas_pressure_max": _num(required=True, above=0.0, hi=1e8),  # Pa
    "stale_s": _num(required=True, above=0.0, hi=1.0),  # a watchdog slower than a second is none
    "frequency_max": _num(above=0.0, hi=1000.0),
}
# the damper's heat path in this cell, for the pre-flight's reachable temperatures (optional:
# measured as heat capacity / the cooling time constant of a warm damper at rest)
THERMAL = {"ambient": _num(above=173.15, hi=373.15), "conductance": _num(above=0.0, hi=1e4)}
TABLES = ("rig", "devices", "channels", "limits", "thermal")


@dataclass
class DeviceConfig:
    name: str
    transport: str
    params: dict
    line: int


@dataclass
class Channel:
    name: str
    device: str
    signal: str
    gain: float  # SI unit per device unit
    offset: float  # SI unit
    unit: str
    line: int
    drives: str = ""  # what of the damper it drives (DRIVES); "" for a reading
    sensor: str = ""  # the instrument: make, model, serial ("" not given)
    calibrated: str = ""  # its last calibration, an ISO date ("" not given)

    def scale(self, raw):
        """Device output (V, degC ...) to SI: the one place bytes become physics."""
        return self.gain * raw + self.offset

    def unscale(self, value):
        return (value - self.offset) / self.gain


@dataclass
class RigConfig:
    name: str
    rate_hz: float
    safe_position: float  # m
    devices: dict
    channels: dict
    limits: dict
    path: str = "<config>"
    text: str = field(default="", repr=False)
    actuator: str = ""  # name of the device that takes the setpoint
    thermal: dict = field(default_factory=dict)  # ambient [K], conductance [W/K], if given
    realtime_priority: int | None = None  # SCHED_FIFO priority of the loop in real time, if asked for


def at_rate(config: RigConfig, hz: float) -> RigConfig:
    """The config with its loop, and every device that streams frames, at hz (a virtual
    cell that samples faster: its emulators send a frame per device each tick)."""
    devices = {n: dataclasses.replace(d, params={**d.params, "frame_hz": hz})
               if "frame_hz" in TRANSPORTS[d.transport].schema else d for n, d in config.devices.items()}
    return dataclasses.replace(config, rate_hz=hz, devices=devices)


def driven(config: RigConfig, channel: str, kind: str) -> RigConfig:
    """The config with `channel` declared to drive the damper (DRIVES: kind)."""
    return dataclasses.replace(config, channels={**config.channels,
                                                 channel: dataclasses.replace(config.channels[channel], drives=kind)})


def quantity(channel_name):
    """(SI unit, plausible low, high) of a channel by its name; None for aux.* and others."""
    for pattern, unit, lo, hi in QUANTITIES:
        if re.fullmatch(pattern, channel_name):
            return unit, lo, hi
    return None


def path_of(path_or_name=None) -> Path:
    """The file of a config path, or of the name of a shipped config (default: virtual)."""
    s = "virtual" if path_or_name is None else str(path_or_name)
    return Path(s) if s.endswith(".toml") or "/" in s else CONFIG_DIR / f"{s}.toml"


def load(path_or_name=None) -> RigConfig:
    """A config file path, or the name of a shipped config (default: virtual)."""
    s = "virtual" if path_or_name is None else str(path_or_name)
    path = path_of(s)
    if not path.exists():
        raise RigError(f"{s}: no such rig config (shipped: "
                       f"{', '.join(sorted(p.stem for p in CONFIG_DIR.glob('*.toml')))})")
    if not path.is_file():
        raise RigError(f"{s}: not a file")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise RigError(f"{path.name}: not a text (TOML) file") from None
    except OSError as e:
        raise RigError(f"{path.name}: cannot read ({e.strerror})") from None
    return parse(text, path.name)


def parse(text: str, where="<config>") -> RigConfig:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = re.search(r"line (\d+)", str(e))
        raise RigError(f"{where}:{m.group(1) if m else '?'}: {str(e).split(' (at')[0]}") from None
    except RecursionError:
        raise RigError(f"{where}: nested too deeply to be a cell file") from None
    c = Checker(text, where)
    for name in data:
        if name not in TABLES:
            near = difflib.get_close_matches(name, TABLES, n=1, cutoff=0.6)
            if isinstance(data[name], dict):
                line, what = c.line([name]) or line_of(text, [name, *list(data[name])[:1]]), f"table [{name}]"
            else:  # a stray top-level key = value
                line, what = _key_line(text, name), f"key {name!r}"
            c.fail(line, f"unknown {what}" + (f"; did you mean [{near[0]}]?" if near else
                                              f" (known: {', '.join(f'[{t}]' for t in TABLES)})"))
    rig = c.fields(c.table(data.get("rig", {}), ["rig"], "rig"), ["rig"], RIG, "rig")
    devices = _devices(c, c.table(data.get("devices", {}), ["devices"], "devices"))
    channels = _channels(c, c.table(data.get("channels", {}), ["channels"], "channels"), devices)
    limits = _limits(c, c.table(data.get("limits", {}), ["limits"], "limits"), devices)
    thermal = c.fields(c.table(data.get("thermal", {}), ["thermal"], "thermal"), ["thermal"], THERMAL, "thermal")
    safe = float(rig.get("safe_position", (limits["x_min"] + limits["x_max"]) / 2))
    if not limits["x_min"] <= safe <= limits["x_max"]:
        c.fail(c.line(["rig"], "safe_position"), "rig.safe_position: must lie within the stroke limits "
                                                 f"{limits['x_min']:g}..{limits['x_max']:g} m")
    actuator = next(n for n, d in devices.items() if TRANSPORTS[d.transport].takes_setpoints(d.params))
    return RigConfig(rig.get("name", where), float(rig.get("rate_hz", 1000)), safe, devices, channels, limits,
                     where, text, actuator, {k: float(v) for k, v in thermal.items()}, rig.get("realtime_priority"))


def _key_line(text, key):
    """1-based line of a top-level `key = ...` (before any table), 1 if not found."""
    for i, ln in enumerate(text.splitlines()):
        if ln.lstrip().startswith("["):
            break
        if re.match(rf"^\s*[\"']?{re.escape(key)}[\"']?\s*=", ln):
            return i + 1
    return 1


def _devices(c, table):
    devices, where = {}, {}
    for name, d in table.items():
        parts = ["devices", name]
        d = c.table(d, parts, f"devices.{name}")
        t = d.get("transport")
        if not isinstance(t, str) or t not in TRANSPORTS:
            near = difflib.get_close_matches(str(t), TRANSPORTS, n=1, cutoff=0.6)
            c.fail(c.line(parts, "transport"), f"device {name!r}: " + (
                "missing 'transport'" if t is None else f"unknown transport {t!r}") + (
                f"; did you mean {near[0]!r}?" if near else f" (one of {', '.join(TRANSPORTS)})"))
        transport = TRANSPORTS[t]
        params = c.fields({k: v for k, v in d.items() if k != "transport"}, parts,
                          {**transport.schema, **ACTUATOR_RATINGS}, f"device {name!r}")
        if not transport.takes_setpoints(params):
            for key in ACTUATOR_RATINGS:
                if key in params:
                    c.fail(c.line(parts, key), f"device {name!r}: {key} is a rating of the actuator only")
        problem = transport.check(params)
        if problem:
            c.fail(c.line(parts, problem[0]), f"device {name!r}: {problem[1]}")
        devices[name] = DeviceConfig(name, t, params, c.line(parts))
        # one device per address: a serial port, a Modbus host:port and id, a CAN node kind on a bus
        address = (t, transport.address(params), params.get("node"))
        if address in where:
            c.fail(c.line(parts), f"device {name!r}: {transport.address(params)}"
                                  f"{' node ' + params['node'] if 'node' in params else ''} is taken by device "
                                  f"{where[address]!r} (one device per address)")
        where[address] = name
    if not devices:
        c.fail(1, "no [devices.NAME] tables")
    actuators = [n for n, d in devices.items() if TRANSPORTS[d.transport].takes_setpoints(d.params)]
    if len(actuators) != 1:
        c.fail(c.line(["devices"]), f"exactly one actuator device (one that takes setpoints: CAN node "
                                    f"'actuator') is needed, found {len(actuators)}")
    return devices


def _channels(c, table, devices):
    channels, used = {}, {}
    for name, ch in table.items():
        parts = ["channels", name]
        ch = c.fields(c.table(ch, parts, f"channels.{name}"), parts, CHANNEL, f"channel {name!r}")
        dev = devices.get(ch["device"])
        if dev is None:
            near = difflib.get_close_matches(ch["device"], devices, n=1, cutoff=0.6)
            c.fail(c.line(parts, "device"), f"channel {name!r}: unknown device {ch['device']!r}"
                   + (f"; did you mean {near[0]!r}?" if near else f" (devices: {', '.join(devices)})"))
        signals = signals_of(dev)
        if ch["signal"] not in signals:
            c.fail(c.line(parts, "signal"), f"channel {name!r}: device {dev.name!r} has no signal {ch['signal']!r} "
                                            f"(it has {', '.join(signals)})")
        key = (ch["device"], ch["signal"])
        if key in used:
            c.fail(c.line(parts), f"channel {name!r}: duplicates channel {used[key]!r} ({ch['device']}.{ch['signal']})")
        used[key] = name
        q = quantity(name)
        unit = ch["unit"]
        if q is not None and unit != q[0]:
            c.fail(c.line(parts, "unit"), f"channel {name!r}: unit {unit!r} is not its SI unit {q[0]!r} "
                                          f"(scale with gain and offset to {q[0]})")
        if q is None and unit not in AUX_UNITS:
            c.fail(c.line(parts, "unit"), f"channel {name!r}: unit {unit!r} is not an SI unit "
                                          f"({', '.join(AUX_UNITS)})")
        if ch.get("drives") and not name.startswith("aux."):
            c.fail(c.line(parts, "drives"), f"channel {name!r}: only an aux.* channel drives the damper")
        channels[name] = Channel(name, ch["device"], ch["signal"], float(ch["gain"]), float(ch.get("offset", 0.0)),
                                 unit, c.line(parts), ch.get("drives", ""), ch.get("sensor", ""),
                                 ch.get("calibrated", ""))
    for name in REQUIRED_CHANNELS:
        if name not in channels:
            c.fail(c.line(["channels"]), f"required channel {name!r} is missing")
    return channels


def _limits(c, table, devices):
    L = {k: float(v) for k, v in c.fields(table, ["limits"], LIMITS, "limits").items()}
    if not L["x_min"] < L["x_max"]:
        c.fail(c.line(["limits"], "x_min"), "limits: x_min must be below x_max")
    act = next(d for d in devices.values() if TRANSPORTS[d.transport].takes_setpoints(d.params))
    for key, rating, what in (("x_max", "stroke", "m"), ("force_max", "force_rating", "N"),
                              ("velocity_max", "velocity_rating", "m/s")):
        if rating in act.params and L[key] > act.params[rating]:
            c.fail(c.line(["limits"], key), f"limits.{key}: {L[key]:g} {what} is beyond what the actuator "
                                            f"declares ({rating} = {act.params[rating]:g} {what})")
    return L


def signals_of(dev: DeviceConfig):
    return TRANSPORTS[dev.transport].signals(dev.params)
