"""Device drivers behind one small protocol, and the one registry of transports.

A driver (one object per configured device) has
    open()            connect; RigError naming the device if it cannot
    poll(now) -> [(signal, value, fault or None[, age s])]   received since the last poll
    close()
and the device that takes setpoints also `send(mode, setpoint)` and `state`. Bytes become
device outputs (V, degC) here; calibration to SI is the channel's (rig/config.py).

Each transport module (can, serial, modbus) declares a Transport: its configuration keys,
its signals, how its drivers are made, its address for people, its rate. Configuration,
safety and the virtual rig's emulators all read TRANSPORTS: adding a transport is one
driver module here and one emulator in sim_backend/emulators/.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Protocol


FRAME_HZ = 1000.0  # frames per second a streaming device sends unless its config says (frame_hz)


def frame_hz(params) -> float:
    return float(params.get("frame_hz", FRAME_HZ))


class Device(Protocol):
    def open(self) -> None: ...
    def poll(self, now: float) -> list: ...
    def close(self) -> None: ...


@dataclass(frozen=True)
class Transport:
    name: str
    schema: dict  # key -> rig.schema.Field: the [devices.NAME] table of this transport
    signals: Callable[[dict], tuple]  # params -> the device's signal names
    drivers: Callable[[dict, bool], dict]  # ({name: config Device}, threaded) -> {name: driver}
    address: Callable[[dict], str]  # params -> where it is, for people
    rate_hz: Callable[[dict, float], float]  # (params, loop rate) -> samples per second of each signal
    takes_setpoints: Callable[[dict], bool] = field(default=lambda p: False)  # the actuator
    max_age: Callable[[dict, float], float] = field(default=lambda p, stale_s: stale_s)  # watchdog [s]
    check: Callable[[dict], tuple | None] = field(default=lambda p: None)  # (key, problem) beyond the schema


def _registry():
    from rig.devices import can, modbus, serial
    return {t.name: t for t in (can.TRANSPORT, serial.TRANSPORT, modbus.TRANSPORT)}


TRANSPORTS = _registry()


def by_transport(config):
    """{transport name: [device names]} of a RigConfig's devices, for the transports it uses."""
    out = {}
    for name, d in config.devices.items():
        out.setdefault(d.transport, []).append(name)
    return out


def make(config, threaded=False):
    """{device name: driver} for a RigConfig. threaded: polled devices get threads of their
    own (real time)."""
    out = {}
    for name, names in by_transport(config).items():
        out.update(TRANSPORTS[name].drivers({n: config.devices[n] for n in names}, threaded))
    return {n: out[n] for n in config.devices}  # in the configuration's order
