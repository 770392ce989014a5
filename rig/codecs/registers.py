"""Modbus register maps as data (rig/codecs/registers/*.toml, documented in docs/wiring.md):
which registers hold which value, their type, word order, scale and fault bits.

decode() turns a block of raw 16-bit registers into {value name: (value, fault or None)};
encode() is its inverse, used by the virtual rig's Modbus server.
"""
from __future__ import annotations

import struct
import tomllib
from dataclasses import dataclass
from pathlib import Path

from rig.errors import RigError

MAP_DIR = Path(__file__).parent / "registers"
TYPES = {"int16": ("h", 1), "uint16": ("H", 1), "int32": ("i", 2), "uint32": ("I", 2), "float32": ("f", 2)}


@dataclass(frozen=True)
class Value:
    name: str
    address: int  # 0-based
    type: str
    word_order: str  # "big": high word first
    scale: float
    offset: float
    unit: str
    fault_address: int | None
    fault_bit: int | None
    fault: str


@dataclass(frozen=True)
class RegisterMap:
    name: str
    description: str
    table: str  # "input" or "holding"
    start: int
    count: int
    values: tuple
    identity: tuple | None = None  # (address, value): a register holding the module's type code


def _int_or_none(v):
    if v is not None and (isinstance(v, bool) or not isinstance(v, int)):
        raise ValueError(f"expected an integer, got {v!r}")
    return v


def load(name_or_path) -> RegisterMap:
    s = str(name_or_path)
    path = Path(s) if s.endswith(".toml") else MAP_DIR / f"{s}.toml"
    if not path.exists():
        known = ", ".join(sorted(p.stem for p in MAP_DIR.glob("*.toml")))
        raise RigError(f"unknown register map {s!r} (known: {known})")
    if not path.is_file():
        raise RigError(f"register map {s}: not a file")
    try:
        data = tomllib.loads(path.read_text())
        values = []
        for vname, v in data["values"].items():
            if v["type"] not in TYPES:
                raise RigError(f"{path.name}: values.{vname}.type: one of {', '.join(TYPES)}")
            values.append(Value(vname, int(v["address"]), v["type"], v.get("word_order", "big"),
                                float(v.get("scale", 1.0)), float(v.get("offset", 0.0)), v.get("unit", ""),
                                _int_or_none(v.get("fault_address")), _int_or_none(v.get("fault_bit")),
                                str(v.get("fault", "fault"))))
        ident = data.get("identity")
        identity = (int(ident["address"]), int(ident["value"])) if ident is not None else None
        m = RegisterMap(path.stem, data.get("description", ""), data.get("table", "input"),
                        int(data["start"]), int(data["count"]), tuple(values), identity)
    except tomllib.TOMLDecodeError as e:
        raise RigError(f"{path.name}: {e}") from None
    except KeyError as e:
        raise RigError(f"{path.name}: missing {e.args[0]!r}") from None
    except (TypeError, ValueError, AttributeError) as e:
        raise RigError(f"{path.name}: malformed ({e})") from None
    except OSError as e:
        raise RigError(f"{path.name}: cannot read ({e.strerror})") from None
    owner = {}
    for v in m.values:
        last = v.address + TYPES[v.type][1] - 1
        if v.address < m.start or last >= m.start + m.count or v.word_order not in ("big", "little"):
            raise RigError(f"{path.name}: values.{v.name}: address or word order outside the block")
        for a in range(v.address, last + 1):
            if a in owner:
                raise RigError(f"{path.name}: values.{v.name}: register {a} also holds values.{owner[a]}")
            owner[a] = v.name
        if v.fault_address is not None and (not m.start <= v.fault_address < m.start + m.count
                                            or v.fault_bit is None or not 0 <= v.fault_bit <= 15):
            raise RigError(f"{path.name}: values.{v.name}: fault_address outside the block or fault_bit not 0-15")
    return m


def _words(value: Value, regs, start):
    n = TYPES[value.type][1]
    words = list(regs[value.address - start:value.address - start + n])
    if len(words) != n:
        raise RigError(f"register block too short for {value.name}")
    return words if value.word_order == "big" else words[::-1]


def decode(m: RegisterMap, regs) -> dict:
    """{name: (scaled value, fault text or None)} from the map's register block."""
    if len(regs) != m.count or any(not 0 <= r <= 0xFFFF for r in regs):
        raise RigError(f"{m.name}: expected {m.count} registers of 16 bits, got {list(regs)[:8]}")
    out = {}
    for v in m.values:
        fmt = TYPES[v.type][0]
        raw = struct.unpack(">" + fmt, struct.pack(">" + "H" * TYPES[v.type][1], *_words(v, regs, m.start)))[0]
        fault = None
        if v.fault_address is not None:
            if (regs[v.fault_address - m.start] >> v.fault_bit) & 1:
                fault = v.fault
        out[v.name] = (raw * v.scale + v.offset, fault)
    return out


def encode(m: RegisterMap, values: dict, faults=()) -> list[int]:
    """The register block holding `values` {name: value}; `faults` names the values whose
    fault bit is set (a value beyond its integer range saturates and sets it too)."""
    regs = [0] * m.count
    for v in m.values:
        raw = (values.get(v.name, 0.0) - v.offset) / v.scale
        fmt, n = TYPES[v.type]
        if fmt != "f":
            lo, hi = {"h": (-2**15, 2**15 - 1), "H": (0, 2**16 - 1), "i": (-2**31, 2**31 - 1),
                      "I": (0, 2**32 - 1)}[fmt]
            clipped = min(max(int(round(raw)), lo), hi)  # saturate like an ADC
            if clipped != int(round(raw)) and v.fault_address is not None:
                regs[v.fault_address - m.start] |= 1 << v.fault_bit
            raw = clipped
        words = list(struct.unpack(">" + "H" * n, struct.pack(">" + fmt, raw)))
        if v.word_order == "little":
            words = words[::-1]
        regs[v.address - m.start:v.address - m.start + n] = words
        if v.name in faults and v.fault_address is not None:
            regs[v.fault_address - m.start] |= 1 << v.fault_bit
    return regs
