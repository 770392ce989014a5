"""The actuator controller and the LVDT/LVT conditioner as CAN nodes (rig/dyno.dbc) on
any python-can bus: the in-process virtual bus, or the socketcand link of `dyno sim-rig`."""
from __future__ import annotations

import can

from rig import can_codec

from .emulated import outputs


class CanNodes:
    def __init__(self, bus, config, plant):
        self.bus, self.config, self.plant = bus, config, plant
        self.devices = {d.params["node"]: name for name, d in config.devices.items() if d.transport == "can"}
        self.counter = 0
        self.bus_off = False  # fault: the nodes fall silent

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


def _clip(volts, limit=16.7):
    return float(min(max(volts, -limit), limit))
