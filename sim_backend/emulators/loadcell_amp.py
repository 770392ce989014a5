"""The load-cell amplifier on a pseudo-terminal: the driver opens the slave like any tty.
Frames as rig/codecs/loadcell.py; an output beyond +/-10 V saturates and says so."""
from __future__ import annotations

import fcntl
import os
import select
import struct
import termios
import time
import tty

import numpy as np

from rig.codecs import loadcell as serial_frame

from sim_backend.emulators.outputs import outputs

FULL_SCALE = 10.0  # V


class LoadCellAmp:
    def __init__(self, config, device, faults):
        self.config, self.device = config, device
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # binary: no line discipline between us and the driver
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self.slave)
        self.seq = 0
        self.faults = faults  # serial_corrupt, serial_truncate, serial_garbage, loadcell_saturated
        self.rng = np.random.default_rng(7)
        self.overruns = 0
        self.expect = 0  # bytes the reader's side should hold once the kernel has moved our last frame
        self.waiting = select.poll()
        self.waiting.register(self.slave, select.POLLIN)

    def _queued(self):
        """Bytes the reader's side of the pty holds now."""
        return struct.unpack("i", fcntl.ioctl(self.slave, termios.FIONREAD, b"\0\0\0\0"))[0]

    def link(self, path):
        """Make `path` a symlink to our pty (what a fixed-path config opens)."""
        self.link_path = path
        os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
        if os.path.islink(path):
            os.unlink(path)
        os.symlink(self.path, path)

    def publish(self, readings):
        v = outputs(self.config, self.device, readings).get("output", 0.0)
        status = 0
        if "loadcell_saturated" in self.faults or abs(v) > FULL_SCALE:
            v, status = float(np.copysign(FULL_SCALE, v if v else 1.0)), serial_frame.SATURATED
        frame = serial_frame.encode(self.seq, status, v)
        self.seq = (self.seq + 1) & 0xFF
        if "serial_corrupt" in self.faults:
            frame = frame[:5] + bytes([frame[5] ^ 0x5A]) + frame[6:]
        if "serial_truncate" in self.faults:
            frame = frame[:6]
        if "serial_garbage" in self.faults:
            frame = self.rng.integers(0, 256, 7, dtype=np.uint8).tobytes() + frame
        try:
            queued = self._queued()
            os.write(self.master, frame)
            self.expect = queued + len(frame)
        except BlockingIOError:
            self.overruns += 1  # nobody reads: the line overruns, as a real one would
            self.expect = 0

    def settle(self, until):
        """Wait until the reader's side holds our last frame, or until `until` [s,
        time.perf_counter]: the kernel moves pty bytes on a work queue, so under load a frame
        can reach the driver a tick late. Simulated time stands still meanwhile, which makes
        the embedded rig's readings the tick's own; a reader that lets the line fill (the
        line discipline holds 4 KiB) is not waited for. On the wall clock the bound is a
        fraction of a tick: the worker runs at normal priority, and beside a busy program
        waiting for it stalled a real-time loop 70 ms."""
        if not 0 < self.expect < 2048:
            return
        while (queued := self._queued()) < self.expect and (left := until - time.perf_counter()) > 0:
            # the line empty: sleep until the kernel's worker moves our frame onto it; but no
            # wake-up tells when ours join bytes the reader left, and poll() sleeps whole
            # milliseconds (the wall clock's bound is a fraction of one)
            if queued or left < 1e-3:
                time.sleep(1e-5)
            else:
                self.waiting.poll(left * 1e3)

    def close(self):
        if getattr(self, "link_path", None) and os.path.islink(self.link_path):
            os.unlink(self.link_path)
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


class LoadCellAmps:
    """Every serial device of the configuration, one pseudo-terminal each."""

    def __init__(self, config, names):
        self.faults = set()
        self.amps = []
        for name in names:
            amp = LoadCellAmp(config, name, self.faults)
            self.amps.append(amp)
            p = config.devices[name].params
            if p["port"] == "auto":
                p["port"] = amp.path
            else:  # a fixed path for a separate process: link it to our pty
                amp.link(p["port"])

    def service(self):
        pass

    def settle(self, until):
        for a in self.amps:
            a.settle(until)

    def publish(self, readings):
        for a in self.amps:
            a.publish(readings)

    def close(self):
        for a in self.amps:
            a.close()


def serve(config, names, plant):
    return LoadCellAmps(config, names)
