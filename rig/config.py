"""Rig configuration (TOML): which device sits on which transport and address, which
channel comes from which device signal, its calibration, and the safety limits.

Every problem is reported as "FILE:LINE: what is wrong" (RigError) before anything
connects. The shipped configs are rig/configs/virtual.toml (the embedded default) and
rig/configs/example-cell.toml (a real cell's wiring, commented).
"""
from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from . import modbus_map
from .errors import RigError

CONFIG_DIR = Path(__file__).parent / "configs"
TRANSPORTS = {
    "can": {"required": ("interface", "channel", "node"), "optional": ("bitrate", "host", "port")},
    "serial": {"required": ("port",), "optional": ("baudrate",)},
    "modbus": {"required": ("host", "port", "device_id", "map"), "optional": ("poll_hz", "timeout_s")},
}
CAN_NODES = {"actuator": ("position",), "daq": ("lvdt", "lvt")}
SERIAL_SIGNALS = ("output",)
REQUIRED_CHANNELS = ("force", "x")
LIMITS = ("x_min", "x_max", "force_max", "velocity_max", "temperature_max", "gas_pressure_max", "stale_s")


@dataclass
class Device:
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


def _line(text, section, key=None):
    """1-based line of [section] (or of key inside it) in the TOML text, 0 if not found."""
    lines = text.splitlines()
    head = re.compile(r"^\s*\[\s*" + re.escape(section).replace(r"\.", r"\s*\.\s*") + r"\s*\]")
    for i, ln in enumerate(lines):
        if head.match(ln):
            if key is None:
                return i + 1
            for j in range(i + 1, len(lines)):
                if lines[j].lstrip().startswith("["):
                    break
                if re.match(r"^\s*" + re.escape(key) + r"\s*=", lines[j]):
                    return j + 1
            return i + 1
    return 0


def load(path_or_name=None) -> RigConfig:
    """A config file path, or the name of a shipped config (default: virtual)."""
    s = "virtual" if path_or_name is None else str(path_or_name)
    path = Path(s) if s.endswith(".toml") else CONFIG_DIR / f"{s}.toml"
    if not path.exists():
        raise RigError(f"{s}: no such rig config (shipped: "
                       f"{', '.join(sorted(p.stem for p in CONFIG_DIR.glob('*.toml')))})")
    return parse(path.read_text(), path.name)


def parse(text: str, where="<config>") -> RigConfig:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = re.search(r"line (\d+)", str(e))
        raise RigError(f"{where}:{m.group(1) if m else '?'}: {str(e).split(' (at')[0]}") from None

    def fail(line, msg):
        raise RigError(f"{where}:{line}: {msg}")

    rig = data.get("rig", {})
    devices = {}
    for name, d in data.get("devices", {}).items():
        line = _line(text, f"devices.{name}")
        if not isinstance(d, dict):
            fail(line, f"devices.{name}: expected a table")
        t = d.get("transport")
        if t not in TRANSPORTS:
            fail(_line(text, f"devices.{name}", "transport"),
                 f"device {name!r}: unknown transport {t!r} (one of {', '.join(TRANSPORTS)})")
        spec = TRANSPORTS[t]
        for key in spec["required"]:
            if key not in d:
                fail(line, f"device {name!r}: missing {key!r} for transport {t!r}")
        for key in d:
            if key != "transport" and key not in spec["required"] + spec["optional"]:
                fail(_line(text, f"devices.{name}", key), f"device {name!r}: unknown key {key!r}")
        if t == "can" and d["node"] not in CAN_NODES:
            fail(_line(text, f"devices.{name}", "node"),
                 f"device {name!r}: unknown CAN node {d['node']!r} (one of {', '.join(CAN_NODES)})")
        if t == "modbus":
            try:
                modbus_map.load(d["map"])
            except RigError as e:
                fail(_line(text, f"devices.{name}", "map"), f"device {name!r}: {e}")
        devices[name] = Device(name, t, {k: v for k, v in d.items() if k != "transport"}, line)
    if not devices:
        fail(1, "no [devices.NAME] tables")
    actuators = [n for n, d in devices.items() if d.transport == "can" and d.params["node"] == "actuator"]
    if len(actuators) != 1:
        fail(1, f"exactly one actuator device (CAN node 'actuator') is needed, found {len(actuators)}")

    channels = {}
    used = {}
    for name, c in data.get("channels", {}).items():
        line = _line(text, f"channels.{name}")
        for key in ("device", "signal", "gain"):
            if key not in c:
                fail(line, f"channel {name!r}: missing {key!r}")
        dev = devices.get(c["device"])
        if dev is None:
            fail(_line(text, f"channels.{name}", "device"),
                 f"channel {name!r}: unknown device {c['device']!r} (devices: {', '.join(devices)})")
        signals = _signals(dev)
        if c["signal"] not in signals:
            fail(_line(text, f"channels.{name}", "signal"),
                 f"channel {name!r}: device {dev.name!r} has no signal {c['signal']!r} "
                 f"(it has {', '.join(signals)})")
        key = (c["device"], c["signal"])
        if key in used:
            fail(line, f"channel {name!r}: duplicates channel {used[key]!r} ({c['device']}.{c['signal']})")
        used[key] = name
        try:
            gain, offset = float(c["gain"]), float(c.get("offset", 0.0))
        except (TypeError, ValueError):
            fail(line, f"channel {name!r}: gain and offset must be numbers")
        if gain == 0:
            fail(_line(text, f"channels.{name}", "gain"), f"channel {name!r}: gain must not be zero")
        channels[name] = Channel(name, c["device"], c["signal"], gain, offset, c.get("unit", ""), line)
    for name in REQUIRED_CHANNELS:
        if name not in channels:
            fail(_line(text, "channels") or 1, f"required channel {name!r} is missing")

    limits = data.get("limits", {})
    for name in LIMITS:
        if not isinstance(limits.get(name), (int, float)):
            fail(_line(text, "limits", name) or _line(text, "limits") or 1, f"limits.{name}: missing or not a number")
    if not limits["x_min"] < limits["x_max"]:
        fail(_line(text, "limits", "x_min"), "limits: x_min must be below x_max")
    rate = rig.get("rate_hz", 1000)
    if not isinstance(rate, (int, float)) or not 0 < rate <= 10000:
        fail(_line(text, "rig", "rate_hz"), f"rig.rate_hz: must be in (0, 10000], got {rate!r}")
    safe = rig.get("safe_position", (limits["x_min"] + limits["x_max"]) / 2)
    if not limits["x_min"] <= safe <= limits["x_max"]:
        fail(_line(text, "rig", "safe_position"), "rig.safe_position: must lie within the stroke limits")
    return RigConfig(rig.get("name", where), float(rate), float(safe), devices, channels,
                     {k: float(limits[k]) for k in LIMITS}, where, text, actuators[0])


def _signals(dev: Device):
    if dev.transport == "can":
        return CAN_NODES[dev.params["node"]]
    if dev.transport == "serial":
        return SERIAL_SIGNALS
    return tuple(v.name for v in modbus_map.load(dev.params["map"]).values)
