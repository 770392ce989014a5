"""Serial: the load-cell amplifier's binary stream (rig/codecs/loadcell.py) on a tty, dated
from its frame counter (rig/stream_clock.py)."""
from __future__ import annotations

import serial

from rig.codecs import loadcell
from rig.errors import RigError
from rig.schema import Field, number
from rig.stream_clock import StreamClock
from rig.devices.transport import Transport, frame_hz


class SerialLoadCell:
    """The load-cell amplifier's binary stream (rig/codecs/loadcell.py) on a tty."""

    def __init__(self, name, params):
        self.name, self.params = name, params
        self.port = None
        self.parser = loadcell.FrameParser()
        self.frames = 0
        self.glitches = []  # frame counts at which bytes were dropped or frames lost
        self.clock = StreamClock(1.0 / frame_hz(params))
        self.dropped_at_frame = 0  # parser.dropped when the last valid frame came

    def open(self):
        try:
            self.port = serial.serial_for_url(self.params["port"], baudrate=self.params.get("baudrate", 921600),
                                              timeout=0)
        except (serial.SerialException, OSError, ValueError) as e:
            raise RigError(f"device {self.name!r}: cannot open serial port {self.params['port']!r} ({e})") from None

    def poll(self, now):
        try:
            # only what the line discipline already holds (TIOCINQ): on a tty a read or select
            # that finds nothing waits for the kernel's flush worker, which the FIFO threads
            # of a busy cell kept off its core for up to 3 ms at 4 kHz; bytes still in the
            # flip buffer come a tick later, dated by their frame counter all the same
            waiting = self.port.in_waiting
            data = self.port.read(waiting) if waiting else b""
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
            fault = ("load cell saturated" if f.status & loadcell.SATURATED
                     else "load cell sensor fault" if f.status & loadcell.SENSOR_FAULT else None)
            out.append(("output", f.volts, fault, now - t))
        if self.parser.dropped > dropped:
            self.glitches.append(self.frames)
        if frames:
            self.dropped_at_frame = self.parser.dropped
        elif self.parser.dropped - self.dropped_at_frame > 3 * loadcell.SIZE:
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


TRANSPORT = Transport(
    name="serial",
    schema={"port": Field("string", True), "baudrate": Field("integer", above=0),
            "frame_hz": number(above=0.0, hi=100000.0)},
    signals=lambda p: ("output",),
    drivers=lambda devices, threaded: {n: SerialLoadCell(n, d.params) for n, d in devices.items()},
    address=lambda p: p["port"],
    rate_hz=lambda p, loop_hz: frame_hz(p),
)
