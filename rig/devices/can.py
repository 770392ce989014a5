"""CAN: the actuator controller and the LVDT/LVT conditioner as nodes on one bus (frames in
rig/codecs/dyno.dbc), through any python-can interface; socketcand opened with timeouts."""
from __future__ import annotations

import logging
import socket

import can

from rig.codecs import can as can_codec
from rig.codecs.actuator import MODES
from rig.errors import RigError
from rig.schema import Field, number
from rig.stream_clock import StreamClock
from rig.devices.transport import FRAME_HZ, Transport, frame_hz

NODES = {"actuator": ("position",), "daq": ("lvdt", "lvt")}  # node -> its signals
ROUTES = {"ACT_STATUS": "actuator", "DAQ_MOTION": "daq"}  # frame -> node
CONNECT_TIMEOUT_S = 2.0  # every network wait has one


SOCKETCAND = ("127.0.0.1", 29536)  # host and port when the cell file gives none


def _probe_socketcand(host, port, where, timeout):
    """Connect and read the daemon's greeting with a timeout: python-can's client retries a
    refused connection for 10 s and waits for the greeting forever."""
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
    kwargs = {"interface": params["interface"], "channel": params["channel"]}
    if "bitrate" in params:
        kwargs["bitrate"] = params["bitrate"]
    timeout = float(params.get("timeout_s", CONNECT_TIMEOUT_S))
    old_timeout = socket.getdefaulttimeout()
    if params["interface"] == "socketcand":
        host, port = params.get("host", SOCKETCAND[0]), int(params.get("port", SOCKETCAND[1]))
        _probe_socketcand(host, port, where, timeout)
        kwargs.update(host=host, port=port, tcp_tune=True)
        # it warns on every split read and logs tracebacks for errors we report ourselves
        logging.getLogger("can.interfaces.socketcand.socketcand").setLevel(logging.CRITICAL)
        socket.setdefaulttimeout(timeout)  # its socket: the handshake cannot block forever
    try:
        return can.Bus(**kwargs)
    except Exception as e:  # noqa: BLE001 - python-can raises per-interface errors
        raise RigError(f"{where}: cannot open CAN {params['interface']} {params['channel']!r} "
                       f"({str(e).splitlines()[0][:160] if str(e) else type(e).__name__})") from None
    finally:
        socket.setdefaulttimeout(old_timeout)


class CanBus:
    """One CAN bus shared by the devices (nodes) on it: frames are routed by id."""

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
            except Exception as e:  # noqa: BLE001 - python-can raises per-interface errors
                raise RigError(f"{self.where}: CAN receive failed ({str(e).splitlines()[0][:120]})") from None
            if msg is None:
                return
            try:
                name, sig = can_codec.decode(msg.arbitration_id, msg.data)
            except RigError:
                self.errors += 1  # a frame we do not know: counted, not fatal
                continue
            node = ROUTES.get(name)
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

    def __init__(self, name, bus: CanBus, node, frame_hz=FRAME_HZ):
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


def _drivers(devices, threaded):
    """{name: CanNode}; nodes on the same interface and channel share one bus."""
    buses, out = {}, {}
    for name, d in devices.items():
        key = (d.params["interface"], str(d.params["channel"]))
        if key not in buses:
            buses[key] = CanBus(d.params, f"device {name!r}")
        out[name] = CanNode(name, buses[key], d.params["node"], frame_hz(d.params))
    return out


def _address(p):
    where = f" {p['host']}:{p.get('port', SOCKETCAND[1])}" if "host" in p else ""
    return f"{p['interface']} {p['channel']}{where}"


TRANSPORT = Transport(
    name="can",
    schema={"interface": Field("string", True), "channel": Field("string", True),
            "node": Field("string", True, choices=tuple(NODES)), "bitrate": Field("integer", above=0),
            "host": Field("string"), "port": Field("port"), "timeout_s": number(above=0.0, hi=60.0),
            "frame_hz": number(above=0.0, hi=100000.0)},
    signals=lambda p: NODES[p["node"]],
    drivers=_drivers,
    address=_address,
    takes_setpoints=lambda p: p["node"] == "actuator",
    rate_hz=lambda p, loop_hz: frame_hz(p),
)
