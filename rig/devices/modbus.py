"""Modbus TCP: modules polled for their register block (rig/codecs/registers/*.toml),
each checked at connect by its identity register; on a real-time rig each on a thread of
its own, so a slow or silent module never stalls the control loop."""
from __future__ import annotations

import logging
import threading
import time

from rig.codecs import registers
from rig.errors import RigError
from rig.pacing import device_thread
from rig.schema import Field, number
from rig.devices.transport import Transport

logging.getLogger("pymodbus").setLevel(logging.CRITICAL)  # we report errors ourselves

IDENTIFY_TRIES = 3  # identity reads at open before a module counts as silent
TIMEOUT_S = 0.1  # s: a module on a real-time rig answers in milliseconds
SIMULATED_TIMEOUT_S = 1.0  # s: on the simulated clock the rig's time stands still while it
# waits, so a machine busy with other work must not make a module look silent
MISSED_REPLIES = 2  # requests in a row without a reply before the device counts as failed (one is a busy machine)


class ModbusModule:
    """A Modbus TCP module polled for its register block (rig/codecs/registers/*.toml).

    On a real-time rig (threaded=True) a thread of its own polls it, so a slow or silent
    module never stalls the control loop; poll() then hands over what the thread read,
    or the error it met. On the simulated clock, poll() requests in line when due."""

    def __init__(self, name, params, threaded=False):
        self.name, self.params, self.threaded = name, params, threaded
        self.map = registers.load(params["map"])
        self.period = 1.0 / float(params.get("poll_hz", 10))
        self.next_poll = None
        self.client = None
        self.frames = 0
        self.missed = 0  # requests in a row without a reply
        self.trouble = ""  # why its channels may be ageing (a request unanswered), "" when it answers
        self._results, self._error = [], None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = None

    def open(self):
        from pymodbus.client import ModbusTcpClient
        p = self.params
        timeout = float(p.get("timeout_s", TIMEOUT_S if self.threaded else SIMULATED_TIMEOUT_S))
        self.client = ModbusTcpClient(p["host"], port=int(p["port"]), timeout=timeout, retries=0)
        if not self.client.connect():
            raise RigError(f"device {self.name!r}: no Modbus server at {p['host']}:{p['port']}")
        self._identify()
        self.next_poll = None
        if self.threaded:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name=f"modbus:{self.name}", daemon=True)
            self._thread.start()

    def _identify(self):
        """A module that says what it is must say it is this one: a wrong device_id would
        otherwise read another module's registers as this one's values."""
        from pymodbus.exceptions import ModbusException
        m, p = self.map, self.params
        if m.identity is None:
            return
        where = f"device {self.name!r}: Modbus unit {p['device_id']} at {p['host']}:{p['port']}"
        read = self.client.read_input_registers if m.table == "input" else self.client.read_holding_registers
        for attempt in range(IDENTIFY_TRIES):  # at open, not in the loop: a busy module may miss one
            try:
                r = read(m.identity[0], count=1, device_id=int(p["device_id"]))
                break
            except (ModbusException, OSError) as e:
                if attempt == IDENTIFY_TRIES - 1:
                    raise RigError(f"{where}: no answer to the identity read after {IDENTIFY_TRIES} tries "
                                   f"({str(e).split('] ')[-1]})") from None
        if r.isError():
            raise RigError(f"{where}: refuses the identity read of register {m.identity[0]} (exception code "
                           f"{getattr(r, 'exception_code', '?')}); wrong device_id?")
        if r.registers[0] != m.identity[1]:
            raise RigError(f"{where}: identifies as 0x{r.registers[0]:04X}, not the {m.name}'s "
                           f"0x{m.identity[1]:04X}: wrong device_id?")

    def _run(self):
        device_thread()
        t0 = time.monotonic()
        while not self._stop.is_set():
            try:
                out = self._request()
            except RigError as e:
                with self._lock:
                    self._error = e
                return
            with self._lock:
                self._results.extend(out)
            self._stop.wait(max(0.0, self.period - (time.monotonic() - t0) % self.period))

    def poll(self, now):
        if self.threaded:
            with self._lock:
                out, self._results = self._results, []
                if self._error is not None:
                    raise self._error
            return out
        if self.next_poll is not None and now < self.next_poll:
            return []
        self.next_poll = now + self.period if self.next_poll is None else max(self.next_poll + self.period, now)
        return self._request()

    def _request(self):
        from pymodbus.exceptions import ModbusException
        m = self.map
        read = self.client.read_input_registers if m.table == "input" else self.client.read_holding_registers
        try:
            r = read(m.start, count=m.count, device_id=int(self.params["device_id"]))
        except (ModbusException, OSError) as e:
            self.missed += 1
            self.trouble = (f"Modbus request failed {self.missed} time{'s' * (self.missed > 1)} in a row "
                            f"({str(e).split('] ')[-1]})")
            # a new connection for the next request: on the old one the late reply to this
            # request would be taken as the answer to the next (pymodbus 3.16 accepts it)
            self.client.close()
            if self.missed < MISSED_REPLIES:  # a reply lost on a busy machine: its channels age, the
                return []                     # stale-channel watchdog trips if the device stays silent
            raise RigError(f"device {self.name!r}: Modbus request failed {self.missed} times in a row "
                           f"({str(e).split('] ')[-1]})") from None
        self.missed, self.trouble = 0, ""
        if r.isError():
            raise RigError(f"device {self.name!r}: Modbus exception response, code {getattr(r, 'exception_code', '?')}")
        self.frames += 1
        return [(name, value, fault) for name, (value, fault) in registers.decode(m, r.registers).items()]

    def close(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
            self._thread = None
        if self.client is not None:
            self.client.close()
            self.client = None


def _check(params):
    try:
        registers.load(params["map"])
    except RigError as e:
        return "map", str(e)
    return None


TRANSPORT = Transport(
    name="modbus",
    schema={"host": Field("string", True), "port": Field("port", True),
            "device_id": Field("integer", True, lo=0, hi=247), "map": Field("string", True),
            "poll_hz": number(above=0.0, hi=1000.0), "timeout_s": number(above=0.0, hi=10.0)},
    signals=lambda p: tuple(v.name for v in registers.load(p["map"]).values),
    drivers=lambda devices, threaded: {n: ModbusModule(n, d.params, threaded) for n, d in devices.items()},
    address=lambda p: f"{p['host']}:{p['port']} id {p['device_id']}",
    rate_hz=lambda p, loop_hz: float(p.get("poll_hz", 10)),
    # a polled channel may be up to 10 poll periods old
    max_age=lambda p, stale_s: max(stale_s, 10.0 / float(p.get("poll_hz", 10))),
    check=_check,
)
