"""Device drivers: bytes from the transports in, device outputs (V, degC) out.

One small class per transport, all with the same three methods the rig uses:
    open()            connect; RigError naming the device if it cannot
    poll(now) -> list of (signal, value, fault or None[, age s]) received since the last poll
    close()
and the actuator's `send(mode, setpoint)`. Calibration to SI is not here: it is the
channel's (rig/config.py, Channel.scale).
"""
from __future__ import annotations

import logging
import threading
import time

import can
import serial

from . import can_codec, modbus_map, serial_frame
from .errors import RigError
from .stream_clock import StreamClock

logging.getLogger("pymodbus").setLevel(logging.CRITICAL)  # we report errors ourselves
MODES = {"off": 0, "hold": 1, "follow": 2}


CONNECT_TIMEOUT_S = 2.0  # every network wait has one


def _probe_socketcand(host, port, where, timeout):
    """Connect and read the daemon's greeting with a timeout: python-can's client retries a
    refused connection for 10 s and waits for the greeting forever."""
    import socket
    try:
        with socket.create_connection((host, port), timeout=timeout) as s:
            greeting = s.recv(16)
    except socket.timeout:
        raise RigError(f"{where}: socketcand at {host}:{port} did not answer in {timeout:g} s") from None
    except OSError as e:
        raise RigError(f"{where}: no socketcand at {host}:{port} ({e.strerror or e})") from None
    if not greeting.startswith(b"< hi >"):
        raise RigError(f"{where}: {host}:{port} does not speak socketcand (it said {greeting[:16]!r})")


def open_can_bus(params: dict, where: str):
    import socket
    kwargs = {"interface": params["interface"], "channel": params["channel"]}
    if "bitrate" in params:
        kwargs["bitrate"] = params["bitrate"]
    timeout = float(params.get("timeout_s", CONNECT_TIMEOUT_S))
    old_timeout = socket.getdefaulttimeout()
    if params["interface"] == "socketcand":
        host, port = params.get("host", "127.0.0.1"), int(params.get("port", 29536))
        _probe_socketcand(host, port, where, timeout)
        kwargs.update(host=host, port=port, tcp_tune=True)
        # it warns on every split read and logs tracebacks for errors we report ourselves
        logging.getLogger("can.interfaces.socketcand.socketcand").setLevel(logging.CRITICAL)
        socket.setdefaulttimeout(timeout)  # its socket: the handshake cannot block forever
    try:
        return can.Bus(**kwargs)
    except Exception as e:  # python-can raises per-interface errors
        raise RigError(f"{where}: cannot open CAN {params['interface']} {params['channel']!r} "
                       f"({str(e).splitlines()[0][:160] if str(e) else type(e).__name__})") from None
    finally:
        socket.setdefaulttimeout(old_timeout)


class CanBus:
    """One CAN bus shared by the devices (nodes) on it: frames are routed by id."""

    ROUTES = {"ACT_STATUS": "actuator", "DAQ_MOTION": "daq"}

    def __init__(self, params, where):
        self.params, self.where = params, where
        self.bus = None
        self.pending = {"actuator": [], "daq": []}
        self.errors = 0

    def open(self):
        if self.bus is None:
            self.bus = open_can_bus(self.params, self.where)

    def pump(self):
        """Drain received frames into per-node queues."""
        while True:
            try:
                msg = self.bus.recv(timeout=0.0)
            except Exception as e:
                raise RigError(f"{self.where}: CAN receive failed ({str(e).splitlines()[0][:120]})") from None
            if msg is None:
                return
            try:
                name, sig = can_codec.decode(msg.arbitration_id, msg.data)
            except RigError:
                self.errors += 1  # a frame we do not know: counted, not fatal
                continue
            node = self.ROUTES.get(name)
            if node:
                self.pending[node].append((name, sig))

    def send(self, name, signals):
        try:
            self.bus.send(can.Message(arbitration_id=can_codec.frame_id(name), is_extended_id=False,
                                      data=can_codec.encode(name, signals)))
        except (can.CanError, OSError) as e:
            raise RigError(f"{self.where}: CAN send failed ({e})") from None

    def close(self):
        if self.bus is not None:
            self.bus.shutdown()
            self.bus = None


class CanNode:
    """The actuator controller or the LVDT/LVT conditioner on a CanBus; each streams its
    frames at frame_hz with a counter, which dates them (rig/stream_clock.py)."""

    def __init__(self, name, bus: CanBus, node, frame_hz=1000.0):
        self.name, self.bus, self.node = name, bus, node
        self.counter = 0
        self.state = None  # actuator: (state, alarm)
        self.frames = 0
        self.clock = StreamClock(1.0 / frame_hz)

    def open(self):
        self.bus.open()

    def poll(self, now):
        self.bus.pump()
        frames = self.bus.pending[self.node]
        sent = self.clock.stamp([int(sig["counter"]) for _, sig in frames], now)
        out = []
        for (_, sig), t in zip(frames, sent):
            self.frames += 1
            if self.node == "actuator":
                self.state = (int(sig["state"]), int(sig["alarm"]))
                out.append(("position", sig["position"], None, now - t))
            else:
                st = int(sig["status"])
                out.append(("lvdt", sig["lvdt"], "LVDT out of range" if st & 1 else None, now - t))
                out.append(("lvt", sig["lvt"], "LVT out of range" if st & 2 else None, now - t))
        frames.clear()
        return out

    def send(self, mode, setpoint):
        self.counter = (self.counter + 1) & 0xFF
        self.bus.send("ACT_CMD", {"setpoint": setpoint, "mode": MODES[mode], "counter": self.counter})

    def close(self):
        self.bus.close()


class SerialLoadCell:
    """The load-cell amplifier's binary stream (rig/serial_frame.py) on a tty."""

    def __init__(self, name, params):
        self.name, self.params = name, params
        self.port = None
        self.parser = serial_frame.Parser()
        self.frames = 0
        self.glitches = []  # frame counts at which bytes were dropped or frames lost
        self.clock = StreamClock(1.0 / params.get("frame_hz", serial_frame.RATE_HZ))
        self.dropped_at_frame = 0  # parser.dropped when the last valid frame came

    def open(self):
        try:
            self.port = serial.serial_for_url(self.params["port"], baudrate=self.params.get("baudrate", 921600),
                                              timeout=0)
        except (serial.SerialException, OSError, ValueError) as e:
            raise RigError(f"device {self.name!r}: cannot open serial port {self.params['port']!r} ({e})") from None

    def poll(self, now):
        try:
            data = self.port.read(self.port.in_waiting or 1)
        except (serial.SerialException, OSError) as e:
            raise RigError(f"device {self.name!r}: serial read failed ({e})") from None
        dropped, lost = self.parser.dropped, self.clock.lost
        frames = self.parser.feed(data)
        sent = self.clock.stamp([f.seq for f in frames], now)
        if self.clock.lost > lost:
            self.glitches.append(self.frames)
        out = []
        for f, t in zip(frames, sent):
            self.frames += 1
            fault = ("load cell saturated" if f.status & serial_frame.SATURATED
                     else "load cell sensor fault" if f.status & serial_frame.SENSOR_FAULT else None)
            out.append(("output", f.volts, fault, now - t))
        if self.parser.dropped > dropped:
            self.glitches.append(self.frames)
        if frames:
            self.dropped_at_frame = self.parser.dropped
        elif self.parser.dropped - self.dropped_at_frame > 3 * serial_frame.SIZE:
            raise RigError(f"device {self.name!r}: serial line corrupt ({self.parser.dropped - self.dropped_at_frame} "
                           f"bytes since the last valid frame, {self.parser.bad_frames} bad frames)")
        # one glitch is noise; three within 100 frames is a line that cannot be trusted
        self.glitches = [g for g in self.glitches if g > self.frames - 100]
        if len(self.glitches) >= 3 and out:
            name, volts, fault, age = out[-1]
            out[-1] = (name, volts, fault or f"serial line corrupt ({self.parser.dropped} bytes dropped, "
                                               f"{self.parser.bad_frames} bad frames)", age)
        return out

    def close(self):
        if self.port is not None:
            self.port.close()
            self.port = None


class ModbusModule:
    """A Modbus TCP module polled for its register block (rig/registers/*.toml).

    On a real-time rig (threaded=True) a thread of its own polls it, so a slow or silent
    module never stalls the control loop; poll() then hands over what the thread read,
    or the error it met. On the simulated clock, poll() requests in line when due."""

    def __init__(self, name, params, threaded=False):
        self.name, self.params, self.threaded = name, params, threaded
        self.map = modbus_map.load(params["map"])
        self.period = 1.0 / float(params.get("poll_hz", 10))
        self.next_poll = None
        self.client = None
        self.frames = 0
        self._results, self._error = [], None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = None

    def open(self):
        from pymodbus.client import ModbusTcpClient
        p = self.params
        self.client = ModbusTcpClient(p["host"], port=int(p["port"]), timeout=float(p.get("timeout_s", 0.1)),
                                      retries=0)
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
        try:
            r = read(m.identity[0], count=1, device_id=int(p["device_id"]))
        except (ModbusException, OSError) as e:
            raise RigError(f"{where}: no answer to the identity read ({str(e).split('] ')[-1]})") from None
        if r.isError():
            raise RigError(f"{where}: refuses the identity read of register {m.identity[0]} (exception code "
                           f"{getattr(r, 'exception_code', '?')}); wrong device_id?")
        if r.registers[0] != m.identity[1]:
            raise RigError(f"{where}: identifies as 0x{r.registers[0]:04X}, not the {m.name}'s "
                           f"0x{m.identity[1]:04X}: wrong device_id?")

    def _run(self):
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
            raise RigError(f"device {self.name!r}: Modbus request failed ({str(e).split('] ')[-1]})") from None
        if r.isError():
            raise RigError(f"device {self.name!r}: Modbus exception response, code {getattr(r, 'exception_code', '?')}")
        self.frames += 1
        return [(name, value, fault) for name, (value, fault) in modbus_map.decode(m, r.registers).items()]

    def close(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
            self._thread = None
        if self.client is not None:
            self.client.close()
            self.client = None


def make(config, threaded=False):
    """{device name: driver} for a RigConfig; CAN devices on one bus share it. threaded:
    polled devices get threads of their own (real time)."""
    buses, out = {}, {}
    for name, d in config.devices.items():
        if d.transport == "can":
            key = (d.params["interface"], str(d.params["channel"]))
            if key not in buses:
                buses[key] = CanBus(d.params, f"device {name!r}")
            out[name] = CanNode(name, buses[key], d.params["node"], d.params.get("frame_hz", 1000.0))
        elif d.transport == "serial":
            out[name] = SerialLoadCell(name, d.params)
        else:
            out[name] = ModbusModule(name, d.params, threaded)
    return out
