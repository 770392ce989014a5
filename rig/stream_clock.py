"""When a streamed frame was sent, from its counter: a device that streams at a fixed rate
sends frame k at t0 + k period. Stamping frames on receipt instead puts every frame of a
bunch (TCP, USB and OS scheduling deliver them in bursts) at the same instant: 2 % of the
forces a tick late on the serial line, and LVDT samples 0-2 ms off over socketcand.

A frame is never received before it is sent, so t0 is the least (receipt - k period) seen,
allowed to creep 100 ppm per frame to follow the device's clock; a stream that paused (its
sender stopped, or frames were lost beyond what the counter can tell) re-anchors. t0 moves
back by at most half a period per poll, so the stamps never run backwards (a backlog read
at start is dated late at first, and the anchor slides onto the truth within a few
hundred polls).
"""
from __future__ import annotations


class StreamClock:
    def __init__(self, period, modulo=256):
        self.period, self.modulo = float(period), int(modulo)
        self.last = None  # last counter seen
        self.n = -1  # index of the last frame sent, counting lost ones
        self.t0 = None  # rig clock when frame 0 was sent [s]
        self.lost = 0

    def stamp(self, counters, now):
        """Send times [s, rig clock] of frames received by `now` with these counters (in
        order); counts frames lost in between."""
        index = []
        for c in counters:
            step = 1 if self.last is None else (c - self.last) % self.modulo or self.modulo
            self.lost += step - 1
            self.n += step
            self.last = c
            index.append(self.n)
        if not index:
            return []
        t0 = now - self.n * self.period
        if self.t0 is None or t0 - self.t0 > 5 * self.period:
            self.t0 = t0
        else:
            self.t0 = max(min(self.t0 + 1e-4 * self.period * len(index), t0), self.t0 - 0.5 * self.period)
        return [self.t0 + k * self.period for k in index]
