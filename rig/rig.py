"""The rig: one object a protocol uses whatever the wiring.

    rig = Rig(config.load("my-cell.toml"), clock)
    rig.open()
    rig.poll()                         # take in what the devices sent
    rig.read()["force"]                # latest Reading(t, value [SI], fault)
    rig.drain()                        # every sample since the last drain, per channel
    rig.follow(x); rig.hold(); rig.stop()
    rig.actuator()                     # ("following", [alarms])
    rig.close()

Samples are timestamped by the rig's clock when they arrive: on a real cell seconds on the
monotonic clock since open(), on the embedded virtual rig its simulated seconds. It is the
one clock of a run: the control loop, the safety watchdogs, setpoints and events all read
`rig.clock()`, and `rig.wall_start` is the wall-clock time (Unix seconds) of its zero.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from rig import devices
from rig.codecs.actuator import STATES, alarm_texts
from rig.errors import RigError


@dataclass(frozen=True)
class Reading:
    t: float  # s, rig clock
    value: float  # SI
    fault: str | None


class Rig:
    def __init__(self, config, clock=None):
        """clock: the simulated clock of a virtual rig; None for real time (the monotonic
        clock from open(), polled devices on threads of their own)."""
        self.config = config
        self._t0 = time.monotonic()
        self.clock = clock or (lambda: time.monotonic() - self._t0)
        self.wall_start = time.time() - self.clock()
        self.drivers = devices.make(config, threaded=clock is None)
        self.by_signal = {(c.device, c.signal): c for c in config.channels.values()}
        self.latest: dict[str, Reading] = {}
        self._buf = {name: ([], []) for name in config.channels}
        self.failed: set[str] = set()  # devices whose transport failed: not polled again until open()
        self.is_open = False

    def open(self):
        """Connect every device; RigError "CONFIG:LINE: ..." naming the first that fails."""
        self._t0 = time.monotonic()
        self.wall_start = time.time() - self.clock()
        self.failed.clear()
        opened = []
        for name, d in self.drivers.items():
            try:
                d.open()
            except RigError as e:
                for o in opened:
                    o.close()
                raise RigError(f"{self.config.path}:{self.config.devices[name].line}: {e}") from None
            opened.append(d)
        self.is_open = True

    def poll(self):
        """Take in everything the devices sent since the last poll. RigError names a
        device whose transport failed; it is not polled again (a silent module would cost
        each later poll its timeout while the rig moves to the safe position)."""
        now = self.clock()
        for name, drv in self.drivers.items():
            if name in self.failed:
                continue
            try:
                polled = drv.poll(now)
            except RigError as e:
                e.device = name  # the loop may still trust the other devices' readings
                self.failed.add(name)
                raise
            for signal, raw, fault, *age in polled:
                ch = self.by_signal.get((name, signal))
                if ch is None:
                    continue
                value = ch.scale(raw)
                t = now - age[0] if age else now
                self.latest[ch.name] = Reading(t, value, fault)
                ts, vs = self._buf[ch.name]
                ts.append(t)
                vs.append(value)
        return now

    def read(self) -> dict:
        return dict(self.latest)

    def trouble(self, device) -> str:
        """What a device knows is wrong while its channels age (a Modbus request unanswered:
        the watchdog's message names it), "" when nothing."""
        return getattr(self.drivers.get(device), "trouble", "")

    def drain(self) -> dict:
        """{channel: (t [s], values [SI])} of every sample since the last drain."""
        out = {}
        for name, (ts, vs) in self._buf.items():
            out[name] = (np.array(ts), np.array(vs))
            ts.clear()
            vs.clear()
        return out

    # --- actuator -----------------------------------------------------------------------
    @property
    def _actuator(self):
        return self.drivers[self.config.actuator]

    def follow(self, x):
        """Position setpoint [m from full extension]; the caller checks the limits."""
        self._actuator.send("follow", float(x))

    def hold(self):
        self._actuator.send("hold", 0.0)

    def stop(self):
        """Valve closed: the actuator locks where it is."""
        self._actuator.send("off", 0.0)

    def actuator(self):
        """(state, [alarm texts]) from the actuator's last status frame; ("unknown", [])
        before the first."""
        st = self._actuator.state
        if st is None:
            return "unknown", []
        state, alarm = st
        return STATES.get(state, f"state {state}"), alarm_texts(alarm)

    def close(self):
        for d in self.drivers.values():
            d.close()
        self.is_open = False
