"""The actuator controller and the LVDT/LVT conditioner as CAN nodes (rig/codecs/dyno.dbc)
on any python-can bus: the in-process virtual bus, or the socketcand server of
`dyno sim-rig`."""
from __future__ import annotations

import itertools
import os

import can

from rig.codecs import can as can_codec

from sim_backend.emulators.outputs import outputs
from sim_backend.emulators.socketcand_server import SocketcandServer

_ids = itertools.count()


class CanNodes:
    def __init__(self, bus, config, names, plant):
        self.bus, self.config, self.plant = bus, config, plant
        self.devices = {config.devices[n].params["node"]: n for n in names}
        self.counter = 0
        self.faults = set()  # can_bus_off: the nodes fall silent

    @property
    def bus_off(self):
        return "can_bus_off" in self.faults

    def service(self):
        """Apply every setpoint frame received."""
        while True:
            msg = self.bus.recv(timeout=0.0)
            if msg is None:
                return
            if self.bus_off or msg.arbitration_id != can_codec.frame_id("ACT_CMD") or len(msg.data) != 8:
                continue
            _, sig = can_codec.decode(msg.arbitration_id, msg.data)
            self.plant.command(int(sig["mode"]), sig["setpoint"])

    def settle(self, until):
        pass  # python-can's virtual bus hands a frame over at once

    def publish(self, readings):
        if self.bus_off:
            return
        self.counter = (self.counter + 1) & 0xFF
        p = self.plant
        if "actuator" in self.devices:
            o = outputs(self.config, self.devices["actuator"], readings)
            self._send("ACT_STATUS", {"position": _clip(o.get("position", 0.0)), "state": p.state,
                                      "alarm": p.alarm, "counter": self.counter})
        if "daq" in self.devices:
            o = outputs(self.config, self.devices["daq"], readings)
            lvdt, lvt = o.get("lvdt", 0.0), o.get("lvt", 0.0)
            status = int(abs(lvdt) > 10.0) | int(abs(lvt) > 10.0) << 1
            self._send("DAQ_MOTION", {"lvdt": _clip(lvdt), "lvt": _clip(lvt), "status": status,
                                      "counter": self.counter})

    def _send(self, name, signals):
        self.bus.send(can.Message(arbitration_id=can_codec.frame_id(name), is_extended_id=False,
                                  data=can_codec.encode(name, signals, strict=False)))


    def close(self):
        self.bus.shutdown()


def _clip(volts, limit=16.7):
    return float(min(max(volts, -limit), limit))


def serve(config, names, plant):
    """The CAN nodes of `names` on the bus their configuration gives: "auto" becomes an
    in-process virtual bus; socketcand on 127.0.0.1 is served on its port."""
    params = [config.devices[n].params for n in names]
    if params[0]["channel"] == "auto":
        channel = f"dyno-virtual-{os.getpid()}-{next(_ids)}"
        for p in params:
            p["interface"], p["channel"] = "virtual", channel
    p = params[0]
    if p["interface"] == "virtual":
        bus = can.Bus(interface="virtual", channel=p["channel"])
    elif p["interface"] == "socketcand" and p.get("host") == "127.0.0.1":
        bus = SocketcandServer(int(p["port"]))
    else:
        raise ValueError(f"the virtual rig serves CAN as 'virtual' or 'socketcand' on 127.0.0.1, "
                         f"not {p['interface']} {p.get('host', '')} {p['channel']}")
    return CanNodes(bus, config, names, plant)
