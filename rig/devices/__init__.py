"""Device drivers behind one small protocol, and the one registry of transports.

A driver (one object per configured device) has
    open()            connect; RigError naming the device if it cannot
    poll(now) -> [(signal, value, fault or None[, age s])]   received since the last poll
    close()
and the device that takes setpoints also `send(mode, setpoint)` and `state`. Bytes become
device outputs (V, degC) here; calibration to SI is the channel's (rig/config.py).

Each transport module (can, serial, modbus) declares a Transport (rig/devices/transport.py): its configuration keys,
its signals, how its drivers are made, its address for people, its rate. Configuration,
safety and the virtual rig's emulators all read TRANSPORTS: adding a transport is one
driver module here and one emulator in sim_backend/emulators/.
"""
from __future__ import annotations

from rig.devices import can, modbus, serial

TRANSPORTS = {t.name: t for t in (can.TRANSPORT, serial.TRANSPORT, modbus.TRANSPORT)}


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
