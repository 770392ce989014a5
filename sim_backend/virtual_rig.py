"""The virtual rig: the plant behind device emulators that speak the real wire protocols.

    vr = VirtualRig(config.load("virtual"), damper="koni")
    cfg = vr.start()          # the config with its "auto" addresses filled in
    rig = Rig(cfg, clock=vr.clock); rig.open()
    vr.step(1e-3)             # simulated time: the caller paces it (as fast as the CPU allows)
    ...
    vr.close()

In process: CAN on python-can's virtual bus (or a socketcand server on 127.0.0.1), the
load-cell amplifier on a pseudo-terminal, the Modbus modules on a TCP server at
127.0.0.1 (sim_backend/emulators/). Faults are injected with `inject(name)`.
"""
from __future__ import annotations

import copy
import math
import gc
import time
from pathlib import Path

from rig.devices import TRANSPORTS, by_transport
from rig.devices.transport import FRAME_HZ, frame_hz
from rig.pacing import realtime_priority, short_slice
from sim_backend.emulators import EMULATORS
from sim_backend.emulators.ports import free_port
from sim_backend.plant import Plant

PLANT_STEP = 5e-4  # s: the plant's longest integration step

FAULTS = {
    "can_bus_off": "CAN nodes fall silent (bus-off)",
    "serial_corrupt": "load-cell frames with bad checksums",
    "serial_truncate": "load-cell frames cut short",
    "serial_garbage": "garbage bytes between load-cell frames",
    "modbus_exception": "Modbus modules answer with exception responses",
    "modbus_timeout": "Modbus modules stop answering in time",
    "modbus_late": "Modbus modules answer 150 ms late (a busy machine)",
    "open_thermocouple": "thermocouples read open",
    "loadcell_stuck": "load cell output frozen",
    "loadcell_saturated": "load cell amplifier saturated",
    "actuator_alarm": "actuator controller raises a valve alarm",
}


def sim_rig_config(folder, rate_hz=None, stale_s=None):
    """Write the shipped sim-rig config with free ports and the load cell's pty link in
    `folder` (so several sim-rigs can run side by side); returns its path."""
    from rig import config
    text = config.CONFIG_DIR.joinpath("sim-rig.toml").read_text()
    text = text.replace("29536", str(free_port())).replace("29502", str(free_port()))
    text = text.replace("/tmp/dyno-sim-rig/loadcell", str(Path(folder) / "loadcell"))
    if rate_hz is not None:
        text = text.replace("rate_hz = 1000", f"rate_hz = {rate_hz:g}")
    if stale_s is not None:
        text = text.replace("stale_s = 0.05", f"stale_s = {stale_s:g}")
    path = Path(folder) / "sim-rig.toml"
    path.write_text(text)
    return path


class VirtualRig:
    def __init__(self, config, damper="koni", seed=0, T0=None, effects=None, params=None):
        """effects: hidden physics {name: value} (sim_backend/effects/); params: the
        plant's parameters if not sim_backend/plant.toml."""
        self.config = copy.deepcopy(config)
        # the emulators send a frame per device each step: in real time at the devices' rate
        self.frame_hz = max((frame_hz(d.params) for d in self.config.devices.values()
                             if "frame_hz" in TRANSPORTS[d.transport].schema), default=FRAME_HZ)
        tick = 1.0 / max(self.config.rate_hz, self.frame_hz)  # a whole number of plant steps per tick
        self.plant = Plant(damper, T0=T0, h=tick / math.ceil(tick / PLANT_STEP - 1e-9), seed=seed, params=params,
                           effects=effects)
        self.t = 0.0
        self.emulators = []

    def clock(self):
        return self.t

    def start(self):
        """Start an emulator per transport; returns the config with "auto" addresses filled in."""
        cfg = self.config
        # the pty's frames first: the kernel moves them on a work queue while the others
        # publish, so settle() rarely has to wait for them
        for transport, names in sorted(by_transport(cfg).items(), key=lambda tn: tn[0] != "serial"):
            self.emulators.append(EMULATORS[transport](cfg, names, self.plant))
        self.plant.advance(self.plant.h)  # compiles the damper model before anyone listens
        self.publish()
        return cfg

    def step(self, dt, settle_s=1.0):
        """Apply received setpoints, advance the plant by dt [s] of simulated time, and
        publish one frame per device. settle_s: wait up to this long [s] until the driver
        can read them (simulated time does not pass while a transport moves a frame); on
        the wall clock a fraction of a tick at most, 0 when a driver in another process
        reads them."""
        for e in self.emulators:
            e.service()
        self.plant.advance(dt)
        self.t += dt
        self.publish()
        if settle_s:
            end = time.perf_counter() + settle_s
            for e in self.emulators:
                e.settle(end)

    def publish(self):
        r = self.plant.readings()
        for e in self.emulators:
            e.publish(r)

    def run_realtime(self, stop, faults=()):
        """Step in real time, a frame per device each period of the devices' rate, until the
        threading.Event `stop` is set; `faults`: (time s, name) injected when the clock
        reaches them."""
        dt = 1.0 / self.frame_hz
        pending = sorted(faults)
        # as a real cell's devices keep their time: SCHED_FIFO, else the shortest slice
        if realtime_priority(self.config.realtime_priority) is None:
            short_slice()
        gc.disable()  # no collector pauses in the real-time plant (it makes no cycles)
        t0 = time.perf_counter()
        k = 0
        while not stop.is_set():
            k += 1
            while pending and pending[0][0] <= self.t:
                self.inject(pending.pop(0)[1])
            self.step(dt, settle_s=0)
            left = t0 + k * dt - time.perf_counter()
            if left > 0:
                time.sleep(left)

    def inject(self, fault, on=True):
        if fault not in FAULTS:
            raise ValueError(f"unknown fault {fault!r} (known: {', '.join(FAULTS)})")
        for t in [self.plant.faults] + [e.faults for e in self.emulators]:
            (t.add if on else t.discard)(fault)

    def close(self):
        for e in self.emulators:
            e.close()
