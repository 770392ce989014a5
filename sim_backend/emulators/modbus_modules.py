"""The thermocouple and analog-input modules as a Modbus TCP server on 127.0.0.1
(pymodbus), one device id per module; each read encodes the plant's latest readings."""
from __future__ import annotations

import asyncio
import logging
import threading

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from rig.codecs import registers as modbus_map

from sim_backend.emulators.outputs import outputs
from sim_backend.emulators.ports import free_port

logging.getLogger("pymodbus").setLevel(logging.CRITICAL)

LATE_S = 0.15  # s: a late answer, as from a machine busy with other work


class ModbusModules:
    def __init__(self, config, devices, port, faults):
        """devices: names of the config's Modbus devices served on this port."""
        self.config, self.port = config, port
        self.maps = {name: modbus_map.load(config.devices[name].params["map"]) for name in devices}
        self.ids = {name: int(config.devices[name].params["device_id"]) for name in devices}
        self.readings = {}  # the plant's latest; encoded only when a client reads
        self.faults = faults  # modbus_exception, modbus_timeout, modbus_late, open_thermocouple
        self.loop = asyncio.new_event_loop()
        self.server = None
        self.ready = threading.Event()
        self.thread = threading.Thread(target=self._run, name=f"modbus:{port}", daemon=True)

    def _action(self, name):
        async def action(fc, start, address, count, regs, set_values):
            if "modbus_exception" in self.faults:
                return ExcCodes.DEVICE_FAILURE
            if "modbus_timeout" in self.faults:
                await asyncio.sleep(2.0)
            if "modbus_late" in self.faults:
                await asyncio.sleep(LATE_S)
            m = self.maps[name]
            if address >= m.start + m.count or address + count <= m.start:
                return None  # not the value block (the identity register holds its type code)
            faults = ()
            if "open_thermocouple" in self.faults and "tc" in m.name:
                faults = tuple(v.name for v in m.values)
            off = m.start - start
            regs[off:off + m.count] = modbus_map.encode(m, outputs(self.config, name, self.readings), faults)
            return None
        return action

    async def _serve(self):
        def blocks(m):
            out = [SimData(m.start, values=[0] * m.count, datatype=DataType.REGISTERS)]
            if m.identity is not None:
                out.append(SimData(m.identity[0], values=[m.identity[1]], datatype=DataType.REGISTERS))
            return out
        devices = [SimDevice(id=self.ids[n], simdata=blocks(m), action=self._action(n))
                   for n, m in self.maps.items()]
        self.server = ModbusTcpServer(devices, address=("127.0.0.1", self.port))
        await self.server.serve_forever(background=True)  # returns once listening

    def _run(self):
        asyncio.set_event_loop(self.loop)
        try:
            self.loop.run_until_complete(self._serve())
        finally:
            self.ready.set()
        self.loop.run_forever()

    def start(self):
        self.thread.start()
        self.ready.wait(5.0)
        if self.server is None or self.server.transport is None:
            raise OSError(f"Modbus server could not listen on 127.0.0.1:{self.port}")

    def publish(self, readings):
        self.readings = readings  # one reference swap: the server thread reads it when polled

    def close(self):
        if self.loop.is_running():
            if self.server is not None:
                asyncio.run_coroutine_threadsafe(self.server.shutdown(), self.loop).result(5.0)
            self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5.0)


class ModbusServers:
    """A Modbus TCP server on 127.0.0.1 per port of the configuration's modules ("auto":
    one free port for all), each module at its device id."""

    def __init__(self, config, names):
        self.faults = set()
        by_port, auto = {}, None
        for name in names:
            p = config.devices[name].params
            if p["port"] == "auto":
                auto = auto or free_port()
                p["port"] = auto
            by_port.setdefault(int(p["port"]), []).append(name)
        self.servers = []
        for port, group in by_port.items():
            m = ModbusModules(config, group, port, self.faults)
            m.start()
            self.servers.append(m)

    def service(self):
        pass

    def settle(self, until):
        pass  # polled: a read's answer is this tick's registers

    def publish(self, readings):
        for m in self.servers:
            m.publish(readings)

    def close(self):
        for m in self.servers:
            m.close()


def serve(config, names, plant):
    return ModbusServers(config, names)
